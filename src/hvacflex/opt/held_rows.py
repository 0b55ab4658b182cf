"""The rows of the open-loop LP that HiGHS holds, in HiGHS's order, and how they change.

An :class:`~hvacflex.opt.solve.RMPCSolver`'s LP has *core rows* (dynamics, comfort, flows,
the comfort knee's, power, peak, visible offers) and, in the IL event model, *event rows* after them
(:mod:`hvacflex.opt.events`). HiGHS holds every core row, first and in the LP's order, then
the event rows: all of them (``event_rows="full"``) or those the lazy generation chose, in
the order they were added. :class:`HeldRows` keeps the map HiGHS row → LP row and makes the
changes in as few HiGHS calls as it can:

* **moving rows** (:class:`MovingRows`): the step-varying coefficients (p_k on the power rows,
  φ_k on the peak rows, ρ·p_k and q_k on the visible-offer rows) all sit in the last core
  rows. Instead of one ``changeCoeff`` per moved coefficient (≈ 1,600 a step on office5's
  product LP, 0.8 µs each), :meth:`HeldRows.push` deletes the rows from the first moving row
  on (they, then the event rows held) and adds the moving rows with the step's coefficients
  and bounds, the event rows kept and the new ones, in one ``deleteRows`` and one ``addRows``.
  HiGHS's row order stays what per-entry changes would leave, so it holds the same LP row for
  row (the same simplex path, the same optimum). Where the varying coefficients are sparse
  among their rows (:data:`MOVING_ROWS_MAX_NONZEROS_PER_VARYING`; the dual form's σ) or the
  event rows would travel with them (full event rows), there are no moving rows and the
  solver changes the coefficients one by one;
* **lazy event rows**: :meth:`HeldRows.set_event_rows` deletes the rows no longer wanted and
  appends the new ones (HiGHS keeps the order of those that stay; new rows are basic),
  :meth:`HeldRows.add_event_rows` appends violated rows between runs.

The HiGHS handle is the solver's (this module calls its methods, it does not import highspy).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from hvacflex.opt.lp import LinearProgram
from hvacflex.opt.problem import BoolArray, FloatArray, IntArray

__all__ = ["MOVING_ROWS_MAX_NONZEROS_PER_VARYING", "HeldRows", "MovingRows", "moving_rows"]

#: Moving rows are replaced as one block when they hold at most this many nonzeros per
#: step-varying coefficient; else the moved coefficients are changed one by one.
MOVING_ROWS_MAX_NONZEROS_PER_VARYING = 4.0

Int32Array = NDArray[np.int32]


@dataclass(frozen=True, eq=False)
class MovingRows:
    """The LP rows whose coefficients move from step to step, as one CSR block to re-add.

    ``rows`` (num_moving,) are consecutive LP rows (the first row with a varying coefficient
    to the last core row); ``starts`` (num_moving,), ``indices`` (nnz,) int32 their CSR
    pattern; ``base`` (nnz,) the constant coefficients with 0 where a varying one sits, and
    ``positions`` (num_varying,) where each varying coefficient of
    :attr:`~hvacflex.opt.lp.LinearProgram.varying` goes in it.
    """

    rows: IntArray
    starts: Int32Array
    indices: Int32Array
    base: FloatArray
    positions: IntArray

    def values(self, varying_values: FloatArray) -> FloatArray:
        """(nnz,) the block's coefficients with ``varying_values`` (num_varying,) in place."""
        weights = np.bincount(self.positions, weights=varying_values, minlength=self.base.size)
        result: FloatArray = self.base + weights
        return result


def moving_rows(lp: LinearProgram, matrix: sparse.csc_matrix, num_core: int) -> MovingRows | None:
    """The moving rows of ``lp`` (with its constant coefficients; ``matrix`` its full
    constraint matrix, varying zeros kept), or None where re-adding them would not pay or
    not be exact: no varying coefficient, one outside the core rows (< ``num_core``), more
    than :data:`MOVING_ROWS_MAX_NONZEROS_PER_VARYING` nonzeros per varying coefficient, or a
    varying coefficient twice or where a constant one sits."""
    varying, constant = lp.varying, lp.constant
    assert constant is not None
    if varying.rows.size == 0 or int(varying.rows.max()) >= num_core:
        return None
    first = int(varying.rows.min())
    block = matrix[first:num_core].tocsr()
    block.sort_indices()
    if block.nnz > MOVING_ROWS_MAX_NONZEROS_PER_VARYING * varying.rows.size:
        return None
    row_of_entry = np.repeat(np.arange(block.shape[0]), np.diff(block.indptr))
    keys = row_of_entry * lp.num_cols + block.indices
    wanted = (varying.rows - first) * lp.num_cols + varying.cols
    positions = np.minimum(np.searchsorted(keys, wanted), keys.size - 1)
    if (
        np.any(keys[positions] != wanted)
        or np.unique(positions).size != positions.size
        or np.isin(wanted, (constant.rows - first) * lp.num_cols + constant.cols).any()
    ):
        return None
    base = np.array(block.data, dtype=np.float64)
    base[positions] = 0.0
    return MovingRows(
        rows=np.arange(first, num_core, dtype=np.int64),
        starts=block.indptr[:-1].astype(np.int32),
        indices=block.indices.astype(np.int32),
        base=base,
        positions=positions.astype(np.int64),
    )


