"""The HiGHS boundary: the only module of hvacflex that imports highspy.

:class:`HighsSession` is the one HiGHS session of a warm-started solver: the handle and its
options (:data:`BASE_OPTIONS`, the feasibility tolerance, the per-run scaling and algorithm),
``run()`` with the time limit re-armed per solve, the status mapping, the stored simplex basis
(get/set, :class:`~hvacflex.opt.basis.SolverBasis`), the start from it and the retry ladder
(rotated start → unrotated → cold). The open-loop :class:`~hvacflex.opt.solve.RMPCSolver` and
the :class:`~hvacflex.opt.feedback_solve.FeedbackSolver` are strategies on it: each builds and
updates its own LP in the session's handle and maps the stored basis onto it.

Around it: a silent HiGHS handle (:func:`quiet_highs`), the ``HighsLp`` of a sparse LP
(:func:`highs_lp`), one-call model replacement (:func:`pass_csc_model`), basis conversion
(:func:`highs_basis`) and the cold one-shot solve (:func:`solve_lp`). Everything else in
hvacflex sees :class:`~hvacflex.opt.solution.SolveStatus` and numpy arrays.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, NamedTuple

import highspy
import numpy as np
from scipy import sparse

from hvacflex.errors import ProblemError
from hvacflex.opt.basis import SolverBasis, StatusArray, checked_basis
from hvacflex.opt.problem import FloatArray, IntArray
from hvacflex.opt.solution import SolveStatus

__all__ = [
    "BASE_OPTIONS",
    "DANTZIG_PRICING",
    "DEVEX_PRICING",
    "HIGHS_ERROR",
    "STATUS_MAP",
    "WARM_DUAL_FEASIBILITY_TOLERANCE",
    "WARM_PRICING",
    "WARM_SCALE_STRATEGY",
    "HighsSession",
    "LPResult",
    "RunOutcome",
    "SessionOptions",
    "check_time_limit",
    "highs_basis",
    "highs_lp",
    "pass_csc_model",
    "quiet_highs",
    "set_feasibility_tolerance",
    "solve_lp",
]

HIGHS_ERROR = highspy.HighsStatus.kError
"""The ``HighsStatus`` of a call that failed."""

#: Options of every HiGHS handle: silent and single-threaded (reproducible).
_QUIET_OPTIONS: Mapping[str, Any] = MappingProxyType(
    {"output_flag": False, "log_to_console": False, "threads": 1}
)
#: Options of every :class:`HighsSession`: quiet, single-threaded, Devex dual pricing (1).
#: Every step re-initialises the simplex (a new basis; the power-row coefficients p_k change),
#: and dual steepest-edge weights would then be recomputed from scratch, one BTRAN per row.
#: A cold run keeps HiGHS's presolve and scaling: on the feedback LP, without presolve and
#: with max-value scaling (``simplex_scale_strategy`` 4) a cold office5 step took ≈ 20–40 %
#: less CPU (≈ 7,300 instead of ≈ 8,100 iterations), but every warm step after it took
#: ≈ 20–35 % more (with fewer iterations; the cause was not isolated), which cancelled the gain
#: within a day (docs/reference/performance.md, "Feedback RMPC").
BASE_OPTIONS: Mapping[str, Any] = MappingProxyType(
    {**_QUIET_OPTIONS, "simplex_dual_edge_weight_strategy": 1}  # DEVEX_PRICING
)
#: ``simplex_scale_strategy`` of a warm run (0: no scaling); cold runs keep HiGHS's default.
WARM_SCALE_STRATEGY = 0
#: ``simplex_dual_edge_weight_strategy`` of a warm run of a session that asks for it (0:
#: Dantzig pricing). On the open-loop event LP it takes ≈ 40 % fewer iterations than Devex
#: from the rotated basis (docs/reference/performance.md, issue 32); cold runs keep Devex.
DANTZIG_PRICING = 0
#: ``simplex_dual_edge_weight_strategy`` 1: Devex pricing (:data:`BASE_OPTIONS`' own).
DEVEX_PRICING = 1
#: Warm pricing per LP family, chosen by measurement (``benchmarks/bench_pricing.py``, both
#: pricings side by side on the same problems; docs/reference/performance.md, "Warm pricing per LP
#: family", 2026-12-06): the event model (the product LP) takes Dantzig (median 64 instead of
#: 142 iterations over 48 closed-loop steps); the whole-horizon model Devex (29 instead of 81
#: on bench_rmpc's 200 steps, 4 instead of 2 in the closed loop at the same CPU); the feedback
#: LP keeps Devex and one dual tolerance (None: 5 against Dantzig's 6, the same CPU).
WARM_PRICING: Mapping[str, int | None] = MappingProxyType(
    {"event": DANTZIG_PRICING, "whole-horizon": DEVEX_PRICING, "feedback": None}
)
#: HiGHS's dual feasibility tolerance on a warm Dantzig run (HiGHS's default 1e-7 let one
#: office5 step stop 1.5e-9 relative above the optimum; 1e-9 costs no measurable time).
WARM_DUAL_FEASIBILITY_TOLERANCE = 1e-9

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

    A generic one-shot HiGHS call (the feedback solver's ``warm_start=False`` path);
    single-threaded and silent like :class:`HighsSession`, with HiGHS's default pricing.

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
        *_QUIET_OPTIONS.items(),
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


Statuses = tuple[StatusArray, StatusArray]
"""(num_cols,), (num_rows,) HiGHS basis status codes of the columns and rows of an LP."""


class RunOutcome(NamedTuple):
    """What :meth:`HighsSession.run_with_retries` ended with: the status of the last run, the
    wall time of every ``run()`` [s], the simplex iterations of every run, and whether the last
    run started from a basis (warm)."""

    status: SolveStatus
    highs_time_s: float
    iterations: int
    warm: bool


@dataclass(frozen=True)
class SessionOptions:
    """What every warm-started solver lets its caller choose about its HiGHS session.

    ``time_limit_s``: wall-clock limit per solve [s] (every run of one solve, not
    cumulative), None = no limit; ``time_shift``: each LP is the previous one a step later, so
    a stored basis is rotated by one step (False: used as is); ``feasibility_tolerance``:
    HiGHS's primal and dual feasibility tolerances, None keeps HiGHS's 1e-7.
    """

    time_limit_s: float | None = None
    time_shift: bool = True
    feasibility_tolerance: float | None = None


class HighsSession:
    """One HiGHS handle kept over a sequence of LPs, and its warm start.

    The session owns how HiGHS runs; the strategy that holds it (``RMPCSolver``,
    ``FeedbackSolver``) owns the LP in :attr:`highs` and how a stored basis maps onto it
    (which rows HiGHS holds, the bounds that decide nonbasic statuses).

    * options: :data:`BASE_OPTIONS` and the feasibility tolerance once; per run, a warm run
      has no scaling (:data:`WARM_SCALE_STRATEGY`) and the dual simplex, a cold run HiGHS's
      default scaling and ``method`` (an option is set only when it changes);
    * :meth:`run`: one ``run()``, the time limit re-armed so that it holds per solve;
    * the basis: :attr:`basis` holds the statuses the next solve starts from (the last
      optimal basis as solved, or the one :meth:`set_basis` gave); :meth:`start_statuses`
      rotates it by one step, :meth:`set_start` passes a start to HiGHS;
    * :meth:`run_with_retries`: the ladder rotated start → the basis unrotated → cold.

    Parameters
    ----------
    source : the strategy's name, for error messages
    fingerprint : the problem structure's fingerprint (:class:`SolverBasis` carries it)
    options : time limit, time shift and feasibility tolerance (:class:`SessionOptions`)
    method : HiGHS ``solver`` option of a cold run ("simplex", "ipm", "choose"; warm runs are
        "simplex"); None leaves HiGHS's default ("choose") for every run
    warm_pricing : ``simplex_dual_edge_weight_strategy`` of a warm run (e.g.
        :data:`DANTZIG_PRICING`), which then also solves to a dual feasibility tolerance of
        :data:`WARM_DUAL_FEASIBILITY_TOLERANCE` (or the caller's, if tighter); None keeps
        :data:`BASE_OPTIONS`' Devex and one tolerance for every run

    Raises
    ------
    ProblemError
        if ``time_limit_s`` is not a positive number of seconds.
    """

    def __init__(
        self,
        source: str,
        fingerprint: str,
        options: SessionOptions,
        *,
        method: str | None = None,
        warm_pricing: int | None = None,
    ) -> None:
        time_limit_s = options.time_limit_s
        check_time_limit(time_limit_s, source=source)
        # highspy's Python wrapper is only partly typed; treat the handle as Any.
        self.highs: Any = quiet_highs()
        for option, value in BASE_OPTIONS.items():
            self.highs.setOptionValue(option, value)
        _, cold_scale_strategy = self.highs.getOptionValue("simplex_scale_strategy")
        set_feasibility_tolerance(self.highs, options.feasibility_tolerance)
        self._run_options: dict[bool, dict[str, Any]] = {
            True: {"simplex_scale_strategy": WARM_SCALE_STRATEGY},
            False: {"simplex_scale_strategy": cold_scale_strategy},
        }
        if method is not None:
            self._run_options[True]["solver"] = "simplex"
            self._run_options[False]["solver"] = method
        pricing, dual_tolerance = "simplex_dual_edge_weight_strategy", "dual_feasibility_tolerance"
        _, cold_dual_tolerance = self.highs.getOptionValue(dual_tolerance)
        if warm_pricing is not None:
            self._run_options[True][pricing] = warm_pricing
            self._run_options[False][pricing] = BASE_OPTIONS[pricing]
            warm_tolerance = min(WARM_DUAL_FEASIBILITY_TOLERANCE, cold_dual_tolerance)
            self._run_options[True][dual_tolerance] = warm_tolerance
            self._run_options[False][dual_tolerance] = cold_dual_tolerance
        self._options_now: dict[str, Any] = {
            "simplex_scale_strategy": cold_scale_strategy,
            pricing: BASE_OPTIONS[pricing],
            dual_tolerance: cold_dual_tolerance,
        }
        self._time_limit_s = float(time_limit_s) if time_limit_s is not None else None
        self.source = source
        self.fingerprint = fingerprint
        self.time_shift = options.time_shift
        self.basis: Statuses | None = None
        """The statuses the next solve starts from (as solved, not rotated), or None."""
        self.basis_given = False
        """:attr:`basis` came from :meth:`set_basis` since the last solve."""
        self.has_basis = False
        """HiGHS holds a basis to start from (its own, or one just set)."""

    def check_same_structure(self, differences: list[str]) -> None:
        """Refuse a problem whose structure differs from the session's LP in ``differences``
        (field names; empty: the same structure).

        Raises
        ------
        ProblemError
            naming the first difference, if there is one.
        """
        if differences:
            raise ProblemError(
                f"the problem's structure differs from the solver's in {differences}",
                source=self.source,
                field=differences[0],
                hint=f"build a new {self.source} for a problem with another structure",
            )

    # ------------------------------------------------------------------ runs
    def run(self, warm: bool) -> tuple[float, SolveStatus]:
        """One HiGHS ``run()`` with the warm or cold options; its wall time [s] and status."""
        highs = self.highs
        for option, value in self._run_options[warm].items():
            if self._options_now.get(option) != value:
                highs.setOptionValue(option, value)
                self._options_now[option] = value
        if self._time_limit_s is not None:
            # HiGHS checks ``time_limit`` against the handle's run clock, which accumulates
            # over every run() of this handle: re-arm it so the limit is per solve.
            highs.setOptionValue("time_limit", float(highs.getRunTime()) + self._time_limit_s)
        tick = time.perf_counter()
        run_status = highs.run()
        elapsed = time.perf_counter() - tick
        if run_status == HIGHS_ERROR:
            return elapsed, SolveStatus.ERROR
        return elapsed, STATUS_MAP.get(highs.getModelStatus(), SolveStatus.ERROR)

    def run_with_retries(self, warm: bool, restart: Callable[[], bool]) -> RunOutcome:
        """Run (from the start already set if ``warm``) and, on a solver error after a warm
        start, retry.

        A rotated basis can be numerically (near-)singular for HiGHS (entries of the ZOH
        matrices down to 1e-10; "ratio test failed due to excessive dual values"): with
        ``time_shift`` and a stored basis the run is repeated from ``restart()`` (the
        strategy sets the stored basis unrotated, one HiGHS factorised before, and says
        whether it could), then from scratch (cold) before the error is reported.
        """
        highs_time, status = self.run(warm)
        iterations = self.iterations()
        started_warm = warm
        if status is SolveStatus.ERROR and warm and self.time_shift and self.basis is not None:
            warm = restart()
            more_time, status = self.run(warm)
            highs_time, iterations = highs_time + more_time, iterations + self.iterations()
        if status is SolveStatus.ERROR and started_warm:
            self.highs.clearSolver()
            warm = self.has_basis = False
            more_time, status = self.run(False)
            highs_time, iterations = highs_time + more_time, iterations + self.iterations()
        return RunOutcome(status, highs_time, iterations, warm)

    def iterations(self) -> int:
        """Simplex iterations of the last run (0 where HiGHS reports none)."""
        status, count = self.highs.getInfoValue("simplex_iteration_count")
        if status != highspy.HighsStatus.kOk:  # no valid record (a failed run): HiGHS's own
            count = self.highs.getInfo().simplex_iteration_count
        return max(0, int(count))

    def values(self) -> FloatArray:
        """(num_cols,) primal values of the last run."""
        return np.asarray(self.highs.getSolution().col_value)

    def basic_variables(self) -> IntArray:
        """(num_rows held,) HiGHS's basic variables: column j ≥ 0, row i as −1 − i."""
        _, basic = self.highs.getBasicVariables()
        return np.asarray(basic, dtype=np.int64)

    def model_status_text(self) -> str:
        """HiGHS's model status of the last run, in words."""
        return str(self.highs.modelStatusToString(self.highs.getModelStatus()))

    # ------------------------------------------------------------------ basis
    def rotates(self, shift: bool) -> bool:
        """Whether a start asked for with ``shift`` is rotated by one step."""
        return self.time_shift and shift

    def start_statuses(self, rotation: tuple[IntArray, IntArray], *, shift: bool) -> Statuses:
        """The stored basis (not None), rotated by ``rotation`` (column and row maps,
        ``new = old[map]``) if :meth:`rotates`; the caller makes it fit the bounds."""
        assert self.basis is not None
        col_status, row_status = self.basis
        if self.rotates(shift):
            return col_status[rotation[0]], row_status[rotation[1]]
        return col_status, row_status

    def set_start(self, col_status: StatusArray, row_status: StatusArray) -> bool:
        """Start the next run from these statuses (of the rows HiGHS holds); whether HiGHS
        took them (if not, it starts cold rather than fail)."""
        basis = highs_basis(col_status, row_status)
        basis.valid = True
        basis.alien = False  # a rotation of a basis keeps the count of basic variables
        if self.highs.setBasis(basis) == HIGHS_ERROR:
            self.highs.clearSolver()
            self.has_basis = False
        else:
            self.has_basis = True
        return self.has_basis

    def keep(self, basis: Statuses | None) -> None:
        """After a solve: the next one starts from ``basis`` (None: from HiGHS's own, if it
        holds a valid one, else cold)."""
        self.basis = basis
        self.basis_given = False
        self.has_basis = basis is not None or bool(self.highs.getBasis().valid)

    def get_basis(self, *, or_highs: bool = False) -> SolverBasis | None:
        """The stored basis as a :class:`SolverBasis` (copies), or None; with ``or_highs``
        HiGHS's own basis when none is stored (valid only where HiGHS holds every row)."""
        statuses = self.basis
        if statuses is None and or_highs:
            held = self.highs.getBasis()
            if held.valid:
                statuses = (
                    np.array([int(s) for s in held.col_status], dtype=np.int8),
                    np.array([int(s) for s in held.row_status], dtype=np.int8),
                )
        if statuses is None:
            return None
        return SolverBasis(
            fingerprint=self.fingerprint,
            col_status=statuses[0].copy(),
            row_status=statuses[1].copy(),
        )

    def set_basis(self, basis: SolverBasis, num_cols: int, num_rows: int) -> None:
        """Start the next solve from ``basis`` (taken as the previous step's: rotated with
        ``time_shift``, so a checkpoint resumes as if never stopped).

        Raises
        ------
        ProblemError
            if ``basis`` belongs to another structure or LP size, or is no simplex basis.
        """
        self.basis = checked_basis(basis, self.fingerprint, num_cols, num_rows)
        self.basis_given = True
        self.has_basis = True
