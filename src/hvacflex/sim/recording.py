"""Record the LPs a closed loop's MPC controller builds (for exactness tests and benchmarks).

:func:`recorded_problems` runs a scenario's closed loop (the real plant, forecasts and
controller) for a number of steps and returns every :class:`~hvacflex.opt.problem.RMPCProblem`
the controller solved, in order: a receding-horizon sequence as the warm-started solver sees
it, to be re-solved warm or cold elsewhere.
"""

from __future__ import annotations

from hvacflex.config import ScenarioConfig
from hvacflex.control.mpc import MPCController
from hvacflex.errors import ConfigError
from hvacflex.opt.problem import RMPCProblem
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.setup import prepare

__all__ = ["recorded_problems"]


def recorded_problems(config: ScenarioConfig, steps: int) -> list[RMPCProblem]:
    """The problems ``config``'s MPC controller builds over the first ``steps`` closed-loop
    steps (30-min periods; ``config`` must cover them).

    Raises
    ------
    ConfigError
        if the scenario's controller is not an MPC controller, or ``steps`` < 1.
    """
    if steps < 1:
        raise ConfigError(
            "record at least one step",
            source="recorded_problems",
            field="steps",
            value=steps,
            hint="pass steps ≥ 1",
        )
    loop = ClosedLoop(prepare(config))
    problems: list[RMPCProblem] = []
    controller = loop.controller
    if not isinstance(controller, MPCController):
        raise ConfigError(
            "only an MPC controller builds LPs",
            source="recorded_problems",
            field="controller",
            value=type(controller).__name__,
            hint="record an rmpc or nmpc scenario",
        )
    controller.observe_problems(problems.append)
    while loop.k < steps:
        loop.step()
    return problems
