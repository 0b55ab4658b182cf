"""The one place where a period is decided: :class:`ControlStep`.

Every driver — the closed loop (:mod:`hvacflex.sim.closed_loop`), the live service
(:mod:`hvacflex.service.runtime`) and a fleet's building agents (:mod:`hvacflex.fleet.agent`) —
decides a period through :meth:`ControlStep.decide`, which owns the controller, the IL event
tracker (:class:`hvacflex.sim.events.EventTracker`, ``docs/explanation/il_events.md``), the lock
rules and the plan's side of the history (commitments, ρ, the filter's input):

1. the period's IL role from the activation signal (served, curtail the fresh plan, an event
   starts, an event continues, beyond the model);
2. every period asks the controller once, with the period's complete
   :class:`~hvacflex.control.base.PeriodInputs` (the driver's part from its
   :class:`~hvacflex.sim.history.PeriodHistory`, the step's part laid over it by
   :meth:`ControlStep.prepared`); a locked event period hands the locked plan's step as
   ``inputs.locked``, which the controller returns without deciding (a filter still
   measures); ``plan``: a plan decided elsewhere, the fleet coordinator's, applied as the
   solver's;
3. an event start locks the plan just made;
4. the tracker settles the period (curtailed?, allowance, reference power); the flow the
   plant will run (or, where the driver reports it, what the air delivered) is the input
   of the controller's filter, handed with the next period's inputs;
5. **market timing** (a controller with ``commits_ahead`` = g > 0, the MPC under the event
   model): the reserve of period k was committed at k − g. The step keeps the commitments
   of the next g periods (flows and kW), hands them to the controller (which plans with them
   fixed), pays the period what was committed for it (``reserve_kw``), and commits the offer for
   k + g: the fresh plan's ``Action.offer_ahead``, or, in a locked event period j, the
   locked plan's step j + g (what the building will run anyway). Nothing planned (a
   fallback, a skipped period) commits nothing.
6. **the meter's response** (the event model with reserve offered, ``[reserve]
   meter_calibrated_offers``): the step keeps the plan's and the meter's power of the recent
   periods (:attr:`ControlStep.meter`, the meter of k − 1 arriving with k) and hands the
   controller ρ in the period's inputs (:mod:`hvacflex.control.meter_response`); the period's
   ``Action.offer_meter_ratio`` is the ρ its paid ``reserve_kw`` was sized with.

A period may be decided more than once (the service: a boundary plan, then the
measurement; an activation during the period). With ``replannable=True`` each decision of a
period starts from the controller and tracker state *before* the period, which
:meth:`ControlStep.get_state` stores, so a restarted service re-plans exactly as the
running one would. Periods nobody decided (a building that posted nothing) only advance the
IL bookkeeping.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from hvacflex.config import ScenarioConfig
from hvacflex.constants import PERIODS_PER_DAY
from hvacflex.control.base import (
    Action,
    Controller,
    EventPlan,
    FloatArray,
    PeriodInputs,
    ReserveOffer,
    WarmRestart,
)
from hvacflex.control.meter_response import MeterHistory, period_classes
from hvacflex.errors import InputError
from hvacflex.sim.events import EventTracker, PeriodOutcome, Role

STATE_KIND = "control-step"
"""Tag of a :meth:`ControlStep.get_state` (inside the versioned :mod:`hvacflex.state`)."""


class ConflictError(InputError):
    """The request contradicts what is stored (e.g. a different measurement for a period,
    or a period before the building's latest planned one: plans only go forward)."""


class DecisionStatus(enum.Enum):
    """How a period's action came about."""

    PLANNED = "planned"
    """The controller's optimal plan (an MPC)."""
    RULE = "rule"
    """A rule-based controller decided."""
    FALLBACK = "fallback"
    """The plan could not be used; a safe rule decided (solver failure, capped plan)."""
    LOCKED = "locked"
    """A locked IL event plan's step: no decision was made."""


@dataclass(frozen=True)
class Decision:
    """What the building runs in one period.

    Attributes
    ----------
    action : the plan's first step (u₀, r₀, …), or the locked event plan's step j.
    status : how the action came about.
    role : the period's IL role.
    outcome : the period's IL columns (curtailed, beyond model, allowance α in force,
        reference power).
    applied_flow_kg_s : (m,) the flow to run [kg/s]: u − r when curtailed, else u.
    plan : the optimal plan over the horizon made this period (an ``RMPCSolution``), or None
        (a rule, a fallback, a locked period).
    locked : the locked event plan and the period's index in it when the period belongs to
        it (an event's start or continuation), else None.
    """

    action: Action
    status: DecisionStatus
    role: Role
    outcome: PeriodOutcome
    applied_flow_kg_s: FloatArray
    plan: Any
    locked: tuple[EventPlan, int] | None

    @property
    def allowance_k(self) -> float:
        """α in force this period [K] (0 outside an event and its recovery)."""
        return float(self.outcome.allowance_k)


def event_tracker(config: ScenarioConfig) -> EventTracker:
    """The tracker of ``config``'s reserve model."""
    reserve = config.reserve
    events = reserve.event_max_steps is not None
    return EventTracker(
        reserve.event_max_steps,
        reserve.event_recovery_steps if events else 0,
        reserve.event_allowance_k if events else 0.0,
    )


def _classes(inputs: PeriodInputs) -> np.ndarray:
    """(N,) the forecast's periods' classes for the meter's offsets (occupied, pull-down,
    idle: :func:`hvacflex.control.meter_response.period_classes`)."""
    occupied = inputs.forecast.occupied
    return period_classes(occupied, len(occupied))


def _unplanned(zones: int) -> Action:
    """The action of a period nobody planned (only its IL bookkeeping is advanced)."""
    nan = np.full(zones, math.nan)
    zero = np.zeros(zones)
    return Action.unoptimised(nan, zero, math.nan, nan, nan, status="not-planned", fallback=True)


class ControlStep:
    """A building's controller and IL event state, deciding one period at a time.

    Parameters
    ----------
    config : the building's scenario (``[reserve]``: the event model).
    controller : the controller (any :class:`~hvacflex.control.base.Controller`).
    zones : m, the number of zones.
    replannable : keep the state before each period so the period can be decided again
        (the service); the closed loop and the fleet decide each period once.
    """

    def __init__(
        self,
        config: ScenarioConfig,
        controller: Controller,
        zones: int,
        *,
        replannable: bool = False,
    ) -> None:
        self.controller = controller
        self.tracker = event_tracker(config)
        self.zones = zones
        self.replannable = replannable
        self.filter_takes_delivered = config.controller.linearisation in ("fixed", "plan")
        """Whether the plant's delivered input reaches the controller's filter: its input is
        the fixed model's (or, under ``"plan"``, the same ṁ_ref's with B scaled); a model
        re-linearised about the plan's flow has another operating point."""
        self.period = -1
        """The latest period decided (−1: none)."""
        reserve = config.reserve
        calibrated = (
            reserve.event_max_steps is not None
            and reserve.meter_calibrated_offers
            and config.controller.reserve
        )
        self.meter_max_lag_steps = reserve.event_max_steps if calibrated else 0
        """D: the meter's response is measured over lags 1 … D [periods] (the event model's
        longest event); 0: offers are not scaled (no reserve offered, the whole-horizon
        model, or ``meter_calibrated_offers`` off)."""
        level = config.controller.power_level
        self.meter_levelled = level == "meter" or (
            level == "auto" and config.plant.kind == "energyplus"
        )
        """Whether the plan's power is levelled to the meter (``[controller] power_level``:
        ``"auto"`` levels it on an EnergyPlus plant)."""
        self.tracks_meter = bool(self.meter_max_lag_steps) or self.meter_levelled
        """Whether the meter history is kept (for ρ, or for the meter's offset)."""
        self.meter = MeterHistory()
        """The plan's and the meter's power of the recent periods
        (:mod:`hvacflex.control.meter_response`): the model's own power, without the meter's
        offset."""
        self._before: dict[str, Any] | None = None
        self.commit_ahead = int(controller.commits_ahead)
        """g: periods ahead that reserve is committed (0: decided at each period's start)."""
        self.committed_flow_kg_s = np.zeros((self.commit_ahead, zones))
        """(g, m) reserve flows committed for the next g periods, the coming one first."""
        self.committed_kw = np.zeros(self.commit_ahead)
        """(g,) reserve capacity committed (and paid) for the next g periods [kW]."""
        self.committed_meter_ratio = np.full(self.commit_ahead, math.nan)
        """(g,) ρ each commitment was sized with (NaN: not scaled)."""
        self._filter_flow_kg_s: FloatArray | None = None
        """(m,) the input of the controller's filter in the latest decided period: the flow
        the plant ran, or what the air delivered (the driver's report, under the fixed
        linearisation only: :attr:`filter_takes_delivered`); None before the first."""

    @property
    def takes_measurements(self) -> bool:
        """True when :meth:`decide` needs ``measured_zone_temp_degc``."""
        return bool(self.controller.takes_measurements)

    @property
    def allowance_carry_steps(self) -> int:
        """Periods from now that still belong to the recovery of the last event."""
        return self.tracker.carry_steps

    def prepared(self, inputs: PeriodInputs) -> PeriodInputs:
        """``inputs`` (the driver's part, :func:`hvacflex.sim.history.period_inputs`) with
        the step's part laid over: the recovery carried from an event, the commitments of
        the coming g periods, ρ and the filter's input of the period before. Reads the
        step's state only (a fleet's building builds its coordination problem from it
        before the period is decided)."""
        ratio = math.nan
        if self.meter_max_lag_steps:
            ratio = self.meter.ratio(self.meter_max_lag_steps)
        return replace(
            inputs,
            allowance_carry_steps=self.tracker.carry_steps,
            committed_reserve_kg_s=self.committed_flow_kg_s if self.commit_ahead else None,
            meter_ratio=ratio,
            meter_offset_kw=(
                self.meter.offsets_kw(
                    len(inputs.forecast.occupied), PERIODS_PER_DAY, _classes(inputs)
                )
                if self.meter_levelled
                else None
            ),
            previous_flow_kg_s=self._filter_flow_kg_s,
        )

    def decide(self, k: int, inputs: PeriodInputs, *, activated: Callable[[int], bool]) -> Decision:
        """Decide period ``k``.

        Parameters
        ----------
        k : the period (steps from the scenario's start).
        inputs : the driver's inputs of the period (:func:`hvacflex.sim.history.
            period_inputs`: the state, the forecast from ``k`` with signals applied, the
            peak floor, zone-air readings for a controller with a filter, the settlement
            baselines, the meter and the plant's delivered input of k − 1, a plan decided
            elsewhere); the step lays its own part over them (:meth:`prepared`), whatever
            the caller put there. The delivered input is taken only when k − 1 is the
            latest decided period (a skipped period's plant input is not the filter's last
            step), and kept for a decision of k again.
        activated : whether IL is activated in period j.

        Raises
        ------
        ConflictError : ``k`` is before the latest decided period.
        """
        self._start_period(k, activated, inputs.delivered_flow_kg_s)
        controller, tracker = self.controller, self.tracker
        if self.tracks_meter:
            self.meter.advance(k, inputs.previous_power_kw)
        role = tracker.role(activated(k))
        inputs = self.prepared(inputs)
        if role is Role.EVENT_LOCKED:  # the locked plan runs, whatever the controller says
            locked_action = tracker.locked_action()
            held = controller.act(replace(inputs, locked=locked_action))
            action = replace(locked_action, step_model=held.step_model)
        else:
            action = controller.act(inputs)
        if role is Role.EVENT_START:
            tracker.lock(action.event_plan)
        action = self._commit(action, locked_period=role is Role.EVENT_LOCKED)
        locked = None
        if tracker.locked is not None and role in (Role.EVENT_START, Role.EVENT_LOCKED):
            locked = (tracker.locked, tracker.plan_step)
        outcome = tracker.finish(role, action)
        applied_flow = action.applied_flow_kg_s(curtailed=outcome.curtailed)
        self._filter_flow_kg_s = applied_flow
        status = decision_status(role, action)
        if self.tracks_meter:
            usable = (  # served by a fresh plan, outside events and recoveries
                status is DecisionStatus.PLANNED
                and not outcome.curtailed
                and not outcome.event_window
            )
            offset = 0.0 if inputs.meter_offset_kw is None else float(inputs.meter_offset_kw[0])
            model_kw = action.planned_power_kw - offset  # the model's own
            self.meter.open(k, model_kw if usable else math.nan, int(_classes(inputs)[0]))
        made = action.plan if status is DecisionStatus.PLANNED else None
        return Decision(action, status, role, outcome, applied_flow, made, locked)

    def _start_period(
        self, k: int, activated: Callable[[int], bool], delivered_flow_kg_s: FloatArray | None
    ) -> None:
        if k < self.period:
            raise ConflictError(
                f"period {k} is before the building's latest planned period {self.period}",
                field="time",
                value=k,
                hint="plans go forward: post the measurement of the current period",
            )
        before = self._before if k == self.period else None
        if before is not None:  # decide again from before it
            self.controller.set_state(before["controller"])
            self.tracker.set_state(before["events"])
            self._set_commitments(before.get("commitments"))
            self._set_meter(before.get("meter"))
            self._filter_flow_kg_s = before.get("filter_flow_kg_s")
        else:
            for j in range(self.period + 1, k):
                self._skip(activated(j))
        taken = before is not None or k == self.period + 1
        if delivered_flow_kg_s is not None and taken and self.filter_takes_delivered:
            self._filter_flow_kg_s = np.asarray(delivered_flow_kg_s, dtype=float)
        if self.replannable:
            self._before = {
                "controller": self.controller.get_state(),
                "events": self.tracker.get_state(),
                "commitments": self._commitments(),
                "meter": self.meter.get_state(),
                "filter_flow_kg_s": self._filter_flow_kg_s,
            }
        self.period = k

    def _skip(self, activated: bool) -> None:
        tracker = self.tracker
        role = tracker.role(activated)
        action = tracker.locked_action() if role is Role.EVENT_LOCKED else _unplanned(self.zones)
        if role is Role.EVENT_START:
            tracker.lock(None)
        action = self._commit(action, locked_period=role is Role.EVENT_LOCKED)
        tracker.finish(role, action)

    def _commit(self, action: Action, *, locked_period: bool) -> Action:
        """The period's action paid what was committed for it; the commitments moved on by
        one period with the offer for k + g (see the module docstring, item 5)."""
        g = self.commit_ahead
        if not g:
            return action
        offer = action.offer_ahead
        if locked_period:
            plan, j = self.tracker.locked, self.tracker.plan_step
            ahead = j + g
            offer = None
            if plan is not None and 0 <= ahead < plan.steps:
                offer = ReserveOffer(
                    flow_kg_s=np.asarray(plan.reserve_flow_kg_s[ahead], dtype=float),
                    reserve_kw=float(plan.reserve_kw[ahead]),
                    meter_ratio=plan.meter_ratio,
                )
        committed_kw = float(self.committed_kw[0])
        committed_ratio = float(self.committed_meter_ratio[0])
        new_flow = np.zeros(self.zones) if offer is None else offer.flow_kg_s
        new_kw = 0.0 if offer is None else offer.reserve_kw
        new_ratio = math.nan if offer is None else offer.meter_ratio
        self.committed_flow_kg_s = np.vstack([self.committed_flow_kg_s[1:], new_flow[None]])
        self.committed_kw = np.append(self.committed_kw[1:], new_kw)
        self.committed_meter_ratio = np.append(self.committed_meter_ratio[1:], new_ratio)
        return replace(action, reserve_kw=committed_kw, offer_meter_ratio=committed_ratio)

    def restart_warm(self) -> None:
        """Continue as if resumed from :meth:`get_state` (see
        :class:`hvacflex.control.base.WarmRestart`)."""
        if isinstance(self.controller, WarmRestart):
            self.controller.restart_warm()

    # -- the one checkpoint format ----------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        """Data only (:mod:`hvacflex.state`): the controller and tracker after the latest
        decision, and before it (``replannable``)."""
        return {
            "kind": STATE_KIND,
            "period": self.period,
            "before": self._before,
            "controller": self.controller.get_state(),
            "events": self.tracker.get_state(),
            "commitments": self._commitments(),
            "meter": self.meter.get_state(),
            "filter_flow_kg_s": self._filter_flow_kg_s,
        }

    def _set_meter(self, state: dict[str, Any] | None) -> None:
        """Restore the meter history (a state from before it was kept: an empty one)."""
        self.meter = MeterHistory()
        if state is not None:
            self.meter.set_state(state)

    def _commitments(self) -> dict[str, Any]:
        return {
            "flow_kg_s": self.committed_flow_kg_s.copy(),
            "kw": self.committed_kw.copy(),
            "meter_ratio": self.committed_meter_ratio.copy(),
        }

    def _set_commitments(self, state: dict[str, Any] | None) -> None:
        g = self.commit_ahead
        ratio = np.full(g, math.nan)
        if state is None:
            flow, kw = np.zeros((g, self.zones)), np.zeros(g)
        else:
            flow = np.asarray(state["flow_kg_s"], dtype=float).reshape(g, self.zones)
            kw = np.asarray(state["kw"], dtype=float).reshape(g)
            if state.get("meter_ratio") is not None:  # kept since 2026-12-05
                ratio = np.asarray(state["meter_ratio"], dtype=float).reshape(g)
        self.committed_flow_kg_s, self.committed_kw = flow.copy(), kw.copy()
        self.committed_meter_ratio = ratio.copy()

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`get_state`."""
        if state.get("kind") != STATE_KIND:
            raise InputError(
                "not the state of a control step",
                field="kind",
                value=state.get("kind"),
                hint="start afresh",
            )
        self.period = int(state["period"])
        self._before = state["before"]
        self.controller.set_state(state["controller"])
        self.tracker.set_state(state["events"])
        self._set_commitments(state.get("commitments"))
        self._set_meter(state.get("meter"))
        self._filter_flow_kg_s = state.get("filter_flow_kg_s")


def decision_status(role: Role, action: Action) -> DecisionStatus:
    """How ``action`` came about in a period of IL role ``role``."""
    if role is Role.EVENT_LOCKED:
        return DecisionStatus.LOCKED
    if action.fallback:
        return DecisionStatus.FALLBACK
    if action.status == "rule":
        return DecisionStatus.RULE
    return DecisionStatus.PLANNED
