"""RMPCProblem.power_cap (PowerCap): a bound on the plan's power (the fleet's per-building
cap)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt import PowerCap, RMPCSolver, solve_rmpc
from hvacflex.opt.testing import random_problem


def test_cap_bounds_the_plan_and_warm_start_agrees() -> None:
    problem = random_problem(np.random.default_rng(4))
    free = solve_rmpc(problem)
    assert free.ok
    floor = problem.power_offset_kw + np.sum(problem.power_coeff_kw_per_kg_s * problem.u_min, 1)
    cap = np.maximum(floor + 1e-3, 0.8 * free.power_kw)
    capped = dataclasses.replace(problem, power_cap=PowerCap(power_max_kw=cap))
    cold = solve_rmpc(capped)
    assert cold.ok and np.all(cold.power_kw <= cap + 1e-7)
    assert cold.objective_sgd >= free.objective_sgd - 1e-7
    solver = RMPCSolver(problem, time_shift=False)
    solver.solve(problem)
    warm = solver.solve(capped)
    assert warm.objective_sgd == pytest.approx(cold.objective_sgd, rel=1e-7, abs=1e-7)


def test_cap_refused_for_feedback() -> None:
    problem = random_problem(np.random.default_rng(4))
    with pytest.raises(ProblemError, match="power_cap"):
        dataclasses.replace(problem, robust="feedback", power_cap=PowerCap(power_max_kw=1.0))


def _highs_objective(problem: object) -> float:
    solver = RMPCSolver(problem, time_shift=False)  # type: ignore[arg-type]
    assert solver.solve(problem).ok  # type: ignore[arg-type]
    return solver.highs_objective_sgd()


def test_cap_values_match_finite_differences_of_the_optimal_objective() -> None:
    """The cap value is a subgradient of the optimal objective in the cap: between the gain
    per kW of loosening the cap and the loss per kW of tightening it (one-sided finite
    differences, each from a fresh cold solve); 0 where the cap is slack."""
    problem = random_problem(np.random.default_rng(4))
    free = solve_rmpc(problem)
    floor = problem.power_offset_kw + np.sum(problem.power_coeff_kw_per_kg_s * problem.u_min, 1)
    cap = np.maximum(floor + 1e-3, 0.8 * free.power_kw)
    cap[1::2] = free.power_kw[1::2] + 5.0  # slack in the odd periods
    capped = dataclasses.replace(problem, power_cap=PowerCap(power_max_kw=cap))
    solver = RMPCSolver(capped, time_shift=False)
    assert solver.solve(capped).ok
    values = solver.power_cap_values_sgd_per_kw()
    assert values.shape == (problem.horizon,) and np.all(values >= 0.0)
    base = solver.highs_objective_sgd()
    step_kw = 1e-4
    for k in range(problem.horizon):
        looser, tighter = cap.copy(), cap.copy()
        looser[k] += step_kw
        tighter[k] -= step_kw
        gain = (
            base
            - _highs_objective(
                dataclasses.replace(problem, power_cap=PowerCap(power_max_kw=looser))
            )
        ) / step_kw
        loss = (
            _highs_objective(dataclasses.replace(problem, power_cap=PowerCap(power_max_kw=tighter)))
            - base
        ) / step_kw
        assert gain - 1e-3 <= values[k] <= loss + 1e-3, (k, gain, values[k], loss)
        if k % 2:
            assert values[k] == 0.0 and abs(gain) < 1e-3 and abs(loss) < 1e-3
        else:
            assert values[k] > 0.01  # the even caps bind and cost something


def test_cap_values_need_an_optimal_solve() -> None:
    problem = random_problem(np.random.default_rng(4))
    solver = RMPCSolver(problem, time_shift=False)
    with pytest.raises(ProblemError, match="optimal"):
        solver.power_cap_values_sgd_per_kw()
    solver.solve(problem)
    values = solver.power_cap_values_sgd_per_kw()
    assert np.all(values == 0.0)  # no cap: nothing to gain from more of it


def test_with_price_and_cap_equals_replace_and_checks_its_fields() -> None:
    problem = random_problem(np.random.default_rng(5))
    price = problem.energy_price_sgd_per_mwh + np.linspace(0.0, 40.0, problem.horizon)
    cap = np.full(problem.horizon, 1e3)
    variant = problem.with_price_and_cap(price, cap)
    replaced = dataclasses.replace(
        problem, energy_price_sgd_per_mwh=price, power_cap=PowerCap(power_max_kw=cap)
    )
    np.testing.assert_array_equal(variant.power_max_kw, replaced.power_max_kw)
    for f in dataclasses.fields(problem):
        if f.init and f.name != "power_cap":
            np.testing.assert_array_equal(
                np.asarray(getattr(variant, f.name), dtype=object),
                np.asarray(getattr(replaced, f.name), dtype=object),
                err_msg=f.name,
            )
    assert variant.structure is problem.structure
    assert problem.power_max_kw.shape == (problem.horizon,) and np.all(
        np.isinf(problem.power_max_kw)
    )
    solver = RMPCSolver(problem, time_shift=False)
    solver.solve(problem)
    warm = solver.solve(variant)
    assert warm.objective_sgd == pytest.approx(solve_rmpc(replaced).objective_sgd, rel=1e-7)
    with pytest.raises(ProblemError, match="energy_price_sgd_per_mwh"):
        problem.with_price_and_cap(price[:-1])
    with pytest.raises(ProblemError, match="power_max_kw"):
        problem.with_price_and_cap(price, -np.inf)
    feedback = dataclasses.replace(problem, robust="feedback")
    with pytest.raises(ProblemError, match="power_cap"):
        feedback.with_price_and_cap(price, cap)
