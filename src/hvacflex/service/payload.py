"""The plan a building receives: the decision of a period as the service's JSON payload.

Periods are decided by :class:`hvacflex.sim.step.ControlStep` (the rules of ``hvacflex
simulate``, ``docs/explanation/il_events.md``); this module only turns its
:class:`~hvacflex.sim.step. Decision` into the horizon and IL columns of the plan (those of
``results.parquet``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.control.base import FloatArray
from hvacflex.sim.events import Role
from hvacflex.sim.step import Decision


def finite(value: float) -> float | None:
    """``value``, or None when it is NaN or infinite (JSON has no NaN)."""
    return float(value) if math.isfinite(value) else None


def finite_list(values: Any) -> list[float | None]:
    return [finite(float(v)) for v in np.asarray(values, dtype=float).ravel()]


def horizon_columns(
    decision: Decision, solution: Any, c_matrix: FloatArray, index: pd.DatetimeIndex, horizon: int
) -> dict[str, Any]:
    """The plan's horizon (times, power, reserve, zone temperatures) and objective.

    ``solution``: the optimal plan of this period (``None`` for a fallback or a rule); a
    period that runs a locked event plan reports the rest of that plan.
    """
    action = decision.action
    objective: float | None = None
    if decision.locked is not None and decision.role is Role.EVENT_LOCKED:
        plan, j = decision.locked
        power = finite_list(plan.served_power_kw[j:])
        reserve = finite_list(plan.reserve_kw[j:])
        temps = np.asarray(plan.predicted_served_degc[j:], dtype=float).tolist()
    elif solution is not None:
        power = finite_list(solution.power_kw)
        reserve = finite_list(solution.reserve_kw)
        temps = (np.asarray(solution.x_served)[1:] @ c_matrix.T).tolist()
        objective = finite(float(solution.objective_sgd))
    else:
        power = [finite(action.planned_power_kw)]
        reserve = [float(action.reserve_kw)]
        temps = [list(np.asarray(action.predicted_served_degc, dtype=float))]
    return {
        "objective_sgd": objective,
        "horizon_time": [t.isoformat() for t in index[: len(power)][:horizon]],
        "horizon_power_kw": power,
        "horizon_reserve_kw": reserve,
        "horizon_temp_degc": [[finite(float(v)) for v in row] for row in temps],
    }


def event_columns(decision: Decision, activated: bool) -> dict[str, Any]:
    """The plan's IL columns (those of ``results.parquet``) and the flow to run."""
    outcome = decision.outcome
    return {
        "il_activated": activated,
        "il_role": decision.role.value,
        "il_curtailed": outcome.curtailed,
        "il_beyond_model": outcome.beyond_model,
        "il_event_window": outcome.event_window,
        "il_allowance_k": float(outcome.allowance_k),
        "il_reference_power_kw": finite(outcome.reference_power_kw),
        "applied_flow_kg_s": [float(v) for v in decision.applied_flow_kg_s],
    }
