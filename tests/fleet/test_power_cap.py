"""RMPCProblem.power_max_kw: a bound on the plan's power (the fleet's per-building cap)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt import RMPCSolver, solve_rmpc
from hvacflex.opt.testing import random_problem


def test_cap_bounds_the_plan_and_warm_start_agrees() -> None:
    problem = random_problem(np.random.default_rng(4))
    free = solve_rmpc(problem)
    assert free.ok
    floor = problem.power_offset_kw + np.sum(problem.power_coeff_kw_per_kg_s * problem.u_min, 1)
    cap = np.maximum(floor + 1e-3, 0.8 * free.power_kw)
    capped = dataclasses.replace(problem, power_max_kw=cap)
    cold = solve_rmpc(capped)
    assert cold.ok and np.all(cold.power_kw <= cap + 1e-7)
    assert cold.objective_sgd >= free.objective_sgd - 1e-7
    solver = RMPCSolver(problem, time_shift=False)
    solver.solve(problem)
    warm = solver.solve(capped)
    assert warm.objective_sgd == pytest.approx(cold.objective_sgd, rel=1e-7, abs=1e-7)


def test_cap_refused_for_feedback() -> None:
    problem = random_problem(np.random.default_rng(4))
    with pytest.raises(ProblemError, match="power_max_kw"):
        dataclasses.replace(problem, robust="feedback", power_max_kw=1.0)
