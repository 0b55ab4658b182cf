"""Simplex bases as status arrays (:mod:`hvacflex.opt.basis`), on hand-made statuses."""

from __future__ import annotations

import numpy as np

from hvacflex.opt.basis import (
    BASIC,
    LOWER,
    UPPER,
    ZERO,
    bounded_start,
    held_shift,
    nonbasic_status,
    rotation,
)
from hvacflex.opt.lp import LinearProgram, Triplets


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


def _lp_with_blocks(time_cols: tuple[np.ndarray, ...], num_cols: int) -> LinearProgram:
    """A column-only LP skeleton whose time-indexed column blocks are ``time_cols``."""
    empty = np.zeros(0, dtype=np.int64)
    return LinearProgram(
        num_cols=num_cols,
        num_rows=0,
        cost=np.zeros(num_cols),
        col_lower=np.zeros(num_cols),
        col_upper=np.ones(num_cols),
        row_lower=np.zeros(0),
        row_upper=np.zeros(0),
        constant=None,
        varying=Triplets(empty, empty, np.zeros(0)),
        time_cols=time_cols,
        time_rows=(),
    )


def test_held_shift_moves_each_block_one_step_and_holds_the_last() -> None:
    # a (3 steps, 2)-block in columns 0..5, a (3,)-block in 6..8, β alone in column 9
    x = np.arange(6).reshape(3, 2)
    power = np.arange(6, 9)
    lp = _lp_with_blocks((x, power), 10)
    values = np.array([10.0, 11.0, 20.0, 21.0, 30.0, 31.0, 1.0, 2.0, 3.0, 99.0])
    shifted = values[held_shift(lp)]
    assert shifted.tolist() == [20.0, 21.0, 30.0, 31.0, 30.0, 31.0, 2.0, 3.0, 3.0, 99.0]
    # the basis rotation wraps the last step instead (a permutation); the shift does not
    col_map, _ = rotation(lp)
    assert values[col_map].tolist()[4:6] == [10.0, 11.0]
