"""A building's periods in the service: the IL event model of the closed loop, restart-safe.

The rules are those of ``hvacflex simulate`` (:class:`hvacflex.sim.events.EventTracker`,
``docs/il_events.md``); this module only drives the tracker from the service's triggers.
Under the event model (``[reserve] event_max_steps`` = D, the product presets) an activation
that starts in period s locks the plan made at s and the building runs its curtailed flows
u_j − r_j for at most D periods without the solver being asked (the controller only
:meth:`~hvacflex.control.mpc.MPCController.hold` s); after the curtailment the R recovery
periods are re-planned with the allowance α (``allowance_carry_steps``). Under the
whole-horizon model (``paper-*`` presets) each activated period curtails its fresh plan.

A period may be planned more than once (a boundary plan, then the measurement; an activation
start or end during the period): each time it is re-planned from the controller and tracker
state *before* the period, which is stored with the state after it (:meth:`PeriodStepper.
get_state`), so a restarted service re-plans exactly as the running one would.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.config import ScenarioConfig
from hvacflex.control.base import Action, Controller, EventPlan, FloatArray
from hvacflex.control.mpc import MPCController
from hvacflex.data.forecast import Forecast
from hvacflex.errors import InputError
from hvacflex.sim.events import EventTracker, PeriodOutcome, Role


class ConflictError(InputError):
    """The request contradicts what is stored (e.g. a different measurement for a period,
    or a period before the building's latest planned one: plans only go forward)."""


@dataclass(frozen=True)
class Decision:
    """What the building runs in one period.

    Attributes
    ----------
    action : the plan's first step (u₀, r₀, …), or the locked event plan's step j.
    role : the period's IL role (:class:`hvacflex.sim.events.Role`).
    outcome : the period's IL columns (curtailed, beyond model, allowance, reference power).
    applied_flow_kg_s : (m,) the flow to run [kg/s]: u − r when curtailed, else u.
    locked : the locked event plan and the period's index in it, when the period runs it
        (``None`` otherwise).
    """

    action: Action
    role: Role
    outcome: PeriodOutcome
    applied_flow_kg_s: FloatArray
    locked: tuple[EventPlan, int] | None


def event_tracker(config: ScenarioConfig) -> EventTracker:
    """The tracker of ``config``'s reserve model, as the closed loop builds it."""
    reserve = config.reserve
    events = reserve.event_max_steps is not None
    return EventTracker(
        reserve.event_max_steps,
        reserve.event_recovery_steps if events else 0,
        reserve.event_allowance_k if events else 0.0,
    )


def _unplanned(zones: int) -> Action:
    """The action of a period nobody planned (only its IL bookkeeping is advanced)."""
    nan = np.full(zones, math.nan)
    return Action(
        flow_kg_s=nan,
        reserve_flow_kg_s=np.zeros(zones),
        reserve_kw=0.0,
        planned_power_kw=math.nan,
        status="not-planned",
        fallback=True,
        solve_time_s=0.0,
        planned_slack_max_k=math.nan,
        delta_max_k=math.nan,
        predicted_served_degc=nan,
        predicted_curtailed_degc=nan,
    )


class PeriodStepper:
    """The IL event state of one building and the period it was last planned for.

    Parameters
    ----------
    config : the building's scenario (``[reserve]``, ``[estimation]``).
    c_matrix : (m, n) zone selection of the controller's model.
    """

    def __init__(self, config: ScenarioConfig, c_matrix: FloatArray) -> None:
        self.tracker = event_tracker(config)
        self.c_matrix = c_matrix
        self.kalman = config.estimation.mode == "kalman"
        self.period = -1
        """The latest period planned (−1: none)."""
        self._before: dict[str, Any] | None = None
        """Controller and tracker state before ``period`` was planned."""

    def decide(
        self,
        controller: Controller,
        k: int,
        x_degc: FloatArray,
        forecast: Forecast,
        *,
        peak_floor_kw: float,
        activated: Callable[[int], bool],
    ) -> Decision:
        """Plan period ``k`` from the measured node temperatures (n,) [°C].

        ``activated(j)``: whether IL is activated in period j. Periods between the last one
        planned and ``k`` that nobody planned only advance the IL bookkeeping.

        Raises
        ------
        ConflictError : ``k`` is before the latest planned period.
        """
        if k < self.period:
            raise ConflictError(
                f"period {k} is before the building's latest planned period {self.period}",
                field="time",
                value=k,
                hint="plans go forward: post the measurement of the current period",
            )
        tracker = self.tracker
        if k == self.period and self._before is not None:  # re-plan the period from before it
            controller.set_state(self._before["controller"])
            tracker.set_state(self._before["events"])
        else:
            for j in range(self.period + 1, k):
                self._skip(activated(j))
        self._before = {"controller": controller.get_state(), "events": tracker.get_state()}
        self.period = k
        mpc = controller if isinstance(controller, MPCController) else None
        measured = self.c_matrix @ x_degc if self.kalman and mpc is not None else None
        role = tracker.role(activated(k))
        if role is Role.EVENT_LOCKED:
            action = tracker.locked_action()
            if mpc is not None:
                mpc.hold(forecast, action.flow_kg_s - action.reserve_flow_kg_s, measured)
        elif mpc is not None and measured is not None:
            action = mpc.act(
                x_degc,
                forecast,
                peak_floor_kw=peak_floor_kw,
                allowance_carry_steps=tracker.carry_steps,
                measured_zone_temp_degc=measured,
            )
        else:
            action = controller.act(
                x_degc,
                forecast,
                peak_floor_kw=peak_floor_kw,
                allowance_carry_steps=tracker.carry_steps,
            )
        if role is Role.EVENT_START:
            tracker.lock(action.event_plan)
        locked = None
        if tracker.locked is not None and role in (Role.EVENT_START, Role.EVENT_LOCKED):
            locked = (tracker.locked, tracker.plan_step)
        outcome = tracker.finish(role, action)
        applied = action.flow_kg_s - action.reserve_flow_kg_s if outcome.curtailed else None
        applied_flow = action.flow_kg_s if applied is None else applied
        if mpc is not None:
            mpc.note_applied_flow(applied_flow)
        return Decision(action, role, outcome, np.asarray(applied_flow, dtype=float), locked)

    def _skip(self, activated: bool) -> None:
        tracker = self.tracker
        role = tracker.role(activated)
        if role is Role.EVENT_LOCKED:
            action = tracker.locked_action()
        else:
            action = _unplanned(self.c_matrix.shape[0])
        if role is Role.EVENT_START:
            tracker.lock(None)
        tracker.finish(role, action)

    # -- the database's copy ----------------------------------------------------------------
    def get_state(self, controller: Controller) -> dict[str, Any]:
        """Picklable: the controller and tracker after the latest plan, and before it."""
        return {
            "period": self.period,
            "before": self._before,
            "controller": controller.get_state(),
            "events": self.tracker.get_state(),
        }

    def set_state(self, controller: Controller, state: dict[str, Any]) -> None:
        """Restore :meth:`get_state` (after a restart)."""
        self.period = int(state["period"])
        self._before = state["before"]
        controller.set_state(state["controller"])
        self.tracker.set_state(state["events"])


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
