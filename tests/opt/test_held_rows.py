"""The rows HiGHS holds: the moving rows found and replaced in one block, HiGHS's row order
kept, the lazy event rows' changes (a hand-made LP in a real HiGHS handle)."""

from __future__ import annotations

from typing import Any

import highspy
import numpy as np
import pytest
from scipy import sparse

from hvacflex.opt.held_rows import HeldRows, moving_rows
from hvacflex.opt.highs_lp import highs_lp, quiet_highs
from hvacflex.opt.lp import LinearProgram, LPBuilder, sparse_matrix


def _small_lp(scale: float = 1.0, *, clash: bool = False) -> LinearProgram:
    """3 columns; core rows 0–2 (row 2 with varying coefficients 2s, 3s on x1, x2), event
    rows 3–5 (constant). ``clash``: a varying coefficient where a constant one sits."""
    lp = LPBuilder()
    cols = lp.add_columns((3,), lower=0.0, upper=10.0)
    core = lp.add_rows((3,), upper=np.array([5.0, 6.0, 7.0 * scale]))
    lp.add_coefficients(core[:2], cols[:2], 1.0)
    lp.add_coefficients(core[2], cols[0], 1.0)
    lp.add_varying_coefficients(core[2], cols[1:], np.array([2.0, 3.0]) * scale)
    if clash:
        lp.add_varying_coefficients(core[2], cols[0], scale)
    events = lp.add_rows((3,), upper=np.array([8.0, 9.0, 10.0]))
    lp.add_coefficients(events, cols, np.array([1.0, 2.0, 4.0]))
    lp.add_coefficients(events, cols[2], 0.5)
    lp.set_cost(cols, -1.0)
    return lp.finish()


def _matrix(lp: LinearProgram) -> sparse.csc_matrix:
    assert lp.constant is not None
    return sparse_matrix(lp, lp.constant, keep_varying_zeros=True, csc=True)


def _held_lp(highs: Any) -> tuple[np.ndarray, np.ndarray]:
    """HiGHS's constraint matrix (dense) and row upper bounds, in its row order."""
    lp = highs.getLp()
    colwise = lp.a_matrix_.format_ == highspy.MatrixFormat.kColwise
    matrix = (sparse.csc_matrix if colwise else sparse.csr_matrix)(
        (
            np.asarray(lp.a_matrix_.value_),
            np.asarray(lp.a_matrix_.index_),
            np.asarray(lp.a_matrix_.start_),
        ),
        shape=(lp.num_row_, lp.num_col_),
    )
    return matrix.toarray(), np.asarray(lp.row_upper_)


def test_moving_rows_are_the_core_rows_from_the_first_varying_one() -> None:
    lp = _small_lp()
    moving = moving_rows(lp, _matrix(lp), num_core=3)
    assert moving is not None
    assert moving.rows.tolist() == [2]
    # the block's coefficients: the constant 1 on x0, the varying ones put in their places
    block = sparse.csr_matrix(
        (moving.values(np.array([20.0, 30.0])), moving.indices, [0, moving.base.size]),
        shape=(1, 3),
    )
    np.testing.assert_array_equal(block.toarray(), [[1.0, 20.0, 30.0]])


@pytest.mark.parametrize("case", ["clash", "outside the core", "too sparse"])
def test_no_moving_rows_where_one_block_would_not_be_exact_or_pay(
    case: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.opt.held_rows as held_rows

    lp = _small_lp(clash=case == "clash")
    num_core = 2 if case == "outside the core" else 3
    if case == "too sparse":  # 3 nonzeros for 2 varying coefficients
        monkeypatch.setattr(held_rows, "MOVING_ROWS_MAX_NONZEROS_PER_VARYING", 1.0)
    assert moving_rows(lp, _matrix(lp), num_core) is None


def _held(lp: LinearProgram) -> tuple[Any, HeldRows]:
    highs = quiet_highs()
    matrix = _matrix(lp)
    held = HeldRows(highs, lp, matrix, 3, lazy=True)
    model = highs_lp(
        lp.cost, matrix[:3], lp.row_lower[:3], lp.row_upper[:3], lp.col_lower, lp.col_upper
    )
    highs.passModel(model)
    return highs, held


def test_push_replaces_the_moving_rows_and_keeps_highs_row_order() -> None:
    """Event rows 2 then 0 held (added in that order); a push with new coefficients and
    bounds keeps that order, and one with other wanted rows keeps those that stay and
    appends the new ones — the LP of the new step, row for row."""
    lp = _small_lp()
    highs, held = _held(lp)
    held.add_event_rows(np.array([2]), lp)
    held.add_event_rows(np.array([0]), lp)
    assert held.model_rows.tolist() == [0, 1, 2, 5, 3]
    moved = _small_lp(scale=2.0)
    held.stale = True
    held.push(None, moved)
    assert moved.constant is not None
    expected = sparse_matrix(moved, moved.constant, keep_varying_zeros=False, csc=False)
    matrix, upper = _held_lp(highs)
    assert held.model_rows.tolist() == [0, 1, 2, 5, 3] and not held.stale
    np.testing.assert_array_equal(matrix, expected.toarray()[held.model_rows])
    np.testing.assert_array_equal(upper, moved.row_upper[held.model_rows])
    held.stale = True
    held.set_event_rows(np.array([False, True, True]), moved)  # 3 goes, 4 comes, 5 stays
    assert held.model_rows.tolist() == [0, 1, 2, 5, 4]
    assert held.present.tolist() == [False, True, True]
    matrix, upper = _held_lp(highs)
    np.testing.assert_array_equal(matrix, expected.toarray()[held.model_rows])
    np.testing.assert_array_equal(upper, moved.row_upper[held.model_rows])
