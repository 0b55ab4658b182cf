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
