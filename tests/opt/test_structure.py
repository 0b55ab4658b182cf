"""The structure that fixes an RMPC problem's LP: what differs, and the fingerprint a
stored basis is matched by."""

from __future__ import annotations

import numpy as np

from hvacflex.opt import StepLinearisation
from hvacflex.opt.testing import random_problem


def test_equal_problems_share_a_structure_and_a_step_linearisation_changes_it() -> None:
    plain, again = random_problem(0), random_problem(0, x0=np.full(4, 23.0))
    assert plain.structure.differences(again.structure) == []  # x0 is not structure
    assert plain.structure.fingerprint() == again.structure.fingerprint()
    block = StepLinearisation(input_scale=np.full((8, 2), 0.9))
    scaled = random_problem(0, step_linearisation=block)
    assert plain.structure.differences(scaled.structure) == ["input_scale"]
    assert plain.structure.fingerprint() != scaled.structure.fingerprint()
    np.testing.assert_allclose(scaled.step_b_matrix, 0.9 * plain.step_b_matrix)
    np.testing.assert_array_equal(plain.step_b_matrix[3], plain.b_matrix)
    other = StepLinearisation(input_scale=np.full((8, 2), 0.8))
    moved = random_problem(0, step_linearisation=other)
    assert scaled.structure.differences(moved.structure) == ["input_scale"]
    assert random_problem(0, robust="none").structure.differences(plain.structure) == ["robust"]
