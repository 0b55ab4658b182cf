"""The fan-only air of an identified building in the plan: the idle bound delivers what the
fan-only air delivers (checked against the linearised heat balance by hand), only in the
coil's off hours, at the fan's own flow for units per zone; with one air system a calling zone
starts the coil for the idle ones, with a unit per zone it does not."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.building.discretize import linearize
from hvacflex.building.identified import IdentifiedIdleAir, IdentifiedPower
from hvacflex.building.io import load_building
from hvacflex.config import preset
from hvacflex.control.base import PeriodInputs
from hvacflex.control.idle_air import (
    coil_started_flows_kg_s,
    fan_only_input_kg_s,
    fans_started_flows_kg_s,
    idle_flow_min_kg_s,
    shares_one_coil,
)
from hvacflex.control.mpc import MPCController
from hvacflex.control.problem_builder import PlanContext, build_problem
from hvacflex.identify.greybox import GreyBoxParameters
from hvacflex.identify.model_file import AirSystem, IdentifiedModel, write_identified_model
from hvacflex.sim.setup import make_controller, prepare
from hvacflex.units import CP_AIR_J_PER_KG_K

ZONES = np.array(
    [
        [800.0, 3.0e4, 0.05, 0.8, 0.03, 3.0, 6.0, 0.0, 2.0, 0.5, 0.0, 1.5, 0.4],
        [1200.0, 6.0e4, 0.08, 1.2, 0.05, 5.0, 8.0, 1.0, 0.0, 0.0, 3.0, 2.5, 0.2],
    ]
)
FLOW_MIN_KG_S = np.array([0.14, 0.08])
NIGHT = tuple(p < 12 or p >= 40 for p in range(48))  # 20:00–06:00
DIFFERENCE_K = (-0.8, 1.5)


def _model(tmp_path: Path, idle: IdentifiedIdleAir | None, power: bool = False) -> Path:
    model = IdentifiedModel(
        name="two zones",
        zones=("a", "b"),
        energyplus_zones=("A", "B"),
        parameters=GreyBoxParameters(ZONES, np.array([[0, 1]], dtype=np.int64), np.array([0.3])),
        power=IdentifiedPower(base_kw=1.0, kw_per_kw_cooling=0.3, kw_per_k_outdoor=0.02)
        if power
        else None,
        provenance={},
        air=AirSystem(16.0, tuple(FLOW_MIN_KG_S), (0.5, 0.8), tuple(FLOW_MIN_KG_S), (24.0, 24.0)),
        idle_air=idle,
    )
    return write_identified_model(model, tmp_path / "model.toml")


def test_the_idle_bound_delivers_the_fan_only_air_in_the_coils_off_hours(tmp_path: Path) -> None:
    idle = IdentifiedIdleAir(
        fan_only=(NIGHT,) * 5 + ((True,) * 48,) * 2, fan_only_difference_k=DIFFERENCE_K
    )
    building = load_building(_model(tmp_path, idle))
    model = linearize(building)
    index = pd.date_range("2014-03-25 19:00", periods=4, freq="30min", tz="Asia/Singapore")
    u_min = np.tile(FLOW_MIN_KG_S, (4, 1))
    zone_temp = np.array([27.0, 25.5])
    bound = idle_flow_min_kg_s(u_min, building, model, index, zone_temp)
    np.testing.assert_array_equal(bound[:2], u_min[:2])  # 19:00, 19:30: the coil's hours
    # 20:00 on: the linearised HVAC heat c_p (T_s − T₀) u − ṁ₀ c_p (Ta − T₀) [W] of the bound
    # is the fan-only air's, −ṁ_min c_p ΔT — except where that would exceed the minimum flow
    t0, ts = model.linearisation_temp_degc, model.supply_temp_degc
    heat_w = CP_AIR_J_PER_KG_K * ((ts - t0) * bound[2] - FLOW_MIN_KG_S * (zone_temp - t0))
    fan_w = -FLOW_MIN_KG_S * CP_AIR_J_PER_KG_K * np.array(DIFFERENCE_K)
    assert heat_w[0] == pytest.approx(fan_w[0], rel=1e-9)
    assert bound[2, 0] < FLOW_MIN_KG_S[0]  # warmer air than the zone's: less than no air
    assert (bound[2:] <= u_min[2:]).all()
    np.testing.assert_array_equal(bound[2], bound[3])


def test_units_per_zone_deliver_the_fan_only_air_at_their_fans_flow(tmp_path: Path) -> None:
    """``fan_only_flow_kg_s`` (a packaged unit per zone, the minimum flow 0): the bound is the
    fan's flow of fan-only air, and a zone's call does not start the others' coils."""
    fan_kg_s = (0.5, 0.6)
    idle = IdentifiedIdleAir(
        fan_only=(NIGHT,) * 7, fan_only_difference_k=DIFFERENCE_K, fan_only_flow_kg_s=fan_kg_s
    )
    building = load_building(_model(tmp_path, idle))
    assert not shares_one_coil(building)
    model = linearize(building)
    index = pd.date_range("2014-03-25 20:00", periods=1, freq="30min", tz="Asia/Singapore")
    u_min = np.tile(FLOW_MIN_KG_S, (1, 1))
    zone_temp = np.array([27.0, 25.5])
    bound = idle_flow_min_kg_s(u_min, building, model, index, zone_temp)
    t0, ts = model.linearisation_temp_degc, model.supply_temp_degc
    heat_w = CP_AIR_J_PER_KG_K * ((ts - t0) * bound[0] - FLOW_MIN_KG_S * (zone_temp - t0))
    fan_w = -np.array(fan_kg_s) * CP_AIR_J_PER_KG_K * np.array(DIFFERENCE_K)
    assert heat_w[0] == pytest.approx(fan_w[0], rel=1e-9)  # 0.5 kg/s of air 0.8 K warmer
    fan_input = fan_only_input_kg_s(building, model, zone_temp)
    assert fan_input is not None
    np.testing.assert_array_equal(bound[0], np.minimum(u_min[0], fan_input))
    one_coil = replace(idle, fan_only_flow_kg_s=None)
    assert shares_one_coil(load_building(_model(tmp_path, one_coil)))
    assert not shares_one_coil(load_building(_model(tmp_path, None)))


