"""Every LP family against its CVXPY reference (:mod:`hvacflex.opt.reference`), to 1e-6
relative: the office5 LPs a closed loop builds (event model with visible offers and committed
reserve, nominal event model, whole-horizon, feedback) and random problems (every robust mode,
every feedback structure, a power cap, q ≠ p, a rank-deficient E). A change of the LP that
its reference does not share fails here (issue 56 item 9: the benchmark's CVXPY model had
drifted from the event LP by 2 % once the offers became baseline-visible, and no test saw it)."""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import numpy as np
import pytest

from hvacflex.config import preset
from hvacflex.opt import (
    FeedbackOptions,
    ILEventModel,
    PowerCap,
    ReserveCommitment,
    RMPCProblem,
    RMPCSolver,
    SolveStatus,
    StepLinearisation,
    solve_rmpc,
)
from hvacflex.opt.options import FEEDBACK_STRUCTURES
from hvacflex.opt.reference import margins, reference_event_rows, solve_reference
from hvacflex.opt.robust import comfort_margins
from hvacflex.opt.testing import random_problem
from hvacflex.sim.recording import recorded_problems

REL_TOL = 1e-6
START = "2014-05-05"
#: cvxpy's interval arithmetic warns on the ±inf comfort bounds of unoccupied hours
pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered in matmul:RuntimeWarning")


@functools.cache
def _recorded(scenario: str, steps: int) -> tuple[RMPCProblem, ...]:
    return tuple(recorded_problems(preset(scenario, start=START, days=1), steps))


def _relative(ours: float, reference: float) -> float:
    return abs(ours - reference) / max(1.0, abs(ours))


def _window(prob: RMPCProblem, first: int, horizon: int) -> RMPCProblem:
    """The problem on steps first … first + horizon − 1 only (a smaller LP of the same family,
    from the same building and series)."""
    steps = slice(first, first + horizon)
    names = [
        "d_forecast",
        "d_sigma",
        "energy_price_sgd_per_mwh",
        "reserve_price_sgd_per_mwh",
        "power_offset_kw",
        "power_coeff_kw_per_kg_s",
        "reserve_power_coeff_kw_per_kg_s",
        "u_min",
        "u_max",
        "y_min",
        "y_max",
        "peak_price_sgd_per_kw",
    ]
    fields = {name: getattr(prob, name)[steps] for name in names}
    if prob.power_cap is not None:
        fields["power_cap"] = PowerCap(power_max_kw=prob.power_cap.kw[steps])
    return dataclasses.replace(prob, **fields)


def test_office5_event_lp_with_visible_offers_equals_cvxpy() -> None:
    """The product LP (rmpc: D = 4, R = 2, α = 1 K, offers paid for what the baselines see,
    two committed steps), warm-started through 4 receding steps as the controller does."""
    problems = _recorded("rmpc", 4)
    assert all(p.offer_baselines is not None for p in problems)
    assert problems[-1].fixed_reserve_steps > 0
    solver = RMPCSolver(problems[0])
    for index, problem in enumerate(problems):
        solution = solver.solve(problem)
        assert solution.status is SolveStatus.OPTIMAL, solution.message
        if index not in (0, 3):
            continue
        reference = solve_reference(problem)
        assert reference.status == "optimal"
        assert reference.family == "event model, visible offers"
        assert _relative(solver.highs_objective_sgd(), reference.objective_sgd) < REL_TOL
        # the offers the LP is paid for are what the reference's baselines see
        paid = solution.reserve_kw[problem.fixed_reserve_steps :]
        assert paid.sum() == pytest.approx(
            reference.reserve_kw[problem.fixed_reserve_steps :].sum(), abs=1e-5
        )


def test_the_comparison_sees_the_offer_rows() -> None:
    """Not vacuous: the reference without the visible-offer rows (the benchmark's model before
    issue 56) misses the LP's optimum by far more than the tolerance."""
    problems = _recorded("rmpc", 4)
    solver = RMPCSolver(problems[0])
    for problem in problems[:2]:
        solver.solve(problem)
    stale = solve_reference(dataclasses.replace(problems[1], offer_baselines=None))
    assert _relative(solver.highs_objective_sgd(), stale.objective_sgd) > 1e-3


@pytest.mark.parametrize(
    ("scenario", "family"),
    [("nmpc", "event model, visible offers"), ("paper-rmpc", "whole-horizon")],
)
def test_office5_open_loop_families_equal_cvxpy(scenario: str, family: str) -> None:
    problem = _recorded(scenario, 2)[-1]
    solver = RMPCSolver(problem)
    assert solver.solve(problem).ok
    reference = solve_reference(problem)
    assert (reference.status, reference.family) == ("optimal", family)
    assert _relative(solver.highs_objective_sgd(), reference.objective_sgd) < REL_TOL


