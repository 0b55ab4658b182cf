"""Every optimised open-loop path equals the cold solve (issue 16).

The closed loop of the product ``rmpc`` preset on office5 (IL event model, fixed
linearisation) is recorded, and each step's LP is solved twice: by one warm-started
:class:`RMPCSolver` over the whole sequence (time-shifted basis, lazy event rows — the path
the controller takes) and by a fresh cold solver holding every event row. HiGHS's objectives
(tie-break included) must agree to 1e-8 relative: each solve stops at a basis that is primal
and dual feasible to the solver's 1e-9 tolerances, so two solves from different starting
bases may differ by a few times 1e-9 (step 1 of this day did, 2.3e-9, once the reserve price
was recalibrated to 48.5 SGD/MWh and reserve entered the optimum); a wrong warm start shows
as 1e-6 or more. The default suite checks 12 steps; the
slow suite a recorded week (336 steps, ``-m slow``).
"""

from __future__ import annotations

import pytest

from hvacflex.config import preset
from hvacflex.errors import ConfigError
from hvacflex.opt.problem import RMPCProblem
from hvacflex.opt.solve import RMPCSolver, SolveStatus
from hvacflex.sim.recording import recorded_problems

RELATIVE_TOLERANCE = 1e-8


def _relative_differences(problems: list[RMPCProblem]) -> list[float]:
    """Per step |warm − cold| / max(1, |cold|) of HiGHS's objective [-].

    Also checks that the solver's path is the warm one: at most 1 step in 10 may fall back
    to a cold solve (a warm start HiGHS cannot use, see docs/reference/performance.md)."""
    warm_solver = RMPCSolver(problems[0])
    differences = []
    warm_steps = 0
    for problem in problems:
        warm = warm_solver.solve(problem)
        assert warm.status is SolveStatus.OPTIMAL, warm.message
        warm_steps += warm.warm_start
        cold_solver = RMPCSolver(problem, event_rows="full")
        cold = cold_solver.solve(problem)
        assert cold.status is SolveStatus.OPTIMAL and not cold.warm_start
        reference = cold_solver.highs_objective_sgd()
        difference = abs(warm_solver.highs_objective_sgd() - reference)
        differences.append(difference / max(1.0, abs(reference)))
    assert warm_steps >= 0.9 * (len(problems) - 1)
    return differences


def test_warm_open_loop_steps_equal_cold_solves() -> None:
    problems = recorded_problems(preset("rmpc", start="2014-05-05", days=1), 12)
    assert len(problems) == 12
    assert problems[0].events is not None  # the product LP: IL event model
    differences = _relative_differences(problems)
    assert max(differences) <= RELATIVE_TOLERANCE, differences


@pytest.mark.slow
def test_a_recorded_week_of_warm_steps_equals_cold_solves() -> None:
    problems = recorded_problems(preset("rmpc", start="2014-05-05", days=8), 336)
    assert len(problems) == 336
    differences = _relative_differences(problems)
    assert max(differences) <= RELATIVE_TOLERANCE, max(differences)


def test_recording_refuses_a_rule_controller_and_no_steps() -> None:
    with pytest.raises(ConfigError, match="MPC controller"):
        recorded_problems(preset("thermostat", start="2014-05-05", days=1), 1)
    with pytest.raises(ConfigError, match="at least one step"):
        recorded_problems(preset("rmpc", start="2014-05-05", days=1), 0)
