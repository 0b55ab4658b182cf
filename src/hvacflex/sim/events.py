"""Interruptible-load events in the closed loop: what the building does while activated.

Event model (``[reserve] event_max_steps`` = D set; ``docs/explanation/il_events.md``): when an
activation starts at step s, the building locks the plan made at s and applies its
curtailed flows u_j − r_j while the activation lasts, for at most D periods, without
re-optimising. After D periods it resumes consumption (the NEMS 120-min rule); activated
periods after that are **beyond the model** and counted. The allowance α is granted only to a
building that was actually curtailed (reserve offered, r > 0, in the event's periods): while
the event's plan runs, in full; when the curtailment ends, the R periods after it are the
event's recovery, whose allowance decays (α·R/(R+1), …, α/(R+1); the controller re-plans with
``allowance_carry_steps``). With no activation α is never granted. The locked plan's served
power p0_j + p_jᵀu_j is recorded (``il_reference_power_kw``) for the recovery-energy KPI;
delivery is settled against metered power (:mod:`hvacflex.settlement`).

Whole-horizon model (D = None, the paper's): every activated period curtails the fresh plan
of that period (u₀ − r₀), which the model keeps inside the strict band for any activation.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from hvacflex.control.base import Action, EventPlan


class Role(Enum):
    """What a period is for the IL contract."""

    SERVED = "served"
    """No activation: the plan's served flows u₀."""
    CURTAIL_FRESH = "curtail-fresh"
    """Whole-horizon model, activated: the fresh plan's u₀ − r₀."""
    EVENT_START = "event-start"
    """Event model, an activation starts: plan now, lock it, apply u₀ − r₀."""
    EVENT_LOCKED = "event-locked"
    """Event model, an activation continues (< D periods in): the locked plan's u_j − r_j."""
    BEYOND_MODEL = "beyond-model"
    """Event model, activated for more than D periods: consumption resumes (counted)."""


@dataclass
class PeriodOutcome:
    """The IL columns of one period (``results.parquet``)."""

    curtailed: bool
    beyond_model: bool
    event_window: bool
    allowance_k: float
    reference_power_kw: float


def recovery_allowance_k(allowance_k: float, recovery_left: int, recovery_steps: int) -> float:
    """The allowance in force at the end of a recovery period [K]: ``α · min(1, c / (R +
    1))`` with c the recovery periods left including this one — the plans' decaying
    allowance (:func:`hvacflex.opt.events.carry_allowance` at t = 1)."""
    return allowance_k * min(1.0, recovery_left / (recovery_steps + 1))


