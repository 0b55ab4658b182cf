"""The plant interface: RCPlant is the nonlinear RC network, and any Plant runs a closed loop."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hvacflex.building.discretize import delivered_flow_kg_s
from hvacflex.building.hvac import hvac_power_kw
from hvacflex.building.plant import NonlinearPlant
from hvacflex.config import preset, with_overrides
from hvacflex.control.base import Action, Controller, PeriodInputs
from hvacflex.identify.model_file import IdentifiedModel, write_identified_model
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.plant import Actuation, Disturbance, Observation, Plant, RCPlant
from hvacflex.sim.setup import prepare

START = "2014-03-03"


@pytest.fixture(scope="module")
def setup():  # type: ignore[no-untyped-def]
    # the whole-horizon reserve model: every activated period curtails its fresh plan
    cfg = with_overrides(
        preset("paper-rmpc", start=f"{START}T10:00", days=0.25), {"activation.mode": "always"}
    )
    return prepare(cfg)


def test_an_actuation_carries_exactly_one_way_to_drive_the_plant() -> None:
    assert Actuation(setpoint_degc=np.array([24.0])).kind == "setpoint"
    with pytest.raises(ValueError, match="exactly one"):
        Actuation()
    with pytest.raises(ValueError, match="exactly one"):
        Actuation(flow_kg_s=np.ones(1), cooling_kw=np.ones(1))


def test_rc_plant_is_the_nonlinear_network_and_the_exact_power(setup) -> None:  # type: ignore[no-untyped-def]
    building = setup.building
    plant = RCPlant(building)
    assert isinstance(plant, Plant)
    plant.reset(26.0)
    reference = NonlinearPlant(building)
    x = np.full(reference.n, 26.0)
    flow = 0.5 * np.asarray(building.hvac.flow_max_kg_s)
    d = setup.exogenous.disturbances[20]
    t_out = float(setup.exogenous.outdoor_temp_degc[20])
    w = float(setup.exogenous.outdoor_humidity_ratio_kg_per_kg[20])
    observed = plant.step(Actuation(flow_kg_s=flow), Disturbance(d, t_out, w), 1800.0)
    x_next = reference.step(x, flow, d, 1800.0)
    zones = reference.network.zone_node_index
    np.testing.assert_array_equal(observed.node_temp_degc, x_next)
    np.testing.assert_array_equal(observed.zone_temp_degc, x_next[zones])
    mean = 0.5 * (x[zones] + x_next[zones])
    assert observed.power_kw == hvac_power_kw(building.hvac, flow, mean, t_out, w)
    # a snapshot restores the state exactly
    saved = plant.get_state()
    plant.step(Actuation(flow_kg_s=flow), Disturbance(d, t_out, w), 1800.0)
    plant.set_state(saved)
    np.testing.assert_array_equal(plant.x, x_next)
    with pytest.raises(ValueError, match="flow-actuated"):
        plant.step(Actuation(setpoint_degc=np.full(5, 24.0)), Disturbance(d, t_out, w), 1800.0)


class ZoneOnlyPlant:
    """A test double of an external emulator: zone temperatures only, no snapshots, power a
    fixed kW per kg/s of flow."""

    can_snapshot = False
    actuations = ("flow",)

    def __init__(self, zone_names: tuple[str, ...]) -> None:
        self.zone_names = zone_names
        self.temps = np.zeros(len(zone_names))
        self.flows: list[np.ndarray] = []

    def reset(self, initial_temp_degc: float) -> Observation:
        self.temps = np.full(len(self.zone_names), initial_temp_degc)
        return self._observe(np.zeros(len(self.zone_names)))

    def step(self, actuation: Actuation, disturbance: Disturbance, dt_s: float) -> Observation:
        flow = np.asarray(actuation.flow_kg_s, dtype=float)
        self.flows.append(flow)
        # relax towards the outdoor temperature, cooled by the flow
        self.temps = self.temps + 0.1 * (disturbance.outdoor_temp_degc - self.temps) - 0.1 * flow
        return self._observe(flow)

    def _observe(self, flow: np.ndarray) -> Observation:
        return Observation(
            self.temps.copy(), self.temps.copy(), None, flow, 2.0 * float(flow.sum()),
            float("nan"), float("nan"),
        )  # fmt: skip

    def get_state(self) -> dict[str, Any]:  # for a checkpoint only: replay, not a snapshot
        return {"flows": np.array(self.flows)}

    def set_state(self, state: dict[str, Any]) -> None:
        raise AssertionError("the closed loop must not snapshot a plant that cannot")


class HalfFlowOffering(Controller):
    """Half the maximum flow, a quarter of it offered as reserve: a controller that always
    offers, so an always-activated run curtails every period."""

    def __init__(self, flow_max_kg_s: np.ndarray) -> None:
        self.flow = 0.5 * np.asarray(flow_max_kg_s, dtype=float)

    def act(self, inputs: PeriodInputs) -> Action:
        zones = len(self.flow)
        return Action(
            flow_kg_s=self.flow, reserve_flow_kg_s=0.25 * self.flow, reserve_kw=1.0,
            planned_power_kw=float("nan"), status="rule", fallback=False, solve_time_s=0.0,
            planned_slack_max_k=float("nan"), delta_max_k=float("nan"),
            predicted_served_degc=np.full(zones, 25.0),
            predicted_curtailed_degc=np.full(zones, 25.5),
        )  # fmt: skip

    def get_state(self) -> dict[str, Any]:
        return {}

    def set_state(self, state: dict[str, Any]) -> None:
        return None


def test_a_test_double_plant_runs_a_closed_loop(setup) -> None:  # type: ignore[no-untyped-def]
    plant = ZoneOnlyPlant(setup.zone_names)
    controller = HalfFlowOffering(setup.building.hvac.flow_max_kg_s)
    loop = ClosedLoop(setup, controller, plant=plant)
    while loop.k < loop.steps:
        loop.step()
    frame = loop.frame()
    assert len(plant.flows) == loop.steps  # one plant step a period: no counterfactual
    applied = np.array(plant.flows)
    np.testing.assert_allclose(frame["power_kw"], 2.0 * applied.sum(axis=1))
    zone = setup.zone_names[0]
    np.testing.assert_allclose(frame[f"temp_end_{zone}_degc"].iloc[-1], plant.temps[0])
    # activated all along: curtailed periods have no served counterfactual, and vice versa
    curtailed = frame["il_curtailed"].to_numpy()
    assert curtailed.any()
    assert frame.loc[curtailed, "power_served_kw"].isna().all()
    assert not frame.loc[curtailed, "power_curtailed_kw"].isna().any()


class PlenumPlant(ZoneOnlyPlant):
    """ZoneOnlyPlant that also reads one unconditioned zone (a plenum) at a known value."""

    plenum_degc = 31.5

    def _observe(self, flow: np.ndarray) -> Observation:
        observed = super()._observe(flow)
        return replace(observed, boundary_temp_degc=np.array([self.plenum_degc]))


def _identified_setup(model: IdentifiedModel, tmp_path: Path):  # type: ignore[no-untyped-def]
    """The two-zone identified model with a plenum boundary node, on a 2-hour run."""
    path = write_identified_model(model, tmp_path / "model.toml")
    cfg = with_overrides(
        preset("nmpc", start=f"{START}T10:00", days=2 / 24), {"building": str(path)}
    )
    return prepare(cfg)


def test_the_observer_takes_the_plants_boundary_readings(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    setup = _identified_setup(identified_model, tmp_path)
    plenum = setup.model.node_names.index("PLENUM-1")
    controller = HalfFlowOffering(setup.building.hvac.flow_max_kg_s)
    # a plant that reads the plenum: the state carries its reading after every period
    loop = ClosedLoop(setup, controller, plant=PlenumPlant(setup.zone_names))
    assert loop.x[plenum] == PlenumPlant.plenum_degc
    loop.step()
    assert loop.x[plenum] == PlenumPlant.plenum_degc
    # one that does not: the model carries the plenum from its estimated start (25.5 °C)
    loop = ClosedLoop(setup, controller, plant=ZoneOnlyPlant(setup.zone_names))
    assert loop.x[plenum] == 25.5
    loop.step()
    assert loop.x[plenum] != PlenumPlant.plenum_degc and 20.0 < loop.x[plenum] < 35.0


class MeanBelowEndPlant(ZoneOnlyPlant):
    """ZoneOnlyPlant whose period-mean zone temperatures lie 0.5 K below the end ones."""

    def _observe(self, flow: np.ndarray) -> Observation:
        return replace(super()._observe(flow), zone_mean_temp_degc=self.temps - 0.5)


class FanOnlyPlant(MeanBelowEndPlant):
    """... whose air arrives at the zone's mean temperature (a coil off: fan-only air)."""

    def _observe(self, flow: np.ndarray) -> Observation:
        observed = super()._observe(flow)
        return replace(observed, supply_temp_degc=observed.zone_mean_temp_degc.copy())


