"""The LP container and its index allocator."""

from __future__ import annotations

import numpy as np

from hvacflex.opt.lp_builder import LPBuilder, sparse_matrix


def test_builder_hands_out_consecutive_ranges_and_bounds() -> None:
    lp = LPBuilder()
    x = lp.add_columns((3, 2), lower=0.0, upper=np.array([1.0, 2.0]), time_indexed=True)
    y = lp.add_columns((1,))
    rows = lp.add_rows((2,), lower=np.array([-1.0, 0.0]), upper=5.0)
    lp.add_coefficients(rows[:, None], x[:2], 1.0)
    lp.add_varying_coefficients(rows, y, np.array([0.0, 3.0]))
    lp.set_cost(x, 2.0)
    program = lp.finish()
    assert x.tolist() == [[0, 1], [2, 3], [4, 5]] and y.tolist() == [6]
    assert (program.num_cols, program.num_rows) == (7, 2)
    np.testing.assert_array_equal(program.col_upper, [1, 2, 1, 2, 1, 2, np.inf])
    np.testing.assert_array_equal(program.row_lower, [-1.0, 0.0])
    np.testing.assert_array_equal(program.cost, [2, 2, 2, 2, 2, 2, 0])
    assert [block.tolist() for block in program.time_cols] == [x.tolist()]
    assert program.constant is not None
    kept = sparse_matrix(program, program.constant, keep_varying_zeros=True, csc=True)
    dropped = sparse_matrix(program, program.constant, keep_varying_zeros=False, csc=False)
    assert kept.nnz == 4 + 2 and dropped.nnz == 4 + 1
    np.testing.assert_array_equal(kept.toarray(), dropped.toarray())


def test_later_column_bounds_win() -> None:
    """A feature block narrows bounds after the plan's columns exist (set_column_bounds)."""
    lp = LPBuilder()
    x = lp.add_columns((3,), lower=0.0, upper=5.0)
    lp.set_column_bounds(x[1:], lower=np.array([1.0, 2.0]), upper=np.array([1.0, 4.0]))
    program = lp.finish()
    np.testing.assert_array_equal(program.col_lower, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(program.col_upper, [5.0, 1.0, 4.0])
    assert program.num_cols == 3
