"""The HiGHS boundary: the only module of hvacflex that imports highspy.

A silent HiGHS handle (:func:`quiet_highs`), the ``HighsLp`` of a sparse LP
(:func:`highs_lp`), the status mapping, basis conversion (:func:`highs_basis`) and the cold
one-shot solve used by the feedback solver (:func:`solve_lp`). Everything else in hvacflex sees
:class:`~hvacflex.opt.solution.SolveStatus` and numpy arrays.
"""

from __future__ import annotations

import time
from typing import Any, NamedTuple

import highspy
import numpy as np
from scipy import sparse

from hvacflex.errors import ProblemError
from hvacflex.opt.problem import FloatArray
from hvacflex.opt.solution import SolveStatus

__all__ = [
    "HIGHS_ERROR",
    "STATUS_MAP",
    "LPResult",
    "check_time_limit",
    "highs_basis",
    "highs_lp",
    "pass_csc_model",
    "quiet_highs",
    "solve_lp",
]

HIGHS_ERROR = highspy.HighsStatus.kError
"""The ``HighsStatus`` of a call that failed."""

_BASIS_STATUS = np.array([highspy.HighsBasisStatus(code) for code in range(5)], dtype=object)


def quiet_highs() -> Any:
    """A HiGHS handle with ``output_flag`` off before anything can print.

    highspy's ``Highs()`` enables its Python callbacks in its constructor, and that first
    call prints the HiGHS version banner while ``output_flag`` is still on; the core class
    ``_Highs`` (which has every method used here) does not. Falls back to ``Highs``.
    """
    highs: Any = getattr(highspy, "_Highs", highspy.Highs)()
    highs.setOptionValue("output_flag", False)
    return highs


def highs_basis(col_status: Any, row_status: Any) -> Any:
    """A ``highspy.HighsBasis`` from integer status codes (HiGHS's ``HighsBasisStatus``).

    Parameters
    ----------
    col_status, row_status : (num_cols,), (num_rows,) integer arrays of codes 0..4
    """
    basis = highspy.HighsBasis()
    basis.col_status = _BASIS_STATUS.take(col_status).tolist()
    basis.row_status = _BASIS_STATUS.take(row_status).tolist()
    return basis


STATUS_MAP = {
    highspy.HighsModelStatus.kOptimal: SolveStatus.OPTIMAL,
    highspy.HighsModelStatus.kInfeasible: SolveStatus.INFEASIBLE,
    # The LP is bounded by construction (bounded u, r; ε, β with non-negative costs), so
    # "unbounded or infeasible" can only mean infeasible.
    highspy.HighsModelStatus.kUnboundedOrInfeasible: SolveStatus.INFEASIBLE,
    highspy.HighsModelStatus.kUnbounded: SolveStatus.UNBOUNDED,
    highspy.HighsModelStatus.kTimeLimit: SolveStatus.TIME_LIMIT,
}


def highs_lp(
    cost: FloatArray,
    matrix: sparse.csc_matrix | sparse.csr_matrix,
    row_lower: FloatArray,
    row_upper: FloatArray,
    col_lower: FloatArray,
    col_upper: FloatArray,
) -> Any:
    """A ``highspy.HighsLp`` of ``min costᵀx s.t. row bounds, column bounds`` (CSC or CSR)."""
    num_rows, num_cols = matrix.shape
    lp = highspy.HighsLp()
    lp.num_col_ = num_cols
    lp.num_row_ = num_rows
    lp.col_cost_ = np.asarray(cost, dtype=np.float64)
    lp.col_lower_ = np.asarray(col_lower, dtype=np.float64)
    lp.col_upper_ = np.asarray(col_upper, dtype=np.float64)
    lp.row_lower_ = np.asarray(row_lower, dtype=np.float64)
    lp.row_upper_ = np.asarray(row_upper, dtype=np.float64)
    colwise = isinstance(matrix, sparse.csc_matrix)
    lp.a_matrix_.format_ = (
        highspy.MatrixFormat.kColwise if colwise else highspy.MatrixFormat.kRowwise
    )
    lp.a_matrix_.num_col_ = num_cols
    lp.a_matrix_.num_row_ = num_rows
    lp.a_matrix_.start_ = matrix.indptr.astype(np.int32)
    lp.a_matrix_.index_ = matrix.indices.astype(np.int32)
    lp.a_matrix_.value_ = matrix.data.astype(np.float64)
    return lp


