"""The one list of types a stored state may hold (:mod:`hvacflex.state`'s allow-list).

A checkpoint (a run's, a fleet's) and the service's stored controller state hold
:meth:`hvacflex.sim.step.ControlStep.get_state`: plain data plus the frozen dataclasses and
enums below (the solver's basis and plan, the controller's model, the Kalman filter's state,
a locked IL event plan). :func:`hvacflex.state.decode` builds these and nothing else: a state
naming any other class is refused, and no module is ever imported by a name read from a
state. Importing :mod:`hvacflex.sim` registers them.

A new type in a controller's or a plant's state is added here: until then a state holding it
is refused on load (the resume tests fail).
"""

from __future__ import annotations

from hvacflex import state
from hvacflex.building.channels import DisturbanceChannel
from hvacflex.building.discretize import LinearModel
from hvacflex.building.model import Window
from hvacflex.control.base import EventPlan
from hvacflex.control.estimation import AppliedStep, EstimatorState
from hvacflex.control.trajectory import StepMatrices
from hvacflex.opt.basis import SolverBasis
from hvacflex.opt.solution import RMPCSolution, SolveStatus
from hvacflex.sim.events import Role

STORED_TYPES: tuple[type, ...] = (
    AppliedStep,  # the Kalman filter's last applied step
    DisturbanceChannel,  # a LinearModel's channels
    EstimatorState,  # the Kalman filter's state
    EventPlan,  # an IL event's locked plan
    LinearModel,  # the step model the controller plans with
    RMPCSolution,  # the previous plan
    Role,  # an IL period's role
    SolveStatus,  # a solution's status
    SolverBasis,  # HiGHS's basis, to warm-start after a resume
    StepMatrices,  # a LinearModel's step matrices
    Window,  # a DisturbanceChannel's window
)
"""Every dataclass and enum a stored state holds (with the types their fields hold)."""

state.register_stored_types(*STORED_TYPES)
