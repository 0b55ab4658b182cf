"""The fit recovers a model it can represent, and refuses what it cannot fit."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from hvacflex.data.weather import EpwLocation
from hvacflex.errors import InputError
from hvacflex.identify.fit import (
    FitData,
    air_system,
    evaluate,
    fit_inputs,
    fit_model,
    idle_air,
    tune_filter,
    tune_predictor,
)
from hvacflex.identify.greybox import (
    EXOGENOUS_INPUTS,
    ZONE_PARAMETERS,
    FilterNoise,
    GreyBoxParameters,
    cooling_change_kw,
    discretize,
    one_step_predictions,
)
from hvacflex.identify.trend import read_trend, write_trend

ZONES = ("Room-A", "ROOM_b")
SITE = EpwLocation(1.37, 103.98, 8.0, 15.0, "Singapore Changi")
COOLING = len(EXOGENOUS_INPUTS)


@pytest.fixture(scope="module")
def trend(
    tmp_path_factory: pytest.TempPathFactory, synthetic_trend: Callable[..., pd.DataFrame]
) -> Path:
    path = tmp_path_factory.mktemp("fit") / "trend.csv"
    write_trend(synthetic_trend(days=6, seed=1, noise_k=0.02), path)
    return path


def test_the_fit_predicts_a_model_of_its_own_structure(trend: Path) -> None:
    data = read_trend(trend)
    inputs = fit_inputs(data, ("room-a", "room_B"), SITE)  # any case
    assert inputs.zones == ZONES
    result = fit_model(inputs, [(0, 1)], (0, 5 * 48))
    report = evaluate(result, inputs, (5 * 48, 6 * 48))
    # noise 0.02 K on the measurements; a zero model error would leave ~0.02 K
    assert (report["rmse_24h_k"] < 0.15).all(), report
    assert (report["rmse_1step_k"] < 0.1).all(), report
    assert (report["bias_k"].abs() < 0.1).all()
    # the morning and afternoon walls are told apart from the horizontal (near the equator
    # the north and south walls see mostly diffuse light: less well determined)
    assert result.parameters.value("solar_wall_east_m2") == pytest.approx([4.0, 0.0], abs=0.2)
    assert result.parameters.value("solar_wall_west_m2") == pytest.approx([0.0, 3.0], abs=0.2)
    # the standard errors exist and are finite for the well-identified capacitances
    assert np.isfinite(result.standard_errors.zone[:, 0]).all()


def _random_inputs(
    rng: np.random.Generator,
    steps: int,
    *,
    outdoor_sd_k: float,
    cooling_kw: np.ndarray | None = None,
) -> np.ndarray:
    """(steps, 10) inputs of a two-zone grey box: outdoor air about 28 °C (± ``outdoor_sd_k``
    [K]), the sun, occupancy, the constant, the four walls' sun, and the two zones' cooling
    [kW] (``cooling_kw`` (steps, 2), or drawn uniform 0 … 3 after the rest)."""
    exogenous = [
        28 + rng.normal(0, outdoor_sd_k, steps),
        rng.uniform(0, 0.8, steps),
        rng.integers(0, 2, steps),
        np.ones(steps),
        rng.uniform(0, 0.5, (steps, 4)),  # the walls
    ]
    cooling = rng.uniform(0, 3, (steps, 2)) if cooling_kw is None else cooling_kw
    return np.column_stack([*exogenous, cooling])


def test_the_filter_tuned_on_data_with_a_hidden_gain_carries_a_gain_state() -> None:
    zone = np.array(
        [
            [800.0, 3.0e4, 0.05, 0.8, 0.03, 3.0, 6.0, 0.0, 2.0, 0.0, 1.0, 1.5, 0.4],
            [1200.0, 6.0e4, 0.08, 1.2, 0.05, 5.0, 8.0, 1.0, 0.0, 2.0, 0.0, 2.5, 0.2],
        ]
    )
    model = discretize(GreyBoxParameters(zone, np.array([[0, 1]]), np.array([0.3])))
    rng = np.random.default_rng(4)
    steps = 6 * 48
    index = pd.date_range("2014-03-03", periods=steps, freq="30min", tz="Asia/Singapore")
    u = _random_inputs(rng, steps, outdoor_sd_k=1.0)
    hidden_kw = np.where((np.arange(steps) // 40) % 2 == 0, 1.0, -0.5)  # both zones
    x, y = np.full(4, 25.0), np.empty((steps, 2))
    for k in range(steps):
        u_true = u[k].copy()
        u_true[COOLING:] -= hidden_kw[k]
        y[k] = model.c_mean @ x + model.d_mean @ u_true
        x = model.a @ x + model.b @ u_true
    data = FitData(index=index, zones=ZONES, y=y, u=u)
    starts = np.arange(1, 6) * 48
    noise = tune_filter(model, data, starts)
    assert noise.gain_kw > 0
    rows = slice(48, steps)

    def mse(n: FilterNoise) -> float:
        return float(((one_step_predictions(model, y, u, n)[rows] - y[rows]) ** 2).mean())

    assert mse(noise) < 0.5 * mse(FilterNoise())


@pytest.mark.parametrize("share", [0.0, 0.3])
def test_the_predictor_finds_how_much_of_the_cooling_change_comes_early(share: float) -> None:
    """Data from the model whose cooling's change comes early by ``share`` (a setpoint step
    answered at once by the plant's coil): tuned on them, the predictor takes that share."""
    params = GreyBoxParameters(
        np.array(
            [
                [300.0, 3.0e4, 0.02, 0.5, 0.03, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 1.0, 0.4],
                [400.0, 6.0e4, 0.03, 0.6, 0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 1.5, 0.2],
            ]
        ),
        np.array([[0, 1]]),
        np.array([0.05]),
    )
    truth = discretize(params, cooling_change_share=share)
    rng = np.random.default_rng(8)
    steps = 6 * 48
    levels = np.repeat(rng.choice([0.0, 1.0, 3.0], size=(steps // 4, 2)), 4, axis=0)
    u = _random_inputs(rng, steps, outdoor_sd_k=0.5, cooling_kw=levels)  # stepping every 2 h
    change = cooling_change_kw(u, 2)
    x, y = np.full(4, 25.0), np.empty((steps, 2))
    for k in range(steps):
        y[k] = truth.c_mean @ x + truth.d_mean @ u[k] + truth.d_change @ change[k]
        x = truth.a @ x + truth.b @ u[k] + truth.b_change @ change[k]
    y += rng.normal(0, 0.02, y.shape)
    index = pd.date_range("2014-03-03", periods=steps, freq="30min", tz="Asia/Singapore")
    found, _ = tune_predictor(params, FitData(index, ZONES, y, u), np.arange(1, 6) * 48)
    assert found == pytest.approx(share)


def test_too_few_days_are_refused(trend: Path) -> None:
    inputs = fit_inputs(read_trend(trend), ZONES, SITE)
    with pytest.raises(InputError, match="too few days to fit"):
        fit_model(inputs, [], (0, 3 * 48))


def test_a_zone_the_data_lacks_or_without_supply_air_is_refused(
    trend: Path, tmp_path: Path, synthetic_trend: Callable[..., pd.DataFrame]
) -> None:
    data = read_trend(trend)
    with pytest.raises(InputError, match="no such zone") as caught:
        fit_inputs(data, ("Room-A", "attic"), SITE)
    assert caught.value.value == "attic"
    frame = synthetic_trend(days=1).drop(
        columns=["supply_flow_ROOM_b_kg_s", "supply_temp_ROOM_b_degc"]
    )
    path = write_trend(frame, tmp_path / "setpoint_only.csv")
    with pytest.raises(InputError, match="supply flow and supply temperature"):
        fit_inputs(read_trend(path), ZONES, SITE)


def test_a_parameter_pushed_onto_its_bound_is_named_in_the_warnings() -> None:
    from hvacflex.identify.fit import _bound_warnings, _initial_and_bounds

    prior, low, high, _ = _initial_and_bounds(2, 1)
    theta = prior.copy()
    k = len(ZONE_PARAMETERS)
    theta[0], theta[k + 1] = low[0], high[k + 1]  # zone A's c_air, zone B's c_mass
    assert _bound_warnings(theta, low, high, ("A", "B")) == [
        "A: c_air_kj_per_k at its bound 10",
        "B: c_mass_kj_per_k at its bound 1e+07",
    ]
    assert _bound_warnings(prior, low, high, ("A", "B")) == []


def test_a_boundary_node_is_recovered_from_its_own_balance() -> None:
    """A plenum that follows the node's forward-Euler balance exactly: the fitted node has
    the capacitance, outdoor conductance, solar share and gain it was made with."""
    from hvacflex.identify.fit import FitData, fit_boundary_nodes
    from hvacflex.identify.greybox import GreyBoxParameters

    rng = np.random.default_rng(4)
    steps = 400
    index = pd.date_range("2014-03-03", periods=steps, freq="30min", tz="Asia/Singapore")
    zone = 24.0 + rng.normal(0, 1.0, (steps, 1))
    outdoor, ghi = 28.0 + rng.normal(0, 2.0, steps), rng.uniform(0, 0.9, steps)
    occupied = (rng.uniform(size=steps) > 0.5).astype(float)
    c_kj, ua_zone, ua_out, solar, gain = 2000.0, 0.4, 0.1, 3.0, 0.5
    plenum = np.empty(steps)
    plenum[0] = 26.0
    for k in range(steps - 1):
        heat = ua_zone * (zone[k, 0] - plenum[k]) + ua_out * (outdoor[k] - plenum[k])
        heat += solar * ghi[k] + gain * occupied[k]
        plenum[k + 1] = plenum[k] + 1800.0 / c_kj * heat
    walls = np.zeros((steps, 4))
    u = np.column_stack([outdoor, ghi, occupied, np.ones(steps), walls, np.zeros(steps), plenum])
    data = FitData(index, ("room",), zone, u, boundaries=("Plenum",))
    parameters = GreyBoxParameters(
        np.zeros((1, len(ZONE_PARAMETERS))),
        np.zeros((0, 2), dtype=np.int64),
        np.zeros(0),
        boundaries=1,
        boundary_couplings=np.array([[0, 0]], dtype=np.int64),
        boundary_ua_kw_per_k=np.array([ua_zone]),
    )
    (node,) = fit_boundary_nodes(parameters, data, (0, steps), (300, steps))
    assert node.c_kj_per_k == pytest.approx(c_kj, rel=1e-6)
    assert node.ua_out_kw_per_k == pytest.approx(ua_out, rel=1e-6)
    assert node.solar_m2 == pytest.approx(solar, rel=1e-6)
    assert node.occupied_gain_kw == pytest.approx(gain, rel=1e-6)
    assert node.temp_degc == pytest.approx(plenum[300:].mean())


def _fan_only_trend(frame: pd.DataFrame) -> pd.DataFrame:
    """The synthetic trend with its coil scheduled off on working days 20:00–06:00 and all
    weekend: there the zones idle at the least flow on air 0.8 K warmer than the zone."""
    out = frame.copy()
    hour = out.index.hour
    off = (hour < 6) | (hour >= 20) | (out.index.day_of_week >= 5)
    for zone in ZONES:
        out.loc[off, f"supply_flow_{zone}_kg_s"] = 0.05
        out.loc[off, f"supply_temp_{zone}_degc"] = out.loc[off, f"temp_{zone}_degc"] + 0.8
    return out


def _week_fitted(tmp_path: Path, trend: pd.DataFrame) -> tuple[Any, Any, tuple[int, int], Any]:
    """A week's trend written and read back: the data, the fit's inputs, the week as the
    training range and the air system seen in it."""
    path = tmp_path / "trend.csv"
    write_trend(trend, path)
    data = read_trend(path)
    inputs = fit_inputs(data, ZONES, SITE)
    train = (0, 7 * 48)
    return data, inputs, train, air_system(inputs, data, train, np.zeros(2))


def test_the_fan_only_hours_and_air_are_learned_from_the_air_or_the_coil_schedule(
    tmp_path: Path, synthetic_trend: Callable[..., pd.DataFrame]
) -> None:
    data, inputs, train, air = _week_fitted(
        tmp_path, _fan_only_trend(synthetic_trend(days=7, seed=3))
    )
    idle = idle_air(inputs, data, train, air)
    assert idle is not None
    table = np.array(idle.fan_only)
    period = np.arange(48)
    night = (period < 12) | (period >= 40)
    # idle air was seen at every period of the day; fan-only exactly where the coil was off
    assert (table[:5] == night).all()
    assert table[5:].all()
    assert idle.fan_only_difference_k == pytest.approx([-0.8, -0.8], abs=1e-6)
    # with the IDF's coil schedule (here: off 22:00–06:00 only) the hours are the schedule's
    starts = inputs.index
    coil = ~np.asarray((starts.hour < 6) | (starts.hour >= 22))
    scheduled = idle_air(inputs, data, train, air, coil)
    assert scheduled is not None
    expected = (period < 12) | (period >= 44)
    assert (np.array(scheduled.fan_only) == expected).all()


def test_no_fan_only_hours_without_fan_only_air_or_with_equivalent_flows(
    tmp_path: Path, synthetic_trend: Callable[..., pd.DataFrame]
) -> None:
    path = tmp_path / "trend.csv"
    frame = synthetic_trend(days=4, seed=4)
    write_trend(frame, path)
    data = read_trend(path)
    inputs = fit_inputs(data, ZONES, SITE)
    air = air_system(inputs, data, (0, 4 * 48), np.zeros(2))
    assert idle_air(inputs, data, (0, 4 * 48), air) is None  # the supply always cools
    cycling = replace(air, supply_temp_degc=19.5)  # a cycling unit's equivalent flows
    fan = tmp_path / "fan.csv"
    write_trend(_fan_only_trend(frame), fan)
    fan_data = read_trend(fan)
    assert idle_air(fit_inputs(fan_data, ZONES, SITE), fan_data, (0, 4 * 48), cycling) is None


def _unit_trend(frame: pd.DataFrame) -> pd.DataFrame:
    """The synthetic trend as a packaged unit per zone: the fans run at 0.4 kg/s on working
    days 06:00–22:00 and not otherwise; the coils cool only 08:00–18:00, so from 06:00 to
    08:00 and 18:00 to 22:00 the zones get fan-only air 0.8 K warmer than the zone."""
    out = frame.copy()
    hour, weekday = out.index.hour, out.index.day_of_week
    fan = (weekday < 5) & (hour >= 6) & (hour < 22)
    fan_only = fan & ((hour < 8) | (hour >= 18))
    for zone in ZONES:
        out[f"supply_flow_{zone}_kg_s"] = np.where(fan, 0.4, 0.0)
        out.loc[fan_only, f"supply_temp_{zone}_degc"] = out.loc[fan_only, f"temp_{zone}_degc"] + 0.8
    return out


def test_units_per_zone_get_their_fans_flow_of_fan_only_air_in_the_fans_hours(
    tmp_path: Path, synthetic_trend: Callable[..., pd.DataFrame]
) -> None:
    """Fan-only air at the fan's flow (above the idle share of the flow range): a unit per
    zone. With the IDF's fan schedule (here on 06:00–22:00 on every day, the coils always
    available) the hours are the schedule's on the weekdays whose training days it covers;
    from the air alone they are where the air was fan-only."""
    trend = _unit_trend(synthetic_trend(days=7, seed=5))
    data, inputs, train, air = _week_fitted(tmp_path, trend)
    assert air.supply_temp_degc < 18.0  # the coil's air, not equivalent flows
    period = np.arange(48)
    from_air = idle_air(inputs, data, train, air)
    assert from_air is not None and from_air.fan_only_flow_kg_s == pytest.approx([0.4, 0.4])
    table = np.array(from_air.fan_only)
    fan_only_hours = ((period >= 12) & (period < 16)) | ((period >= 36) & (period < 44))
    assert (table[:5] == fan_only_hours).all()
    assert not table[5:].any()  # the fans never ran at the weekend
    assert from_air.fan_only_difference_k == pytest.approx([-0.8, -0.8], abs=1e-6)
    hour = inputs.index.hour
    fans = np.asarray((hour >= 6) & (hour < 22))
    coils = np.ones(len(fans), dtype=bool)
    scheduled = idle_air(inputs, data, train, air, coils, fans)
    assert scheduled is not None and scheduled.fan_only_flow_kg_s == pytest.approx([0.4, 0.4])
    assert (np.array(scheduled.fan_only) == ((period >= 12) & (period < 44))).all()
    # units per zone: the coils' schedule alone does not decide (the air does, as above)
    assert idle_air(inputs, data, train, air, coils) == from_air
