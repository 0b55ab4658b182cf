"""Simplex bases as arrays of HiGHS status codes: the time shift, statuses from bounds, checks.

Pure numpy (no solver): :class:`hvacflex.opt.highs_lp.HighsSession` passes these statuses to
and from HiGHS.
Codes are HiGHS's ``HighsBasisStatus``: 0 lower, 1 basic, 2 upper, 3 zero (free), 4 nonbasic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from hvacflex.errors import ProblemError
from hvacflex.opt.lp import LinearProgram
from hvacflex.opt.problem import FloatArray, IntArray

LOWER, BASIC, UPPER, ZERO = 0, 1, 2, 3

StatusArray = NDArray[np.int8]


@dataclass(frozen=True, eq=False)
class SolverBasis:
    """A picklable simplex basis of an :class:`~hvacflex.opt.solve.RMPCSolver` (to resume a
    checkpoint warm).

    ``col_status`` and ``row_status`` hold HiGHS basis status codes (0 lower, 1 basic,
    2 upper, 3 zero, 4 nonbasic); ``fingerprint`` identifies the problem structure.
    """

    fingerprint: str
    col_status: StatusArray
    row_status: StatusArray


def rotation(lp: LinearProgram) -> tuple[IntArray, IntArray]:
    """Index maps that rotate a basis by one time step: ``new = old[map]``.

    Step k of every time-indexed column and row block takes the status of step k + 1, step
    N − 1 that of step 0; row blocks with a permutation (the IL event rows) follow it; the
    other blocks (β, the dual form's λ's and rows) keep theirs.
    """
    col_map = np.arange(lp.num_cols)
    row_map = np.arange(lp.num_rows)
    for index_map, blocks in ((col_map, lp.time_cols), (row_map, lp.time_rows)):
        for block in blocks:
            if block.size:
                index_map[block.ravel()] = np.roll(block, -1, axis=0).ravel()
    for block, permutation in lp.permuted_rows:
        row_map[block] = block[permutation]
    return col_map, row_map


def nonbasic_status(lower: FloatArray, upper: FloatArray) -> StatusArray:
    """Status of a nonbasic variable from its bounds alone: at the lower bound if finite,
    else at the upper bound if finite, else zero (free)."""
    status = np.where(np.isfinite(upper), UPPER, ZERO)
    status[np.isfinite(lower)] = LOWER
    return status.astype(np.int8)


def consistent_status(
    status: StatusArray, lower: FloatArray, upper: FloatArray, nonbasic: StatusArray
) -> StatusArray:
    """``status`` with each nonbasic status that the bounds do not allow (a bound that became
    infinite) replaced by ``nonbasic``, the one the bounds imply."""
    bad = ((status == LOWER) & ~np.isfinite(lower)) | ((status == UPPER) & ~np.isfinite(upper))
    bad |= (status == ZERO) & (np.isfinite(lower) | np.isfinite(upper))
    bad |= status > ZERO
    if bad.any():
        status = np.where(bad, nonbasic, status).astype(np.int8)
    return status


def bounded_start(
    col_status: StatusArray,
    row_status: StatusArray,
    col_lower: FloatArray,
    col_upper: FloatArray,
    col_nonbasic: StatusArray,
    row_nonbasic: StatusArray,
) -> tuple[StatusArray, StatusArray]:
    """A stored basis made a valid start for the current bounds.

    Parameters
    ----------
    col_status, row_status : (num_cols,), (num_rows,) stored statuses (rotated or not)
    col_lower, col_upper : (num_cols,) the column bounds now
    col_nonbasic, row_nonbasic : (num_cols,), (num_rows,) :func:`nonbasic_status` of the
        column and row bounds now

    Returns
    -------
    The column statuses through :func:`consistent_status`, and the row statuses with every
    nonbasic row at its only finite bound (every row is an equality or one-sided).
    """
    col_status = consistent_status(col_status, col_lower, col_upper, col_nonbasic)
    row_status = np.where(row_status == BASIC, BASIC, row_nonbasic).astype(np.int8)
    return col_status, row_status


def optimal_statuses(
    values: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    col_nonbasic: StatusArray,
    row_nonbasic: StatusArray,
    basic: IntArray,
) -> tuple[StatusArray, StatusArray]:
    """Statuses of an optimal basis from its basic variables and the primal ``values``.

    ``basic`` lists the basic variables as HiGHS's ``getBasicVariables`` does (column j ≥ 0,
    row i as −1 − i). A nonbasic column sits at the bound nearer to its value; a nonbasic row
    at its only finite bound (every row is an equality or one-sided).
    """
    with np.errstate(invalid="ignore"):
        at_upper = np.isfinite(upper) & (~np.isfinite(lower) | (values - lower > upper - values))
    col_status = np.where(at_upper, UPPER, col_nonbasic).astype(np.int8)
    row_status = row_nonbasic.copy()
    col_status[basic[basic >= 0]] = BASIC
    row_status[-1 - basic[basic < 0]] = BASIC
    return col_status, row_status


def checked_basis(
    basis: SolverBasis, fingerprint: str, num_cols: int, num_rows: int
) -> tuple[StatusArray, StatusArray]:
    """The (column, row) statuses of ``basis`` if it is a simplex basis of the LP with
    ``fingerprint`` and these sizes; else raise :class:`~hvacflex.errors.ProblemError`."""
    if (
        basis.fingerprint != fingerprint
        or basis.col_status.size != num_cols
        or basis.row_status.size != num_rows
    ):
        raise ProblemError(
            "the basis was saved from a solver with another problem structure",
            source="RMPCSolver",
            field="basis",
            hint="restore a basis only into a solver built for the same A, B, E, C, N, "
            "reserve mask and robust mode",
        )
    col_status = np.asarray(basis.col_status, dtype=np.int8)
    row_status = np.asarray(basis.row_status, dtype=np.int8)
    num_basic = int(np.count_nonzero(col_status == BASIC) + np.count_nonzero(row_status == BASIC))
    if (
        num_basic != num_rows
        or min(col_status.min(), row_status.min()) < 0
        or max(col_status.max(), row_status.max()) > ZERO + 1
    ):
        raise ProblemError(
            f"not a simplex basis: {num_basic} basic variables for {num_rows} rows, "
            "or status codes outside 0..4",
            source="RMPCSolver",
            field="basis",
            hint="pass a basis from get_basis(), or solve cold",
        )
    return col_status.copy(), row_status.copy()
