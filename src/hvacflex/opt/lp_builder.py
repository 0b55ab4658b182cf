"""The LP container and its index allocator, for every LP hvacflex builds.

:class:`LPBuilder` hands out column and row index ranges and collects bounds, costs and
coefficients (each ``add_…`` family of :mod:`hvacflex.opt.lp` and :mod:`hvacflex.opt.feedback`
adds through it); :meth:`LPBuilder.finish` returns the :class:`LinearProgram`, and
:func:`sparse_matrix` its constraint matrix.

Constant and varying coefficients
---------------------------------
Coefficients that depend only on the problem's structure (A, B, E, C, N, mask) are
*constant*: a builder made with ``constants=False`` skips them, so a receding-horizon solver
rebuilds costs, bounds and the few step-varying coefficients (``p_k``, ``φ_k``, σ in the dual
form) every step without re-assembling the matrix. Varying coefficients are kept even when
zero, so that their positions in the matrix are known and can be updated in place. A rebuild
that is given the structure's varying pattern (``LPBuilder(varying_pattern=...)``, the
:attr:`LinearProgram.varying` of the LP built with its constants) computes only their values:
the positions are the structure's, in the same order, and are not broadcast again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = ["LPBuilder", "LinearProgram", "Triplets", "sparse_matrix"]


@dataclass(frozen=True, eq=False)
class Triplets:
    """Coefficients ``A[rows[i], cols[i]] = values[i]`` (flat arrays of equal length)."""

    rows: IntArray
    cols: IntArray
    values: FloatArray

    @staticmethod
    def join(parts: list[tuple[IntArray, IntArray, FloatArray]]) -> Triplets:
        """Concatenate (rows, cols, values) blocks."""
        if not parts:
            empty = np.zeros(0, dtype=np.int64)
            return Triplets(empty, empty, np.zeros(0))
        return Triplets(
            np.concatenate([p[0] for p in parts]),
            np.concatenate([p[1] for p in parts]),
            np.concatenate([p[2] for p in parts]),
        )


@dataclass(frozen=True, eq=False)
class LinearProgram:
    """``min costᵀx  s.t.  row_lower ≤ A x ≤ row_upper,  col_lower ≤ x ≤ col_upper``.

    ``constant`` holds the structural coefficients (None if the builder skipped them),
    ``varying`` the step-varying ones in a fixed order (zeros kept). ``time_cols`` and
    ``time_rows`` are the blocks whose first axis is the step k (for the warm start's
    time shift); ``permuted_rows`` are (block, permutation) pairs of row blocks that are not
    rectangular in k: one step later row ``block[e]`` starts from ``block[permutation[e]]``.
    """

    num_cols: int
    num_rows: int
    cost: FloatArray
    col_lower: FloatArray
    col_upper: FloatArray
    row_lower: FloatArray
    row_upper: FloatArray
    constant: Triplets | None
    varying: Triplets
    time_cols: tuple[IntArray, ...]
    time_rows: tuple[IntArray, ...]
    permuted_rows: tuple[tuple[IntArray, IntArray], ...] = ()


def sparse_matrix(
    lp: LinearProgram, constant: Triplets, *, keep_varying_zeros: bool, csc: bool
) -> sparse.csc_matrix | sparse.csr_matrix:
    """The constraint matrix (num_rows × num_cols) from ``constant`` and ``lp.varying``.

    Explicit zeros are dropped, except varying ones if ``keep_varying_zeros`` (so that an
    in-place update finds them). CSC with sorted indices if ``csc``, else CSR.
    """
    keep = constant.values != 0.0
    rows, cols, values = constant.rows[keep], constant.cols[keep], constant.values[keep]
    varying = lp.varying
    keep_v = np.ones(varying.values.size, dtype=bool)
    if not keep_varying_zeros:
        keep_v = varying.values != 0.0
    rows = np.concatenate([rows, varying.rows[keep_v]])
    cols = np.concatenate([cols, varying.cols[keep_v]])
    values = np.concatenate([values, varying.values[keep_v]])
    shape = (lp.num_rows, lp.num_cols)
    if csc:
        matrix = sparse.csc_matrix((values, (rows, cols)), shape=shape, dtype=np.float64)
        matrix.sort_indices()
        return matrix
    return sparse.csr_matrix((values, (rows, cols)), shape=shape)


_Block = tuple[slice, tuple[int, ...]]
"""A block the builder handed out: its consecutive indices and its shape."""
_Assignment = tuple[_Block, FloatArray | float, FloatArray | float]


class LPBuilder:
    """Hands out column and row index ranges; collects bounds, costs and coefficients.

    Parameters
    ----------
    constants : record the constant (structural) coefficients; False for a rebuild that
        only needs costs, bounds and the varying coefficients
    varying_pattern : the varying coefficients of an LP of the same structure built by the
        same calls (its rows and columns are reused; only the values are computed), or None
    """

    def __init__(self, *, constants: bool = True, varying_pattern: Triplets | None = None) -> None:
        self.records_constants = constants
        self._pattern = varying_pattern
        self._varying_values: list[FloatArray] = []
        self.num_cols = 0
        self.num_rows = 0
        self._cols: list[_Assignment] = []
        self._rows: list[_Assignment] = []
        self._cols_narrowed: list[tuple[IntArray, FloatArray | float, FloatArray | float]] = []
        self._costs: list[tuple[IntArray, FloatArray | float]] = []
        self._constant: list[tuple[IntArray, IntArray, FloatArray]] = []
        self._varying: list[tuple[IntArray, IntArray, FloatArray]] = []
        self._time_cols: list[IntArray] = []
        self._time_rows: list[IntArray] = []
        self._permuted_rows: list[tuple[IntArray, IntArray]] = []

    @staticmethod
    def _take(start: int, shape: tuple[int, ...]) -> IntArray:
        size = math.prod(shape)
        return np.arange(start, start + size, dtype=np.int64).reshape(shape)

    def add_columns(
        self,
        shape: tuple[int, ...],
        *,
        lower: FloatArray | float = -np.inf,
        upper: FloatArray | float = np.inf,
        time_indexed: bool = False,
    ) -> IntArray:
        """A new block of variables shaped ``shape`` with bounds (broadcast); its indices."""
        index = self._take(self.num_cols, shape)
        self._cols.append(((slice(self.num_cols, self.num_cols + index.size), shape), lower, upper))
        self.num_cols += index.size
        if time_indexed:
            self._time_cols.append(index)
        return index

    def add_rows(
        self,
        shape: tuple[int, ...],
        *,
        lower: FloatArray | float = -np.inf,
        upper: FloatArray | float = np.inf,
        time_indexed: bool = False,
        time_permutation: IntArray | None = None,
    ) -> IntArray:
        """A new block of constraints ``lower ≤ row ≤ upper`` shaped ``shape``; its indices.

        ``time_indexed``: the first axis is the step k (the warm start rolls it by one);
        ``time_permutation`` (flat block size): instead, one step later row ``index[e]``
        starts from row ``index[time_permutation[e]]`` (for blocks not rectangular in k).
        """
        index = self._take(self.num_rows, shape)
        self._rows.append(((slice(self.num_rows, self.num_rows + index.size), shape), lower, upper))
        self.num_rows += index.size
        if time_indexed:
            self._time_rows.append(index)
        if time_permutation is not None:
            self._permuted_rows.append((index.ravel(), time_permutation))
        return index

    def set_column_bounds(
        self, cols: IntArray, *, lower: FloatArray | float, upper: FloatArray | float
    ) -> None:
        """New bounds of existing columns ``cols`` (broadcast; later calls win)."""
        self._cols_narrowed.append((cols, lower, upper))

    def set_cost(self, cols: IntArray, cost: FloatArray | float) -> None:
        """Objective coefficients of ``cols`` (broadcast; later calls win)."""
        self._costs.append((cols, cost))

    def add_coefficients(self, rows: object, cols: object, values: object) -> None:
        """Constant coefficients (broadcast together); skipped if not ``records_constants``."""
        if self.records_constants:
            self._constant.append(_broadcast(rows, cols, values))

    def add_varying_coefficients(self, rows: object, cols: object, values: object) -> None:
        """Coefficients that change from step to step (broadcast together; zeros kept).

        With a ``varying_pattern`` only the values are kept (broadcast to the common shape).
        """
        if self._pattern is None:
            self._varying.append(_broadcast(rows, cols, values))
            return
        value = np.asarray(values, dtype=np.float64)
        shape = np.broadcast(np.asarray(rows), np.asarray(cols), value).shape
        flat = np.empty(shape)
        flat[...] = value  # broadcast
        self._varying_values.append(flat.ravel())

    def finish(self) -> LinearProgram:
        """The LP collected so far."""
        cost = np.zeros(self.num_cols)
        col_lower = np.full(self.num_cols, -np.inf)
        col_upper = np.full(self.num_cols, np.inf)
        row_lower = np.full(self.num_rows, -np.inf)
        row_upper = np.full(self.num_rows, np.inf)
        for bounds, assignments in (
            ((col_lower, col_upper), self._cols),
            ((row_lower, row_upper), self._rows),
        ):
            for (block, shape), lower, upper in assignments:  # views of consecutive entries
                bounds[0][block].reshape(shape)[...] = lower
                bounds[1][block].reshape(shape)[...] = upper
        for index, lower, upper in self._cols_narrowed:  # after the blocks' own bounds
            col_lower[index] = lower
            col_upper[index] = upper
        for index, value in self._costs:
            cost[index] = value
        return LinearProgram(
            num_cols=self.num_cols,
            num_rows=self.num_rows,
            cost=cost,
            col_lower=col_lower,
            col_upper=col_upper,
            row_lower=row_lower,
            row_upper=row_upper,
            constant=Triplets.join(self._constant) if self.records_constants else None,
            varying=self._varying_triplets(),
            time_cols=tuple(self._time_cols),
            time_rows=tuple(self._time_rows),
            permuted_rows=tuple(self._permuted_rows),
        )

    def _varying_triplets(self) -> Triplets:
        """The varying coefficients collected: triplets, or the pattern's positions with the
        values computed now."""
        pattern = self._pattern
        if pattern is None:
            return Triplets.join(self._varying)
        values = np.concatenate(self._varying_values) if self._varying_values else np.zeros(0)
        if values.size != pattern.values.size:
            raise ValueError(
                f"{values.size} varying coefficients for a pattern of {pattern.values.size}: "
                "the pattern belongs to another LP structure"
            )
        return Triplets(pattern.rows, pattern.cols, values)


def _broadcast(rows: object, cols: object, values: object) -> tuple[IntArray, IntArray, FloatArray]:
    r, c, v = np.broadcast_arrays(np.asarray(rows), np.asarray(cols), np.asarray(values))
    return (
        r.ravel().astype(np.int64),
        c.ravel().astype(np.int64),
        v.ravel().astype(np.float64),
    )
