"""The plan graded by the meter, on hand-made frames whose answers are computed by hand."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from hvacflex import meter_grade

TZ = "Asia/Singapore"


def frame(
    start: str,
    power_kw: list[float],
    planned_kw: list[float],
    committed_kw: list[float] | None = None,
    freq: str = "30min",
) -> pd.DataFrame:
    index = pd.date_range(start, periods=len(power_kw), freq=freq, tz=TZ, name="time")
    columns: dict[str, object] = {"power_kw": power_kw, "planned_power_kw": planned_kw}
    if committed_kw is not None:
        columns["committed_peak_kw"] = committed_kw
    return pd.DataFrame(columns, index=index)


def test_planned_over_metered_energy_in_occupied_and_unoccupied_periods() -> None:
    df = frame("2014-03-03 07:00", [10.0, 40.0, 44.0, 6.0], [8.0, 44.0, 44.0, 3.0])
    occupied = np.array([False, True, True, False])
    out = meter_grade.planned_metered_kwh(df, occupied, step_h=0.5)
    assert out["planned_occupied_kwh"] == pytest.approx(44.0)  # (44 + 44) × 0.5
    assert out["metered_occupied_kwh"] == pytest.approx(42.0)  # (40 + 44) × 0.5
    assert out["planned_over_metered_occupied"] == pytest.approx(88.0 / 84.0)
    assert out["planned_over_metered_unoccupied"] == pytest.approx(11.0 / 16.0)


def test_a_rule_without_a_plan_grades_nan() -> None:
    nan = math.nan
    df = frame("2014-03-03 07:00", [10.0, 40.0], [nan, nan])
    out = meter_grade.planned_metered_kwh(df, np.array([False, True]), step_h=0.5)
    assert math.isnan(out["planned_over_metered_occupied"])
    assert math.isnan(out["metered_occupied_kwh"])  # graded only where there is a plan
    assert out["unplanned_periods"] == 2
    assert meter_grade.monthly_peaks(df).empty


def test_weekday_peaks_against_the_days_largest_commitment() -> None:
    # Friday 2014-03-07 and Saturday 03-08, two periods each, 12 h apart
    df = frame(
        "2014-03-07 10:00",
        [40.0, 42.0, 50.0, 1.0],
        [41.0, 41.0, 30.0, 1.0],
        committed_kw=[40.0, 41.0, 30.0, 30.0],
        freq="12h",
    )
    days = meter_grade.weekday_peaks(df)
    assert len(days) == 1  # the Saturday is not graded
    assert days["metered_peak_kw"].iloc[0] == 42.0
    assert days["ratio"].iloc[0] == pytest.approx(42.0 / 41.0)
    out = meter_grade.summary(df, np.ones(4, dtype=bool), step_h=12.0)
    assert out["weekday_peak_over_committed_max"] == pytest.approx(42.0 / 41.0)
    assert out["weekday_peak_within_commitment_share"] == 1.0  # 1.024 ≤ 1.05
    # the month's metered peak is Saturday's 50 against a largest plan of 41
    assert out["monthly_peak_over_planned_max"] == pytest.approx(50.0 / 41.0)


def test_a_day_over_its_commitment_counts_against_the_share() -> None:
    df = frame("2014-03-03 10:00", [40.0, 50.0], [40.0, 40.0], [40.0, 40.0], freq="24h")
    out = meter_grade.summary(df, np.ones(2, dtype=bool), step_h=0.5)
    assert out["weekday_peak_within_commitment_share"] == pytest.approx(0.5)  # 1.25 > 1.05


def test_without_a_committed_peak_the_peak_keys_are_nan() -> None:
    df = frame("2014-03-03 10:00", [40.0, 50.0], [40.0, 40.0])
    out = meter_grade.summary(df, np.ones(2, dtype=bool), step_h=0.5)
    assert math.isnan(out["weekday_peak_over_committed_max"])
    assert math.isnan(out["weekday_peak_within_commitment_share"])


def test_a_period_without_a_plan_is_graded_by_neither_sum() -> None:
    df = frame("2014-03-03 08:00", [40.0, 40.0, 44.0], [44.0, math.nan, 44.0])
    out = meter_grade.planned_metered_kwh(df, np.ones(3, dtype=bool), step_h=0.5)
    assert out["planned_occupied_kwh"] == pytest.approx(44.0)
    assert out["metered_occupied_kwh"] == pytest.approx(42.0)
    assert out["unplanned_periods"] == 1