def pass_csc_model(
    highs: Any,
    cost: FloatArray,
    col_lower: FloatArray,
    col_upper: FloatArray,
    row_lower: FloatArray,
    row_upper: FloatArray,
    matrix: tuple[Any, Any, FloatArray],
) -> bool:
    """Replace ``highs``'s model by ``min costᵀx s.t. row bounds, column bounds`` in one call.

    ``matrix`` is ``(indptr (num_cols + 1,), indices (nnz,), data (nnz,))`` of a CSC matrix
    with int32 indices. Much cheaper than :func:`highs_lp` + ``passModel`` (no ``HighsLp``
    object: the arrays go straight to HiGHS). Returns False if HiGHS refused the model.
    """
    indptr, indices, data = matrix
    num_cols, num_rows = cost.size, row_lower.size
    status = highs.passModel(
        num_cols,
        num_rows,
        data.size,
        int(highspy.MatrixFormat.kColwise),
        int(highspy.ObjSense.kMinimize),
        0.0,
        cost,
        col_lower,
        col_upper,
        row_lower,
        row_upper,
        indptr[:-1],
        indices,
        data,
        np.zeros(num_cols, dtype=np.int32),  # continuous (HiGHS reads integrality[num_cols])
    )
    return bool(status != highspy.HighsStatus.kError)


def check_time_limit(time_limit_s: float | None, *, source: str) -> None:
    """Refuse a per-solve time limit that is not a positive number of seconds (None = none)."""
    if time_limit_s is not None and not time_limit_s > 0:
        raise ProblemError(
            "time limit must be > 0 s or None",
            source=source,
            field="time_limit_s",
            value=time_limit_s,
        )


class LPResult(NamedTuple):
    """Outcome of :func:`solve_lp`: status, primal values (NaN unless optimal), message, time."""

    status: SolveStatus
    x: FloatArray
    message: str
    time_s: float


def set_feasibility_tolerance(highs: Any, tolerance: float | None) -> None:
    """Set HiGHS's primal and dual feasibility tolerances to ``tolerance``; None leaves
    HiGHS's (1e-7)."""
    if tolerance is not None:
        for option in ("primal_feasibility_tolerance", "dual_feasibility_tolerance"):
            highs.setOptionValue(option, tolerance)


def solve_lp(
    cost: FloatArray,
    a_csr: Any,
    row_lower: FloatArray,
    row_upper: FloatArray,
    col_lower: FloatArray,
    col_upper: FloatArray,
    *,
    time_limit_s: float | None = None,
    method: str = "choose",
    feasibility_tolerance: float | None = None,
) -> LPResult:
    """Solve ``min costᵀx s.t. row_lower ≤ A x ≤ row_upper, col_lower ≤ x ≤ col_upper`` cold.

    A generic one-shot HiGHS call (used by :class:`FeedbackSolver`); single-threaded and
    silent like :class:`RMPCSolver`.

    Parameters
    ----------
    cost, col_lower, col_upper : (num_cols,) objective and column bounds (±inf allowed)
    a_csr : (num_rows, num_cols) ``scipy.sparse.csr_matrix`` constraint matrix
    row_lower, row_upper : (num_rows,) row bounds (±inf allowed)
    time_limit_s : wall-clock limit [s]; None = no limit
    method : HiGHS ``solver`` option: "choose", "simplex" or "ipm"
    feasibility_tolerance : HiGHS's primal and dual feasibility tolerances; None keeps
        HiGHS's (1e-7)

    Returns
    -------
    :class:`LPResult`; ``x`` is NaN unless the status is OPTIMAL; ``time_s`` is the wall time
    of HiGHS ``run()``.
    """
    highs: Any = quiet_highs()
    for option, value in (
        ("output_flag", False),
        ("log_to_console", False),
        ("threads", 1),
        ("solver", method),
        ("time_limit", float(time_limit_s) if time_limit_s is not None else np.inf),
    ):
        highs.setOptionValue(option, value)
    set_feasibility_tolerance(highs, feasibility_tolerance)
    num_cols = a_csr.shape[1]
    lp = highs_lp(cost, a_csr, row_lower, row_upper, col_lower, col_upper)
    if highs.passModel(lp) == highspy.HighsStatus.kError:
        return LPResult(SolveStatus.ERROR, np.full(num_cols, np.nan), "HiGHS refused the LP", 0.0)
    tick = time.perf_counter()
    run_status = highs.run()
    elapsed = time.perf_counter() - tick
    model_status = highs.getModelStatus()
    if run_status == highspy.HighsStatus.kError:
        status = SolveStatus.ERROR
    else:
        status = STATUS_MAP.get(model_status, SolveStatus.ERROR)
    info = highs.getInfo()
    message = (
        f"HiGHS: {highs.modelStatusToString(model_status)} "
        f"({int(info.simplex_iteration_count)} simplex, {int(info.ipm_iteration_count)} IPM "
        f"iterations)"
    )
    if not status.ok:
        return LPResult(status, np.full(num_cols, np.nan), message, elapsed)
    return LPResult(status, np.asarray(highs.getSolution().col_value), message, elapsed)
