"""The meter's response to the plan (ρ), and the history it is measured on."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hvacflex.control.meter_response import (
    IDLE,
    MIN_PAIRS,
    OCCUPIED,
    PULL_DOWN,
    WINDOW_PERIODS,
    MeterHistory,
    meter_offset_kw,
    meter_response_ratio,
    period_classes,
)
from hvacflex.state import decode, encode


def _day_plan(periods: int = 40, seed: int = 1) -> np.ndarray:
    """A plan's power that moves from period to period [kW]."""
    rng = np.random.default_rng(seed)
    return 20.0 + 5.0 * np.sin(np.arange(periods) / 3.0) + rng.normal(0.0, 1.0, periods)


@settings(max_examples=40, deadline=None)
@given(
    slope=st.floats(0.0, 1.0),
    offset_kw=st.floats(-10.0, 10.0),
    lag=st.integers(1, 6),
)
def test_an_exact_affine_meter_gives_its_slope(slope: float, offset_kw: float, lag: int) -> None:
    """meter = a + b·plan: the offset cancels in the changes, ρ = b (for b in [0, 1])."""
    plan = _day_plan()
    assert meter_response_ratio(plan, offset_kw + slope * plan, lag) == pytest.approx(
        slope, abs=1e-9
    )


def test_the_slope_is_computed_by_hand_over_lags_one_and_two() -> None:
    """ρ = Σ ΔP̂ ΔM / Σ ΔP̂² over the pairs at lags 1 and 2, NaN periods left out."""
    plan = np.array([10.0, 12.0, 11.0, math.nan, 15.0, 14.0] * 4)
    meter = np.array([9.0, 10.0, 10.5, 8.0, 11.0, 11.0] * 4)
    cross = square = 0.0
    for lag in (1, 2):
        for k in range(lag, plan.size):
            dp, dm = plan[k] - plan[k - lag], meter[k] - meter[k - lag]
            if np.isfinite(dp) and np.isfinite(dm):
                cross, square = cross + dp * dm, square + dp * dp
    assert 0.0 < cross / square < 1.0
    assert meter_response_ratio(plan, meter, 2, min_pairs=4) == pytest.approx(cross / square)


def test_without_evidence_the_model_s_own_scale() -> None:
    plan = _day_plan()
    half = 0.5 * plan
    # too few pairs: the last few periods only
    few = MIN_PAIRS // 2
    assert meter_response_ratio(plan[:few], half[:few], 1) == 1.0
    # a flat plan says nothing about the response
    flat = np.full(40, 20.0)
    assert meter_response_ratio(flat, half, 4) == 1.0
    # unusable periods (NaN) are no evidence either
    assert meter_response_ratio(np.full(40, math.nan), half, 4) == 1.0
    assert meter_response_ratio(plan, half, 4) == pytest.approx(0.5)


def test_the_ratio_is_clipped_to_the_model_s_lower_bound_and_zero() -> None:
    plan = _day_plan()
    assert meter_response_ratio(plan, 1.5 * plan, 4) == 1.0  # never above q·r
    assert meter_response_ratio(plan, -0.5 * plan, 4) == 0.0  # a meter that moves against it


def test_rows_follow_time_with_gaps_for_periods_nobody_decided_or_metered() -> None:
    history = MeterHistory(window_periods=6)
    history.advance(0, None)  # nothing open yet: nothing recorded
    history.open(0, 10.0)
    history.advance(1, 9.0)
    history.open(1, math.nan)  # not usable (curtailed, unoccupied, no plan)
    history.advance(2, 8.0)
    history.open(2, 12.0)
    history.advance(5, 7.0)  # 3 and 4 skipped: period 2's meter was never read, no pair
    np.testing.assert_array_equal(
        history.planned_kw, [10.0, math.nan, math.nan, math.nan, math.nan]
    )
    np.testing.assert_array_equal(history.metered_kw, [9.0, 8.0, math.nan, math.nan, math.nan])
    history.open(5, 11.0)
    history.advance(6, 10.0)
    history.open(6, 13.0)
    history.advance(7, None)  # the meter of 6 not read
    assert history.planned_kw.size == 6  # the window
    np.testing.assert_array_equal(history.planned_kw[-2:], [11.0, 13.0])
    np.testing.assert_array_equal(history.metered_kw[-2:], [10.0, math.nan])
    history.open(7, 1.0)
    history.advance(7 + 3 * WINDOW_PERIODS, 1.0)  # a long gap: bounded by the window
    assert np.isnan(history.planned_kw).all() and history.planned_kw.size == 6
    # a period started but never decided (its decision failed): its row is NaN, and the
    # next decided period's row lands in its own place
    history = MeterHistory(window_periods=6)
    history.advance(0, None)
    history.open(0, 10.0)
    history.advance(1, 9.0)  # period 1 starts, nothing is opened for it
    history.advance(2, 8.0)
    history.open(2, 12.0)
    history.advance(3, 11.0)
    np.testing.assert_array_equal(history.planned_kw, [10.0, math.nan, 12.0])
    np.testing.assert_array_equal(history.metered_kw, [9.0, math.nan, 11.0])


