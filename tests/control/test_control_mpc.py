"""MPC and thermostat actions without a plan: the rule, and the fallback after a failed solve."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from hvacflex.config import preset, with_overrides
from hvacflex.control.base import PeriodInputs
from hvacflex.control.baselines import ThermostatController, unplanned_action
from hvacflex.control.mpc import MPCController
from hvacflex.control.offers import OfferSizer, seen_steps, snapped_flows_kg_s
from hvacflex.control.problem_builder import model_error_margins
from hvacflex.errors import ConfigError
from hvacflex.opt import RMPCProblem, RMPCSolution, SolveStatus
from hvacflex.opt.solution import failed_solution
from hvacflex.sim.setup import Setup, make_controller, prepare

START = "2014-03-03"  # a Monday


@pytest.fixture(scope="module")
def setup() -> Setup:
    return prepare(preset("rmpc-ppp", start=START, days=1.0))


def test_unplanned_action_predicts_one_step_on_the_model_by_hand(setup: Setup) -> None:
    model = setup.model
    rng = np.random.default_rng(7)
    x = 24.0 + rng.uniform(-1.0, 1.0, size=model.a.shape[0])
    flow = rng.uniform(0.1, 1.0, size=model.b.shape[1])
    d = setup.exogenous.disturbances[20]
    action = unplanned_action(
        model, x, flow, d, status="rule", fallback=False, solve_time_s=0.0, plan_margin_k=0.0
    )
    zone_nodes = np.argmax(model.c, axis=1)  # C selects the zone air nodes
    expected = (model.a @ x + model.b @ flow + model.e @ d + model.g)[zone_nodes]
    np.testing.assert_allclose(action.predicted_served_degc, expected, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(action.predicted_curtailed_degc, action.predicted_served_degc)
    assert not action.reserve_flow_kg_s.any()
    assert action.reserve_kw == 0.0
    assert np.isnan(action.planned_power_kw)


def _timed_out(problem: RMPCProblem) -> RMPCSolution:
    """A solve of ``problem`` that timed out without a plan."""
    return failed_solution(
        problem,
        status=SolveStatus.TIME_LIMIT,
        message="time limit",
        delta=np.zeros((problem.horizon, problem.ny)),
        start=time.perf_counter(),
        highs_time_s=0.0,
        simplex_iterations=0,
        warm_start=False,
    )


class _FailingSolver:
    """Stands in for the LP solver: every solve reports a time-out without a plan."""

    def solve(self, problem: RMPCProblem) -> RMPCSolution:
        return _timed_out(problem)


def test_failed_solve_without_previous_plan_falls_back_to_the_thermostat(setup: Setup) -> None:
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    controller.solver_slot.solve = _FailingSolver().solve  # type: ignore[method-assign]
    k = 20  # an occupied period
    forecast = setup.forecaster.forecast(k, setup.config.controller.horizon_steps + 1)
    x = np.full(setup.model.a.shape[0], 25.5)
    action = controller.act(PeriodInputs(x, forecast, 0.0))

    thermostat = ThermostatController(
        setup.model, setup.building.hvac, setup.config.controller.thermostat_setpoint_degc
    )
    rule = thermostat.act(PeriodInputs(x, forecast, 0.0))
    assert action.fallback and not rule.fallback
    assert action.status == "time_limit" and rule.status == "rule"
    np.testing.assert_array_equal(action.flow_kg_s, rule.flow_kg_s)
    np.testing.assert_array_equal(action.predicted_served_degc, rule.predicted_served_degc)
    assert not action.reserve_flow_kg_s.any()
    assert np.isnan(action.planned_slack_max_k) and np.isnan(action.delta_max_k)
    assert rule.planned_slack_max_k == 0.0 and rule.delta_max_k == 0.0


def test_fallback_after_held_periods_takes_the_plans_step_for_this_period(
    setup: Setup,
) -> None:
    """A plan made at k, two periods held by an IL event (k+1, k+2), then a failed solve at
    k+3: the fallback runs the plan's step 3, not step 1 (it counted fallbacks only, until
    2026-12-05), and a second failure at k+4 its step 4."""
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    steps = setup.config.controller.horizon_steps + 1
    k = 18
    x = np.full(setup.model.a.shape[0], 25.0)
    first = controller.act(PeriodInputs(x, setup.forecaster.forecast(k, steps), 0.0))
    plan = controller.last_plan
    assert plan is not None
    for held in (k + 1, k + 2):
        locked = replace(first, flow_kg_s=plan.u[held - k], reserve_flow_kg_s=np.zeros(5))
        forecast = setup.forecaster.forecast(held, steps)
        assert controller.act(PeriodInputs(x, forecast, 0.0, locked=locked)).flow_kg_s is (
            locked.flow_kg_s
        )
    controller.solver_slot.solve = _FailingSolver().solve  # type: ignore[method-assign]
    for j in (3, 4):
        forecast = setup.forecaster.forecast(k + j, steps)
        action = controller.act(PeriodInputs(x, forecast, 0.0))
        low = setup.building.hvac.flow_min_at(forecast.occupied[:1])[0]
        expected = np.clip(plan.u[j], low, setup.building.hvac.flow_max_kg_s)
        assert action.fallback
        np.testing.assert_array_equal(action.flow_kg_s, expected)
    assert not np.allclose(plan.u[3], plan.u[1])  # the test tells the two apart


def test_short_forecast_names_the_horizon_setting(setup: Setup) -> None:
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    horizon = setup.config.controller.horizon_steps
    forecast = setup.forecaster.forecast(0, horizon - 1)
    x = np.full(setup.model.a.shape[0], 25.0)
    with pytest.raises(ConfigError, match=r"controller\.horizon_steps"):
        controller.problem_for(PeriodInputs(x, forecast, peak_floor_kw=0.0))


def test_the_reserve_contract_reaches_the_problem_and_the_event_plan(setup: Setup) -> None:
    k = 20
    forecast = setup.forecaster.forecast(k, setup.config.controller.horizon_steps + 1)
    x = np.full(setup.model.a.shape[0], 25.0)
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    reserve = setup.config.reserve
    problem = controller.problem_for(PeriodInputs(x, forecast, 0.0, allowance_carry_steps=2))
    events = problem.events
    assert events is not None
    assert events.max_steps == reserve.event_max_steps == 4
    assert events.allowance_kelvin == reserve.event_allowance_k
    assert events.recovery_steps == reserve.event_recovery_steps
    assert events.carry_steps == 2
    action = controller.act(PeriodInputs(x, forecast, 0.0))
    plan = action.event_plan
    assert plan is not None and plan.steps == 4 + reserve.event_recovery_steps
    np.testing.assert_allclose(plan.flow_kg_s[0], action.flow_kg_s)
    np.testing.assert_allclose(plan.reserve_flow_kg_s[0], action.reserve_flow_kg_s)
    assert plan.reserve_kw[0] == pytest.approx(action.reserve_kw)
    # the paper's preset: whole-horizon model, no carry, no event plan
    paper = prepare(preset("paper-rmpc-ppp", start=START, days=1.0))
    whole = make_controller(paper)
    assert isinstance(whole, MPCController)
    problem = whole.problem_for(PeriodInputs(x, forecast, 0.0, allowance_carry_steps=2))
    assert problem.events is None  # nor, then, any carry
    assert whole.act(PeriodInputs(x, forecast, 0.0)).event_plan is None


def test_model_error_margin_accumulates_the_zone_error_by_hand(setup: Setup) -> None:
    model = setup.model
    m = model.c.shape[0]
    eps = np.linspace(0.1, 0.3, m)
    margin = model_error_margins(model, eps, setup.config.controller)
    horizon = setup.config.controller.horizon_steps
    assert margin.shape == (horizon, m)
    np.testing.assert_allclose(margin[0], eps, atol=1e-12)  # step 1: the one-step error
    # step k: Σ_{j<k} |C A^{k−1−j} Cᵀ| ε, by matrix powers
    k = 5
    expected = sum(
        np.abs(model.c @ np.linalg.matrix_power(model.a, lag) @ model.c.T) @ eps for lag in range(k)
    )
    np.testing.assert_allclose(margin[k - 1], expected, rtol=1e-10)
    assert (np.diff(margin, axis=0) >= -1e-12).all()


def test_model_error_tightens_the_robust_plan_only(setup: Setup) -> None:
    base = MPCController(
        setup.building, setup.model, setup.config.controller, setup.box,
        setup.linearisation_temp_degc,
    )  # fmt: skip
    eps = np.full(setup.model.c.shape[0], 0.2)
    tightened = MPCController(
        setup.building, setup.model, setup.config.controller, setup.box,
        setup.linearisation_temp_degc, model_error_k=eps,
    )  # fmt: skip
    seen: list[RMPCProblem] = []
    for controller in (base, tightened):
        controller.observe_problems(seen.append)
        x = np.full(setup.model.a.shape[0], 25.0)
        controller.act(PeriodInputs(x, setup.forecaster.forecast(20, 49), 0.0))
    assert (seen[1].y_max <= seen[0].y_max + 1e-12).all()
    assert (seen[1].y_max < seen[0].y_max - 0.1).any()
    nominal = replace(setup.config.controller, robust="none")
    ignored = MPCController(
        setup.building, setup.model, nominal, setup.box, setup.linearisation_temp_degc,
        model_error_k=eps,
    )  # fmt: skip
    ignored.observe_problems(seen.append)
    ignored.act(
        PeriodInputs(np.full(setup.model.a.shape[0], 25.0), setup.forecaster.forecast(20, 49), 0.0)
    )
    np.testing.assert_array_equal(seen[2].y_max, seen[0].y_max)


def _decided_now(setup: Setup) -> Setup:
    """``setup`` with each period's offer decided at its start (no commitments ahead)."""
    reserve = replace(setup.config.reserve, commit_ahead_periods=0)
    return replace(setup, config=replace(setup.config, reserve=reserve))


