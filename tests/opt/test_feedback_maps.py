"""The feedback policy's parameterisation: innovations, gain entries, index helpers."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.opt import FeedbackOptions
from hvacflex.opt.feedback_maps import flat_ranges, gain_parameterisation, innovation_basis
from hvacflex.opt.testing import random_problem


def test_innovation_recovers_what_the_state_reveals() -> None:
    rng = np.random.default_rng(7)
    e = rng.uniform(0.0, 1.0, (6, 3))
    e = np.hstack([e, e[:, :1] * 2.0 + e[:, 1:2]])  # a dependent fourth channel
    recover, k_matrix, selected = innovation_basis(e)
    assert selected.tolist() == [0, 1, 2] or len(selected) == 3
    np.testing.assert_allclose(e[:, selected] @ k_matrix, e, atol=1e-12)
    w = rng.normal(size=4)
    np.testing.assert_allclose(recover @ (e @ w), k_matrix @ w, atol=1e-10)
    full_rank = rng.uniform(0.0, 1.0, (6, 3))
    recover, k_matrix, _ = innovation_basis(full_rank)
    np.testing.assert_allclose(k_matrix, np.eye(3))
    np.testing.assert_allclose(recover @ full_rank, np.eye(3), atol=1e-10)


def test_flat_ranges_by_hand() -> None:
    counts = np.array([2, 0, 3], dtype=np.int64)
    assert flat_ranges(counts).tolist() == [0, 1, 0, 1, 2]


@pytest.mark.parametrize("memory", [1, 3])
def test_time_invariant_gains_are_one_block_per_lag(memory: int) -> None:
    """m inputs × r innovation components per lag 1..L (K = I for a full-rank E)."""
    problem = random_problem(0, robust="feedback")
    options = FeedbackOptions(structure="time-invariant", memory_steps=memory)
    gains = gain_parameterisation(problem, options)
    assert gains.shift_invariant
    assert gains.num_gains == memory * problem.m * problem.nd
    assert sorted(set(gains.entry_step.tolist())) == list(range(1, memory + 1))
