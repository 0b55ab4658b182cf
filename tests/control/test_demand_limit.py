"""demand-limit: set-point raises that hold the peak target, and how the target is set."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hvacflex.building.hvac import hvac_power_kw
from hvacflex.config import preset
from hvacflex.control.base import PeriodInputs
from hvacflex.control.demand_limit import (
    UPPER_MARGIN_K,
    DemandLimitController,
    forecast_period_power_kw,
    predicted_power_kw,
)
from hvacflex.sim.setup import Setup, prepare

AFTERNOON_STEP = 28
"""14:00 on 2014-03-03, occupied, a warm afternoon."""


@pytest.fixture(scope="module")
def setup() -> Setup:
    return prepare(preset("demand-limit", start="2014-03-03", days=2))


def _controller(setup: Setup, fraction: float = 0.9) -> DemandLimitController:
    return DemandLimitController(setup.model, setup.building.hvac, 25.5, None, fraction)


def test_predicted_power_is_the_plant_model_at_the_mean_zone_temperature(setup: Setup) -> None:
    hvac = setup.building.hvac
    flow = np.asarray(hvac.flow_max_kg_s) * 0.5
    start, end = np.full(len(flow), 26.0), np.full(len(flow), 25.0)
    expected = float(hvac_power_kw(hvac, flow, np.full(len(flow), 25.5), 31.0, 0.018))
    assert predicted_power_kw(hvac, flow, start, end, 31.0, 0.018) == pytest.approx(expected)


def test_the_predicted_power_takes_outdoor_air_only_where_the_damper_is_open(
    setup: Setup,
) -> None:
    """At 02:00 (unoccupied, no purge) the prediction is the plant's model with the damper
    closed — below the same flows with outdoor air; at 14:00 it is open."""
    hvac, model = setup.building.hvac, setup.model
    flow = np.asarray(hvac.flow_max_kg_s) * 0.3
    x = np.full(len(model.node_names), 27.0)
    for k, is_open in ((4, False), (AFTERNOON_STEP, True)):
        forecast = setup.forecaster.forecast(k, 48)
        end = model.c @ model.step(x, flow, forecast.disturbances[0])
        args = (hvac, flow, model.c @ x, end)
        weather = (
            float(forecast.outdoor_temp_degc[0]),
            float(forecast.outdoor_humidity_ratio_kg_per_kg[0]),
        )
        expected = predicted_power_kw(*args, *weather, damper_open=is_open)
        assert forecast_period_power_kw(model, hvac, x, flow, forecast) == pytest.approx(expected)
        other = predicted_power_kw(*args, *weather, damper_open=not is_open)
        assert (expected < other) is not is_open  # outdoor air costs power in both hours


def test_no_target_before_a_day_has_passed_then_the_fraction_of_yesterdays_peak(
    setup: Setup,
) -> None:
    controller = _controller(setup, fraction=0.8)
    assert controller.target_kw(peak_floor_kw=12.0) == math.inf
    x = np.full(len(setup.model.node_names), 26.0)
    for k in (AFTERNOON_STEP, AFTERNOON_STEP + 1):  # day 1
        controller.act(PeriodInputs(x, setup.forecaster.forecast(k, 9), 0.0))
    yesterday_kw = controller._day_peak_kw
    assert yesterday_kw > 0
    controller.act(PeriodInputs(x, setup.forecaster.forecast(48, 9), 0.0))  # day 2 starts
    assert controller.reference_kw == pytest.approx(yesterday_kw)
    assert controller.target_kw(0.0) == pytest.approx(0.8 * yesterday_kw)
    # the peak already billed this month is never limited
    assert controller.target_kw(yesterday_kw) == pytest.approx(yesterday_kw)


def test_a_target_below_the_thermostat_power_raises_the_setpoint_and_lowers_the_power(
    setup: Setup,
) -> None:
    controller = _controller(setup)
    x = np.full(len(setup.model.node_names), 26.0)
    forecast = setup.forecaster.forecast(AFTERNOON_STEP, 9)
    free_flow, free_raise = controller.limited_flows(x, forecast, math.inf)
    assert free_raise == 0.0
    assert np.allclose(free_flow, controller.flows_now(x, forecast))
    free_kw = controller._power_kw(x, free_flow, forecast)
    flow, raise_k = controller.limited_flows(x, forecast, 0.9 * free_kw)
    assert raise_k > 0
    assert controller._power_kw(x, flow, forecast) < free_kw
    assert np.all(flow <= free_flow + 1e-12)
    # an unreachable target takes the largest raise, still inside the band
    flow, raise_k = controller.limited_flows(x, forecast, 0.0)
    end = setup.model.c @ setup.model.step(x, flow, forecast.disturbances[0])
    upper = forecast.comfort_upper_degc[0]
    assert raise_k == pytest.approx(float(np.max(upper - UPPER_MARGIN_K - 25.5)))
    assert np.all(end <= upper - UPPER_MARGIN_K + 1e-6)


def test_state_round_trips(setup: Setup) -> None:
    first = _controller(setup)
    x = np.full(len(setup.model.node_names), 26.0)
    for k in (AFTERNOON_STEP, 48):
        first.act(PeriodInputs(x, setup.forecaster.forecast(k, 9), 0.0))
    second = _controller(setup)
    second.set_state(first.get_state())
    assert second.reference_kw == first.reference_kw
    assert second.target_kw(0.0) == first.target_kw(0.0)
