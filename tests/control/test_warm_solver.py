"""SolverSlot: the warm solver's lifetime — built on demand, restarted from its basis."""

from __future__ import annotations

import numpy as np

from hvacflex.control.warm_solver import SolverSlot
from hvacflex.opt import SolveStatus
from hvacflex.opt.testing import random_problem


def test_a_restarted_slot_solves_to_the_same_optimum_from_the_kept_basis() -> None:
    problem = random_problem(5)
    slot = SolverSlot(None)
    assert slot.basis() is None
    first = slot.solve(problem)
    assert first.status is SolveStatus.OPTIMAL
    basis = slot.basis()
    assert basis is not None
    slot.restart()
    kept = slot.basis()  # kept for the next solver
    assert kept is not None and kept.fingerprint == basis.fingerprint
    np.testing.assert_array_equal(kept.col_status, basis.col_status)
    np.testing.assert_array_equal(kept.row_status, basis.row_status)
    again = slot.solve(problem)
    assert again.status is SolveStatus.OPTIMAL
    np.testing.assert_allclose(again.objective_sgd, first.objective_sgd, rtol=1e-9)
    restored = SolverSlot(None)
    restored.restore(basis)
    third = restored.solve(problem)
    np.testing.assert_allclose(third.objective_sgd, first.objective_sgd, rtol=1e-9)
    assert third.simplex_iterations <= first.simplex_iterations
