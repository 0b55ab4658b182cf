"""The robust MPC optimisation problem on plain arrays, and its HiGHS solver.

>>> from hvacflex.opt import RMPCProblem, RMPCSolution, RMPCSolver, SolveStatus, solve_rmpc
>>> from hvacflex.opt import FeedbackOptions  # robust="feedback": affine disturbance feedback

See :mod:`hvacflex.opt.problem` for the problem and its LP, :mod:`hvacflex.opt.robust` for
the robust margins, :mod:`hvacflex.opt.solve` for the (warm-started) HiGHS solver,
:mod:`hvacflex.opt.feedback` for the closed-loop (affine disturbance-feedback) RMPC.
"""

from hvacflex.opt.feedback import FeedbackOptions, FeedbackSolver
from hvacflex.opt.problem import RMPCProblem
from hvacflex.opt.solve import RMPCSolution, RMPCSolver, SolverBasis, SolveStatus, solve_rmpc

__all__ = [
    "FeedbackOptions",
    "FeedbackSolver",
    "RMPCProblem",
    "RMPCSolution",
    "RMPCSolver",
    "SolveStatus",
    "SolverBasis",
    "solve_rmpc",
]