def test_no_reserve_is_offered_where_the_baseline_would_not_see_it() -> None:
    """An air handler that was off before (metered baseline ≈ 0 kW): an activation now
    would show no reduction, so nothing is offered; with the baseline unknown or high the
    same plan offers reserve, declared at q·r ≤ p·r. Reserve priced at 200 SGD/MWh: with
    outdoor air by need (curtailment does not shed it) and the part-load chiller, a kg/s
    shed saves ≈ 2.5 times less than under the fixed 37 % share and constant COP, and at the
    synthetic scale of 15 SGD/MWh this day offers nothing."""
    setup = _decided_now(
        prepare(
            with_overrides(
                preset("rmpc-ppp", start=START, days=1.0), {"data.reserve_price_scale": 200.0}
            )
        )
    )
    cfg = setup.config.controller
    x = np.full(len(setup.model.node_names), 25.0)
    for k in range(20, 36):  # 10:00 … 17:30
        forecast = setup.forecaster.forecast(k, cfg.horizon_steps + 1)
        free = make_controller(setup)
        offered = free.act(PeriodInputs(x, forecast, 0.0))
        if offered.reserve_kw > 0:
            break
    else:
        pytest.fail("no offer in the searched periods")
    assert isinstance(free, MPCController)
    blind = make_controller(setup)
    assert blind.act(PeriodInputs(x, forecast, 0.0, baseline_power_kw=0.0)).reserve_kw == 0.0
    high = make_controller(setup)
    action = high.act(PeriodInputs(x, forecast, 0.0, baseline_power_kw=1e6))
    assert action.reserve_kw == pytest.approx(offered.reserve_kw)
    problem = free.problem_for(PeriodInputs(x, forecast, 0.0))
    assert (problem.reserve_kw_per_kg_s <= problem.power_coeff_kw_per_kg_s).all()


