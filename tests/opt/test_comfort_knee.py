"""The comfort knee (:class:`~hvacflex.opt.blocks.ComfortKnee`): ε priced at ρ up to δ and at
ρ₂ ≥ ρ beyond, so a violation the plan cannot avoid is spread instead of put where a kW buys
least (issue 60: zones ≤ 1 K out under limit windows). Checked against the CVXPY reference
(its own ``pos(ε − δ)`` term), by hand, and for what it is for: the largest slack falls."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from hvacflex.config import preset
from hvacflex.errors import ProblemError
from hvacflex.opt import ComfortKnee, PowerCap, RMPCProblem, RMPCSolver, SolveStatus, solve_rmpc
from hvacflex.opt.lp import build_lp
from hvacflex.opt.reference import solve_reference
from hvacflex.opt.solution import comfort_penalty_sgd
from hvacflex.opt.testing import random_problem
from hvacflex.sim.recording import recorded_problems

REL_TOL = 1e-6
pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered in matmul:RuntimeWarning")


def _relative(ours: float, reference: float) -> float:
    return abs(ours - reference) / max(1.0, abs(ours))


def _knee(knee_kelvin: float = 0.1, beyond: float = 1000.0) -> ComfortKnee:
    return ComfortKnee(knee_kelvin=knee_kelvin, penalty_beyond_sgd_per_kelvin_hour=beyond)


@functools.cache
def _squeezed_office5() -> tuple[RMPCProblem, ...]:
    """Two receding office5 ``rmpc`` problems (event model, visible offers, committed reserve)
    under a power cap of 90 % of the free plan's peak, so the plan must leave the band."""
    problems = recorded_problems(preset("rmpc", start="2014-05-05", days=1), 2)
    cap = 0.9 * float(solve_rmpc(problems[0]).power_kw.max())
    return tuple(dataclasses.replace(p, power_cap=PowerCap(power_max_kw=cap)) for p in problems)


def _squeezed_random(seed: int, **overrides: object) -> RMPCProblem:
    """A random problem whose band the flows cannot keep: hot forecast, low flow limit."""
    base = random_problem(seed, **overrides)  # type: ignore[arg-type]
    return dataclasses.replace(base, u_max=np.full(base.m, 0.25), y_max=np.full(base.ny, 24.5))


def test_office5_event_lp_with_a_knee_equals_cvxpy() -> None:
    problems = [dataclasses.replace(p, comfort_knee=_knee()) for p in _squeezed_office5()]
    solver = RMPCSolver(problems[0])
    for problem in problems:  # warm through the receding step, as the controller solves
        solution = solver.solve(problem)
        assert solution.status is SolveStatus.OPTIMAL, solution.message
    assert solution.slack.max() > 0.1  # the knee binds
    reference = solve_reference(problems[-1])
    assert reference.status == "optimal"
    assert _relative(solver.highs_objective_sgd(), reference.objective_sgd) < REL_TOL


@pytest.mark.parametrize("robust", ["tightening", "none", "dual", "feedback"])
def test_random_problems_with_a_knee_equal_cvxpy(robust: str) -> None:
    problem = dataclasses.replace(_squeezed_random(2, robust=robust), comfort_knee=_knee(0.2))
    solution = solve_rmpc(problem)
    assert solution.ok, solution.message
    assert solution.slack.max() > 0.2  # beyond the knee
    reference = solve_reference(problem)
    ours = solution.objective_sgd + solution.tie_break_sgd
    assert _relative(ours, reference.objective_sgd) < REL_TOL


def test_the_knee_spreads_the_violation_and_is_priced_as_written() -> None:
    """Zones sharing a power cap at 90 % of the free plan's peak: the linear penalty warms
    the zone where a kW buys least; the knee shares the warming out."""
    base = random_problem(2, robust="none")
    base = dataclasses.replace(base, y_max=np.full(base.ny, 24.5))
    cap = 0.9 * float(solve_rmpc(base).power_kw.max())
    linear = dataclasses.replace(base, power_cap=PowerCap(power_max_kw=cap))
    kneed = dataclasses.replace(linear, comfort_knee=_knee(0.1, 10_000.0))
    free, spread = solve_rmpc(linear), solve_rmpc(kneed)
    assert free.ok and spread.ok
    assert spread.slack.max() < free.slack.max() - 0.05  # the largest excursion falls …
    assert spread.slack.sum() >= free.slack.sum() - 1e-9  # … at no less discomfort in all
    dt, rho = linear.dt_h, linear.comfort_penalty_sgd_per_kelvin_hour
    by_hand = dt * (rho * spread.slack.sum() + 9_900.0 * np.maximum(spread.slack - 0.1, 0).sum())
    assert spread.comfort_penalty_sgd == pytest.approx(by_hand, rel=1e-12)
    assert comfort_penalty_sgd(linear, free.slack) == pytest.approx(free.comfort_penalty_sgd)
    # ρ₂ = ρ is the linear penalty: the same optimum
    same = solve_rmpc(dataclasses.replace(linear, comfort_knee=_knee(0.1, rho)))
    assert same.objective_sgd == pytest.approx(free.objective_sgd, rel=1e-9)


def test_the_knee_adds_its_columns_and_rows_and_changes_the_structure() -> None:
    problem = random_problem(0)
    kneed = dataclasses.replace(problem, comfort_knee=_knee())
    zeros = np.zeros((problem.horizon, problem.ny))
    (free, _), (more, layout) = build_lp(problem, zeros), build_lp(kneed, zeros)
    cells = problem.horizon * problem.ny
    assert (more.num_cols - free.num_cols, more.num_rows - free.num_rows) == (cells, cells)
    assert problem.structure.differences(kneed.structure) == ["comfort_knee"]
    assert problem.structure.fingerprint() != kneed.structure.fingerprint()
    # the knee's rows come before the rows whose coefficients move each step
    assert more.varying.rows.min() - free.varying.rows.min() == cells
    assert layout.num_cols == more.num_cols


def test_a_warm_solver_follows_a_knee_that_changes_between_steps() -> None:
    """δ and ρ₂ enter only row bounds and costs: the warm solver of the receding office5 steps
    agrees with a cold solve when they change from one step to the next."""
    problems = _squeezed_office5()
    knees = (_knee(0.1, 1000.0), _knee(0.3, 300.0))
    steps = [dataclasses.replace(p, comfort_knee=k) for p, k in zip(problems, knees, strict=True)]
    solver = RMPCSolver(steps[0])
    for problem in steps:
        warm = solver.solve(problem)
        cold = solve_rmpc(problem)
        assert warm.ok and cold.ok
        assert _relative(warm.objective_sgd, cold.objective_sgd) < REL_TOL


def test_the_knee_is_validated() -> None:
    with pytest.raises(ProblemError, match="≥ 0") as info:
        _knee(-0.5)
    assert info.value.field == "comfort_knee.knee_kelvin"
    with pytest.raises(ProblemError, match="finite"):
        _knee(0.5, float("inf"))
    with pytest.raises(ProblemError, match="convex") as info:
        random_problem(0, comfort_knee=_knee(0.5, 50.0))  # ρ = 100
    assert info.value.field == "comfort_knee.penalty_beyond_sgd_per_kelvin_hour"
    assert _knee(np.float32(0.5), np.int64(200)).knee_kelvin == 0.5  # numpy scalars are numbers