class EventTracker:
    """The IL event state of a closed-loop run (checkpointed with it).

    Parameters
    ----------
    max_steps : D [periods]; ``None`` = the whole-horizon model.
    recovery_steps : R [periods] after the curtailment.
    allowance_k : α [K] on the upper comfort bound during the event and its recovery.
    """

    def __init__(self, max_steps: int | None, recovery_steps: int, allowance_k: float) -> None:
        self.max_steps = max_steps
        self.recovery_steps = recovery_steps
        self.allowance_k = allowance_k
        self.locked: EventPlan | None = None
        self.age: int | None = None
        """Periods since the current activation started (None: not activated)."""
        self.plan_step = -1
        """Index of the current period in the locked plan (−1: none)."""
        self.recovery_left = 0
        """Recovery periods still to come after the last curtailment."""
        self._curtailed_last = False
        """The previous period ran an activation's plan (u − r, whatever r was)."""
        self._event_offered = False
        """The current activation has curtailed a period with reserve offered (r > 0)."""

    @property
    def event_model(self) -> bool:
        return self.max_steps is not None

    @property
    def carry_steps(self) -> int:
        """Recovery periods from now on that keep the allowance (for the next plan)."""
        return self.recovery_left if self.event_model else 0

    def role(self, activated: bool) -> Role:
        """Advance to a new period and say what it is (before the controller acts)."""
        age = None if not activated else (0 if self.age is None else self.age + 1)
        self.age = age
        if self.locked is not None:
            self.plan_step += 1
        if age is None:
            role = Role.SERVED
        elif self.max_steps is None:
            role = Role.CURTAIL_FRESH
        elif age == 0:
            role = Role.EVENT_START
        elif age >= self.max_steps:
            role = Role.BEYOND_MODEL
        else:
            role = Role.EVENT_LOCKED if self._curtailed_last else Role.SERVED
        if self._curtailed_last and role not in (Role.EVENT_LOCKED, Role.CURTAIL_FRESH):
            if self._event_offered:  # a real curtailment has just ended
                self.recovery_left = self.recovery_steps
            self._event_offered = False
        return role

    def lock(self, plan: EventPlan | None) -> None:
        """Lock the plan made as an event starts (``None``: no plan, nothing to curtail)."""
        self.locked = plan
        self.plan_step = 0 if plan is not None else -1

    def locked_action(self) -> Action:
        """The action of the current period taken from the locked plan (no optimisation)."""
        plan, j = self.locked, self.plan_step
        assert plan is not None and 0 <= j < plan.steps
        return Action.unoptimised(
            plan.flow_kg_s[j],
            plan.reserve_flow_kg_s[j],
            float(plan.served_power_kw[j]),
            plan.predicted_served_degc[j],
            plan.predicted_curtailed_degc[j],
            status="event-plan",
            reserve_kw=float(plan.reserve_kw[j]),
            offer_meter_ratio=plan.meter_ratio,
        )

    def finish(self, role: Role, action: Action) -> PeriodOutcome:
        """Close the period: whether it curtailed, the allowance in force, and its
        settlement reference.

        A period is **curtailed** when it runs an activation's u − r with reserve offered
        (r > 0); only then do the event window and the allowance α apply (a building that
        offered nothing is granted nothing). α is granted in full while the activation's
        plan runs, and in its recovery the decaying share of :func:`recovery_allowance_k`.
        """
        running = role in (Role.CURTAIL_FRESH, Role.EVENT_LOCKED) or (
            role is Role.EVENT_START and self.locked is not None
        )
        curtailed = running and bool(np.any(np.asarray(action.reserve_flow_kg_s) > 0.0))
        self._event_offered = self._event_offered or curtailed
        in_event = running and self._event_offered
        window = in_event or self.recovery_left > 0
        reference = float("nan")
        allowance = self.allowance_k if in_event else 0.0
        if running:
            reference = self._reference_power_kw(action)
        elif window:
            reference = self._reference_power_kw(None)
            allowance = recovery_allowance_k(
                self.allowance_k, self.recovery_left, self.recovery_steps
            )
            self.recovery_left -= 1
        if not window and self.age is None:
            self.locked, self.plan_step = None, -1
        if not running:
            self._event_offered = False
        self._curtailed_last = running
        return PeriodOutcome(
            curtailed=curtailed,
            beyond_model=role is Role.BEYOND_MODEL,
            event_window=window,
            allowance_k=allowance if self.event_model else 0.0,
            reference_power_kw=reference,
        )

    def _reference_power_kw(self, action: Action | None) -> float:
        """The locked plan's served power for this period (the fresh plan's when none)."""
        plan, j = self.locked, self.plan_step
        if plan is not None and 0 <= j < plan.steps:
            return float(plan.served_power_kw[j])
        return action.planned_power_kw if action is not None else float("nan")

    def get_state(self) -> dict[str, object]:
        return {
            "locked": self.locked,
            "age": self.age,
            "plan_step": self.plan_step,
            "recovery_left": self.recovery_left,
            "curtailed_last": self._curtailed_last,
            "event_offered": self._event_offered,
        }

    def set_state(self, state: dict[str, object]) -> None:
        locked = state["locked"]
        self.locked = locked if isinstance(locked, EventPlan) else None
        age = state["age"]
        self.age = int(age) if isinstance(age, int | np.integer) else None
        self.plan_step = int(state["plan_step"])  # type: ignore[call-overload]
        self.recovery_left = int(state["recovery_left"])  # type: ignore[call-overload]
        self._curtailed_last = bool(state["curtailed_last"])
        self._event_offered = bool(state.get("event_offered", False))