def test_without_idle_air_or_outside_its_hours_the_bounds_are_unchanged(tmp_path: Path) -> None:
    building = load_building(_model(tmp_path, None))
    model = linearize(building)
    index = pd.date_range("2014-03-25 21:00", periods=3, freq="30min", tz="Asia/Singapore")
    u_min = np.tile(FLOW_MIN_KG_S, (3, 1))
    same = idle_flow_min_kg_s(u_min, building, model, index, np.array([27.0, 26.0]))
    np.testing.assert_array_equal(same, u_min)


def test_a_calling_zone_starts_the_coil_for_the_idle_ones() -> None:
    flow_min = np.array([0.14, 0.08, 0.2])
    fan_bound = np.array([0.02, 0.01, 0.2])  # zones 0 and 1 fan-only, zone 2 not
    idle = coil_started_flows_kg_s(np.array([0.02, 0.01, 0.2]), fan_bound, flow_min)
    np.testing.assert_array_equal(idle, [0.02, 0.01, 0.2])  # nobody calls: fan-only air
    calling = coil_started_flows_kg_s(np.array([0.02, 0.3, 0.2]), fan_bound, flow_min)
    np.testing.assert_array_equal(calling, [0.14, 0.3, 0.2])  # zone 1 calls: the coil runs
    coil_hours = coil_started_flows_kg_s(np.array([0.14, 0.3, 0.2]), flow_min, flow_min)
    np.testing.assert_array_equal(coil_hours, [0.14, 0.3, 0.2])


def test_a_calling_zone_starts_every_units_fan_for_the_idle_ones() -> None:
    """Units per zone: the setpoint actuation forces every unit on when one zone calls, so
    the zones that do not call receive their fan-only air (below their minimum flow)."""
    flow_min = np.zeros(3)
    fan_input = np.array([-0.04, -0.03, -0.05])
    quiet = fans_started_flows_kg_s(np.zeros(3), fan_input, flow_min)
    np.testing.assert_array_equal(quiet, [0.0, 0.0, 0.0])  # nobody calls: the fans stay off
    calling = fans_started_flows_kg_s(np.array([0.0, 0.3, 0.0]), fan_input, flow_min)
    np.testing.assert_array_equal(calling, [-0.04, 0.3, -0.05])
    in_hours = fans_started_flows_kg_s(np.array([-0.04, 0.3, -0.05]), fan_input, flow_min)
    np.testing.assert_array_equal(in_hours, [-0.04, 0.3, -0.05])  # already the fans' air


def test_the_mpc_plans_with_the_fan_only_bound_unless_switched_off(tmp_path: Path) -> None:
    """``[controller] fan_only_air``: a night step's lower bound is the fan-only input (on, the
    default) or the minimum flow (off); a working day's office step keeps the minimum."""
    idle = IdentifiedIdleAir(
        fan_only=(NIGHT,) * 5 + ((True,) * 48,) * 2, fan_only_difference_k=DIFFERENCE_K
    )
    path = _model(tmp_path, idle, power=True)
    bounds = {}
    for flag in (True, False):
        config = preset("rmpc", building=str(path), start="2014-03-03", days=1.0)
        config = replace(config, controller=replace(config.controller, fan_only_air=flag))
        setup = prepare(config)
        controller = make_controller(setup)
        assert isinstance(controller, MPCController)
        x = np.full(len(setup.model.node_names), 27.0)
        inputs = PeriodInputs(x, setup.forecaster.forecast(0, 48), 0.0)  # Monday 00:00
        problem = build_problem(setup.model, inputs, controller.contract, PlanContext(x))
        bounds[flag] = np.asarray(problem.u_min)
    np.testing.assert_array_equal(bounds[False][0], FLOW_MIN_KG_S)
    assert (bounds[True][0] < FLOW_MIN_KG_S).all()  # 00:00: the coil is off
    office = 20  # 10:00: the coil's hours
    np.testing.assert_array_equal(bounds[True][office], bounds[False][office])
