"""The open-loop LP's families: constant vs varying coefficients, layout sizes, commitments."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.opt import ILEventModel, ReserveCommitment, SolveStatus
from hvacflex.opt.lp import build_lp
from hvacflex.opt.testing import random_problem


def test_rebuild_without_constants_gives_the_same_vectors() -> None:
    for robust in ("tightening", "dual"):
        prob = random_problem(2, robust=robust, peak_price_sgd_per_kw=np.linspace(0, 2, 8))
        margin = np.full((prob.horizon, prob.ny), 0.1)
        full, layout = build_lp(prob, margin)
        rebuilt, _ = build_lp(prob, margin, constants=False)
        assert full.constant is not None and full.constant.values.size > 0
        assert rebuilt.constant is None
        for name in ("cost", "col_lower", "col_upper", "row_lower", "row_upper"):
            np.testing.assert_array_equal(getattr(full, name), getattr(rebuilt, name))
        np.testing.assert_array_equal(full.varying.values, rebuilt.varying.values)
        assert full.num_cols == layout.num_cols


def test_layout_sizes() -> None:
    prob = random_problem(0, reserve_mask=np.array([True, False]))
    _, layout = build_lp(prob, np.zeros((prob.horizon, prob.ny)))
    horizon, n, m, ny = 8, 4, 2, 2
    assert (
        layout.num_cols == 2 * horizon * n + horizon * m + horizon * 1 + horizon * ny + horizon + 1
    )
    assert layout.num_rows == 2 * horizon * n + 4 * horizon * ny + horizon * 1 + 2 * horizon
    nominal_problem = random_problem(0, reserve_mask=np.zeros(2, dtype=bool))
    _, nominal = build_lp(nominal_problem, np.zeros((horizon, 2)))
    assert not nominal.has_curtailed
    assert nominal.num_rows == horizon * n + 2 * horizon * ny + 2 * horizon


def test_committed_reserve_is_fixed_by_bounds_and_a_warm_solver_follows_it() -> None:
    """A commitment ``ReserveCommitment(reserve_kg_s=...)`` (g, m) fixes r_0 … r_{g−1}
    (column bounds: no new rows); a warm solver re-solving with other commitments returns
    them too, with the cold optimum."""
    from hvacflex.opt import make_solver, solve_rmpc

    events = ILEventModel(max_steps=2, allowance_kelvin=1.0, recovery_steps=1)
    free = random_problem(3, horizon=8, events=events)
    fixed = np.array([[0.2, 0.0], [0.05, 0.3]])
    commitment = ReserveCommitment(reserve_kg_s=fixed)
    problem = random_problem(3, horizon=8, commitments=commitment, events=events)
    assert problem.fixed_reserve_steps == 2 and free.fixed_reserve_steps == 0
    margin = np.zeros((free.horizon, free.ny))
    lp_free, _ = build_lp(free, margin)
    lp_fixed, _ = build_lp(problem, margin)
    assert lp_fixed.num_rows == lp_free.num_rows
    assert (lp_fixed.col_lower != lp_free.col_lower).sum() == 3  # the nonzero fixed r
    solution = solve_rmpc(problem)
    assert solution.status is SolveStatus.OPTIMAL
    np.testing.assert_allclose(solution.r[:2], fixed, atol=1e-9)
    assert (solution.u[:2] - solution.r[:2] >= problem.u_min[:2] - 1e-9).all()
    solver = make_solver(free)
    solver.solve(free)
    warm = solver.solve(problem)
    np.testing.assert_allclose(warm.r[:2], fixed, atol=1e-9)
    assert warm.objective_sgd == pytest.approx(solution.objective_sgd, rel=1e-7, abs=1e-7)
    again = solver.solve(free)
    assert again.objective_sgd <= warm.objective_sgd + 1e-9  # freeing r can only help
