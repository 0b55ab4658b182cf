"""PeriodHistory and period_inputs: the one builder of a period's inputs."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hvacflex import state
from hvacflex.config import preset, with_overrides
from hvacflex.data.signals import OperatorSignals
from hvacflex.settlement import ahead_baselines_kw, start_baseline_kw
from hvacflex.sim.history import PeriodHistory, period_inputs
from hvacflex.sim.setup import prepare


def _index(start: str, periods: int) -> pd.DatetimeIndex:
    return pd.date_range(start, periods=periods, freq="30min", tz="Asia/Singapore")


def test_the_peak_floor_is_the_month_s_metered_peak_so_far_by_hand() -> None:
    """Across a month's end the floor restarts at 0; unmetered periods do not count."""
    index = _index("2014-01-31T22:00", 8)  # 22:00 … 01:30 on 1 February
    history = PeriodHistory.empty(index, 8)
    for k, power in enumerate([5.0, 9.0, 7.0, np.nan, 3.0, 2.0]):
        history.record(k, power, False)
    assert history.peak_floor_kw(0) == 0.0
    assert history.peak_floor_kw(3) == 9.0
    assert history.peak_floor_kw(4) == 0.0  # 00:00 on 1 February: a new month
    assert history.peak_floor_kw(6) == 3.0
    history.opening_peak_kw = 8.5  # the bill started before the run: January's only
    assert history.peak_floor_kw(0) == 8.5 and history.peak_floor_kw(3) == 9.0
    assert history.peak_floor_kw(6) == 3.0
    assert history.previous_power_kw(4) is None  # not metered: unknown
    assert history.start_baseline_kw(4, "pre-event") is None
    assert history.start_baseline_kw(6, "pre-event") == 2.0


def test_baselines_are_the_settlement_s_own() -> None:
    index = _index("2014-03-03", 48 * 3 + 10)
    steps = 48 * 3
    rng = np.random.default_rng(3)
    history = PeriodHistory.empty(index, steps)
    k = 48 * 2 + 20
    power = 20.0 + rng.uniform(0, 5, k)
    active = np.zeros(k, dtype=bool)
    active[30:33] = True
    for j in range(k):
        history.record(j, power[j], bool(active[j]))
    rule = "similar-days"
    reserve = with_overrides(preset("rmpc"), {"reserve.il_baseline": rule}).reserve
    expected = start_baseline_kw(rule, power, active, index[: k + 1])
    assert history.start_baseline_kw(k, rule) == expected
    ahead = history.ahead_baselines_kw(k, reserve)
    expected_ahead = ahead_baselines_kw(rule, power, active, index[: k + reserve.ahead_offer_steps])
    assert ahead is not None and expected_ahead is not None
    np.testing.assert_array_equal(ahead, expected_ahead)
    assert history.ahead_baselines_kw(k, preset("rmpc").reserve) is None  # pre-event


def test_the_delivered_input_reaches_only_the_next_period() -> None:
    history = PeriodHistory.empty(_index("2014-03-03", 10), 10)
    flow = np.array([0.2, 0.3])
    history.record(4, 10.0, False, flow)
    np.testing.assert_array_equal(history.delivered_before_kg_s(5), flow)
    assert history.delivered_before_kg_s(6) is None
    restored = PeriodHistory.empty(history.index, 10)
    restored.set_state(state.decode(state.encode(history.get_state())))
    np.testing.assert_array_equal(restored.power_kw, history.power_kw)
    np.testing.assert_array_equal(restored.delivered_before_kg_s(5), flow)


def test_period_inputs_lays_the_signals_over_the_forecast_and_fills_every_field() -> None:
    config = with_overrides(
        preset("rmpc-ppp", start="2014-03-03", days=1.0), {"reserve.il_baseline": "similar-days"}
    )
    setup = prepare(config)
    history = PeriodHistory.empty(setup.exogenous.index, config.steps)
    for j in range(10):
        history.record(j, 30.0 + j, False)
    x = np.full(len(setup.model.node_names), 25.0)
    signals = OperatorSignals(peak_price_sgd_per_kw=7.5)
    inputs = period_inputs(10, history, setup.forecaster, signals, config, x_degc=x)
    assert inputs.forecast.peak_price_sgd_per_kw is not None
    assert np.all(np.asarray(inputs.forecast.peak_price_sgd_per_kw) == 7.5)
    assert inputs.forecast.disturbances.shape[0] == config.controller.horizon_steps + 1
    assert inputs.peak_floor_kw == 39.0
    assert inputs.previous_power_kw == 39.0
    assert inputs.baseline_ahead_kw is not None
    assert len(inputs.baseline_ahead_kw) == config.reserve.ahead_offer_steps
    assert inputs.baseline_power_kw is not None
    assert inputs.delivered_flow_kg_s is None and inputs.locked is None
    with pytest.raises(IndexError):
        history.record(config.steps, 1.0, False)