def test_commitments_are_fixed_in_the_plan(setup: Setup) -> None:
    """g = 2: r_0, r_1 of the plan are the committed flows (column bounds), the period's
    reserve flow is the commitment, and the plan offers step g ahead."""
    g = setup.config.reserve.commit_ahead_periods
    assert g == 2
    cfg = setup.config.controller
    x = np.full(len(setup.model.node_names), 25.0)
    forecast = setup.forecaster.forecast(20, cfg.horizon_steps + 1)  # 10:00
    controller = make_controller(setup)
    assert isinstance(controller, MPCController) and controller.commits_ahead == g
    committed = np.where(controller.reserve_mask, 0.05, 0.0)[None, :].repeat(g, axis=0)
    inputs = PeriodInputs(x, forecast, 0.0, committed_reserve_kg_s=committed)
    assert controller.problem_for(inputs).fixed_reserve_steps == g
    action = controller.act(inputs)
    plan = controller.last_plan
    assert plan is not None and plan.status is SolveStatus.OPTIMAL
    np.testing.assert_allclose(plan.r[:g], committed, atol=1e-9)
    np.testing.assert_allclose(action.reserve_flow_kg_s, committed[0], atol=1e-9)
    assert action.offer_ahead is not None
    free = make_controller(setup)  # nothing committed: the same period plans r_0 = 0
    free.act(PeriodInputs(x, forecast, 0.0))
    assert free.last_plan is not None
    np.testing.assert_allclose(free.last_plan.r[:g], 0.0, atol=1e-9)  # to the dual tolerance


