"""The thermostat baselines: the dead-beat rule and the learned optimal start."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.config import preset
from hvacflex.control.base import PeriodInputs
from hvacflex.control.baselines import (
    REACHED_TOLERANCE_K,
    OptimalStart,
    ThermostatController,
    rule_action,
)
from hvacflex.data.forecast import Forecast
from hvacflex.sim.setup import Setup, prepare

OCCUPANCY_STEP = 16
"""2014-03-03 (a Monday) is occupied from 08:00, period 16 of the day."""


@pytest.fixture(scope="module")
def setup() -> Setup:
    return prepare(preset("thermostat-25.5", start="2014-03-03", days=1))


def _forecast(setup: Setup, k: int) -> Forecast:
    return setup.forecaster.forecast(k, 9)


def _day_of_observations(start: OptimalStart, setup: Setup, temp_at_occupancy: float) -> None:
    """Observe the morning up to the first occupied period with the zones at 24 °C before
    and ``temp_at_occupancy`` at the start of occupancy."""
    zones = len(setup.zone_names)
    for k in range(OCCUPANCY_STEP - 4, OCCUPANCY_STEP):
        start.observe(_forecast(setup, k), np.full(zones, 27.0 if k < 15 else 26.5))
    start.observe(_forecast(setup, OCCUPANCY_STEP), np.full(zones, temp_at_occupancy))


def test_occupancy_starts_where_the_test_assumes(setup: Setup) -> None:
    occupied = setup.exogenous.occupied
    assert not occupied[OCCUPANCY_STEP - 1] and occupied[OCCUPANCY_STEP]


def test_optimal_start_moves_earlier_after_a_morning_that_missed_the_band(setup: Setup) -> None:
    start = OptimalStart(initial_steps=2)
    _day_of_observations(start, setup, temp_at_occupancy=26.0 + 2 * REACHED_TOLERANCE_K)
    assert start.lead_steps == 3


def test_optimal_start_keeps_the_lead_when_the_band_was_reached_just_in_time(
    setup: Setup,
) -> None:
    start = OptimalStart(initial_steps=2)
    _day_of_observations(start, setup, temp_at_occupancy=25.5)  # 26.5 °C one period before
    assert start.lead_steps == 2


def test_optimal_start_moves_later_when_the_last_precooling_period_was_not_needed(
    setup: Setup,
) -> None:
    start = OptimalStart(initial_steps=2)
    zones = len(setup.zone_names)
    for k in range(OCCUPANCY_STEP - 4, OCCUPANCY_STEP + 1):
        start.observe(_forecast(setup, k), np.full(zones, 25.0))  # in band all along
    assert start.lead_steps == 1


def test_optimal_start_stays_within_floor_and_ceiling(setup: Setup) -> None:
    start = OptimalStart(initial_steps=1, floor_steps=1, ceiling_steps=2)
    for _ in range(3):
        _day_of_observations(start, setup, temp_at_occupancy=28.0)
    assert start.lead_steps == 2
    with pytest.raises(ValueError, match="floor"):
        OptimalStart(initial_steps=5, floor_steps=0, ceiling_steps=4)


def test_precooling_covers_exactly_the_lead_before_occupancy(setup: Setup) -> None:
    start = OptimalStart(initial_steps=3)
    zones = len(setup.zone_names)
    flags = [
        start.observe(_forecast(setup, k), np.full(zones, 25.0))
        for k in range(OCCUPANCY_STEP - 5, OCCUPANCY_STEP + 1)
    ]
    assert flags == [False, False, True, True, True, False]


def test_optimal_start_thermostat_precools_to_the_setpoint_the_plain_one_does_not(
    setup: Setup,
) -> None:
    model, hvac = setup.model, setup.building.hvac
    plain = ThermostatController(model, hvac, 25.5)
    early = ThermostatController(model, hvac, 25.5, OptimalStart(initial_steps=2))
    x = np.full(len(model.node_names), 28.0)
    forecast = _forecast(setup, OCCUPANCY_STEP - 1)
    plain_action = plain.act(PeriodInputs(x, forecast, 0.0))
    early_action = early.act(PeriodInputs(x, forecast, 0.0))
    assert early.precooling and not plain.precooling
    assert np.all(early_action.flow_kg_s > plain_action.flow_kg_s)
    # the dead-beat rule aims at 25.5 °C unless the flow limit binds
    predicted = early_action.predicted_served_degc
    at_max = np.isclose(early_action.flow_kg_s, hvac.flow_max_kg_s)
    assert np.allclose(predicted[~at_max], 25.5, atol=1e-6)
    assert np.all(predicted[at_max] > 25.5)


def test_thermostat_state_round_trips_the_learned_lead(setup: Setup) -> None:
    model, hvac = setup.model, setup.building.hvac
    first = ThermostatController(model, hvac, 25.5, OptimalStart(initial_steps=2))
    _day_of_observations(first.optimal_start, setup, 28.0)  # type: ignore[arg-type]
    second = ThermostatController(model, hvac, 25.5, OptimalStart(initial_steps=2))
    second.set_state(first.get_state())
    assert second.optimal_start is not None and second.optimal_start.lead_steps == 3
    # a thermostat without an optimal start keeps reading its old (empty) state
    ThermostatController(model, hvac).set_state({})


def test_a_rule_action_offers_nothing_and_predicts_one_step_on_the_model(setup: Setup) -> None:
    model = setup.model
    x = np.linspace(24.0, 27.0, model.a.shape[0])
    flow = np.linspace(0.2, 0.6, model.b.shape[1])
    d_now = setup.forecaster.forecast(20, 9).disturbances[0]
    action = rule_action(model, x, flow, d_now)
    predicted = model.c @ (model.a @ x + model.b @ flow + model.e @ d_now + model.g)
    np.testing.assert_allclose(action.predicted_served_degc, predicted, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(action.predicted_curtailed_degc, action.predicted_served_degc)
    np.testing.assert_array_equal(action.reserve_flow_kg_s, np.zeros_like(flow))
    assert (action.status, action.fallback, action.reserve_kw) == ("rule", False, 0.0)
    assert (action.planned_slack_max_k, action.delta_max_k, action.solve_time_s) == (0.0,) * 3
    assert np.isnan(action.planned_power_kw)


def test_the_night_float_rides_the_configured_margin_below_the_unoccupied_bound(
    setup: Setup,
) -> None:
    """Unoccupied, the target is upper − margin (never below the lower bound): 29 °C for
    thermostat-25.5's 1 K, 29.75 °C for the -float preset's 0.25 K, in the 20–30 °C band."""
    model, hvac = setup.model, setup.building.hvac
    forecast = _forecast(setup, 2)  # 01:00, unoccupied
    assert not forecast.occupied[0]
    upper, lower = forecast.comfort_upper_degc[0], forecast.comfort_lower_degc[0]
    for margin in (1.0, 0.25, 50.0):
        rule = ThermostatController(model, hvac, 25.5, unoccupied_margin_k=margin)
        np.testing.assert_array_equal(rule.target_degc(forecast), np.maximum(upper - margin, lower))
    default = ThermostatController(model, hvac, 25.5)
    np.testing.assert_array_equal(default.target_degc(forecast), upper - 1.0)
    # the preset builds its rule with the key's margin
    from hvacflex.sim.setup import make_controller

    floating = make_controller(prepare(preset("thermostat-25.5-float", start="2014-03-03", days=1)))
    assert isinstance(floating, ThermostatController) and floating.unoccupied_margin_k == 0.25
    with pytest.raises(ValueError, match="unoccupied margin"):
        ThermostatController(model, hvac, 25.5, unoccupied_margin_k=-0.1)
