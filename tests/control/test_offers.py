"""OfferSizer and the offer helpers: snapping, the steps sized, the baselines, the paid steps."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from hvacflex.config import preset
from hvacflex.control.base import PeriodInputs
from hvacflex.control.mpc import MPCController
from hvacflex.control.offers import (
    FLOW_SNAP_TOLERANCE_KG_S,
    OfferSizer,
    offer_steps,
    seen_steps,
    snapped_flows_kg_s,
)
from hvacflex.opt import SolveStatus
from hvacflex.opt.solution import failed_solution
from hvacflex.sim.setup import Setup, make_controller, prepare


@pytest.fixture(scope="module")
def setup() -> Setup:
    return prepare(preset("rmpc-ppp", start="2014-03-03", days=1.0))


def _controller(setup: Setup) -> MPCController:
    controller = make_controller(setup)
    assert isinstance(controller, MPCController)
    return controller


def test_the_steps_sized_cover_the_commitment_and_the_event_plan(setup: Setup) -> None:
    contract = _controller(setup).contract
    reserve = setup.config.reserve
    assert contract.commit_ahead == reserve.commit_ahead_periods == 2
    assert offer_steps(contract) == reserve.event_max_steps + reserve.event_recovery_steps  # type: ignore[operator]
    whole = replace(contract, reserve=replace(reserve, event_max_steps=None), commit_ahead=0)
    assert offer_steps(whole) == 1


def test_flows_within_round_off_of_a_limit_are_snapped_and_small_reserves_dropped(
    setup: Setup,
) -> None:
    controller = _controller(setup)
    x = np.full(len(setup.model.node_names), 25.0)
    problem = controller.problem_for(PeriodInputs(x, setup.forecaster.forecast(20, 49), 0.0))
    high = controller.contract.flow_max_kg_s
    low = problem.u_min
    u = np.array(low, dtype=float)
    u[0] += 0.5 * FLOW_SNAP_TOLERANCE_KG_S
    u[1] = high - 0.5 * FLOW_SNAP_TOLERANCE_KG_S
    u[2] = 0.5 * (low[2] + high)
    r = np.zeros_like(u)
    r[2] = 1e-8  # below the solver tolerance: not offered
    r[1] = 10.0  # more than the room above u_min: clipped to it
    made_up = failed_solution(
        problem,
        status=SolveStatus.OPTIMAL,
        message="",
        delta=np.zeros((problem.horizon, problem.ny)),
        start=time.perf_counter(),
        highs_time_s=0.0,
        simplex_iterations=0,
        warm_start=False,
    )
    flow, reserve = snapped_flows_kg_s(problem, replace(made_up, u=u, r=r), 3, high)
    np.testing.assert_array_equal(flow[0], low[0])
    np.testing.assert_array_equal(flow[1], high)
    np.testing.assert_array_equal(flow[2], u[2])
    assert not reserve[2].any()
    np.testing.assert_array_equal(reserve[1], high - low[1])


def test_the_baseline_now_prefers_the_plan_s_own_where_it_is_not_below_the_meter(
    setup: Setup,
) -> None:
    contract = _controller(setup).contract
    sizer = OfferSizer(contract, 30.0, None, 32.0, np.nan)
    assert sizer.baseline_now() == ("planned", 32.0)
    assert replace(sizer, previous_planned_kw=28.0).baseline_now() == ("metered", 30.0)
    assert replace(sizer, baseline_kw=np.nan).baseline_now() == ("metered", -np.inf)
    assert replace(sizer, baseline_kw=None).baseline_now() is None
    assert sizer.scale == 1.0 and replace(sizer, meter_ratio=0.6).scale == 0.6


def test_the_baselines_put_similar_days_in_place_of_the_pre_event_ones(setup: Setup) -> None:
    contract = _controller(setup).contract
    sizer = OfferSizer(contract, 12.0, np.array([np.nan, 40.0]), None, 0.7)
    baselines = sizer.baselines(8)
    np.testing.assert_array_equal(
        baselines.fixed_baseline_kw, [12.0, 40.0, 12.0, 12.0] + [np.nan] * 4
    )
    np.testing.assert_array_equal(baselines.planned_baselines[:3], [True, False, True])
    assert baselines.meter_ratio == 0.7


def test_the_paid_steps_move_on_with_the_periods_since_the_plan_by_hand() -> None:
    seen = np.array([1.0, -1.0, 2.0, -3.0])
    np.testing.assert_array_equal(seen_steps(seen, 0, 4), [True, False, True, False])
    np.testing.assert_array_equal(seen_steps(seen, 1, 4), [False, True, False, False])
    np.testing.assert_array_equal(seen_steps(seen, 3, 4), [False, False, False, False])
    assert seen_steps(None, 2, 4) is None