def _offer_case(
    setup: Setup,
) -> tuple[MPCController, RMPCProblem, Callable[..., RMPCProblem]]:
    """A controller at 10:00 on the first day, its problem from 25 °C, and a function that
    builds the problem again with other period inputs (keywords of ``PeriodInputs``)."""
    x = np.full(len(setup.model.node_names), 25.0)
    forecast = setup.forecaster.forecast(20, setup.config.controller.horizon_steps + 1)
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)

    def rebuild(**told: Any) -> RMPCProblem:
        return controller.problem_for(PeriodInputs(x, forecast, 0.0, **told))

    return controller, rebuild(), rebuild


def _visible_offer_kw(
    controller: MPCController,
    problem: RMPCProblem,
    served_kw: np.ndarray,
    j: int,
    reserve_flow_kg_s: np.ndarray,
    baseline_kw: float | None = None,
    ahead_kw: np.ndarray | None = None,
    meter_ratio: float = np.nan,
) -> float:
    """Step j's offer with reserve flows r_j (m,) [kg/s] under the told baselines and ρ:
    the period's ``OfferSizer.visible_offers_kw`` of that one step [kW]."""
    flows = np.zeros((j + 1, reserve_flow_kg_s.size))
    flows[j] = reserve_flow_kg_s
    sizer = OfferSizer(controller.contract, baseline_kw, ahead_kw, None, meter_ratio)
    return float(sizer.visible_offers_kw(problem, served_kw, flows)[j])


def test_offers_are_sized_to_what_every_covering_baseline_would_see(setup: Setup) -> None:
    """The offer of step j is min(q_j·r_j, min_s B̂_s − (P̂_j − p_j·r_j)) over the starts s of
    the activations covering j (D = 4): P̂_{s−1} for s ≥ 1 and the baseline now for s = 0,
    computed here by hand on a made-up plan power."""
    controller, problem, _ = _offer_case(setup)
    j = 2
    r = np.where(controller.reserve_mask, 0.1, 0.0)
    shed_kw = float(problem.power_coeff_kw_per_kg_s[j] @ r)
    offer_kw = float(problem.reserve_kw_per_kg_s[j] @ r)
    assert 0 < offer_kw <= shed_kw
    served = np.full(problem.horizon, 30.0)
    told: dict[str, Any] = {"baseline_kw": 1e6}
    # flat load: the whole shed is seen, the offer is q·r
    assert _visible_offer_kw(controller, problem, served, j, r, **told) == pytest.approx(offer_kw)
    # rising load: P̂_2 = 30 + shed − 1, lowest baseline P̂_0 = 30: 1 kW is seen
    rising = served.copy()
    rising[1], rising[2] = 30.5, 30.0 + shed_kw - 1.0
    seen = _visible_offer_kw(controller, problem, rising, j, r, **told)
    assert seen == pytest.approx(min(offer_kw, 1.0), abs=1e-5)
    # the air handler off before (baseline now 0): an activation starting now covers j
    told = {"baseline_kw": 0.0}
    assert _visible_offer_kw(controller, problem, served, j, r, **told) == 0.0
    # … but not step 4 = D (its covering starts are 1 … 4)
    assert _visible_offer_kw(controller, problem, served, 4, r, **told) == pytest.approx(
        float(problem.reserve_kw_per_kg_s[4] @ r)
    )
    # unknown baseline now: only the plan's own baselines count
    told = {"baseline_kw": None}
    assert _visible_offer_kw(controller, problem, served, j, r, **told) == pytest.approx(offer_kw)


