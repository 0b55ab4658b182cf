"""Simplex bases as status arrays (:mod:`hvacflex.opt.basis`), on hand-made statuses."""

from __future__ import annotations

import numpy as np

from hvacflex.opt.basis import BASIC, LOWER, UPPER, ZERO, bounded_start, nonbasic_status


def test_bounded_start_fits_a_stored_basis_to_the_bounds_now() -> None:
    col_lower = np.array([0.0, -np.inf, 0.0, -np.inf])
    col_upper = np.array([1.0, 5.0, 1.0, np.inf])
    row_lower = np.array([2.0, -np.inf, -np.inf])
    row_upper = np.array([2.0, 3.0, np.inf])
    # column 1 lost its lower bound, column 3 is now free; row 2 is basic and stays so
    col_status = np.array([UPPER, LOWER, BASIC, LOWER], dtype=np.int8)
    row_status = np.array([UPPER, LOWER, BASIC], dtype=np.int8)
    col_start, row_start = bounded_start(
        col_status,
        row_status,
        col_lower,
        col_upper,
        nonbasic_status(col_lower, col_upper),
        nonbasic_status(row_lower, row_upper),
    )
    assert col_start.tolist() == [UPPER, UPPER, BASIC, ZERO]
    # nonbasic rows sit at their only finite bound: the equality at lower, row 1 at upper
    assert row_start.tolist() == [LOWER, UPPER, BASIC]
    assert row_start.dtype == np.int8