def test_a_history_resumes_identically_from_its_state() -> None:
    history = MeterHistory()
    plan = _day_plan(60)
    for k, power in enumerate(plan):
        history.advance(k, None if k == 0 else 3.0 + 0.6 * plan[k - 1])
        history.open(k, float(power))
    resumed = MeterHistory()
    resumed.set_state(decode(encode(history.get_state())))
    for k in (60, 61):
        for h in (history, resumed):
            h.advance(k, 3.0 + 0.6 * h.open_planned_kw)
            h.open(k, float(plan[k - 60]))
    np.testing.assert_array_equal(resumed.planned_kw, history.planned_kw)
    np.testing.assert_array_equal(resumed.metered_kw, history.metered_kw)
    assert resumed.ratio(4) == history.ratio(4) == pytest.approx(0.6)


def test_the_meter_offset_is_the_mean_residual_of_the_last_usable_periods() -> None:
    planned = np.array([40.0, np.nan, 42.0, 44.0, 41.0, 50.0])
    metered = np.array([30.0, 10.0, 38.0, 40.0, 38.0, np.nan])
    # usable: 30 − 40, 38 − 42, 40 − 44, 38 − 41 → the last three: −4, −4, −3
    assert meter_offset_kw(planned, metered, periods=3, min_periods=2) == pytest.approx(-11 / 3)
    assert meter_offset_kw(planned, metered, periods=10, min_periods=2) == pytest.approx(-5.25)
    assert meter_offset_kw(planned, metered, periods=10, min_periods=5) == 0.0  # 4 usable


def test_the_offsets_follow_the_time_of_day_where_two_days_show_it() -> None:
    """Four days of 4 periods: the model is 6 kW above the meter in period 1 of each day and
    2 kW above it in period 2; periods 0 and 3 are not usable. The offsets of the next day's
    periods are those of their own time of day, the others the overall mean."""
    history = MeterHistory(window_periods=40)
    residual = {1: -6.0, 2: -2.0}
    for k in range(16):
        history.advance(k, None if k == 0 else 30.0 + residual.get((k - 1) % 4, 0.0))
        history.open(k, 30.0 if k % 4 in residual else math.nan)
    history.advance(16, 30.0 + residual.get(15 % 4, 0.0))
    offsets = history.offsets_kw(4, periods_per_day=4)
    assert offsets[1] == pytest.approx(-6.0) and offsets[2] == pytest.approx(-2.0)
    assert offsets[0] == pytest.approx(-4.0) and offsets[3] == pytest.approx(-4.0)


def test_periods_are_classed_occupied_pull_down_or_idle() -> None:
    """The pull-down's unoccupied steps (8 before an occupied spell) are their own class."""
    occupied = np.zeros(30, dtype=bool)
    occupied[12:20] = True
    classes = period_classes(occupied, 24)
    assert classes.shape == (24,)
    np.testing.assert_array_equal(classes[12:20], OCCUPIED)
    np.testing.assert_array_equal(classes[4:12], PULL_DOWN)
    np.testing.assert_array_equal(classes[:4], IDLE)
    np.testing.assert_array_equal(classes[20:], IDLE)


def test_unoccupied_offsets_are_their_own_class_s_over_the_longer_window() -> None:
    """24 days of 4 periods: period 0 is occupied (the model 5 kW above the meter), period
    1 a pull-down (8 kW above), periods 2 and 3 idle (the meter 3 kW above the model). Each
    class's offsets come from its own rows; the occupied ones are those they were before."""
    classes_of_day = [OCCUPIED, PULL_DOWN, IDLE, IDLE]
    residual = [-5.0, -8.0, 3.0, 3.0]
    history = MeterHistory(window_periods=40, idle_window_periods=96)
    for k in range(96):
        history.advance(k, None if k == 0 else 20.0 + residual[(k - 1) % 4])
        history.open(k, 20.0, classes_of_day[k % 4])
    history.advance(96, 20.0 + residual[3])
    classes = np.array(classes_of_day * 2)
    offsets = history.offsets_kw(8, periods_per_day=4, period_class=classes)
    np.testing.assert_allclose(offsets, residual * 2)
    # without classes every period is occupied: the occupied rows' offsets, as before
    occupied_only = history.offsets_kw(4, periods_per_day=4)
    np.testing.assert_allclose(occupied_only, -5.0)
    assert history.planned_kw.size == 40 and np.isfinite(history.planned_kw).sum() == 10
    # ρ reads the occupied rows only
    assert np.isnan(history.planned_kw[1::4]).all()
    resumed = MeterHistory(window_periods=40, idle_window_periods=96)
    resumed.set_state(decode(encode(history.get_state())))
    np.testing.assert_array_equal(
        resumed.offsets_kw(8, periods_per_day=4, period_class=classes), offsets
    )


def test_a_state_stored_before_the_classes_resumes_with_its_rows_occupied() -> None:
    old = {
        "planned_kw": np.array([10.0, math.nan, 12.0]),
        "metered_kw": np.array([9.0, 8.0, 11.0]),
        "next_period": 3,
        "open_period": -1,
        "open_planned_kw": math.nan,
    }
    history = MeterHistory()
    history.set_state(old)
    np.testing.assert_array_equal(history.planned_kw, old["planned_kw"])
    np.testing.assert_array_equal(history.metered_kw, old["metered_kw"])
    np.testing.assert_array_equal(history.period_class, [OCCUPIED, -1, OCCUPIED])