def test_under_similar_days_offers_are_sized_to_the_similar_days_baseline(setup: Setup) -> None:
    """With the driver's similar-days baselines for the coming periods the offer of step j
    is min(q_j·r_j, B_j − (P̂_j − p_j·r_j)), whatever the plan's earlier powers; where B_j is
    unknown (no similar day yet) the pre-event baselines apply, as in the settlement."""
    controller, problem, _ = _offer_case(setup)
    j = 2
    r = np.where(controller.reserve_mask, 0.1, 0.0)
    shed_kw = float(problem.power_coeff_kw_per_kg_s[j] @ r)
    offer_kw = float(problem.reserve_kw_per_kg_s[j] @ r)
    rising = np.full(problem.horizon, 20.0)  # the plan's earlier powers see nothing …
    rising[j] = 30.0
    told: dict[str, Any] = {"baseline_kw": 0.0}
    assert _visible_offer_kw(controller, problem, rising, j, r, **told) == 0.0
    # … the similar days' 30.5 kW at step j show 0.5 kW + the shed below it
    told = {"baseline_kw": 0.0, "ahead_kw": np.array([np.nan, np.nan, 30.5])}
    seen = _visible_offer_kw(controller, problem, rising, j, r, **told)
    assert seen == pytest.approx(min(offer_kw, 0.5 + shed_kw), abs=1e-5)
    # a low similar-days baseline hides an offer the plan's flat load would show
    flat = np.full(problem.horizon, 30.0)
    told = {"baseline_kw": 1e6, "ahead_kw": np.array([np.nan, np.nan, 25.0])}
    assert _visible_offer_kw(controller, problem, flat, j, r, **told) == 0.0
    # no similar day for step j: the pre-event baselines (flat load: all of q·r is seen)
    told = {"baseline_kw": 1e6, "ahead_kw": np.array([25.0, 25.0, np.nan])}
    assert _visible_offer_kw(controller, problem, flat, j, r, **told) == pytest.approx(offer_kw)
    # the event plan's later steps (D + R = 6) are sized to theirs too
    told = {"baseline_kw": 1e6, "ahead_kw": np.array([1e6, 1e6, 1e6, 1e6, 25.0, 1e6])}
    assert _visible_offer_kw(controller, problem, flat, 4, r, **told) == 0.0
    assert _visible_offer_kw(controller, problem, flat, 5, r, **told) > 0.0


def test_offers_are_scaled_by_the_meter_s_response(setup: Setup) -> None:
    """ρ = 0.5 (the meter moves half of what the plan moves): the reserve coefficient the LP
    prices is halved, and so is every offer, the part the baseline sees included; ρ = 1 is
    the model's own scale, bit for bit."""
    controller, own, rebuild = _offer_case(setup)
    halved = rebuild(meter_ratio=0.5)
    np.testing.assert_allclose(halved.reserve_kw_per_kg_s, 0.5 * own.reserve_kw_per_kg_s)
    np.testing.assert_array_equal(halved.power_coeff_kw_per_kg_s, own.power_coeff_kw_per_kg_s)
    j = 2
    r = np.where(controller.reserve_mask, 0.1, 0.0)
    shed_kw = float(own.power_coeff_kw_per_kg_s[j] @ r)
    offer_kw = float(own.reserve_kw_per_kg_s[j] @ r)
    told: dict[str, Any] = {"baseline_kw": 1e6, "meter_ratio": 0.5}
    served = np.full(own.horizon, 30.0)
    assert _visible_offer_kw(controller, halved, served, j, r, **told) == pytest.approx(
        0.5 * offer_kw
    )
    # a rising load leaves 1 kW of the plan's shed visible: 0.5 kW on the meter
    rising = served.copy()
    rising[1], rising[2] = 30.5, 30.0 + shed_kw - 1.0
    seen = _visible_offer_kw(controller, halved, rising, j, r, **told)
    assert seen == pytest.approx(min(0.5 * offer_kw, 0.5), abs=1e-5)
    # a metered baseline (similar days) is a level, not a change of the plan's: the meter
    # sheds ρ·p·r below the plan's served level, so B = P̂_j − 0.8·shed sees nothing …
    nan = np.nan
    told = {
        "baseline_kw": 1e6,
        "meter_ratio": 0.5,
        "ahead_kw": np.array([nan, nan, served[j] - 0.8 * shed_kw]),
    }
    assert _visible_offer_kw(controller, halved, served, j, r, **told) == 0.0
    # … and B = P̂_j − 0.3·shed sees (0.5 − 0.3)·shed
    told = {
        "baseline_kw": 1e6,
        "meter_ratio": 0.5,
        "ahead_kw": np.array([nan, nan, served[j] - 0.3 * shed_kw]),
    }
    seen = _visible_offer_kw(controller, halved, served, j, r, **told)
    assert seen == pytest.approx(min(0.5 * offer_kw, 0.2 * shed_kw), abs=1e-5)
    np.testing.assert_array_equal(
        rebuild(meter_ratio=1.0).reserve_kw_per_kg_s, own.reserve_kw_per_kg_s
    )


