"""make_solver: the one factory of both warm-started solvers; solve_rmpc: the one-shot solve."""

from __future__ import annotations

import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt import FeedbackSolver, RMPCSolver, make_solver, solve_rmpc
from hvacflex.opt.testing import random_problem


@pytest.mark.parametrize(
    ("robust", "kind"), [("tightening", RMPCSolver), ("feedback", FeedbackSolver)]
)
def test_the_robust_mode_picks_the_solver(robust: str, kind: type) -> None:
    problem = random_problem(0, robust=robust)
    solver = make_solver(problem, time_limit_s=30.0)
    assert type(solver) is kind
    warm, once = solver.solve(problem), solve_rmpc(problem)
    assert warm.ok and once.ok
    assert warm.objective_sgd == pytest.approx(once.objective_sgd, rel=1e-9, abs=1e-9)


def test_a_bad_time_limit_is_refused() -> None:
    with pytest.raises(ProblemError):
        make_solver(random_problem(0), time_limit_s=-1.0)
