"""Which solver a problem gets: :func:`make_solver`, the one factory of both warm-started
solvers (:class:`~hvacflex.opt.solve.RMPCSolver` for the open loop,
:class:`~hvacflex.opt.feedback_solve.FeedbackSolver` for ``robust="feedback"``), and
:func:`solve_rmpc`, the one-shot solve of either.
"""

from __future__ import annotations

from hvacflex.opt.feedback_solve import FeedbackSolver
from hvacflex.opt.problem import RMPCProblem
from hvacflex.opt.solution import RMPCSolution
from hvacflex.opt.solve import RMPCSolver

__all__ = ["WarmSolver", "make_solver", "solve_rmpc"]


WarmSolver = RMPCSolver | FeedbackSolver
"""A warm-started solver of either kind (what :func:`make_solver` returns)."""


def make_solver(
    problem: RMPCProblem,
    *,
    time_limit_s: float | None = None,
    time_shift: bool = True,
    feasibility_tolerance: float | None = None,
) -> WarmSolver:
    """The warm-started solver for problems of ``problem``'s structure and robust mode.

    :class:`FeedbackSolver` for ``robust="feedback"``, else :class:`RMPCSolver` (lazy IL
    event rows), each with its defaults for what only it has.

    Parameters
    ----------
    problem : the first problem; fixes the structure
    time_limit_s : wall-clock limit per solve [s]; None = no limit
    time_shift : each problem is the previous one a step later (receding horizon): start from
        the previous basis rotated by one step; False: as is
    feasibility_tolerance : HiGHS's primal and dual feasibility tolerances; None keeps 1e-7

    Raises
    ------
    ProblemError
        if ``time_limit_s`` is not a positive number of seconds.
    """
    solver_class = FeedbackSolver if problem.robust == "feedback" else RMPCSolver
    return solver_class(
        problem,
        time_limit_s=time_limit_s,
        time_shift=time_shift,
        feasibility_tolerance=feasibility_tolerance,
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
    return make_solver(problem, time_limit_s=time_limit_s).solve(problem)
