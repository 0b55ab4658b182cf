"""build_problem: pure, and the comfort bounds and commitments it sets, by hand."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hvacflex.config import preset, with_overrides
from hvacflex.control.base import PeriodInputs
from hvacflex.control.mpc import MPCController
from hvacflex.control.plan_band import band_at_period_ends, comfort_bounds_at_period_ends
from hvacflex.control.problem_builder import (
    PlanContext,
    build_problem,
    committed_cap_in_force_kw,
    pull_down_steps,
)
from hvacflex.opt import solve_rmpc
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


def test_commitments_are_clipped_into_the_room_and_the_reserve_zones(setup: Setup) -> None:
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    contract = controller.contract
    g = contract.commit_ahead
    committed = np.full((g, len(setup.zone_names)), 100.0)  # far more than any room
    inputs = replace(_inputs(setup, 20), committed_reserve_kg_s=committed)
    problem = build_problem(setup.model, inputs, contract, PlanContext(inputs.x_degc))
    assert problem.commitments is not None
    fixed = problem.commitments.reserve_kg_s
    assert fixed.shape == (g, len(setup.zone_names))
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


def test_the_plan_stays_above_the_lower_bound_by_its_margin() -> None:
    """``lower_plan_margin_k`` raises every period end's lower bound and nothing else of the
    problem; a plan that pre-cools to the band's lower bound without it stays 0.3 K above it
    with it."""
    plans = {}
    for margin in (0.0, 0.3):
        setup = prepare(
            with_overrides(
                preset("nmpc", start="2014-03-03", days=1.0),
                {"controller.lower_plan_margin_k": margin},
            )
        )
        controller = make_controller(setup)
        assert isinstance(controller, MPCController)
        inputs = _inputs(setup, k=2)  # 01:00: the night's cheap hours, a cool building
        context = PlanContext(inputs.x_degc)
        plans[margin] = build_problem(setup.model, inputs, controller.contract, context)
    plain, margined = plans[0.0], plans[0.3]
    band_lower, _ = comfort_bounds_at_period_ends(inputs.forecast, plain.y_max.shape[0])
    np.testing.assert_array_equal(plain.y_min, band_lower)
    np.testing.assert_allclose(margined.y_min, band_lower + 0.3)
    for name in ("y_max", "power_offset_kw", "power_coeff_kw_per_kg_s", "d_sigma"):
        np.testing.assert_array_equal(getattr(margined, name), getattr(plain, name))
    above, slack = {}, {}
    for margin, problem in plans.items():
        solution = solve_rmpc(problem)
        assert solution.ok
        above[margin] = solution.x_served[1:] @ setup.model.c.T - band_lower
        slack[margin] = solution.slack
    assert above[0.0].min() < 0.3 - 1e-3  # it rides the lower bound somewhere
    assert (above[0.3] >= 0.3 - slack[0.3] - 1e-6).all()


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
        kw_per_humidity_ratio_occupied=800.0,
    )
    building = replace(setup.building, power_models={"rc": metered})
    contract = replace(controller.contract, building=building.with_power_model_for("rc"))
    inputs = _inputs(setup)
    problem = build_problem(setup.model, inputs, contract, PlanContext(inputs.x_degc))
    t0 = contract.linearisation_temp_degc
    outdoor = problem.d_forecast[:, contract.outdoor_index]
    occupied = inputs.forecast.occupied[:48].astype(float)
    humidity = inputs.forecast.outdoor_humidity_ratio_kg_per_kg[:48]
    assert np.ptp(humidity[occupied > 0]) > 1e-4  # the forecast's humidity varies
    for k in (0, 10, 30):  # 07:00 (unoccupied), 12:00 and 22:00
        low = problem.u_min[k]
        exact = metered_power_kw(
            metered,
            setup.building.hvac.supply_temp_degc,
            low,
            np.full(low.size, t0),
            outdoor[k],
            occupied[k],
            humidity[k],
        )
        row = problem.power_offset_kw[k] + problem.power_coeff_kw_per_kg_s[k] @ low
        assert row == pytest.approx(float(exact), rel=1e-9)
    design = build_problem(setup.model, inputs, controller.contract, PlanContext(inputs.x_degc))
    assert not np.allclose(design.power_offset_kw, problem.power_offset_kw)


def test_band_at_period_ends_on_arrays_uses_the_last_band_alone_at_the_end() -> None:
    lower = np.array([[20.0], [22.0], [21.0]])
    upper = np.array([[30.0], [25.0], [26.0]])
    y_min, y_max = band_at_period_ends(lower, upper, 3)
    np.testing.assert_array_equal(y_min[:, 0], [22.0, 22.0, 21.0])
    np.testing.assert_array_equal(y_max[:, 0], [25.0, 25.0, 26.0])
    _, first = band_at_period_ends(lower[:2], upper[:2], 1)  # one period and the next
    np.testing.assert_array_equal(first, [[25.0]])


def test_the_peak_bound_prices_power_with_the_plans_rows(
    setup: Setup, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One power-row function (lp_power_rows) for the MPC and the peak bound: with the
    perfect forecast the bound's rows over the first horizon are the first plan's, and so is
    its band at the period ends."""
    from hvacflex.sim import peak_bound

    captured: list[peak_bound.PeakBoundProblem] = []
    monkeypatch.setattr(peak_bound, "minimum_peak", captured.append)
    peak_bound.bound_peak_kw(setup.config)
    bound = captured[0]
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    inputs = _inputs(setup, 0)
    problem = build_problem(setup.model, inputs, controller.contract, PlanContext(inputs.x_degc))
    horizon = problem.power_offset_kw.shape[0]
    np.testing.assert_allclose(bound.p0_kw[:horizon], problem.power_offset_kw)
    np.testing.assert_allclose(bound.p_kw_per_kg_s[:horizon], problem.power_coeff_kw_per_kg_s)
    np.testing.assert_allclose(bound.u_min_kg_s[:horizon], problem.u_min)
    y_min, y_max = comfort_bounds_at_period_ends(inputs.forecast, horizon)
    np.testing.assert_array_equal(bound.y_min_degc[:horizon], y_min)
    np.testing.assert_array_equal(bound.y_max_degc[:horizon], y_max)


