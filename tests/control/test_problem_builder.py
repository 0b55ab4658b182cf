"""build_problem: pure, and the comfort bounds and commitments it sets, by hand."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hvacflex.config import preset
from hvacflex.control.base import PeriodInputs
from hvacflex.control.mpc import MPCController
from hvacflex.control.problem_builder import (
    PlanContext,
    below_unoccupied_bound,
    build_problem,
    comfort_bounds_at_period_ends,
)
from hvacflex.sim.setup import Setup, make_controller, prepare


@pytest.fixture(scope="module")
def setup() -> Setup:
    return prepare(preset("rmpc-ppp", start="2014-03-03", days=1.0))


def _inputs(setup: Setup, k: int = 14) -> PeriodInputs:
    x = np.full(len(setup.model.node_names), 25.0)
    return PeriodInputs(x, setup.forecaster.forecast(k, 49), 0.0)


def test_the_problem_is_a_pure_function_of_its_arguments(setup: Setup) -> None:
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    inputs = _inputs(setup)
    context = PlanContext(inputs.x_degc.copy())
    first = build_problem(setup.model, inputs, controller.contract, context)
    second = build_problem(setup.model, inputs, controller.contract, context)
    for name in ("power_offset_kw", "power_coeff_kw_per_kg_s", "y_min", "y_max", "d_sigma"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))
    np.testing.assert_array_equal(inputs.x_degc, 25.0)  # nothing it was given changed
    warmer = build_problem(
        setup.model, inputs, controller.contract, replace(context, x_degc=inputs.x_degc + 1.0)
    )
    np.testing.assert_array_equal(warmer.x0, first.x0 + 1.0)


def test_bounds_at_period_ends_are_the_tighter_of_two_periods_by_hand(setup: Setup) -> None:
    forecast = setup.forecaster.forecast(14, 49)  # 07:00: occupancy starts at 08:00
    lower, upper = comfort_bounds_at_period_ends(forecast, 48)
    band_lower, band_upper = forecast.comfort_lower_degc, forecast.comfort_upper_degc
    for k in range(47):
        np.testing.assert_array_equal(lower[k], np.maximum(band_lower[k], band_lower[k + 1]))
        np.testing.assert_array_equal(upper[k], np.minimum(band_upper[k], band_upper[k + 1]))
    assert (upper[1] < band_upper[1]).all()  # the end of 07:30 is 08:00: occupied band


def test_commitments_are_clipped_into_the_room_and_the_reserve_zones(setup: Setup) -> None:
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    contract = controller.contract
    g = contract.commit_ahead
    committed = np.full((g, len(setup.zone_names)), 100.0)  # far more than any room
    inputs = replace(_inputs(setup, 20), committed_reserve_kg_s=committed)
    problem = build_problem(setup.model, inputs, contract, PlanContext(inputs.x_degc))
    fixed = problem.reserve_fixed_kg_s
    assert fixed is not None and fixed.shape == (g, len(setup.zone_names))
    room = contract.flow_max_kg_s - problem.u_min[:g]
    np.testing.assert_allclose(fixed, np.where(contract.reserve_mask, room, 0.0))


def test_power_rows_take_outdoor_air_only_where_the_damper_is_open(setup: Setup) -> None:
    """The LP's rows are the building's affine model with the plant's damper schedule: an
    unoccupied step's row equals the model with the damper closed, an occupied one's open
    (``[controller] power_model = "design"``: office5's design curves, not its fitted model)."""
    from hvacflex.building.hvac import affine_power_model

    design = prepare(preset("rmpc-ppp", start="2014-03-03", days=1.0, power_model="design"))
    assert design.building.metered_power is None and setup.building.metered_power is not None
    controller = make_controller(design)
    assert isinstance(controller, MPCController)
    inputs = _inputs(design)
    problem = build_problem(design.model, inputs, controller.contract, PlanContext(inputs.x_degc))
    forecast, hvac = inputs.forecast, setup.building.hvac
    horizon = problem.power_offset_kw.shape[0]
    occupied = forecast.occupied[:horizon]
    assert occupied.any() and not occupied.all()
    outdoor = forecast.disturbances[:horizon, controller.contract.outdoor_index]
    for damper in (False, True):
        p0, _ = affine_power_model(
            hvac,
            outdoor,
            forecast.outdoor_humidity_ratio_kg_per_kg[:horizon],
            controller.contract.linearisation_temp_degc,
            latent_gain_w=forecast.occupant_latent_w[:horizon],
            flow_min_kg_s=problem.u_min,
            damper_open=damper,
        )
        rows = occupied == damper
        np.testing.assert_allclose(problem.power_offset_kw[rows], p0[rows])


def test_the_plan_keeps_a_margin_below_the_night_bound_only(setup: Setup) -> None:
    """Ends of unoccupied periods: y_max = band − margin (the default 0.5 K; never below
    y_min); ends touching occupancy keep the band; the margin 0 gives the band back."""

    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    inputs = _inputs(setup)  # 07:00: the horizon holds the day and the night after
    contract = controller.contract
    assert contract.config.unoccupied_plan_margin_k == 0.5
    problem = build_problem(setup.model, inputs, contract, PlanContext(inputs.x_degc))
    forecast = inputs.forecast
    horizon = problem.y_max.shape[0]
    band_lower, band_upper = comfort_bounds_at_period_ends(forecast, horizon)
    occupied = forecast.occupied
    night = np.array([not occupied[k] and not occupied[k + 1] for k in range(horizon)])
    assert night.any() and not night.all()
    np.testing.assert_allclose(problem.y_max[night], band_upper[night] - 0.5)
    np.testing.assert_array_equal(problem.y_max[~night], band_upper[~night])
    np.testing.assert_array_equal(problem.y_min, band_lower)
    # by hand: a 30 °C night bound, 20 °C lower; a margin wider than the band stops at y_min
    y_min, y_max = np.full((horizon, 1), 20.0), np.full((horizon, 1), 30.0)
    wide = below_unoccupied_bound(forecast, y_min, y_max, 50.0)
    np.testing.assert_array_equal(wide[night, 0], 20.0)
    np.testing.assert_array_equal(below_unoccupied_bound(forecast, y_min, y_max, 0.0), y_max)


def test_a_designed_building_with_a_metered_power_model_plans_with_it(setup: Setup) -> None:
    """The LP's rows are the fitted model's tangent at the step's least flow (no previous
    plan): exact there, at T₀, whatever the design curves say."""
    from hvacflex.building.identified import IdentifiedPower, metered_power_kw

    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    metered = IdentifiedPower(
        base_kw=2.0,
        kw_per_kw_cooling=0.3,
        kw_per_k_outdoor=0.0,
        occupied_kw=1.0,
        running_kw=3.0,
        fan_kw_per_kg2_s2=0.5,
    )
    building = replace(setup.building, power_models={"rc": metered})
    contract = replace(controller.contract, building=building.with_power_model_for("rc"))
    inputs = _inputs(setup)
    problem = build_problem(setup.model, inputs, contract, PlanContext(inputs.x_degc))
    t0 = contract.linearisation_temp_degc
    outdoor = problem.d_forecast[:, contract.outdoor_index]
    occupied = inputs.forecast.occupied[:48].astype(float)
    for k in (0, 10, 30):  # 07:00 (unoccupied), 12:00 and 22:00
        low = problem.u_min[k]
        exact = metered_power_kw(
            metered,
            setup.building.hvac.supply_temp_degc,
            low,
            np.full(low.size, t0),
            outdoor[k],
            occupied[k],
        )
        row = problem.power_offset_kw[k] + problem.power_coeff_kw_per_kg_s[k] @ low
        assert row == pytest.approx(float(exact), rel=1e-9)
    design = build_problem(setup.model, inputs, controller.contract, PlanContext(inputs.x_degc))
    assert not np.allclose(design.power_offset_kw, problem.power_offset_kw)
