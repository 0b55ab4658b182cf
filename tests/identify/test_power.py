"""The power model from the meter: recovered from a metered relation written out by hand,
graded per occupied and unoccupied hours, and refused where the data cannot carry it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.building.identified import MIN_RUNNING_PERIODS, metered_power_kw
from hvacflex.errors import InputError
from hvacflex.identify.power import (
    evaluate_power,
    fit_power_model,
    metered_power_model,
    power_inputs,
    power_inputs_from_results,
    power_kw,
)
from hvacflex.identify.trend import read_trend, write_trend
from hvacflex.units import CP_AIR_J_PER_KG_K

ZONES = ("Room-A", "ROOM_b")
SUPPLY_TEMP_DEGC = 13.0
TRUE = {
    "base_kw": 0.8,
    "kw_per_kw_cooling": 0.28,
    "kw_per_k_outdoor": 0.03,
    "occupied_kw": 0.6,
    "kw_per_kg_s_k_outdoor_occupied": 0.4,
    "running_kw": 1.5,
    "fan_kw_per_kg_s": 2.0,
    "fan_kw_per_kg2_s2": 3.0,
    "kw_per_kw_cooling_k_outdoor": 0.006,
    "kw_per_kw2_cooling": -0.002,
    "kw_per_kg_s_occupied": 5.0,
    "kw_per_humidity_ratio_occupied": 900.0,
}
"""A meter of every term the model has (a concave plant: its power per kW falls with load)."""


def _metered_trend(days: int, seed: int = 0) -> pd.DataFrame:
    """(days · 48, columns) a trend whose meter is :data:`TRUE` written out by hand: random
    flows, the loop off at night on some days, zones at random temperatures."""
    rng = np.random.default_rng(seed)
    steps = days * 48
    index = pd.date_range("2014-03-03", periods=steps, freq="30min", tz="Asia/Singapore")
    hour = index.hour.to_numpy() + index.minute.to_numpy() / 60
    occupied = ((hour >= 8) & (hour < 18) & (index.day_of_week.to_numpy() < 5)).astype(float)
    outdoor = 27 + 4 * np.sin((hour - 9) / 24 * 2 * np.pi) + rng.normal(0, 0.5, steps)
    flow = rng.uniform(0.05, 0.6, size=(steps, 2))
    off = (occupied == 0) & (rng.uniform(size=steps) < 0.5)
    flow[off] = 0.0
    temps = rng.uniform(22.0, 28.0, size=(steps, 2))
    total = flow.sum(axis=1)
    cooling = (flow * CP_AIR_J_PER_KG_K / 1000.0 * (temps - SUPPLY_TEMP_DEGC)).sum(axis=1)
    outdoor_air = (flow * (outdoor[:, None] - temps)).sum(axis=1)
    humidity = rng.uniform(0.014, 0.024, steps)
    t = TRUE
    power = (
        t["base_kw"]
        + t["kw_per_k_outdoor"] * outdoor
        + t["occupied_kw"] * occupied
        + t["running_kw"] * (total > 0)
        + t["fan_kw_per_kg_s"] * total
        + t["fan_kw_per_kg2_s2"] * total**2
        + cooling * (t["kw_per_kw_cooling"] + t["kw_per_kw_cooling_k_outdoor"] * (outdoor - 30))
        + t["kw_per_kw2_cooling"] * cooling**2
        + occupied * (t["kw_per_kg_s_k_outdoor_occupied"] * outdoor_air)
        + occupied * t["kw_per_kg_s_occupied"] * total
        + occupied * t["kw_per_humidity_ratio_occupied"] * (humidity - 0.018)
    )
    frame = pd.DataFrame(index=index)
    for i, zone in enumerate(ZONES):
        frame[f"temp_{zone}_degc"] = temps[:, i]
        frame[f"supply_flow_{zone}_kg_s"] = flow[:, i]
        frame[f"supply_temp_{zone}_degc"] = SUPPLY_TEMP_DEGC
    frame["outdoor_temp_degc"] = outdoor
    frame["ghi_w_per_m2"] = 0.0
    frame["outdoor_humidity_ratio_kg_per_kg"] = humidity
    frame["occupied"] = occupied
    frame["hvac_power_kw"] = power
    return frame


@pytest.fixture(scope="module")
def metered(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("power") / "trend.csv"
    write_trend(_metered_trend(days=8), path)
    return path


def test_every_term_of_a_metered_relation_is_recovered(metered: Path) -> None:
    inputs = power_inputs(read_trend(metered))
    power = fit_power_model(inputs, (0, 7 * 48))
    for name, value in TRUE.items():
        assert getattr(power, name) == pytest.approx(value, rel=1e-3, abs=1e-4), name
    assert power.running_periods == np.sum(inputs.flow_kg_s[: 7 * 48].sum(axis=1) > 0)
    # the model file's formula (one supply temperature) gives the fit's power
    fitted = power_kw(power, inputs)
    formula = metered_power_kw(
        power,
        SUPPLY_TEMP_DEGC,
        inputs.flow_kg_s,
        inputs.zone_temp_degc,
        inputs.outdoor_temp_degc,
        inputs.occupied,
        inputs.outdoor_humidity_ratio_kg_per_kg,
    )
    np.testing.assert_allclose(formula, fitted, atol=1e-9)
    np.testing.assert_allclose(fitted, inputs.metered_kw, atol=1e-3)


def test_a_trend_without_outdoor_humidity_leaves_the_moisture_term_out(
    tmp_path: Path,
) -> None:
    frame = _metered_trend(days=8)
    dry = frame.drop(columns="outdoor_humidity_ratio_kg_per_kg")
    inputs = power_inputs(read_trend(write_trend(dry, tmp_path / "dry.csv")))
    assert inputs.outdoor_humidity_ratio_kg_per_kg is None
    power = fit_power_model(inputs, (0, 7 * 48))
    assert power.kw_per_humidity_ratio_occupied == 0.0
    # the moisture it cannot see is left in the residual: the fit is worse than with it
    residual = power_kw(power, inputs) - inputs.metered_kw
    assert np.sqrt(np.mean(residual**2)) > 0.5


def test_the_report_grades_occupied_and_unoccupied_hours_apart(metered: Path) -> None:
    inputs = power_inputs(read_trend(metered))
    exact = fit_power_model(inputs, (0, 7 * 48))
    # a model 0.5 kW high while occupied only: bias 0.5 there, 0 outside
    high = replace(exact, occupied_kw=exact.occupied_kw + 0.5)
    report = evaluate_power(high, inputs, (7 * 48, 8 * 48))
    day = report[report["day"] == "2014-03-10"].set_index("hours")  # a Monday
    assert list(report["day"].unique()) == ["2014-03-10", "test days"]
    occupied_periods = int(inputs.occupied[7 * 48 :].sum())
    assert day.loc["occupied", "periods"] == occupied_periods == 20
    assert day.loc["unoccupied", "periods"] == 48 - occupied_periods
    assert day.loc["occupied", "power_bias_kw"] == pytest.approx(0.5, abs=1e-3)
    assert day.loc["occupied", "power_rmse_kw"] == pytest.approx(0.5, abs=1e-3)
    assert day.loc["unoccupied", "power_rmse_kw"] == pytest.approx(0.0, abs=1e-3)
    measured_kwh = inputs.metered_kw[7 * 48 :].sum() * 0.5
    assert day.loc["all", "measured_kwh"] == pytest.approx(measured_kwh)
    assert day.loc["all", "predicted_kwh"] == pytest.approx(measured_kwh + 0.5 * 0.5 * 20, 1e-4)


def test_the_synthetic_grey_box_trend_gives_its_meter_back(
    tmp_path: Path, synthetic_trend: Callable[..., pd.DataFrame]
) -> None:
    path = write_trend(synthetic_trend(days=6, seed=1, noise_k=0.02), tmp_path / "trend.csv")
    data = read_trend(path)
    power = metered_power_model(data, ZONES, (0, 5 * 48))
    assert power is not None
    assert power.kw_per_kw_cooling == pytest.approx(0.3, abs=2e-3)  # temps carry 0.02 K noise
    assert power.kw_per_k_outdoor == pytest.approx(0.05, abs=2e-3)
    assert power.running_kw == 0.0  # the loop never stops: the intercept carries it
    report = evaluate_power(power, power_inputs(data, ZONES), (5 * 48, 6 * 48))
    every = report[(report["day"] == "test days") & (report["hours"] == "all")]
    assert abs(every["error_pct"].iloc[0]) < 0.5


def test_a_trend_without_a_meter_is_refused_naming_the_column(
    metered: Path, tmp_path: Path
) -> None:
    frame = read_trend(metered).frame.drop(columns=["hvac_power_kw"])
    path = write_trend(frame.rename_axis("time"), tmp_path / "no_meter.csv")
    data = read_trend(path)
    with pytest.raises(InputError, match="no metered HVAC power") as caught:
        power_inputs(data)
    assert caught.value.field == "hvac_power_kw" and "no_meter.csv" in str(caught.value)
    assert metered_power_model(data, ZONES, (0, 48)) is None  # identify fit: ideal loads


def test_too_few_running_periods_are_refused_naming_the_fix(metered: Path) -> None:
    inputs = power_inputs(read_trend(metered))
    with pytest.raises(InputError, match="fewer than 96") as caught:
        fit_power_model(inputs, (0, MIN_RUNNING_PERIODS - 1), source="trend.csv")
    assert caught.value.field == "--train" and "more days" in str(caught.value)


def test_a_run_s_results_are_read_as_the_period_means_of_its_plant() -> None:
    index = pd.date_range("2014-03-03 07:30", periods=2, freq="30min", tz="Asia/Singapore")
    results = pd.DataFrame(
        {
            "flow_a_kg_s": [0.0, 0.4],
            "temp_a_degc": [27.0, 26.0],
            "temp_end_a_degc": [26.0, 24.0],
            "d_outdoor_temp_degc": [28.0, 29.0],
            "power_kw": [1.0, 9.0],
        },
        index=index,
    )
    inputs = power_inputs_from_results(results, ("a",), 13.0)
    np.testing.assert_allclose(inputs.zone_temp_degc[:, 0], [26.5, 25.0])
    np.testing.assert_allclose(inputs.occupied, [0.0, 1.0])  # 08:00: the schedule's
    np.testing.assert_allclose(inputs.supply_temp_degc, 13.0)
    np.testing.assert_allclose(inputs.metered_kw, [1.0, 9.0])
    assert inputs.outdoor_humidity_ratio_kg_per_kg is None  # an older run's: no moisture term
    humid = results.assign(outdoor_humidity_ratio_kg_per_kg=[0.016, 0.021])
    with_humidity = power_inputs_from_results(humid, ("a",), 13.0)
    assert with_humidity.outdoor_humidity_ratio_kg_per_kg is not None
    np.testing.assert_allclose(with_humidity.outdoor_humidity_ratio_kg_per_kg, [0.016, 0.021])
    for slip in (16.0, float("nan")):  # g/kg, an unset period
        bad = results.assign(outdoor_humidity_ratio_kg_per_kg=[0.016, slip])
        with pytest.raises(InputError, match="outdoor humidity ratio") as refused:
            power_inputs_from_results(bad, ("a",), 13.0)
        assert refused.value.field == "outdoor_humidity_ratio_kg_per_kg"
    with pytest.raises(InputError, match="lack the columns") as caught:
        power_inputs_from_results(results.drop(columns=["power_kw"]), ("a",), 13.0)
    assert caught.value.field == "power_kw"
