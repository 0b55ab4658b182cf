"""trim-respond: the Guideline 36-style T&R of zone airflow and supply-air temperature."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.config import preset, with_overrides
from hvacflex.control.base import PeriodInputs
from hvacflex.control.trim_respond import (
    RESPOND_FRACTION,
    SAT_MAX_DEGC,
    SAT_MAX_RESPOND_K,
    SAT_TRIM_K,
    TRIM_FRACTION,
    TrimRespondController,
)
from hvacflex.sim.setup import Setup, make_controller, prepare

AFTERNOON_STEP = 28


@pytest.fixture(scope="module")
def setup() -> Setup:
    return prepare(preset("trim-respond", start="2014-03-03", days=1))


def _controller(setup: Setup, *, reset: bool = False) -> TrimRespondController:
    return TrimRespondController(
        setup.model, setup.building.hvac, 25.0, None, reset_supply_temp=reset
    )


def test_zones_respond_per_request_and_trim_otherwise(setup: Setup) -> None:
    controller = _controller(setup)
    zones = len(setup.zone_names)
    setpoint = np.full(zones, 25.0)
    temps = np.array([25.0, 25.3, 25.8, 27.0, 30.0][:zones])  # 0, 1, 2, 3 (cap), 3 requests
    controller.update(temps, setpoint)
    requests = np.array([0, 1, 2, 3, 3][:zones])
    expected = np.clip(-TRIM_FRACTION + RESPOND_FRACTION * requests, 0.0, 1.0)
    assert np.allclose(controller.loop_fraction, expected)
    for _ in range(50):
        controller.update(np.full(zones, 24.0), setpoint)
    assert np.all(controller.loop_fraction == 0.0)  # trimmed down to the minimum


def test_supply_air_drops_on_requests_and_trims_up_to_its_maximum(setup: Setup) -> None:
    controller = _controller(setup, reset=True)
    zones = len(setup.zone_names)
    design = controller.supply_temp_degc
    controller.loop_fraction = np.ones(zones)  # every zone at full flow: all request
    controller.update(np.full(zones, 30.0), np.full(zones, 25.0))
    assert controller.supply_temp_degc == pytest.approx(design + SAT_TRIM_K - SAT_MAX_RESPOND_K)
    for _ in range(40):
        controller.update(np.full(zones, 20.0), np.full(zones, 25.0))
    assert controller.supply_temp_degc == SAT_MAX_DEGC


def test_flows_follow_the_loops_and_the_rc_plant_gets_no_supply_temperature(
    setup: Setup,
) -> None:
    controller = make_controller(setup)
    assert isinstance(controller, TrimRespondController) and not controller.reset_supply_temp
    hvac = setup.building.hvac
    x = np.full(len(setup.model.node_names), 27.0)
    action = controller.act(PeriodInputs(x, setup.forecaster.forecast(AFTERNOON_STEP, 9), 0.0))
    low, high = hvac.flow_min_at([True])[0], np.asarray(hvac.flow_max_kg_s)
    assert np.allclose(action.flow_kg_s, low + controller.loop_fraction * (high - low))
    assert np.all(action.flow_kg_s > low)
    assert action.supply_temp_degc is None and action.status == "rule"


def test_a_plant_that_takes_a_supply_temperature_gets_the_reset(setup: Setup) -> None:
    config = with_overrides(setup.config, {"plant": {"kind": "energyplus", "actuation": "flow"}})
    controller = make_controller(prepare(config))
    assert isinstance(controller, TrimRespondController) and controller.reset_supply_temp
    x = np.full(len(setup.model.node_names), 27.0)
    action = controller.act(PeriodInputs(x, setup.forecaster.forecast(AFTERNOON_STEP, 9), 0.0))
    assert action.supply_temp_degc == controller.supply_temp_degc


def test_state_round_trips(setup: Setup) -> None:
    first = _controller(setup, reset=True)
    first.update(np.full(len(setup.zone_names), 27.0), np.full(len(setup.zone_names), 25.0))
    second = _controller(setup, reset=True)
    second.set_state(first.get_state())
    assert np.array_equal(second.loop_fraction, first.loop_fraction)
    assert second.supply_temp_degc == first.supply_temp_degc