def test_the_plan_is_paid_for_what_the_told_baselines_see(setup: Setup) -> None:
    """The problem carries the baselines the driver told (``plan_visible_offers``): the one
    of an activation starting now for steps < D, a similar-days baseline in place of the
    pre-event ones, ρ; after a plan, the steps at which no shed could have been seen are
    left out; with the setting off the LP is paid q·r."""
    controller, problem, rebuild = _offer_case(setup)
    assert problem.offer_baselines is not None
    assert np.isnan(problem.offer_baselines.fixed_baseline_kw).all()  # nothing told yet
    assert problem.offer_baselines.offer_steps.all()  # no plan yet: every step
    told = {"meter_ratio": 0.7, "baseline_power_kw": 12.0, "baseline_ahead_kw": [np.nan, 40.0]}
    baselines = rebuild(**told).offer_baselines
    assert baselines is not None and baselines.meter_ratio == 0.7
    max_steps = setup.config.reserve.event_max_steps
    assert max_steps == 4
    np.testing.assert_array_equal(baselines.fixed_baseline_kw[:5], [12.0, 40.0, 12.0, 12.0, np.nan])
    assert not baselines.fixed_on_plan_scale.any()  # no plan for the period before: metered
    np.testing.assert_array_equal(baselines.planned_baselines[:3], [True, False, True])
    x = np.full(len(setup.model.node_names), 25.0)
    forecast = setup.forecaster.forecast(20, 49)
    # the air handler was off: the start-up is not paid
    controller.act(PeriodInputs(x, forecast, 0.0, baseline_power_kw=0.0))
    left_out = rebuild(baseline_power_kw=0.0).offer_baselines
    assert left_out is not None and not left_out.offer_steps.all()
    off = replace(setup.config.reserve, plan_visible_offers=False)
    plain = make_controller(replace(setup, config=replace(setup.config, reserve=off)))
    assert isinstance(plain, MPCController)
    assert plain.problem_for(PeriodInputs(x, forecast, 0.0)).offer_baselines is None


def test_the_paid_steps_move_with_every_period_since_the_plan(setup: Setup) -> None:
    """The steps a plan could show offers at are moved by the periods since that plan —
    the ones held under a locked event included — its last step repeated; the problem of
    the period after a plan moves them by one."""
    controller, problem, rebuild = _offer_case(setup)  # the problem the act below solves
    x = np.full(len(setup.model.node_names), 25.0)
    forecast = setup.forecaster.forecast(20, 49)
    controller.act(PeriodInputs(x, forecast, 0.0))
    plan = controller.last_plan
    assert plan is not None
    seen = OfferSizer(controller.contract, None, None, None, np.nan).seen_kw(problem, plan)
    assert seen is not None and (seen < 0).any() and (seen >= 0).any()
    horizon = seen.size
    steps = seen_steps(seen, 0, horizon)
    assert steps is not None
    np.testing.assert_array_equal(steps, seen >= 0)  # the same period: not moved
    for held in (1, 2):
        steps = seen_steps(seen, held, horizon)
        assert steps is not None
        expected = np.concatenate([seen[held:], np.repeat(seen[-1:], held)]) >= 0
        np.testing.assert_array_equal(steps, expected)
    paid = rebuild().offer_baselines
    assert paid is not None
    np.testing.assert_array_equal(paid.offer_steps, seen_steps(seen, 1, horizon))


def test_planned_flows_within_round_off_of_a_limit_are_the_limit(setup: Setup) -> None:
    """A flow 1e-13 kg/s above an unoccupied zero would start the fan: it is snapped."""
    controller, problem, _ = _offer_case(setup)
    low = np.asarray(problem.u_min, dtype=float)
    u = np.array(low, copy=True)
    u[0] += 3.5e-13
    u[1] = controller.contract.flow_max_kg_s - 1e-12
    plan = replace(_timed_out(problem), u=u, r=np.zeros_like(u))  # a made-up plan
    flow, reserve = snapped_flows_kg_s(problem, plan, 2, controller.contract.flow_max_kg_s)
    np.testing.assert_array_equal(flow[0], low[0])
    np.testing.assert_array_equal(flow[1], controller.contract.flow_max_kg_s)
    assert (reserve == 0.0).all()
