"""The solver of ``robust="feedback"`` problems: :class:`FeedbackSolver`, warm-started.

Builds the affine-feedback LP of :mod:`hvacflex.opt.feedback` and keeps it in one
:class:`~hvacflex.opt.highs_lp.HighsSession` between steps (the session runs HiGHS, keeps the
basis and retries; this module builds the LP and maps the basis onto it);
:func:`hvacflex.opt.factory.make_solver` and :func:`~hvacflex.opt.factory.solve_rmpc` dispatch
here.

Warm start (measurements in ``docs/reference/performance.md``, section "Feedback RMPC"). A cold
solve of the zone-local LP on office5 (7,421 rows, 9,224 columns, ≈ 180k nonzeros) takes ≈ 8,000
dual simplex iterations (≈ 2 s); building it takes ≈ 3 ms. So the time is in the simplex,
and the cure is a good starting basis. The LP's sparsity is fixed (the σ- and p-dependent
coefficients are kept even when zero; the Q block of the robust peak exists for a fixed φ
support), the gains and their response blocks are indexed by the *lag* (shift-invariant
structures), and every block indexed by the step k is marked ``time_indexed``: the previous
optimal basis rotated by one step (:func:`hvacflex.opt.basis.rotation`, Q pairs by
:func:`hvacflex.opt.feedback.pair_shift`) is then a few simplex iterations (median 3, p90 12
over a closed-loop day of office5) from the next optimum.

The σ coefficients of the margin rows (≈ 130k, almost all of which move every step) make
in-place coefficient updates (``changeCoeff``, ≈ 2 µs each) slower than replacing the whole
model: each step the matrix data are assembled into the fixed CSC pattern
(:class:`MatrixPattern`, one ``bincount``), passed to HiGHS in one call
(:func:`hvacflex.opt.highs_lp.pass_csc_model`, ≈ 4 ms) and the rotated basis is set; HiGHS
then factorises that basis once (≈ 20–30 ms, the bulk of a warm step) and iterates. If
HiGHS fails on the rotated basis (near-singular), the step is re-run from the previous
optimal basis unrotated, and only then cold (the session's retry ladder).

``warm_start=False`` is the previous behaviour (rebuild and solve cold each step, with
presolve and scaling), kept for verification and the benchmark.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from hvacflex.errors import ProblemError
from hvacflex.opt.basis import (
    SolverBasis,
    bounded_start,
    nonbasic_status,
    optimal_statuses,
    rotation,
)
from hvacflex.opt.feedback import (
    FeedbackColumns,
    FeedbackLPSize,
    build_feedback_lp,
    feedback_maps,
)
from hvacflex.opt.feedback_result import feedback_solution, gains_tensor, output_response
from hvacflex.opt.highs_lp import (
    HighsSession,
    SessionOptions,
    Statuses,
    pass_csc_model,
    solve_lp,
)
from hvacflex.opt.lp import LinearProgram, PlanColumns, sparse_matrix
from hvacflex.opt.options import FeedbackOptions
from hvacflex.opt.problem import FloatArray, IntArray, RMPCProblem
from hvacflex.opt.solution import RMPCSolution, SolveStatus

__all__ = ["DEFAULT_LP_METHOD", "FeedbackSolver", "MatrixPattern"]

#: HiGHS algorithm for the feedback LP ("simplex", "ipm" or "choose"); warm solves are simplex.
DEFAULT_LP_METHOD = "simplex"


@dataclass(frozen=True, eq=False)
class MatrixPattern:
    """The fixed CSC sparsity of a feedback LP layout and where its coefficients go.

    ``indptr`` (num_cols + 1,), ``indices`` (nnz,) int32; ``constant`` (nnz,) the structural
    coefficients summed per position; ``varying_position`` (num_varying,) the position of each
    varying coefficient (duplicates are summed).
    """

    indptr: NDArray[np.int32]
    indices: NDArray[np.int32]
    constant: FloatArray
    varying_position: IntArray

    @staticmethod
    def of(lp: LinearProgram) -> MatrixPattern:
        """The pattern of ``lp`` (built with its constants): constant nonzeros and every
        varying coefficient, zero or not."""
        assert lp.constant is not None
        keep = lp.constant.values != 0.0
        rows = np.concatenate([lp.constant.rows[keep], lp.varying.rows])
        cols = np.concatenate([lp.constant.cols[keep], lp.varying.cols])
        keys, position = np.unique(cols * lp.num_rows + rows, return_inverse=True)
        position = position.ravel()
        num_constant = int(keep.sum())
        counts = np.bincount(keys // lp.num_rows, minlength=lp.num_cols)
        indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        constant = np.bincount(
            position[:num_constant], weights=lp.constant.values[keep], minlength=keys.size
        ).astype(np.float64)
        return MatrixPattern(
            indptr=indptr,
            indices=(keys % lp.num_rows).astype(np.int32),
            constant=constant,
            varying_position=position[num_constant:],
        )

    @property
    def num_nonzeros(self) -> int:
        """Entries of the pattern (explicit zeros included)."""
        return int(self.indices.size)

    def data(self, varying: FloatArray) -> FloatArray:
        """(nnz,) matrix data with the varying coefficients ``varying`` (num_varying,)."""
        moving = np.bincount(self.varying_position, weights=varying, minlength=self.indices.size)
        data: FloatArray = self.constant + moving
        return data


@dataclass(frozen=True, eq=False)
class _Layout:
    """One fixed LP layout: its φ support, sparsity and time-shift maps."""

    support: bytes  # (φ > 0) per step, the key of the layout
    pattern: MatrixPattern
    col_rotation: IntArray
    row_rotation: IntArray


def _layout(problem: RMPCProblem, lp: LinearProgram, f: FeedbackColumns) -> _Layout:
    """The layout of ``lp`` (built with constants) whose Q columns are ``f.qpos``/``f.qneg``."""
    col_map, row_map = rotation(lp)
    for block in (f.qpos, f.qneg):
        if block.size:
            col_map[block.ravel()] = block[f.q_shift].ravel()
    return _Layout(
        support=(problem.phi > 0).tobytes(),
        pattern=MatrixPattern.of(lp),
        col_rotation=col_map,
        row_rotation=row_map,
    )


class FeedbackSolver:
    """Solver for ``robust="feedback"`` problems of one structure; mirrors :class:`RMPCSolver`.

    The structural coefficients of the LP (gains, Ψ and Y rows, dynamics) are assembled once;
    each :meth:`solve` rebuilds the rest (σ-, p- and φ-dependent coefficients, costs, bounds),
    passes the LP to the HiGHS handle it keeps and, after the first step, starts the dual
    simplex from the previous optimal basis rotated by one step (module docstring).

    Parameters
    ----------
    problem : the first problem (``robust="feedback"``); fixes A, B, E, C, N, mask, options
    time_limit_s : wall-clock limit per solve [s]; None = no limit
    method : HiGHS algorithm of a cold solve, "simplex" (default), "ipm" or "choose"
    warm_start : keep the basis between solves (default); False rebuilds and solves cold
        every step (the behaviour before the warm start; for verification and benchmarks)
    time_shift : each problem is the previous one a step later: rotate the basis by one step
        (False: restart from the previous basis as is, e.g. re-solving one step's problem)
    feasibility_tolerance : HiGHS's primal and dual feasibility tolerances of every solve
        (warm and cold); None keeps HiGHS's 1e-7. Tighter tolerances make the optimum's
        objective independent of the vertex the simplex stops at (the exactness tests use
        1e-10); the product path keeps the default.
    """

    def __init__(
        self,
        problem: RMPCProblem,
        *,
        time_limit_s: float | None = None,
        method: str = DEFAULT_LP_METHOD,
        warm_start: bool = True,
        time_shift: bool = True,
        feasibility_tolerance: float | None = None,
    ) -> None:
        if problem.robust != "feedback" or problem.feedback is None:
            raise ProblemError(
                "FeedbackSolver needs a problem with robust='feedback'",
                source="FeedbackSolver",
                field="robust",
                value=problem.robust,
                hint="use RMPCSolver for the open-loop modes",
            )
        self._structure = problem.structure
        options = SessionOptions(time_limit_s, time_shift, feasibility_tolerance)
        fingerprint = self._structure.fingerprint()
        self._session = HighsSession("FeedbackSolver", fingerprint, options, method=method)
        self._time_limit_s = time_limit_s
        self._method = method
        self._warm_start = warm_start
        self._options: FeedbackOptions = problem.feedback
        self._maps = feedback_maps(problem, self._options)
        first, _, columns = build_feedback_lp(problem, self._maps)
        assert first.constant is not None
        self._constant = first.constant
        self._layout = _layout(problem, first, columns)
        self._num_cols, self._num_rows = first.num_cols, first.num_rows
        self._tolerance = feasibility_tolerance
        self._start: Statuses | None = None  # this solve's start (kept if the solve fails)
        self.last_size: FeedbackLPSize | None = None
        self.last_lp_objective_sgd = float("nan")

    def _check(self, problem: RMPCProblem) -> None:
        differences = self._structure.differences(problem.structure)
        if problem.feedback != self._options:
            differences.append("feedback")
        self._session.check_same_structure(differences)

    def solve(self, problem: RMPCProblem, *, same_step: bool = False) -> RMPCSolution:
        """Solve ``problem`` (same structure and feedback options as the solver's).

        ``same_step``: ``problem`` is the previous solve's step again (other prices or power
        caps): the previous basis is taken as it is, not rotated, whatever ``time_shift``
        says (as :meth:`hvacflex.opt.RMPCSolver.solve`). The first solve of every step is not
        ``same_step``.

        Raises
        ------
        ProblemError
            if ``problem`` has another structure or other feedback options.
        """
        start = time.perf_counter()
        self._check(problem)
        if not self._warm_start:
            return self._solve_cold(problem, start)
        lp, plan_cols, feedback_cols = build_feedback_lp(problem, self._maps, constants=False)
        if (problem.phi > 0).tobytes() != self._layout.support:  # another Q block: new layout
            full, _, columns = build_feedback_lp(problem, self._maps)
            self._layout = _layout(problem, full, columns)
            self._num_cols, self._num_rows = full.num_cols, full.num_rows
            self._session.basis = None
        pattern = self._layout.pattern
        matrix = (pattern.indptr, pattern.indices, pattern.data(lp.varying.values))
        self.last_size = FeedbackLPSize(
            num_cols=lp.num_cols,
            num_rows=lp.num_rows,
            num_nonzeros=pattern.num_nonzeros,
            num_gains=self._maps.gains.num_gains,
        )
        bounds = (lp.col_lower, lp.col_upper, lp.row_lower, lp.row_upper)
        if not pass_csc_model(self._session.highs, lp.cost, *bounds, matrix):
            status, values, message, highs_time, iterations, warm = (
                SolveStatus.ERROR,
                np.full(lp.num_cols, np.nan),
                "HiGHS refused the LP",
                0.0,
                0,
                False,
            )
        else:
            status, values, message, highs_time, iterations, warm = self._run_with_retries(
                lp, shift=not same_step
            )
        return self._solution(
            problem,
            lp,
            (plan_cols, feedback_cols),
            (status, values, message, highs_time, iterations, warm),
            start,
        )

    def _run_with_retries(
        self, lp: LinearProgram, *, shift: bool
    ) -> tuple[SolveStatus, FloatArray, str, float, int, bool]:
        """Run from the previous basis (rotated if ``shift``), through the session's retry
        ladder (unrotated, then cold); keep the optimal basis for the next solve, or this
        solve's start if it failed (the next step rotates it once more). Returns status,
        values (NaN unless optimal), message, HiGHS time [s], iterations and whether it ran
        warm."""
        session = self._session
        status, highs_time, iterations, warm = session.run_with_retries(
            self._start_from(lp, shift=shift), lambda: self._start_from(lp, shift=False)
        )
        message = (
            f"HiGHS: {session.model_status_text()} ({iterations} simplex "
            f"iterations, {'warm' if warm else 'cold'})"
        )
        if not status.ok:
            session.keep(self._start)
            return status, np.full(lp.num_cols, np.nan), message, highs_time, iterations, warm
        values = session.values()
        session.keep(
            optimal_statuses(
                values,
                lp.col_lower,
                lp.col_upper,
                nonbasic_status(lp.col_lower, lp.col_upper),
                nonbasic_status(lp.row_lower, lp.row_upper),
                session.basic_variables(),
            )
        )
        return status, values, message, highs_time, iterations, warm

    def _start_from(self, lp: LinearProgram, *, shift: bool = True) -> bool:
        """Set the previous basis (rotated by one step if the session rotates ``shift``);
        whether one was set.

        Nonbasic statuses that the current bounds do not allow are replaced by the ones the
        bounds imply; nonbasic rows sit at their only finite bound.
        """
        self._start = None
        if self._session.basis is None:
            return False
        col_status, row_status = self._session.start_statuses(
            (self._layout.col_rotation, self._layout.row_rotation), shift=shift
        )
        self._start = bounded_start(
            col_status,
            row_status,
            lp.col_lower,
            lp.col_upper,
            nonbasic_status(lp.col_lower, lp.col_upper),
            nonbasic_status(lp.row_lower, lp.row_upper),
        )
        return self._session.set_start(*self._start)

    def _solution(
        self,
        problem: RMPCProblem,
        lp: LinearProgram,
        columns: tuple[PlanColumns, FeedbackColumns],
        outcome: tuple[SolveStatus, FloatArray, str, float, int, bool],
        start: float,
    ) -> RMPCSolution:
        status, values, message, highs_time, iterations, warm = outcome
        size = self.last_size
        assert size is not None
        self.last_lp_objective_sgd = float(lp.cost @ values)
        where = (
            f"feedback LP '{self._options.structure}' ({size.num_rows} rows, {size.num_cols} "
            f"columns, {size.num_nonzeros} nonzeros)"
        )
        return feedback_solution(
            problem,
            self._maps,
            columns,
            status=status,
            values=values,
            message=f"{where}; {message}",
            start=start,
            highs_time_s=highs_time,
            simplex_iterations=iterations,
            warm_start=warm,
        )

    def _solve_cold(self, problem: RMPCProblem, start: float) -> RMPCSolution:
        """Rebuild the LP and solve it cold with :func:`solve_lp` (``warm_start=False``)."""
        lp, plan_cols, feedback_cols = build_feedback_lp(problem, self._maps, constants=False)
        matrix = sparse_matrix(lp, self._constant, keep_varying_zeros=False, csc=False)
        self.last_size = FeedbackLPSize(
            num_cols=lp.num_cols,
            num_rows=lp.num_rows,
            num_nonzeros=int(matrix.nnz),
            num_gains=self._maps.gains.num_gains,
        )
        result = solve_lp(
            lp.cost,
            matrix,
            lp.row_lower,
            lp.row_upper,
            lp.col_lower,
            lp.col_upper,
            time_limit_s=self._time_limit_s,
            method=self._method,
            feasibility_tolerance=self._tolerance,
        )
        outcome = (result.status, result.x, result.message, result.time_s, 0, False)
        return self._solution(problem, lp, (plan_cols, feedback_cols), outcome, start)

    def gains_tensor(self, theta: FloatArray, horizon: int, m: int, nd: int) -> FloatArray:
        """(N, N, m, nd) gains ``U_{k,j}`` from the gain values Θ (see
        :func:`hvacflex.opt.feedback_result.gains_tensor`)."""
        return gains_tensor(self._maps, theta, horizon, m, nd)

    def output_response(self, tensor: FloatArray) -> FloatArray:
        """(N, N, ny, nd) output response ``Y[k-1, j]`` under the gains ``tensor`` (see
        :func:`hvacflex.opt.feedback_result.output_response`)."""
        return output_response(self._maps, tensor)

    def get_basis(self) -> SolverBasis | None:
        """The basis of the last optimal solve (picklable; as solved, not rotated), or None
        (nothing solved yet, the last solve failed, or ``warm_start=False``)."""
        return self._session.get_basis() if self._warm_start else None

    def set_basis(self, basis: SolverBasis) -> None:
        """Start the next solve from ``basis`` (from :meth:`get_basis` of a solver of the same
        structure, options and φ support); with ``time_shift`` it is taken as the previous
        step's and rotated, so a checkpoint resumes as if never stopped.

        Raises
        ------
        ProblemError
            if the basis belongs to another structure or LP size.
        """
        self._session.set_basis(basis, self._num_cols, self._num_rows)
