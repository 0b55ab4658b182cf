"""Solve :class:`~hvacflex.opt.problem.RMPCProblem` with HiGHS; the only importer of highspy.

:class:`RMPCSolver` builds the sparse LP of :mod:`hvacflex.opt.lp` once per structure
(A, B, E, C, N, reserve mask, robust mode). Each :meth:`RMPCSolver.solve` rebuilds the LP's
costs and bounds without its constant coefficients, pushes only what changed since the
previous solve — costs, column bounds, row bounds (x0, d̂, g, δ, bounds, p0) and the
step-varying coefficients (``p_k`` on the power rows, ``φ_k`` on the peak rows, σ in the dual
form, via ``changeCoeff``) — and re-solves with the dual simplex (warm start).
:class:`FeedbackSolver` solves the affine-feedback LP of :mod:`hvacflex.opt.feedback` cold
each step. HiGHS runs single-threaded with its output silenced, so results are reproducible.
:func:`solve_rmpc` is the one-shot wrapper for both.

Warm start: by default (``time_shift=True``) the previous optimal basis, rotated by one step
of every time-indexed block, starts the next solve; warm solves use Devex dual pricing without
scaling, cold ones HiGHS's default scaling and presolve (why, and the measurements:
``docs/performance.md``, *How the warm start works*).

Failures are never silent: :class:`SolveStatus` says what happened, ``RMPCSolution.message``
says it in words, and every plan array (u, r, P, R, ε, trajectories, costs) is NaN unless the
status is :attr:`SolveStatus.OPTIMAL`. If a warm-started solve ends in a solver error, the
solve is retried once from scratch (cold) before the error is reported.
"""

from __future__ import annotations

import time
from typing import Any, NamedTuple

import highspy
import numpy as np
from scipy import sparse

from hvacflex.errors import ProblemError
from hvacflex.opt import robust as robust_mod
from hvacflex.opt.basis import (
    BASIC,
    SolverBasis,
    StatusArray,
    checked_basis,
    consistent_status,
    nonbasic_status,
    optimal_statuses,
    rotation,
)
from hvacflex.opt.feedback import (
    FeedbackLPSize,
    build_feedback_lp,
    feedback_maps,
    feedback_solution,
    gains_tensor,
    output_response,
)
from hvacflex.opt.lp import LPLayout, build_lp, sparse_matrix
from hvacflex.opt.options import FeedbackOptions
from hvacflex.opt.problem import FloatArray, RMPCProblem
from hvacflex.opt.solution import (
    RMPCSolution,
    SolveStatus,
    failed_solution,
    plan_from_values,
    plan_solution,
)

__all__ = [
    "DEFAULT_LP_METHOD",
    "FeedbackSolver",
    "LPResult",
    "RMPCSolution",
    "RMPCSolver",
    "SolveStatus",
    "SolverBasis",
    "solve_lp",
    "solve_rmpc",
]

#: HiGHS algorithm for the feedback LP ("simplex", "ipm" or "choose").
DEFAULT_LP_METHOD = "simplex"

_STATUS_MAP = {
    highspy.HighsModelStatus.kOptimal: SolveStatus.OPTIMAL,
    highspy.HighsModelStatus.kInfeasible: SolveStatus.INFEASIBLE,
    # The LP is bounded by construction (bounded u, r; ε, β with non-negative costs), so
    # "unbounded or infeasible" can only mean infeasible.
    highspy.HighsModelStatus.kUnboundedOrInfeasible: SolveStatus.INFEASIBLE,
    highspy.HighsModelStatus.kUnbounded: SolveStatus.UNBOUNDED,
    highspy.HighsModelStatus.kTimeLimit: SolveStatus.TIME_LIMIT,
}


#: HiGHS basis status codes (``HighsBasisStatus``) as stored in :class:`SolverBasis`.
_HIGHS_BASIS_STATUS = np.array([highspy.HighsBasisStatus(code) for code in range(5)], dtype=object)
#: Options of every solve: quiet, single-threaded (reproducible), Devex dual pricing (1).
_BASE_OPTIONS: dict[str, Any] = {
    "output_flag": False,
    "log_to_console": False,
    "threads": 1,
    "simplex_dual_edge_weight_strategy": 1,
}