def test_office5_feedback_lp_equals_cvxpy() -> None:
    """rmpc-feedback (zone-local gains, L = 4) on a 10-step window from 08:00, where the
    office is occupied and the gains matter."""
    problem = _window(_recorded("rmpc-feedback", 1)[0], 16, 10)
    assert problem.feedback is not None and problem.feedback.structure == "zone-local"
    solution = solve_rmpc(problem)
    assert solution.ok and solution.feedback_gains is not None
    assert np.abs(solution.feedback_gains).max() > 1e-6  # the gains are used
    reference = solve_reference(problem)
    assert reference.status == "optimal"
    ours = solution.objective_sgd + solution.tie_break_sgd
    assert _relative(ours, reference.objective_sgd) < REL_TOL


@pytest.mark.parametrize("structure", FEEDBACK_STRUCTURES)
@pytest.mark.parametrize("seed", range(3))
def test_feedback_structures_equal_cvxpy(seed: int, structure: str) -> None:
    sigma = random_problem(seed).d_sigma * 2.0  # margins bind: the gains matter
    options = FeedbackOptions(structure=structure, memory_steps=2)  # type: ignore[arg-type]
    problem = random_problem(
        seed,
        robust="feedback",
        feedback=options,
        d_sigma=sigma,
        peak_price_sgd_per_kw=0.5 * seed,
    )
    solution = solve_rmpc(problem)
    open_loop = solve_rmpc(random_problem(seed, d_sigma=sigma, peak_price_sgd_per_kw=0.5 * seed))
    assert solution.objective_sgd < open_loop.objective_sgd - 1e-4  # not the open loop
    reference = solve_reference(problem)
    ours = solution.objective_sgd + solution.tie_break_sgd
    assert _relative(ours, reference.objective_sgd) < REL_TOL


@pytest.mark.parametrize("zero_gains", [False, True])
def test_feedback_with_rank_deficient_e_equals_cvxpy(zero_gains: bool) -> None:
    """E's third channel is the sum of the first two: the gains see only what E w reveals."""
    base = random_problem(4)
    e_matrix = base.e_matrix.copy()
    e_matrix[:, 2] = e_matrix[:, 0] + e_matrix[:, 1]
    options = FeedbackOptions(structure="time-invariant", memory_steps=3, zero_gains=zero_gains)
    problem = dataclasses.replace(
        base, e_matrix=e_matrix, d_sigma=base.d_sigma * 2.0, robust="feedback", feedback=options
    )
    solution = solve_rmpc(problem)
    reference = solve_reference(problem)
    ours = solution.objective_sgd + solution.tie_break_sgd
    assert _relative(ours, reference.objective_sgd) < REL_TOL


@pytest.mark.parametrize("robust", ["tightening", "dual", "none"])
@pytest.mark.parametrize("seed", range(3))
def test_whole_horizon_modes_equal_cvxpy(seed: int, robust: str) -> None:
    """With committed reserve, a power cap and a reserve coefficient q ≠ p."""
    base = random_problem(seed, robust=robust, reserve_price_sgd_per_mwh=np.full(8, 400.0))
    free = solve_rmpc(base)
    assert free.ok
    problem = dataclasses.replace(
        base,
        peak_floor_kw=2.0,
        power_cap=PowerCap(power_max_kw=float(free.power_kw.max()) * 0.95),
        reserve_power_coeff_kw_per_kg_s=base.power_coeff_kw_per_kg_s * 0.7,
        commitments=ReserveCommitment(reserve_kg_s=np.full((2, base.m), 0.01)),
    )
    solver = RMPCSolver(problem)
    assert solver.solve(problem).ok
    reference = solve_reference(problem)
    assert reference.family == "whole-horizon"
    assert _relative(solver.highs_objective_sgd(), reference.objective_sgd) < REL_TOL


@pytest.mark.parametrize("robust", ["tightening", "feedback"])
def test_problems_without_reserve_equal_cvxpy(robust: str) -> None:
    problem = random_problem(1, robust=robust, reserve_mask=np.zeros(2, dtype=bool))
    solution = solve_rmpc(problem)
    reference = solve_reference(problem)
    assert reference.status == "optimal"
    assert not reference.reserve_kw.any()
    ours = solution.objective_sgd + solution.tie_break_sgd
    assert _relative(ours, reference.objective_sgd) < REL_TOL