def test_the_observer_steps_the_hidden_nodes_with_the_delivered_cooling(setup) -> None:  # type: ignore[no-untyped-def]
    controller = HalfFlowOffering(setup.building.hvac.flow_max_kg_s)
    metered = ClosedLoop(setup, controller, plant=MeanBelowEndPlant(setup.zone_names))
    fan_only = ClosedLoop(setup, controller, plant=FanOnlyPlant(setup.zone_names))
    x0 = metered.x.copy()
    np.testing.assert_array_equal(fan_only.x, x0)
    metered.step()
    fan_only.step()
    zones = metered._zone_rows
    np.testing.assert_array_equal(fan_only.x[zones], metered.x[zones])  # the readings
    # the same period, only the air system's input differs: fan-only air delivers no cooling
    flow = np.asarray(metered.plant.flows[0])  # type: ignore[attr-defined]
    mean_temp = metered.plant.temps - 0.5  # type: ignore[attr-defined]
    u = delivered_flow_kg_s(setup.model, flow, mean_temp, mean_temp)
    hidden = np.setdiff1d(np.arange(len(x0)), zones)
    expected = (setup.model.b @ (u - flow))[hidden]
    np.testing.assert_allclose(fan_only.x[hidden] - metered.x[hidden], expected, atol=1e-12)
    assert np.all(expected >= 0.0) and expected.max() > 0.01  # warmer: no cooling delivered