def _quiet_highs() -> Any:
    """A HiGHS handle with ``output_flag`` off before anything can print.

    highspy's ``Highs()`` enables its Python callbacks in its constructor, and that first
    call prints the HiGHS version banner while ``output_flag`` is still on; the core class
    ``_Highs`` (which has every method used here) does not. Falls back to ``Highs``.
    """
    highs: Any = getattr(highspy, "_Highs", highspy.Highs)()
    highs.setOptionValue("output_flag", False)
    return highs


#: ``simplex_scale_strategy`` of a warm solve (0: no scaling); cold solves use HiGHS's default.
_WARM_SCALE_STRATEGY = 0


def _highs_lp(
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


def _timed_run(highs: Any) -> tuple[float, SolveStatus]:
    """Run HiGHS on its current model: (wall time of ``run()`` [s], outcome)."""
    tick = time.perf_counter()
    run_status = highs.run()
    elapsed = time.perf_counter() - tick
    if run_status == highspy.HighsStatus.kError:
        return elapsed, SolveStatus.ERROR
    return elapsed, _STATUS_MAP.get(highs.getModelStatus(), SolveStatus.ERROR)


def _refuse_other_structure(differences: list[str], solver: str) -> None:
    """Refuse a problem whose structure differs from the one ``solver`` was built for."""
    if differences:
        raise ProblemError(
            f"the problem's structure differs from the solver's in {differences}",
            source=solver,
            field=differences[0],
            hint=f"build a new {solver} for a problem with another structure",
        )


def check_time_limit(time_limit_s: float | None, *, source: str) -> None:
    """Refuse a per-solve time limit that is not a positive number of seconds (None = none)."""
    if time_limit_s is not None and not time_limit_s > 0:
        raise ProblemError(
            "time limit must be > 0 s or None",
            source=source,
            field="time_limit_s",
            value=time_limit_s,
        )


class RMPCSolver:
    """Warm-started HiGHS solver for a sequence of problems of one structure.

    Parameters
    ----------
    problem : the first problem; fixes the structure (A, B, E, C, N, reserve mask, robust)
    time_limit_s : wall-clock limit per solve [s] (each :meth:`solve`, not cumulative);
        None = no limit
    time_shift : each problem is the previous one a step later (receding horizon): start
        from the previous optimal basis rotated by one step (see the module docstring).
        False: start from the previous basis as is (e.g. re-solving one step's problem with
        other prices).

    Examples
    --------
    >>> solver = RMPCSolver(problem)                     # doctest: +SKIP
    >>> for step in range(steps):                        # doctest: +SKIP
    ...     sol = solver.solve(problem_at(step))
    """

    def __init__(
        self, problem: RMPCProblem, *, time_limit_s: float | None = None, time_shift: bool = True
    ) -> None:
        check_time_limit(time_limit_s, source="RMPCSolver")
        if problem.robust == "feedback":
            raise ProblemError(
                "RMPCSolver solves the open-loop problem only",
                source="RMPCSolver",
                field="robust",
                value=problem.robust,
                hint="use hvacflex.opt.feedback.FeedbackSolver (or solve_rmpc) for feedback",
            )
        self._structure = problem.structure
        self._fingerprint = self._structure.fingerprint()
        self._responses = robust_mod.impulse_responses(
            problem.a_matrix, problem.e_matrix, problem.c_matrix, problem.horizon
        )
        self._margin_operator = robust_mod.margin_operator(self._responses)
        # highspy's Python wrapper is only partly typed; treat the handle as Any.
        self._highs: Any = _quiet_highs()
        for option, value in _BASE_OPTIONS.items():
            self._highs.setOptionValue(option, value)
        _, self._cold_scale_strategy = self._highs.getOptionValue("simplex_scale_strategy")
        self._scale_strategy = self._cold_scale_strategy
        self._time_limit_s = float(time_limit_s) if time_limit_s is not None else None
        self._time_shift = time_shift
        self._build(problem)
        self._col_rotation, self._row_rotation = rotation(self._lp)
        self._last_problem: RMPCProblem | None = problem
        self._has_basis = False
        # statuses of the last optimal basis (or of set_basis), to start the next solve from
        self._basis: tuple[StatusArray, StatusArray] | None = None
        self._basis_given = False

    # ------------------------------------------------------------------ properties
    @property
    def layout(self) -> LPLayout:
        """Column/row indices of the LP."""
        return self._layout

    @property
    def num_cols(self) -> int:
        """Number of LP variables."""
        return self._lp.num_cols

    @property
    def num_rows(self) -> int:
        """Number of LP constraints."""
        return self._lp.num_rows

    @property
    def num_nonzeros(self) -> int:
        """Nonzeros of the constraint matrix as HiGHS holds it."""
        return int(self._highs.getNumNz())

    # ------------------------------------------------------------------ model
    def _build(self, problem: RMPCProblem) -> None:
        delta = self._delta(problem)
        lp, self._layout = build_lp(
            problem, self._tightening(problem, delta), responses=self._responses
        )
        assert lp.constant is not None
        matrix = sparse_matrix(lp, lp.constant, keep_varying_zeros=True, csc=True)
        highs_lp = _highs_lp(
            lp.cost, matrix, lp.row_lower, lp.row_upper, lp.col_lower, lp.col_upper
        )
        if self._highs.passModel(highs_lp) == highspy.HighsStatus.kError:
            raise ProblemError(
                "HiGHS refused the assembled LP",
                source="RMPCSolver",
                hint="check the problem arrays for extreme magnitudes",
            )
        self._lp = lp
        self._bounds_changed()

    def _bounds_changed(self) -> None:
        """Refresh the bound data that basis statuses are derived from (after any update)."""
        lp = self._lp
        self._col_lower, self._col_upper = lp.col_lower, lp.col_upper
        self._col_nonbasic = nonbasic_status(lp.col_lower, lp.col_upper)
        self._row_nonbasic = nonbasic_status(lp.row_lower, lp.row_upper)

    def _delta(self, problem: RMPCProblem) -> FloatArray:
        if problem.robust == "none":
            return np.zeros((problem.horizon, problem.ny))
        return robust_mod.robust_margins(self._margin_operator, problem.d_sigma)

    @staticmethod
    def _tightening(problem: RMPCProblem, delta: FloatArray) -> FloatArray:
        return np.zeros_like(delta) if problem.robust == "dual" else delta

    def _update(self, problem: RMPCProblem, delta: FloatArray) -> None:
        """Push the costs, bounds and varying coefficients that differ from the last LP."""
        highs = self._highs
        tightening = self._tightening(problem, delta)
        lp, _ = build_lp(problem, tightening, responses=self._responses, constants=False)
        old = self._lp
        changed = np.flatnonzero(lp.cost != old.cost).astype(np.int32)
        if changed.size:
            highs.changeColsCost(changed.size, changed, lp.cost[changed])
        for change_bounds, lower, upper, old_lower, old_upper in (
            (highs.changeColsBounds, lp.col_lower, lp.col_upper, old.col_lower, old.col_upper),
            (highs.changeRowsBounds, lp.row_lower, lp.row_upper, old.row_lower, old.row_upper),
        ):
            changed = np.flatnonzero((lower != old_lower) | (upper != old_upper)).astype(np.int32)
            if changed.size:
                change_bounds(changed.size, changed, lower[changed], upper[changed])
        varying = lp.varying
        moved = np.flatnonzero(varying.values != old.varying.values)
        for row, col, value in zip(
            varying.rows[moved].tolist(),
            varying.cols[moved].tolist(),
            varying.values[moved].tolist(),
            strict=True,
        ):
            highs.changeCoeff(row, col, value)
        self._lp = lp
        self._bounds_changed()

    # ------------------------------------------------------------------ solve
    def solve(self, problem: RMPCProblem) -> RMPCSolution:
        """Solve ``problem`` (same structure as the solver's), warm-started when possible.

        Raises
        ------
        ProblemError
            if ``problem`` has a different structure (A, B, E, C, N, reserve mask, robust
            mode); build a new :class:`RMPCSolver` for it.
        """
        start = time.perf_counter()
        if problem.structure is not self._structure:
            _refuse_other_structure(self._structure.differences(problem.structure), "RMPCSolver")
        delta = self._delta(problem)
        if problem is not self._last_problem:
            self._update(problem, delta)
            self._last_problem = problem
        if self._basis is not None and (self._time_shift or self._basis_given):
            self._start_from(*self._basis)
        warm = self._has_basis
        highs_time, status = self._run(warm)
        iterations = int(self._highs.getInfo().simplex_iteration_count)
        if status is SolveStatus.ERROR and warm:
            self._highs.clearSolver()
            retry_time, status = self._run(False)
            highs_time += retry_time
            iterations += int(self._highs.getInfo().simplex_iteration_count)
            warm = False
        values = np.asarray(self._highs.getSolution().col_value) if status.ok else None
        self._basis_given = False
        if values is not None:
            self._basis = self._optimal_basis(values)
            self._has_basis = True
        else:
            self._basis = None
            self._has_basis = bool(self._highs.getBasis().valid)
        return self._solution(problem, delta, status, start, highs_time, iterations, warm, values)

    def _start_from(self, col_status: StatusArray, row_status: StatusArray) -> None:
        """Pass a basis (rotated by one step if ``time_shift``) to HiGHS for the next run.

        Nonbasic statuses that the current bounds do not allow (a bound that became
        infinite) are replaced by the one the bounds imply.
        """
        if self._time_shift:
            col_status = col_status[self._col_rotation]
            row_status = row_status[self._row_rotation]
        col_status = consistent_status(
            col_status, self._col_lower, self._col_upper, self._col_nonbasic
        )
        row_status = np.where(row_status == BASIC, BASIC, self._row_nonbasic)
        basis = highspy.HighsBasis()
        basis.col_status = _HIGHS_BASIS_STATUS.take(col_status).tolist()
        basis.row_status = _HIGHS_BASIS_STATUS.take(row_status).tolist()
        basis.valid = True
        basis.alien = False  # a rotation of a basis keeps the count of basic variables
        if self._highs.setBasis(basis) == highspy.HighsStatus.kError:
            self._highs.clearSolver()  # start cold rather than fail
            self._has_basis = False
        else:
            self._has_basis = True

    def _optimal_basis(self, values: FloatArray) -> tuple[StatusArray, StatusArray]:
        """Statuses of HiGHS's current (optimal) basis (see :func:`optimal_statuses`)."""
        _, basic = self._highs.getBasicVariables()
        return optimal_statuses(
            values,
            self._col_lower,
            self._col_upper,
            self._col_nonbasic,
            self._row_nonbasic,
            np.asarray(basic),
        )

    def _run(self, warm: bool) -> tuple[float, SolveStatus]:
        scale = _WARM_SCALE_STRATEGY if warm else self._cold_scale_strategy
        if scale != self._scale_strategy:
            self._highs.setOptionValue("simplex_scale_strategy", scale)
            self._scale_strategy = scale
        if self._time_limit_s is not None:
            # HiGHS checks ``time_limit`` against the Highs object's run clock, which
            # accumulates over every run() of this object: re-arm it so the limit is per solve.
            self._highs.setOptionValue(
                "time_limit", float(self._highs.getRunTime()) + self._time_limit_s
            )
        return _timed_run(self._highs)

    def _message(
        self, problem: RMPCProblem, delta: FloatArray, status: SolveStatus, iterations: int
    ) -> str:
        model_status = self._highs.modelStatusToString(self._highs.getModelStatus())
        if status is SolveStatus.OPTIMAL:
            return f"optimal ({iterations} simplex iterations)"
        if status is SolveStatus.INFEASIBLE:
            cap = problem.slack_max_kelvin
            return (
                f"infeasible (HiGHS: {model_status}): no plan keeps both the served and the "
                f"curtailed trajectory within the comfort band (tightened by up to "
                f"{float(delta.max(initial=0.0)):.3g} K for robustness) with "
                f"slack ≤ {cap} K; allow more slack (slack_max_kelvin=None makes comfort "
                f"soft), reduce the uncertainty σ, or widen the band"
            )
        if status is SolveStatus.UNBOUNDED:
            return f"unbounded (HiGHS: {model_status}): check for negative penalties or prices"
        if status is SolveStatus.TIME_LIMIT:
            return (
                f"time limit reached after {iterations} simplex iterations before optimality "
                f"(HiGHS: {model_status}); no plan returned, raise time_limit_s"
            )
        return (
            f"solver failure (HiGHS: {model_status}) after {iterations} simplex iterations; "
            f"no plan returned, fall back to a safe rule"
        )

    def _solution(
        self,
        problem: RMPCProblem,
        delta: FloatArray,
        status: SolveStatus,
        start: float,
        highs_time: float,
        iterations: int,
        warm: bool,
        values: FloatArray | None,
    ) -> RMPCSolution:
        message = self._message(problem, delta, status, iterations)
        if values is None:
            return failed_solution(
                problem,
                status=status,
                message=message,
                delta=delta,
                start=start,
                highs_time_s=highs_time,
                simplex_iterations=iterations,
                warm_start=warm,
            )
        return plan_solution(
            problem,
            status=status,
            message=message,
            plan=plan_from_values(problem, self._layout.plan, values),
            delta=delta,
            start=start,
            highs_time_s=highs_time,
            simplex_iterations=iterations,
            warm_start=warm,
        )

    def highs_objective_sgd(self) -> float:
        """HiGHS's objective value of the last solve (includes the reserve tie-break) [SGD]."""
        return float(self._highs.getInfo().objective_function_value)

    # ------------------------------------------------------------------ basis
    def get_basis(self) -> SolverBasis | None:
        """The basis of the last solve (picklable; as solved, not rotated), or None if none yet."""
        if self._basis is not None:
            return SolverBasis(
                fingerprint=self._fingerprint,
                col_status=self._basis[0].copy(),
                row_status=self._basis[1].copy(),
            )
        basis = self._highs.getBasis()
        if not basis.valid:
            return None
        return SolverBasis(
            fingerprint=self._fingerprint,
            col_status=np.array([int(s) for s in basis.col_status], dtype=np.int8),
            row_status=np.array([int(s) for s in basis.row_status], dtype=np.int8),
        )

    def set_basis(self, basis: SolverBasis) -> None:
        """Start the next solve from ``basis`` (from :meth:`get_basis` of a same-structure solver).

        With ``time_shift`` the basis is taken as the previous step's and rotated by one step,
        exactly as after a solve of this solver: a checkpoint resumes as if never stopped.

        Raises
        ------
        ProblemError
            if the basis belongs to another structure or HiGHS rejects it.
        """
        self._basis = checked_basis(basis, self._fingerprint, self.num_cols, self.num_rows)
        self._basis_given = True
        self._has_basis = True


class FeedbackSolver:
    """Solver for ``robust="feedback"`` problems of one structure; mirrors :class:`RMPCSolver`.

    The structural coefficients of the LP (gains, Ψ and Y rows, dynamics) are assembled once;
    each :meth:`solve` rebuilds the rest (σ-, p- and φ-dependent rows, costs, bounds) and
    solves the LP cold with HiGHS (:func:`solve_lp`). No simplex basis is kept:
    :meth:`get_basis` returns None.

    Parameters
    ----------
    problem : the first problem (``robust="feedback"``); fixes A, B, E, C, N, mask, options
    time_limit_s : wall-clock limit per solve [s]; None = no limit
    method : HiGHS algorithm, "simplex" (default), "ipm" or "choose"
    """

    def __init__(
        self,
        problem: RMPCProblem,
        *,
        time_limit_s: float | None = None,
        method: str = DEFAULT_LP_METHOD,
    ) -> None:
        if problem.robust != "feedback" or problem.feedback is None:
            raise ProblemError(
                "FeedbackSolver needs a problem with robust='feedback'",
                source="FeedbackSolver",
                field="robust",
                value=problem.robust,
                hint="use RMPCSolver for the open-loop modes",
            )
        check_time_limit(time_limit_s, source="FeedbackSolver")
        self._time_limit_s = time_limit_s
        self._method = method
        self._structure = problem.structure
        self._options: FeedbackOptions = problem.feedback
        self._maps = feedback_maps(problem, self._options)
        first, _, _ = build_feedback_lp(problem, self._maps)
        assert first.constant is not None
        self._constant = first.constant
        self.last_size: FeedbackLPSize | None = None

    def solve(self, problem: RMPCProblem) -> RMPCSolution:
        """Solve ``problem`` (same structure and feedback options as the solver's).

        Raises
        ------
        ProblemError
            if ``problem`` has another structure or other feedback options.
        """
        start = time.perf_counter()
        differences = self._structure.differences(problem.structure)
        if problem.feedback != self._options:
            differences.append("feedback")
        _refuse_other_structure(differences, "FeedbackSolver")
        lp, plan_cols, feedback_cols = build_feedback_lp(problem, self._maps, constants=False)
        matrix = sparse_matrix(lp, self._constant, keep_varying_zeros=False, csc=False)
        size = FeedbackLPSize(
            num_cols=lp.num_cols,
            num_rows=lp.num_rows,
            num_nonzeros=int(matrix.nnz),
            num_gains=self._maps.gains.num_gains,
        )
        self.last_size = size
        result = solve_lp(
            lp.cost,
            matrix,
            lp.row_lower,
            lp.row_upper,
            lp.col_lower,
            lp.col_upper,
            time_limit_s=self._time_limit_s,
            method=self._method,
        )
        where = (
            f"feedback LP '{self._options.structure}' ({size.num_rows} rows, {size.num_cols} "
            f"columns, {size.num_nonzeros} nonzeros)"
        )
        return feedback_solution(
            problem,
            self._maps,
            (plan_cols, feedback_cols),
            status=result.status,
            values=result.x,
            message=f"{where}; {result.message}",
            start=start,
            highs_time_s=result.time_s,
        )

    def gains_tensor(self, theta: FloatArray, horizon: int, m: int, nd: int) -> FloatArray:
        """(N, N, m, nd) gains ``U_{k,j}`` from the gain values Θ (see
        :func:`hvacflex.opt.feedback.gains_tensor`)."""
        return gains_tensor(self._maps, theta, horizon, m, nd)

    def output_response(self, tensor: FloatArray) -> FloatArray:
        """(N, N, ny, nd) output response ``Y[k-1, j]`` under the gains ``tensor`` (see
        :func:`hvacflex.opt.feedback.output_response`)."""
        return output_response(self._maps, tensor)

    def get_basis(self) -> SolverBasis | None:
        """None: the feedback LP is solved cold every step (its size changes with σ, φ)."""
        return None

    def set_basis(self, basis: SolverBasis) -> None:
        """Refuse: a feedback solver keeps no basis (:meth:`get_basis` returns None)."""
        raise ProblemError(
            "a FeedbackSolver keeps no simplex basis",
            source="FeedbackSolver",
            field="basis",
            value=basis.fingerprint[:12],
            hint="the basis was saved by an open-loop RMPCSolver; resume with the same robust mode",
        )


def solve_rmpc(problem: RMPCProblem, *, time_limit_s: float | None = None) -> RMPCSolution:
    """Solve one problem from scratch (see :class:`RMPCSolver` for sequences).

    Parameters
    ----------
    problem : the validated problem
    time_limit_s : wall-clock limit [s]; None = no limit

    Returns
    -------
    :class:`RMPCSolution`; check ``sol.status`` (arrays are NaN unless OPTIMAL).
    ``robust="feedback"`` problems go to :class:`FeedbackSolver`.
    """
    if problem.robust == "feedback":
        return FeedbackSolver(problem, time_limit_s=time_limit_s).solve(problem)
    return RMPCSolver(problem, time_limit_s=time_limit_s).solve(problem)


# ---------------------------------------------------------------------- generic LP


class LPResult(NamedTuple):
    """Outcome of :func:`solve_lp`: status, primal values (NaN unless optimal), message, time."""

    status: SolveStatus
    x: FloatArray
    message: str
    time_s: float


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

    Returns
    -------
    :class:`LPResult`; ``x`` is NaN unless the status is OPTIMAL; ``time_s`` is the wall time
    of HiGHS ``run()``.
    """
    highs: Any = _quiet_highs()
    for option, value in (
        ("output_flag", False),
        ("log_to_console", False),
        ("threads", 1),
        ("solver", method),
        ("time_limit", float(time_limit_s) if time_limit_s is not None else np.inf),
    ):
        highs.setOptionValue(option, value)
    num_cols = a_csr.shape[1]
    lp = _highs_lp(cost, a_csr, row_lower, row_upper, col_lower, col_upper)
    if highs.passModel(lp) == highspy.HighsStatus.kError:
        return LPResult(SolveStatus.ERROR, np.full(num_cols, np.nan), "HiGHS refused the LP", 0.0)
    elapsed, status = _timed_run(highs)
    info = highs.getInfo()
    message = (
        f"HiGHS: {highs.modelStatusToString(highs.getModelStatus())} "
        f"({int(info.simplex_iteration_count)} simplex, {int(info.ipm_iteration_count)} IPM "
        f"iterations)"
    )
    if not status.ok:
        return LPResult(status, np.full(num_cols, np.nan), message, elapsed)
    return LPResult(status, np.asarray(highs.getSolution().col_value), message, elapsed)
