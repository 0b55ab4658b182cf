"""The robust MPC optimisation problem on plain arrays, and its HiGHS solver.

>>> from hvacflex.opt import RMPCProblem, RMPCSolution, RMPCSolver, SolveStatus, solve_rmpc

See :mod:`hvacflex.opt.problem` for the problem and its LP, :mod:`hvacflex.opt.robust` for
the robust margins, :mod:`hvacflex.opt.solve` for the (warm-started) HiGHS solver.
"""

from hvacflex.opt.problem import RMPCProblem
from hvacflex.opt.solve import RMPCSolution, RMPCSolver, SolverBasis, SolveStatus, solve_rmpc

__all__ = [
    "RMPCProblem",
    "RMPCSolution",
    "RMPCSolver",
    "SolveStatus",
    "SolverBasis",
    "solve_rmpc",
]
