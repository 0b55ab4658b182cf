"""The robust MPC optimisation problem on plain arrays, and its HiGHS solver.

>>> from hvacflex.opt import RMPCProblem, RMPCSolution, RMPCSolver, SolveStatus, solve_rmpc
>>> from hvacflex.opt import FeedbackOptions  # robust="feedback": affine disturbance feedback

Modules, each importing only those above it:

- :mod:`~hvacflex.opt.options`: robust modes, feedback options, ρ default, tie-break;
- :mod:`~hvacflex.opt.robust`: the robust margins δ (pure numpy; the one home of δ);
- :mod:`~hvacflex.opt.events`: the IL event rows, their rotation and worst output (numpy);
- :mod:`~hvacflex.opt.checks`: checks of plain arrays and numbers (shapes, NaN, signs);
- :mod:`~hvacflex.opt.blocks`: the problem's feature blocks (IL events, reserve commitment,
  offer baselines, power cap), each with its own validation and ``add_…`` LP family;
- :mod:`~hvacflex.opt.problem`: :class:`RMPCProblem` (core + feature blocks) and its
  validation;
- :mod:`~hvacflex.opt.lp_builder`: the index allocator and the LP container;
- :mod:`~hvacflex.opt.lp`: the open-loop LP, one ``add_…`` function per constraint family;
- :mod:`~hvacflex.opt.solution`: :class:`RMPCSolution` and how it is built from a plan;
- :mod:`~hvacflex.opt.feedback_maps`: the affine disturbance-feedback parameterisation (which
  gains exist, their index maps);
- :mod:`~hvacflex.opt.feedback`: the affine disturbance-feedback LP;
- :mod:`~hvacflex.opt.feedback_result`: a feedback LP's solution (gains, realised margins);
- :mod:`~hvacflex.opt.basis`: simplex bases as arrays (time shift, checks);
- :mod:`~hvacflex.opt.highs_lp`: the only highspy importer: ``HighsSession`` (handle, options,
  runs, time limit, status, basis, retry ladder), model passing, the one-shot solve;
- :mod:`~hvacflex.opt.feedback_solve`: ``FeedbackSolver``, the feedback LP's strategy on a
  session;
- :mod:`~hvacflex.opt.solve`: ``RMPCSolver``, the open-loop LP's strategy on a session;
- :mod:`~hvacflex.opt.factory`: ``make_solver``, the one factory of both solvers, and
  ``solve_rmpc``, the one-shot solve;
- :mod:`~hvacflex.opt.testing`: seeded random problems for tests and benchmarks.
"""

from hvacflex.opt.basis import SolverBasis
from hvacflex.opt.blocks import (
    ComfortKnee,
    ILEventModel,
    OfferBaselines,
    PowerCap,
    ReserveCommitment,
    StepLinearisation,
)
from hvacflex.opt.factory import WarmSolver, make_solver, solve_rmpc
from hvacflex.opt.feedback_solve import FeedbackSolver
from hvacflex.opt.options import FeedbackOptions
from hvacflex.opt.problem import RMPCProblem
from hvacflex.opt.solution import RMPCSolution, SolveStatus
from hvacflex.opt.solve import RMPCSolver

__all__ = [
    "ComfortKnee",
    "FeedbackOptions",
    "FeedbackSolver",
    "ILEventModel",
    "OfferBaselines",
    "PowerCap",
    "RMPCProblem",
    "RMPCSolution",
    "RMPCSolver",
    "ReserveCommitment",
    "SolveStatus",
    "SolverBasis",
    "StepLinearisation",
    "WarmSolver",
    "make_solver",
    "solve_rmpc",
]
