"""The LP container and its index allocator."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.opt.lp_builder import LinearProgram, LPBuilder, Triplets, sparse_matrix


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


def _build(pattern: Triplets | None = None, scale: float = 1.0) -> LinearProgram:
    lp = LPBuilder(constants=pattern is None, varying_pattern=pattern)
    x = lp.add_columns((3, 2))
    rows = lp.add_rows((3,), upper=1.0)
    lp.add_varying_coefficients(rows[:, None], x, scale * np.arange(6.0).reshape(3, 2))
    lp.add_varying_coefficients(rows, x[:, 0], -scale)
    return lp.finish()


def test_a_rebuild_with_the_varying_pattern_computes_only_the_values() -> None:
    """Given the structure's varying coefficients, a rebuild keeps their positions (the same
    arrays) and computes values equal to a full rebuild's."""
    structure = _build()
    full = _build(scale=2.0)
    rebuilt = _build(structure.varying, scale=2.0)
    assert rebuilt.varying.rows is structure.varying.rows
    np.testing.assert_array_equal(rebuilt.varying.values, full.varying.values)
    np.testing.assert_array_equal(rebuilt.varying.cols, full.varying.cols)
    assert rebuilt.varying.values.tolist() == [0, 2, 4, 6, 8, 10, -2, -2, -2]


def test_a_varying_pattern_of_another_structure_is_refused() -> None:
    lp = LPBuilder(constants=False, varying_pattern=_build().varying)
    rows = lp.add_rows((2,))
    lp.add_varying_coefficients(rows, rows, 1.0)
    with pytest.raises(ValueError, match="another LP structure"):
        lp.finish()