def test_reference_margins_and_event_rows_by_hand() -> None:
    """δ equals hvacflex's robust margins; the rows of D = 2, R = 1, N = 4 listed by hand."""
    problem = random_problem(0, horizon=4, events=ILEventModel(max_steps=2, recovery_steps=1))
    expected = comfort_margins(
        problem.a_matrix, problem.e_matrix, problem.c_matrix, problem.d_sigma
    )
    np.testing.assert_allclose(margins(problem), expected, rtol=1e-12, atol=1e-12)
    step, start, length, allowance = reference_event_rows(problem)
    rows: list[tuple[Any, ...]] = list(
        zip(step.tolist(), start.tolist(), length.tolist(), allowance.tolist(), strict=True)
    )
    # t = 1: (s 0, lag 1) allowance L 1; t = 2: lags 2, 1 allowance L 2, 1; t = 3: lag 3
    # allowance L 2 and strict L 1 (3 ≥ R + 2), lags 2, 1 allowance; t = 4: lag 4 strict L 2
    # (4 > D + R: no allowance), lag 3 allowance + strict L 1, lags 2, 1 allowance
    assert rows == [
        (0, 0, 1, True),
        (1, 0, 2, True),
        (1, 1, 1, True),
        (2, 0, 2, True),
        (2, 0, 1, False),
        (2, 1, 2, True),
        (2, 2, 1, True),
        (3, 0, 2, False),
        (3, 1, 2, True),
        (3, 1, 1, False),
        (3, 2, 2, True),
        (3, 3, 1, True),
    ]


def _scaled(problem: RMPCProblem, seed: int) -> RMPCProblem:
    """``problem`` with each step's cooling per kg/s scaled by s_k in [0.7, 1.3] (N, m)."""
    scale = np.random.default_rng(seed).uniform(0.7, 1.3, (problem.horizon, problem.m))
    return dataclasses.replace(problem, step_linearisation=StepLinearisation(input_scale=scale))


def test_office5_event_lp_with_an_input_scale_equals_cvxpy() -> None:
    """B diag(s_k) (``linearisation = "plan"``) in the served and curtailed dynamics and the
    IL event rows of the product LP, lazy rows included, against CVXPY's (which scales the
    flow variables); not vacuous: the scale moves the optimum."""
    problem = _recorded("rmpc", 2)[-1]
    scaled = _scaled(problem, 0)
    solver = RMPCSolver(scaled)
    solution = solver.solve(scaled)
    assert solution.ok, solution.message
    reference = solve_reference(scaled)
    assert (reference.status, reference.family) == ("optimal", "event model, visible offers")
    assert _relative(solver.highs_objective_sgd(), reference.objective_sgd) < REL_TOL
    assert _relative(solve_reference(problem).objective_sgd, reference.objective_sgd) > 1e-4
    # the plan's event trajectory (s = 0, L = D) steps through B diag(s_k) too
    assert scaled.events is not None and solution.r.any()
    x, g = scaled.x0.copy(), np.broadcast_to(scaled.g, (scaled.horizon, scaled.n))
    for k in range(scaled.horizon):
        flow = solution.u[k] - (solution.r[k] if k < scaled.events.max_steps else 0.0)
        x = scaled.a_matrix @ x + scaled.step_b_matrix[k] @ flow
        x = x + scaled.e_matrix @ scaled.d_forecast[k] + g[k]
        np.testing.assert_allclose(solution.x_curtailed[k + 1], x, atol=1e-6)


@pytest.mark.parametrize("robust", ["tightening", "none"])
def test_whole_horizon_lp_with_an_input_scale_equals_cvxpy(robust: str) -> None:
    """The curtailed trajectory z of the whole-horizon model through B diag(s_k) too."""
    base = random_problem(2, robust=robust, reserve_price_sgd_per_mwh=np.full(8, 400.0))
    scaled = _scaled(base, 1)
    solver = RMPCSolver(scaled)
    assert solver.solve(scaled).ok
    reference = solve_reference(scaled)
    assert reference.family == "whole-horizon"
    assert _relative(solver.highs_objective_sgd(), reference.objective_sgd) < REL_TOL
    ones = dataclasses.replace(
        base, step_linearisation=StepLinearisation(input_scale=np.ones((base.horizon, base.m)))
    )
    assert solve_rmpc(ones).objective_sgd == pytest.approx(solve_rmpc(base).objective_sgd, 1e-12)