class HeldRows:
    """The rows HiGHS holds of one open-loop LP structure (see the module docstring).

    Parameters
    ----------
    highs : the HiGHS handle that holds the LP (passed the core rows, and every event row
        unless ``lazy``, in the LP's order)
    lp : the LP with its constant coefficients; ``matrix`` its constraint matrix (CSC,
        varying zeros kept)
    num_core : the number of core rows (the event rows are the LP's rows from there on)
    lazy : lazy event rows (HiGHS starts with the core rows only)
    """

    def __init__(
        self,
        highs: Any,
        lp: LinearProgram,
        matrix: sparse.csc_matrix,
        num_core: int,
        *,
        lazy: bool,
    ) -> None:
        self.highs = highs
        self.num_core = num_core
        self.event_matrix = matrix[num_core:].tocsr()
        """(num_event_rows, num_cols) CSR matrix of the event rows."""
        self._event_indices = np.asarray(self.event_matrix.indices, dtype=np.int32)
        num_events = lp.num_rows - num_core
        self.model_rows = np.arange(num_core if lazy else lp.num_rows, dtype=np.int64)
        """(rows HiGHS holds,) the LP row of each HiGHS row."""
        self.present = np.zeros(num_events, dtype=bool)
        """(num_event_rows,) lazy mode: the event rows HiGHS holds."""
        self.moving = moving_rows(lp, matrix, num_core) if lazy or num_events == 0 else None
        """The moving rows replaced as one block (None: coefficients one by one)."""
        self.stale = False
        """HiGHS lacks the current moving rows (:meth:`push` them before the next run)."""

    def set_event_rows(self, wanted: BoolArray, lp: LinearProgram) -> None:
        """Lazy mode: make HiGHS hold exactly the event rows ``wanted`` (num_event_rows,) of
        ``lp`` (and its moving rows, if :attr:`stale`)."""
        if self.stale:
            self.push(wanted, lp)
            return
        if np.array_equal(wanted, self.present):
            return
        positions = np.flatnonzero(self.model_rows >= self.num_core)  # event rows in HiGHS
        held = self.model_rows[positions] - self.num_core  # event ids, HiGHS order
        drop = ~wanted[held]
        if drop.any():  # HiGHS keeps the order of the rows that stay
            gone = positions[drop].astype(np.int32)
            self.highs.deleteRows(gone.size, gone)
            self.model_rows = np.delete(self.model_rows, gone)
            self.present[held[drop]] = False
        self.add_event_rows(np.flatnonzero(wanted & ~self.present), lp)

    def push(self, wanted: BoolArray | None, lp: LinearProgram) -> None:
        """Give HiGHS the moving rows of ``lp`` and, in lazy mode, exactly the event rows
        ``wanted`` (num_event_rows,; None: those it holds), keeping HiGHS's row order: one
        ``deleteRows`` of the rows from the first moving row on, one ``addRows`` of the
        moving rows, the event rows kept and the new ones. HiGHS's basis must be set again
        after this."""
        moving = self.moving
        assert moving is not None
        held = self.model_rows
        first = int(moving.rows[0])  # HiGHS holds the core rows first, in the LP's order
        end = first + moving.rows.size
        assert np.array_equal(held[first:end], moving.rows)
        events = held[end:] - self.num_core  # event ids held, in HiGHS's order
        if wanted is not None:
            self.present[events[~wanted[events]]] = False
            new = np.flatnonzero(wanted & ~self.present)
            events = np.concatenate([events[wanted[events]], new])
            self.present[new] = True
        self.highs.deleteRows(held.size - first, np.arange(first, held.size, dtype=np.int32))
        data = moving.values(lp.varying.values)
        starts, indices, values = self.event_block(events)
        rows = np.concatenate([moving.rows, self.num_core + events])
        self.highs.addRows(
            rows.size,
            lp.row_lower[rows],
            lp.row_upper[rows],
            data.size + values.size,
            np.concatenate([moving.starts, starts + data.size]),
            np.concatenate([moving.indices, indices]),
            np.concatenate([data, values]),
        )
        self.model_rows = np.concatenate([held[:first], rows])
        self.stale = False

    def event_block(self, ids: IntArray) -> tuple[Int32Array, Int32Array, FloatArray]:
        """CSR row starts (ids.size,), column indices and values of the event rows ``ids``."""
        indptr = self.event_matrix.indptr
        first, lengths = indptr[ids], indptr[ids + 1] - indptr[ids]
        starts = np.zeros(ids.size, dtype=np.int32)
        np.cumsum(lengths[:-1], out=starts[1:])
        entries = np.repeat(first - starts, lengths) + np.arange(int(lengths.sum()))
        return starts, self._event_indices[entries], self.event_matrix.data[entries]

    def add_event_rows(self, ids: IntArray, lp: LinearProgram) -> None:
        """Lazy mode: append the event rows ``ids`` of ``lp`` to HiGHS's LP (HiGHS makes them
        basic)."""
        if ids.size == 0:
            return
        starts, indices, values = self.event_block(ids)
        rows = self.num_core + ids
        self.highs.addRows(
            ids.size, lp.row_lower[rows], lp.row_upper[rows], values.size, starts, indices, values
        )
        self.model_rows = np.concatenate([self.model_rows, rows])
        self.present[ids] = True