def test_pull_down_steps_by_hand() -> None:
    """Spells starting at steps 10 and 30 of a 40-step plan (and one at 40, just past it):
    the 8 steps before each and its first 2; a spell already running at step 0 has none."""
    occupied = np.zeros(41, dtype=bool)
    occupied[10:20] = occupied[30:35] = occupied[40] = True
    mask = pull_down_steps(occupied, 40)
    expected = np.zeros(40, dtype=bool)
    expected[2:12] = expected[22:32] = expected[32:40] = True
    np.testing.assert_array_equal(mask, expected)
    running = np.ones(41, dtype=bool)
    assert not pull_down_steps(running, 40).any()
    np.testing.assert_array_equal(
        pull_down_steps(occupied, 40, 2, 1), np.isin(np.arange(40), [8, 9, 10, 28, 29, 30, 38, 39])
    )


def test_the_cap_in_force_is_the_larger_of_the_previous_peak_and_the_billed() -> None:
    assert np.isnan(committed_cap_in_force_kw(None, 0.0))
    assert committed_cap_in_force_kw(None, 31.5) == 31.5


def test_the_plan_holds_the_morning_pull_down_to_the_committed_cap(setup: Setup) -> None:
    """From 00:00 (occupancy at 08:00, step 16) with the month's billed peak at a cap below
    the uncapped plan's pull-down: P_k ≤ cap in the pull-down steps 8 … 17 (the LP's power,
    solved), never below the step's least power (a lower cap bounds it there: the occupied
    steps' ventilation flows draw ≈ 30 kW), other steps unbounded; φ = 0 sets no cap."""
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    contract = controller.contract
    inputs = _inputs(setup, 0)
    free = build_problem(setup.model, inputs, contract, PlanContext(inputs.x_degc))
    assert np.isinf(free.power_max_kw).all()  # the billed peak 0: no cap in force
    pull_down = pull_down_steps(inputs.forecast.occupied, free.horizon)
    assert np.flatnonzero(pull_down).tolist() == list(range(8, 18))
    uncapped = solve_rmpc(free)
    least = free.power_offset_kw + (free.power_coeff_kw_per_kg_s * free.u_min).sum(axis=1)
    # a cap between the pull-down's least power and the uncapped plan's pull-down peak
    cap_kw = 0.5 * float(least[pull_down].max() + uncapped.power_kw[pull_down].max())
    assert uncapped.power_kw[pull_down].max() > cap_kw + 1.0  # the cap will bind
    capped_inputs = replace(inputs, peak_floor_kw=cap_kw)
    problem = build_problem(setup.model, capped_inputs, contract, PlanContext(inputs.x_degc))
    np.testing.assert_allclose(problem.power_max_kw[pull_down], cap_kw)
    assert np.isinf(problem.power_max_kw[~pull_down]).all()
    solution = solve_rmpc(problem)
    assert solution.power_kw[pull_down].max() <= cap_kw + 1e-6
    # a cap below the least power of a step bounds that step at its least power
    low_inputs = replace(inputs, peak_floor_kw=0.5 * float(least[pull_down].max()))
    low = build_problem(setup.model, low_inputs, contract, PlanContext(inputs.x_degc))
    np.testing.assert_allclose(
        low.power_max_kw[pull_down], np.maximum(low_inputs.peak_floor_kw, least[pull_down])
    )
    no_phi = replace(contract, config=replace(contract.config, peak_price_sgd_per_kw=0.0))
    unpriced = build_problem(setup.model, capped_inputs, no_phi, PlanContext(inputs.x_degc))
    assert np.isinf(unpriced.power_max_kw).all()


