"""ControlStep: the one place a period is decided (roles, hold/lock, replanning, state)."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from hvacflex import state
from hvacflex.config import preset, with_overrides
from hvacflex.control.base import Action, Controller, EventPlan, PeriodInputs, ReserveOffer
from hvacflex.control.meter_response import MIN_OFFSET_PERIODS
from hvacflex.sim.events import Role
from hvacflex.sim.step import ConflictError, ControlStep, DecisionStatus

ZONES = 2
STEPS = 6  # D + R of the product presets: 4 + 2


OCCUPIED = SimpleNamespace(occupied=np.ones(1, dtype=bool))
"""A stand-in forecast: the step reads only whether the period is occupied (the meter
history's rows, :mod:`hvacflex.control.meter_response`)."""


class CountingController(Controller):
    """Plans flows that grow with each call; records what the step asks of it."""

    def __init__(self) -> None:
        self.calls = 0
        self.holds: list[np.ndarray] = []
        self.applied: list[np.ndarray] = []
        self.inputs: list[PeriodInputs] = []

    def act(self, inputs: PeriodInputs) -> Action:
        if inputs.previous_flow_kg_s is not None:  # a filter's last step, as the plant ran it
            self.applied.append(np.asarray(inputs.previous_flow_kg_s))
        if inputs.locked is not None:  # a locked event period: nothing to decide
            self.holds.append(inputs.locked.applied_flow_kg_s(curtailed=True))
            return inputs.locked
        self.calls += 1
        self.inputs.append(inputs)
        flow = np.full((STEPS, ZONES), 1.0 + self.calls)
        event = EventPlan(
            flow_kg_s=flow,
            reserve_flow_kg_s=0.25 * flow,
            served_power_kw=np.full(STEPS, 10.0),
            reserve_kw=np.full(STEPS, 2.0),
            predicted_served_degc=np.full(flow.shape, 25.0),
            predicted_curtailed_degc=np.full(flow.shape, 25.5),
        )
        return Action(
            flow_kg_s=flow[0],
            reserve_flow_kg_s=0.25 * flow[0],
            reserve_kw=2.0,
            planned_power_kw=10.0,
            status="optimal",
            fallback=False,
            solve_time_s=0.0,
            planned_slack_max_k=0.0,
            delta_max_k=0.0,
            predicted_served_degc=np.full(ZONES, 25.0),
            predicted_curtailed_degc=np.full(ZONES, 25.5),
            event_plan=event,
        )

    def get_state(self) -> dict[str, Any]:
        return {"calls": self.calls}

    def set_state(self, state: dict[str, Any]) -> None:
        self.calls = int(state["calls"])


def _step(replannable: bool = False) -> tuple[ControlStep, CountingController]:
    controller = CountingController()
    config = preset("rmpc", start="2014-03-03", days=1.0)  # event model: D = 4, R = 2
    return ControlStep(config, controller, ZONES, replannable=replannable), controller


def _decide(step: ControlStep, k: int, active: set[int], measured: np.ndarray | None = None) -> Any:
    inputs = PeriodInputs(
        np.full(3, 25.0),
        OCCUPIED,  # type: ignore[arg-type]  # the counting controller never reads it
        peak_floor_kw=0.0,
        measured_zone_temp_degc=measured,
    )
    return step.decide(k, inputs, activated=lambda j: j in active)


def test_an_event_locks_the_start_plan_holds_and_curtails_then_resumes() -> None:
    step, controller = _step()
    active = {1, 2, 3, 4, 5, 6}  # longer than D = 4
    decisions = [_decide(step, k, active) for k in range(8)]
    roles = [d.role for d in decisions]
    assert roles[:6] == [
        Role.SERVED,
        Role.EVENT_START,
        Role.EVENT_LOCKED,
        Role.EVENT_LOCKED,
        Role.EVENT_LOCKED,
        Role.BEYOND_MODEL,
    ]
    # the locked periods ask nothing of the controller: it only holds, at u − r of the plan
    assert controller.calls == 8 - 3
    assert len(controller.holds) == 3
    np.testing.assert_allclose(controller.holds[0], 0.75 * 3.0)  # plan made at k = 1
    statuses = [d.status for d in decisions]
    assert statuses[2:5] == [DecisionStatus.LOCKED] * 3
    assert statuses[0] is DecisionStatus.PLANNED
    # curtailed periods run u − r, and the controller is told the flow that ran (with the
    # next period's inputs: every period's but the last)
    assert [d.outcome.curtailed for d in decisions[:6]] == [False, True, True, True, True, False]
    np.testing.assert_allclose(decisions[1].applied_flow_kg_s, 0.75 * 3.0)
    np.testing.assert_allclose(decisions[0].applied_flow_kg_s, 2.0)
    assert len(controller.applied) == 7
    for told, decision in zip(controller.applied, decisions, strict=False):
        np.testing.assert_array_equal(told, decision.applied_flow_kg_s)
    assert decisions[1].locked is not None and decisions[1].locked[1] == 0
    assert decisions[3].locked is not None and decisions[3].locked[1] == 2
    assert decisions[1].allowance_k > 0  # the event's allowance is in force


def test_measurements_reach_the_controller() -> None:
    step, controller = _step()
    reading = np.array([24.0, 26.0])
    _decide(step, 0, set(), measured=reading)
    np.testing.assert_array_equal(controller.inputs[0].measured_zone_temp_degc, reading)


def test_the_controller_gets_the_trackers_recovery_allowance_not_the_callers() -> None:
    step, controller = _step()
    active = {1, 2}  # a curtailed event of 2 periods; then the recovery of R = 2 periods
    for k in range(6):
        bogus = PeriodInputs(np.full(3, 25.0), OCCUPIED, 0.0, allowance_carry_steps=99)  # type: ignore[arg-type]
        step.decide(k, bogus, activated=lambda j: j in active)
    # period 2 is locked (no act); period 3 plans with both recovery periods ahead, 4 with one
    asked = [inputs.allowance_carry_steps for inputs in controller.inputs]
    assert asked == [0, 0, 2, 1, 0]


def test_a_replannable_step_decides_a_period_again_from_before_it() -> None:
    step, controller = _step(replannable=True)
    first = _decide(step, 0, set())
    again = _decide(step, 0, set())  # e.g. the measurement after the boundary plan
    np.testing.assert_array_equal(first.action.flow_kg_s, again.action.flow_kg_s)
    assert controller.calls == 1  # restored to before period 0, then decided once more
    with pytest.raises(ConflictError, match="before the building's latest planned period"):
        _decide(step, -1, set())


class FilteringController(CountingController):
    """... whose state holds the flows it was told (a filter's last step)."""

    def get_state(self) -> dict[str, Any]:
        return {"calls": self.calls, "applied": list(self.applied)}

    def set_state(self, state: dict[str, Any]) -> None:
        self.calls = int(state["calls"])
        self.applied = list(state["applied"])


def test_a_delivered_flow_posted_with_the_next_period_reaches_the_filter_of_its_step() -> None:
    """The plant's delivered input of k − 1 arrives with k's inputs (the closed loop's
    history and the service's measurement alike), replaces the decided flow as the filter's
    last step, and is kept for a decision of k again."""
    controller = FilteringController()
    config = preset("rmpc", start="2014-03-03", days=1.0)  # fixed linearisation
    step = ControlStep(config, controller, ZONES, replannable=True)
    delivered = np.array([0.3, 0.4])
    inputs = PeriodInputs(np.full(3, 25.0), OCCUPIED, 0.0)  # type: ignore[arg-type]
    with_delivered = replace(inputs, delivered_flow_kg_s=delivered)
    step.decide(0, inputs, activated=lambda j: False)
    step.decide(1, with_delivered, activated=lambda j: False)
    np.testing.assert_array_equal(controller.applied[-1], delivered)
    step.decide(1, inputs, activated=lambda j: False)  # decided again: kept
    np.testing.assert_array_equal(controller.applied[-1], delivered)
    # a period skipped: the flow is not the controller's last step's, and is dropped
    skipped = replace(inputs, delivered_flow_kg_s=delivered + 1)
    step.decide(3, skipped, activated=lambda j: False)
    assert not any(np.array_equal(flow, delivered + 1) for flow in controller.applied)
    # a re-linearised controller's filter has another operating point: not told
    relinearised = FilteringController()
    trajectory = ControlStep(preset("rmpc-output-feedback"), relinearised, ZONES)
    trajectory.decide(0, inputs, activated=lambda j: False)
    trajectory.decide(1, with_delivered, activated=lambda j: False)
    assert not any(np.array_equal(f, delivered) for f in relinearised.applied)


def test_periods_nobody_decided_advance_the_event_bookkeeping() -> None:
    step, controller = _step()
    _decide(step, 0, {1, 2})
    later = _decide(step, 3, {1, 2})  # periods 1–2 (an event) were never decided
    assert controller.calls == 2
    assert later.role is Role.SERVED


def test_the_state_is_data_and_resumes_identically() -> None:
    whole, _ = _step()
    active = {2, 3, 4}
    expected = [_decide(whole, k, active) for k in range(7)]
    split, _ = _step()
    for k in range(3):  # stop inside the event
        _decide(split, k, active)
    blob = state.encode(split.get_state())
    resumed, _ = _step()
    resumed.set_state(state.decode(blob))
    for k in range(3, 7):
        got = _decide(resumed, k, active)
        assert got.role is expected[k].role
        np.testing.assert_array_equal(got.applied_flow_kg_s, expected[k].applied_flow_kg_s)
    with pytest.raises(Exception, match="not the state of a control step"):
        resumed.set_state({"kind": "something else"})


class CommittingController(CountingController):
    """Commits g = 2 periods ahead like the MPC: plans with the noted commitments fixed,
    offers 1 + (its call count) kW for the period g ahead."""

    commit = 2

    commits_ahead = commit

    def __init__(self) -> None:
        super().__init__()
        self.noted = np.full((0, ZONES), np.nan)

    def act(self, inputs: PeriodInputs) -> Action:
        if inputs.locked is not None:
            return super().act(inputs)
        assert inputs.committed_reserve_kg_s is not None
        self.noted = np.array(inputs.committed_reserve_kg_s, dtype=float)
        action = super().act(inputs)
        assert action.event_plan is not None
        plan = action.event_plan
        reserve = np.array(plan.reserve_flow_kg_s)
        reserve[: self.commit] = self.noted  # the LP keeps the committed flows
        offered = np.full(ZONES, 0.1 * self.calls)
        reserve[self.commit] = offered
        event = replace(plan, reserve_flow_kg_s=reserve)
        return replace(
            action,
            reserve_flow_kg_s=reserve[0],
            event_plan=event,
            offer_ahead=ReserveOffer(flow_kg_s=offered, reserve_kw=1.0 + self.calls),
        )


def test_reserve_is_committed_g_periods_ahead_and_every_event_period_curtails() -> None:
    controller = CommittingController()
    config = preset("rmpc", start="2014-03-03", days=1.0)
    step = ControlStep(config, controller, ZONES)
    assert step.commit_ahead == 2
    # in the inputs before any decision (a fleet builds its first problem before deciding)
    first = step.prepared(PeriodInputs(np.full(3, 25.0), OCCUPIED, 0.0))  # type: ignore[arg-type]
    np.testing.assert_array_equal(first.committed_reserve_kg_s, np.zeros((2, ZONES)))
    active = {4, 5, 6}  # a 3-period activation
    decisions = [_decide(step, k, active) for k in range(9)]
    kw = [d.action.reserve_kw for d in decisions]
    # nothing committed for the first g periods; then the offer of period k − 2 (its call
    # count was k − 1): periods 2 … 5 were committed by fresh plans (calls 1 … 4)
    assert kw[:6] == [0.0, 0.0, 2.0, 3.0, 4.0, 5.0]
    # period 6 by the plan made as the event started (call 5); periods 7, 8 by the locked
    # plan's steps 1 + g, 2 + g (2 kW each), not by a new decision
    assert kw[6:] == [6.0, 2.0, 2.0]
    roles = [d.role for d in decisions[4:7]]
    assert roles == [Role.EVENT_START, Role.EVENT_LOCKED, Role.EVENT_LOCKED]
    # every period of the activation curtails the flow committed for it
    assert [d.outcome.curtailed for d in decisions[3:8]] == [False, True, True, True, False]
    plan_flow = 1.0 + 5  # the locked plan was made at call 5
    np.testing.assert_allclose(decisions[4].applied_flow_kg_s, plan_flow - 0.1 * 3)
    np.testing.assert_allclose(decisions[5].applied_flow_kg_s, plan_flow - 0.1 * 4)
    np.testing.assert_allclose(decisions[6].applied_flow_kg_s, plan_flow - 0.1 * 5)
    # after the event the controller plans again (calls 6, 7), the last with the next g
    # periods' commitments: those its own plans offered (period 8's by the locked plan)
    assert controller.calls == 7
    np.testing.assert_allclose(controller.noted[:, 0], [1.5, 0.6])
    after = step.prepared(PeriodInputs(np.full(3, 25.0), OCCUPIED, 0.0))  # type: ignore[arg-type]
    assert after.committed_reserve_kg_s is not None
    np.testing.assert_allclose(after.committed_reserve_kg_s[:, 0], [0.6, 0.7])


def test_commitments_survive_the_state_round_trip() -> None:
    controller = CommittingController()
    config = preset("rmpc", start="2014-03-03", days=1.0)
    step = ControlStep(config, controller, ZONES)
    for k in range(3):
        _decide(step, k, set())
    saved = state.decode(state.encode(step.get_state()))
    other = ControlStep(config, CommittingController(), ZONES)
    other.set_state(saved)
    np.testing.assert_array_equal(other.committed_kw, step.committed_kw)
    np.testing.assert_array_equal(other.committed_flow_kg_s, step.committed_flow_kg_s)
    assert [_decide(s, 3, set()).action.reserve_kw for s in (step, other)] == [3.0, 3.0]


class MeteredController(CountingController):
    """... whose plan's power moves from period to period, which keeps the meter ratios it is
    told, and whose offers (the one committed g ahead, the event plan's) say the ρ they were
    sized with."""

    commits_ahead = 2

    def __init__(self) -> None:
        super().__init__()
        self.ratios: list[float] = []

    def act(self, inputs: PeriodInputs) -> Action:
        if inputs.locked is not None:
            return super().act(inputs)
        self.ratios.append(inputs.meter_ratio)
        action = super().act(inputs)
        ratio = self.ratios[-1] if self.ratios else math.nan
        assert action.event_plan is not None
        return replace(
            action,
            planned_power_kw=planned_kw(self.calls),
            offer_ahead=ReserveOffer(np.zeros(ZONES), 1.0, meter_ratio=ratio),
            event_plan=replace(action.event_plan, meter_ratio=ratio),
        )


def planned_kw(call: int) -> float:
    """The plan's power of the controller's ``call``-th decision [kW]."""
    return 20.0 + 4.0 * math.sin(call / 2.0) + (call % 3)


def test_the_meter_s_response_to_the_plan_reaches_the_controller() -> None:
    """The meter moves 0.6 kW per kW of the plan (2 kW below it besides): once enough served
    periods were metered the controller is told ρ = 0.6. The periods of an event and its
    recovery (curtailed, locked, widened band) are no evidence: their meter reads 5 kW less,
    which leaves ρ unchanged. Each period's ``offer_meter_ratio`` is the ρ its paid offer was
    sized with: the decision g = 2 periods before, or the locked plan's. A replannable step
    restores the history."""
    controller = MeteredController()
    config = preset("rmpc", start="2014-03-03", days=1.0)  # event model, calibrated offers
    step = ControlStep(config, controller, ZONES, replannable=True)
    assert step.commit_ahead == 2
    active = {30, 31, 32}  # an event of D − 1 periods, then R = 2 recovery periods
    inputs = PeriodInputs(np.full(3, 25.0), OCCUPIED, 0.0)  # type: ignore[arg-type]
    meter_kw: list[float] = []
    told: dict[int, float] = {}
    decisions = []
    for k in range(45):
        previous = meter_kw[-1] if meter_kw else None
        asked = len(controller.ratios)
        metered = replace(inputs, previous_power_kw=previous)
        decision = step.decide(k, metered, activated=lambda j: j in active)
        if len(controller.ratios) > asked:
            told[k] = controller.ratios[-1]
        if k == 40:  # decided again from before it: the same history, the same ρ
            step.decide(k, metered, activated=lambda j: j in active)
            assert controller.ratios[-1] == told[k]
        decisions.append(decision)
        plan = decision.action.planned_power_kw
        meter_kw.append(2.0 + 0.6 * plan - (5.0 if decision.outcome.curtailed else 0.0))
    assert told[0] == 1.0  # no history yet: the model's own scale
    assert told[29] == pytest.approx(0.6)
    assert 31 not in told and 32 not in told  # locked: nobody decides
    assert told[44] == pytest.approx(0.6)  # the event's meter left out
    ratio = [d.action.offer_meter_ratio for d in decisions]
    assert math.isnan(ratio[0]) and math.isnan(ratio[1])  # nothing committed before the run
    assert ratio[29] == told[27]
    assert ratio[33] == told[30]  # committed at 31 from the plan locked at 30
    off = ControlStep(
        with_overrides(config, {"reserve.meter_calibrated_offers": False}),
        MeteredController(),
        ZONES,
    )
    for k in range(4):
        metered = replace(inputs, previous_power_kw=20.0)
        action = off.decide(k, metered, activated=lambda j: False).action
        assert math.isnan(action.offer_meter_ratio)


class LevelledController(CountingController):
    """... whose model plans 30 kW a period and adds the meter's offset it is told, as the
    MPC's LP does under ``power_level = "meter"``."""

    def __init__(self) -> None:
        super().__init__()
        self.offsets: list[float] = []

    def act(self, inputs: PeriodInputs) -> Action:
        offset = inputs.meter_offset_kw
        self.offsets.append(0.0 if offset is None else float(offset[0]))
        action = super().act(inputs)
        return replace(action, planned_power_kw=30.0 + self.offsets[-1])


def test_the_meter_s_offset_reaches_a_levelled_controller_and_stays_put() -> None:
    """The meter reads 6 kW below the model (EnergyPlus's loops delivering less air than the
    plan): after MIN_OFFSET_PERIODS served periods the controller is told −6 kW, and it stays
    −6 (the history keeps the model's own power, not the levelled plan's, so the offset does
    not feed back on itself). Without ``power_level = "meter"`` it is never told one."""
    config = with_overrides(
        preset("rmpc", start="2014-03-03", days=1.0),
        {"controller.power_level": "meter", "reserve.meter_calibrated_offers": False},
    )
    controller = LevelledController()
    step = ControlStep(config, controller, ZONES)
    assert step.tracks_meter
    inputs = PeriodInputs(np.full(3, 25.0), OCCUPIED, 0.0)  # type: ignore[arg-type]
    meter_kw: list[float] = []
    for k in range(30):
        previous = meter_kw[-1] if meter_kw else None
        decision = step.decide(
            k, replace(inputs, previous_power_kw=previous), activated=set().__contains__
        )
        meter_kw.append(decision.action.planned_power_kw - controller.offsets[-1] - 6.0)
    assert controller.offsets[0] == 0.0  # no history yet
    assert controller.offsets[MIN_OFFSET_PERIODS + 1] == pytest.approx(-6.0)
    assert controller.offsets[-1] == pytest.approx(-6.0)
    plain = ControlStep(
        with_overrides(config, {"controller.power_level": "model"}), LevelledController(), ZONES
    )
    for k in range(12):
        action = plain.decide(
            k, replace(inputs, previous_power_kw=20.0), activated=set().__contains__
        ).action
        assert action.planned_power_kw == 30.0


def test_auto_levels_the_power_to_the_meter_on_an_energyplus_plant_only() -> None:
    config = preset("rmpc", start="2014-03-03", days=1.0)
    assert config.controller.power_level == "auto"
    assert not ControlStep(config, LevelledController(), ZONES).meter_levelled
    on_energyplus = with_overrides(config, {"plant.kind": "energyplus", "plant.idf": "generated"})
    assert ControlStep(on_energyplus, LevelledController(), ZONES).meter_levelled
    model = with_overrides(on_energyplus, {"controller.power_level": "model"})
    assert not ControlStep(model, LevelledController(), ZONES).meter_levelled