def test_the_filter_predicts_with_the_delivered_cooling() -> None:
    """With a Kalman filter the controller's next prediction takes the same input as the
    observer: the cooling the air delivered, not the decided flow (fan-only air: less)."""
    cfg = with_overrides(
        preset("nmpc", start=f"{START}T10:00", days=1 / 12), {"estimation.mode": "kalman"}
    )
    setup = prepare(cfg)
    loop = ClosedLoop(setup, plant=FanOnlyPlant(setup.zone_names))
    loop.step()
    flow = np.asarray(loop.plant.flows[0])  # type: ignore[attr-defined]
    mean_temp = loop.plant.temps - 0.5  # type: ignore[attr-defined]
    u = delivered_flow_kg_s(setup.model, flow, mean_temp, mean_temp)
    estimator = loop.control.controller._estimator  # type: ignore[attr-defined]
    predicted_with: list[np.ndarray] = []
    estimate = estimator.estimate

    def spy(*args: object, **kwargs: object) -> object:
        predicted_with.append(np.array(estimator.last.flow_kg_s))
        return estimate(*args, **kwargs)

    estimator.estimate = spy
    loop.step()  # the next decision's filter predicts period 0 with what the air delivered
    np.testing.assert_allclose(predicted_with[0], u, atol=1e-12)
    assert np.all(u < flow - 1e-3)  # fan-only air: the decided flow would overstate it


# ------------------------------------------------------------------ the in-period peak guard


def _guard(cap_kw: float, upper: list[float], floor: list[float]):  # type: ignore[no-untyped-def]
    from hvacflex.sim.plant import PeakGuard

    return PeakGuard(cap_kw, np.array(upper), np.array(floor), substeps=6)


