"""The solver of ``robust="feedback"`` problems: :class:`FeedbackSolver` (cold each step).

Builds the affine-feedback LP of :mod:`hvacflex.opt.feedback` and solves it with
:func:`hvacflex.opt.highs_lp.solve_lp`; :func:`hvacflex.opt.solve.solve_rmpc` dispatches here.
"""

from __future__ import annotations

import time

from hvacflex.errors import ProblemError
from hvacflex.opt.basis import SolverBasis
from hvacflex.opt.feedback import (
    FeedbackLPSize,
    build_feedback_lp,
    feedback_maps,
    feedback_solution,
    gains_tensor,
    output_response,
)
from hvacflex.opt.highs_lp import check_time_limit, solve_lp
from hvacflex.opt.lp import sparse_matrix
from hvacflex.opt.options import FeedbackOptions
from hvacflex.opt.problem import FloatArray, RMPCProblem
from hvacflex.opt.solution import RMPCSolution

__all__ = ["DEFAULT_LP_METHOD", "FeedbackSolver"]

#: HiGHS algorithm for the feedback LP ("simplex", "ipm" or "choose").
DEFAULT_LP_METHOD = "simplex"


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
        if differences:
            raise ProblemError(
                f"the problem's structure differs from the solver's in {differences}",
                source="FeedbackSolver",
                field=differences[0],
                hint="build a new FeedbackSolver for a problem with another structure",
            )
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