def test_the_meter_s_offsets_level_the_power_rows_period_by_period(setup: Setup) -> None:
    """Each period's row is moved by its own offset (occupied or not: the step gives the
    unoccupied periods their own class's), its flow coefficients untouched."""
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    inputs = _inputs(setup)
    context = PlanContext(inputs.x_degc.copy())
    plain = build_problem(setup.model, inputs, controller.contract, context)
    horizon = len(inputs.forecast.occupied)
    offsets = np.where(np.asarray(inputs.forecast.occupied, dtype=bool), -6.0, 2.5)
    levelled = build_problem(
        setup.model, replace(inputs, meter_offset_kw=offsets), controller.contract, context
    )
    occupied = np.asarray(inputs.forecast.occupied[: len(plain.power_offset_kw)], dtype=bool)
    assert occupied.any() and not occupied.all() and horizon >= occupied.size
    shift = levelled.power_offset_kw - plain.power_offset_kw
    np.testing.assert_allclose(shift[occupied], -6.0)
    np.testing.assert_allclose(shift[~occupied], 2.5)
    np.testing.assert_array_equal(levelled.power_coeff_kw_per_kg_s, plain.power_coeff_kw_per_kg_s)


def test_plan_linearisation_takes_each_step_at_the_previous_plans_zone_temperatures() -> None:
    """``linearisation = "plan"`` (design curves): without a plan the problem is the fixed
    model's; with one, each step's zone temperature is the plan's over that step, one step
    on (by hand: the mean of its start and end, the first from the state now), and at it

    * the power row is the design curves' (a cooler step draws less coil power per kg/s than
      T₀ = 25 °C),
    * B diag(s_k) and g_k are the model linearised at (ṁ_ref, T_k) and discretised, computed
      apart by :func:`hvacflex.control.trajectory.linearize_along`, and the first step's
      model is what the prediction error steps with."""
    from hvacflex.building.hvac import affine_power_model
    from hvacflex.building.rc import build_network
    from hvacflex.control.plan_linearisation import planned_first_step
    from hvacflex.control.trajectory import linearize_along

    def contract_of(linearisation: str) -> tuple[Setup, MPCController]:
        setup = prepare(
            preset(
                "rmpc",
                start="2014-03-03",
                days=1.0,
                power_model="design",
                linearisation=linearisation,
            )
        )
        controller = make_controller(setup)
        assert isinstance(controller, MPCController)
        return setup, controller

    design, fixed = contract_of("fixed")
    _, moving = contract_of("plan")
    inputs = _inputs(design)
    cold = PlanContext(inputs.x_degc)
    plain = build_problem(design.model, inputs, fixed.contract, cold)
    first = build_problem(design.model, inputs, moving.contract, cold)
    np.testing.assert_array_equal(first.power_coeff_kw_per_kg_s, plain.power_coeff_kw_per_kg_s)
    assert first.input_scale is None and plain.input_scale is None
    plan = solve_rmpc(plain)
    assert plan.ok
    x_now = np.full_like(inputs.x_degc, 23.5)
    context = PlanContext(x_now, previous_plan=plan)
    problem = build_problem(design.model, inputs, moving.contract, context)
    model = design.model
    c = model.c
    served = plan.x_served @ c.T
    horizon = served.shape[0] - 1
    by_hand = np.empty((horizon, c.shape[0]))
    by_hand[0] = 0.5 * (c @ x_now + served[2])
    for k in range(1, horizon):
        by_hand[k] = 0.5 * (served[k + 1] + served[min(k + 2, horizon)])
    forecast = inputs.forecast
    outdoor = forecast.disturbances[:horizon, moving.contract.outdoor_index]
    damper = design.building.hvac.outdoor_air_open_at(forecast.occupied, model.dt_s)
    p0, p = affine_power_model(
        design.building.hvac,
        outdoor,
        forecast.outdoor_humidity_ratio_kg_per_kg[:horizon],
        by_hand,
        latent_gain_w=forecast.occupant_latent_w[:horizon],
        flow_min_kg_s=problem.u_min,
        damper_open=damper[:horizon],
    )
    np.testing.assert_allclose(problem.power_coeff_kw_per_kg_s, p, rtol=1e-12)
    np.testing.assert_allclose(problem.power_offset_kw, p0, rtol=1e-12)
    cooler = by_hand < moving.contract.linearisation_temp_degc - 0.5
    assert cooler.any()
    assert np.all(problem.power_coeff_kw_per_kg_s[cooler] < plain.power_coeff_kw_per_kg_s[cooler])
    # the dynamics: each step linearised at (ṁ_ref, T_k), apart
    flow_ref = np.broadcast_to(model.flow_ref_kg_s, by_hand.shape)
    network = build_network(design.building)
    exact = linearize_along(design.building, network, c, flow_ref, by_hand, model.dt_s)
    np.testing.assert_allclose(problem.step_b_matrix, exact.b, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(problem.a_matrix, exact.a[0], rtol=1e-9, atol=1e-12)
    g_steps = np.broadcast_to(problem.g, exact.g.shape)
    np.testing.assert_allclose(g_steps, exact.g, rtol=1e-9, atol=1e-12)
    assert np.abs(problem.input_scale - 1.0).max() > 0.05  # not T₀'s model
    step = planned_first_step(problem, model)
    np.testing.assert_allclose(step.b, exact.b[0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(step.g, exact.g[0], rtol=1e-9, atol=1e-12)