def test_the_guard_sheds_towards_the_floor_in_zones_below_their_bound_by_hand() -> None:
    """P(u) = 10 kW per kg/s of total flow, u = (1, 1), floor 0.2, cap 15 kW: s solves
    10 (0.4 + 1.6 s) = 15, s = 0.6875, u' = 0.75 each; a zone at its upper bound keeps its
    flow: 10 (1.2 + 0.8 s) = 15, s = 0.375, the other zone 0.5; a floor above the cap: the
    floor; under the cap: unchanged."""
    from hvacflex.sim.plant import shed_flows_kg_s

    def power(u: np.ndarray) -> float:
        return 10.0 * float(u.sum())

    flow = np.array([1.0, 1.0])
    shed = shed_flows_kg_s(
        flow, _guard(15.0, [26.0, 26.0], [0.2, 0.2]), np.array([25.0, 25.0]), power
    )
    np.testing.assert_allclose(shed, [0.75, 0.75], atol=1e-9)
    hot = shed_flows_kg_s(
        flow, _guard(15.0, [26.0, 26.0], [0.2, 0.2]), np.array([26.0, 25.0]), power
    )
    np.testing.assert_allclose(hot, [1.0, 0.5], atol=1e-9)
    low = shed_flows_kg_s(
        flow, _guard(3.0, [26.0, 26.0], [0.2, 0.2]), np.array([25.0, 25.0]), power
    )
    np.testing.assert_array_equal(low, [0.2, 0.2])
    fits = shed_flows_kg_s(
        flow, _guard(25.0, [26.0, 26.0], [0.2, 0.2]), np.array([25.0, 25.0]), power
    )
    np.testing.assert_array_equal(fits, flow)


def test_the_rc_plant_holds_the_cap_on_a_synthetic_over_cap_period(setup) -> None:  # type: ignore[no-untyped-def]
    """Full flow on warm zones draws P; a cap of 0.6 P sheds (flag set, metered power within
    1 % of the cap, zones warmer than unguarded but the flows never below the floor); a cap
    above P changes nothing, bit for bit."""
    building = setup.building
    m = len(building.zone_names)
    flow = np.asarray(building.hvac.flow_max_kg_s, dtype=float)
    d = setup.exogenous.disturbances[20]
    disturbance = Disturbance(
        d,
        float(setup.exogenous.outdoor_temp_degc[20]),
        float(setup.exogenous.outdoor_humidity_ratio_kg_per_kg[20]),
    )
    free = RCPlant(building)
    free.reset(25.0)
    unguarded = free.step(Actuation(flow_kg_s=flow), disturbance, 1800.0)
    floor = [0.3] * m
    capped = RCPlant(building)
    capped.reset(25.0)
    cap = 0.6 * unguarded.power_kw
    guarded = capped.step(
        Actuation(flow_kg_s=flow, peak_guard=_guard(cap, [30.0] * m, floor)), disturbance, 1800.0
    )
    assert guarded.peak_guard_active and not unguarded.peak_guard_active
    assert guarded.power_kw == pytest.approx(cap, rel=0.01)
    assert np.all(guarded.supply_flow_kg_s < flow) and np.all(guarded.supply_flow_kg_s >= 0.3)
    assert np.all(guarded.zone_temp_degc > unguarded.zone_temp_degc)
    loose = RCPlant(building)
    loose.reset(25.0)
    same = loose.step(
        Actuation(flow_kg_s=flow, peak_guard=_guard(2 * unguarded.power_kw, [30.0] * m, floor)),
        disturbance,
        1800.0,
    )
    assert not same.peak_guard_active
    assert same.power_kw == unguarded.power_kw
    np.testing.assert_array_equal(same.node_temp_degc, unguarded.node_temp_degc)


def test_a_required_guard_on_a_plant_that_cannot_read_its_meter_is_refused() -> None:
    from hvacflex.errors import ConfigError
    from hvacflex.sim.closed_loop import peak_guard_enabled

    class OncePerPeriod:
        reads_meter_in_period = False

    on = with_overrides(preset("rmpc-ppp"), {"controller.peak_guard": "on"})
    with pytest.raises(ConfigError, match="peak_guard") as info:
        peak_guard_enabled(on, OncePerPeriod())  # type: ignore[arg-type]
    assert info.value.field == "controller.peak_guard"
    assert not peak_guard_enabled(preset("rmpc-ppp"), OncePerPeriod())  # type: ignore[arg-type]
    assert peak_guard_enabled(preset("rmpc-ppp"), RCPlant.__new__(RCPlant))
    off = with_overrides(preset("rmpc-ppp"), {"controller.peak_guard": "off"})
    assert not peak_guard_enabled(off, RCPlant.__new__(RCPlant))
