"""IL events in the closed loop: the tracker's state machine and a stub-controller loop."""

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from hvacflex import state as hvacflex_state
from hvacflex.config import preset, with_overrides
from hvacflex.control.base import Action, Controller, EventPlan, PeriodInputs
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.events import EventTracker, Role
from hvacflex.sim.run import run_simulation
from hvacflex.sim.run_files import CONFIG_FILE
from hvacflex.sim.setup import prepare

START = "2014-03-03"


def _plan(powers: list[float], m: int = 1) -> EventPlan:
    steps = len(powers)
    return EventPlan(
        flow_kg_s=np.full((steps, m), 1.0),
        reserve_flow_kg_s=np.full((steps, m), 0.2),
        served_power_kw=np.array(powers),
        reserve_kw=np.full(steps, 2.0),
        predicted_served_degc=np.full((steps, m), 25.0),
        predicted_curtailed_degc=np.full((steps, m), 25.5),
    )


def _action(plan: EventPlan | None, planned_kw: float = 7.0) -> Action:
    return Action(
        flow_kg_s=np.ones(1),
        reserve_flow_kg_s=np.full(1, 0.2),
        reserve_kw=2.0,
        planned_power_kw=planned_kw,
        status="optimal",
        fallback=False,
        solve_time_s=0.0,
        planned_slack_max_k=0.0,
        delta_max_k=0.0,
        predicted_served_degc=np.full(1, 25.0),
        predicted_curtailed_degc=np.full(1, 25.5),
        event_plan=plan,
    )


def test_event_locks_the_plan_for_d_periods_then_recovers_and_counts_beyond() -> None:
    tracker = EventTracker(max_steps=2, recovery_steps=1, allowance_k=1.0)
    schedule = [0, 1, 1, 1, 0, 0, 1, 0]
    plans = {1: _plan([10.0, 11.0, 12.0]), 6: None}
    roles, outcomes, carries = [], [], []
    for k, activated in enumerate(schedule):
        role = tracker.role(bool(activated))
        carries.append(tracker.carry_steps)
        action = tracker.locked_action() if role is Role.EVENT_LOCKED else _action(plans.get(k))
        if role is Role.EVENT_START:
            tracker.lock(action.event_plan)
        roles.append(role)
        outcomes.append(tracker.finish(role, action))
    assert roles == [
        Role.SERVED,
        Role.EVENT_START,
        Role.EVENT_LOCKED,
        Role.BEYOND_MODEL,  # the 120-min rule: consumption resumes after D periods
        Role.SERVED,
        Role.SERVED,
        Role.EVENT_START,  # no plan to lock: nothing curtailed
        Role.SERVED,
    ]
    assert [o.curtailed for o in outcomes] == [0, 1, 1, 0, 0, 0, 0, 0]
    assert [o.beyond_model for o in outcomes] == [0, 0, 0, 1, 0, 0, 0, 0]
    assert [o.event_window for o in outcomes] == [0, 1, 1, 1, 0, 0, 0, 0]
    # α in full while the plan curtails; in the recovery period (c = 1 of R = 1) α/2
    assert [o.allowance_k for o in outcomes] == [0, 1, 1, 0.5, 0, 0, 0, 0]
    refs = [o.reference_power_kw for o in outcomes]
    assert refs[1:4] == [10.0, 11.0, 12.0]  # the locked plan's served power, recovery incl.
    assert np.isnan([refs[0], *refs[4:]]).all()
    # the plan after the curtailment carries the allowance for the R recovery periods
    assert carries == [0, 0, 0, 1, 0, 0, 0, 0]


def test_an_event_with_nothing_offered_grants_no_allowance_and_no_recovery() -> None:
    tracker = EventTracker(max_steps=2, recovery_steps=2, allowance_k=1.0)
    empty = _plan([10.0, 11.0, 12.0])
    empty = EventPlan(**{**empty.__dict__, "reserve_flow_kg_s": np.zeros((3, 1))})
    outcomes, carries = [], []
    for activated in [1, 1, 0, 0]:
        role = tracker.role(bool(activated))
        carries.append(tracker.carry_steps)
        if role is Role.EVENT_LOCKED:
            action = tracker.locked_action()
        else:
            action = dataclasses.replace(_action(empty), reserve_flow_kg_s=np.zeros(1))
        if role is Role.EVENT_START:
            tracker.lock(action.event_plan)
        outcomes.append(tracker.finish(role, action))
    assert [o.curtailed for o in outcomes] == [0, 0, 0, 0]
    assert [o.event_window for o in outcomes] == [0, 0, 0, 0]
    assert [o.allowance_k for o in outcomes] == [0, 0, 0, 0]
    assert carries == [0, 0, 0, 0]


def test_recovery_allowance_decays_over_r_periods() -> None:
    tracker = EventTracker(max_steps=1, recovery_steps=2, allowance_k=1.5)
    allowances = []
    for activated in [1, 0, 0, 0]:
        role = tracker.role(bool(activated))
        action = _action(_plan([10.0, 11.0]))
        if role is Role.EVENT_START:
            tracker.lock(action.event_plan)
        allowances.append(tracker.finish(role, action).allowance_k)
    np.testing.assert_allclose(allowances, [1.5, 1.0, 0.5, 0.0])


def test_whole_horizon_model_curtails_every_activated_period_with_the_fresh_plan() -> None:
    tracker = EventTracker(max_steps=None, recovery_steps=0, allowance_k=0.0)
    outcomes = []
    for activated in (1, 1, 1, 0):
        role = tracker.role(bool(activated))
        outcomes.append(tracker.finish(role, _action(None, planned_kw=9.0)))
    assert [o.curtailed for o in outcomes] == [1, 1, 1, 0]
    assert [o.beyond_model for o in outcomes] == [0, 0, 0, 0]
    assert [o.reference_power_kw for o in outcomes[:3]] == [9.0, 9.0, 9.0]


class StubPlanner(Controller):
    """A state-dependent planner that offers reserve, for testing the loop without an LP
    (a locked event period's inputs carry the locked action, returned as it is)."""

    def __init__(self, flow_max: np.ndarray, steps: int) -> None:
        self.flow_max, self.steps, self.calls, self.carries = flow_max, steps, 0, []

    def act(self, inputs: PeriodInputs) -> Action:
        if inputs.locked is not None:
            return inputs.locked
        self.calls += 1
        self.carries.append(inputs.allowance_carry_steps)
        level = 0.4 + 0.02 * (float(np.mean(inputs.x_degc)) - 25.0)
        ramp = 1.0 + 0.05 * np.arange(self.steps)[:, None]
        flow = np.clip(level * ramp * self.flow_max, 0.0, self.flow_max)
        plan = EventPlan(
            flow_kg_s=flow,
            reserve_flow_kg_s=0.3 * flow,
            served_power_kw=10.0 + np.arange(self.steps),
            reserve_kw=np.full(self.steps, 3.0),
            predicted_served_degc=np.full(flow.shape, 25.0),
            predicted_curtailed_degc=np.full(flow.shape, 25.5),
        )
        return Action(
            flow_kg_s=flow[0],
            reserve_flow_kg_s=0.3 * flow[0],
            reserve_kw=3.0,
            planned_power_kw=10.0,
            status="optimal",
            fallback=False,
            solve_time_s=0.0,
            planned_slack_max_k=0.0,
            delta_max_k=0.0,
            predicted_served_degc=plan.predicted_served_degc[0],
            predicted_curtailed_degc=plan.predicted_curtailed_degc[0],
            event_plan=plan,
        )

    def get_state(self) -> dict[str, Any]:
        return {}

    def set_state(self, state: dict[str, Any]) -> None:
        return None


def _stub_loop(days: float = 0.25) -> tuple[ClosedLoop, StubPlanner]:
    cfg = with_overrides(preset("nmpc", start=START, days=days), {"activation.mode": "always"})
    setup = prepare(cfg)
    flow_max = np.asarray(setup.building.hvac.flow_max_kg_s)
    planner = StubPlanner(flow_max, 6)  # D + R = 4 + 2
    return ClosedLoop(setup, planner), planner


def test_closed_loop_applies_the_locked_plan_and_resumes_after_d() -> None:
    loop, planner = _stub_loop()
    while loop.k < loop.steps:
        loop.step()
    frame = loop.frame()
    assert frame["il_curtailed"].tolist()[:5] == [True, True, True, True, False]
    assert frame["il_beyond_model"].sum() == loop.steps - 4
    assert planner.calls == loop.steps - 3  # no re-optimisation during the event
    zone = loop.setup.zone_names[0]
    flows = frame[f"flow_{zone}_kg_s"].to_numpy()
    ramp = flows[1:4] / flows[0]
    np.testing.assert_allclose(ramp, [1.05, 1.10, 1.15])  # u_j of the plan made at s = 0
    # after the curtailment the controller re-plans with the recovery steps left
    assert planner.carries[1:4] == [2, 1, 0]
    assert frame["il_event_window"].tolist()[:7] == [True] * 6 + [False]


def test_without_activations_the_allowance_is_zero_in_every_period() -> None:
    cfg = with_overrides(preset("nmpc", start=START, days=0.25), {"activation.mode": "never"})
    setup = prepare(cfg)
    loop = ClosedLoop(setup, StubPlanner(np.asarray(setup.building.hvac.flow_max_kg_s), 6))
    while loop.k < loop.steps:
        loop.step()
    frame = loop.frame()
    assert frame["reserve_kw"].gt(0).all()  # offered in every period, never activated
    assert (frame["il_allowance_k"] == 0.0).all()
    assert not frame["il_event_window"].any() and not frame["il_activated"].any()
    assert frame["il_baseline_power_kw"].isna().all() and (frame["il_delivered_kw"] == 0).all()


def test_closed_loop_settles_the_locked_event_against_the_metered_power() -> None:
    loop, _ = _stub_loop()
    while loop.k < loop.steps:
        loop.step()
    frame = loop.frame()
    # activated from period 0: no period before it, no baseline, nothing shown delivered
    assert frame["il_baseline_power_kw"].isna().all()
    np.testing.assert_allclose(frame["il_shortfall_kw"], frame["reserve_kw"])


def test_the_scenario_baseline_rule_settles_the_closed_loop_frame() -> None:
    from hvacflex.settlement import SETTLEMENT_COLUMNS, settlement_columns

    cfg = with_overrides(
        preset("nmpc", start=START, days=0.25),
        {"activation.mode": "random", "activation.events_per_year": 20_000.0,
         "reserve.il_baseline": "similar-days"},
    )  # fmt: skip
    setup = prepare(cfg)
    loop = ClosedLoop(setup, StubPlanner(np.asarray(setup.building.hvac.flow_max_kg_s), 6))
    while loop.k < loop.steps:
        loop.step()
    frame = loop.frame()
    assert 0 < frame["il_activated"].sum() < len(frame)
    expected = settlement_columns(frame, "similar-days")
    for name in SETTLEMENT_COLUMNS:
        np.testing.assert_array_equal(frame[name].to_numpy(), expected[name].to_numpy())
    assert frame["il_baseline_power_kw"][frame["il_activated"]].notna().any()


def test_checkpoint_mid_event_resumes_identically() -> None:
    whole, _ = _stub_loop()
    while whole.k < whole.steps:
        whole.step()
    split, _ = _stub_loop()
    while split.k < 2:  # inside the event (periods 0 … 3)
        split.step()
    state = hvacflex_state.decode(hvacflex_state.encode(split.get_state()))  # data only
    resumed, _ = _stub_loop()
    resumed.set_state(state)
    while resumed.k < resumed.steps:
        resumed.step()
    pd.testing.assert_frame_equal(whole.frame(), resumed.frame())


def test_event_model_closed_loop_with_the_lp_curtails_at_most_d_periods(tmp_path: Path) -> None:
    cfg = with_overrides(
        preset("nmpc", start=START, days=1.0),
        {"activation.mode": "always", "data.reserve_price_scale": 40.0},
    )
    result = run_simulation(cfg, tmp_path, progress=False)
    frame, summary = result.frame, result.summary
    assert frame["il_curtailed"].sum() <= 4  # the 120-min rule
    assert summary["il_beyond_model_steps"] == len(frame) - 4
    assert summary["reserve_revenue_sgd"] > 0
    assert not frame["fallback"].any()
    config = json.loads((tmp_path / CONFIG_FILE).read_text())
    assert config["reserve"]["event_max_steps"] == 4  # config.json records [reserve]


def test_worst_event_temperature_is_recorded_for_every_fresh_plan(tmp_path: Path) -> None:
    cfg = with_overrides(
        preset("nmpc", start=START, days=0.5),
        {"activation.mode": "always", "data.reserve_price_scale": 40.0},
    )
    setup = prepare(cfg)
    frame = run_simulation(cfg, tmp_path, progress=False).frame
    zones = setup.zone_names
    worst = frame[[f"event_worst_{z}_degc" for z in zones]].to_numpy()
    served = frame[[f"temp_served_{z}_degc" for z in zones]].to_numpy()
    curtailed = frame[[f"temp_curtailed_{z}_degc" for z in zones]].to_numpy()
    fresh = (frame["solve_status"] == "optimal").to_numpy() & ~frame["fallback"].to_numpy()
    locked = (frame["solve_status"] == "event-plan").to_numpy()
    assert fresh.sum() > 0 and locked.sum() > 0  # the event locks the plan for D − 1 periods
    assert np.isfinite(worst[fresh]).all()
    assert np.isnan(worst[~fresh]).all()
    # the worst over the event set × the box is never below the served or the s = 0 event plan
    assert (worst[fresh] >= served[fresh] - 1e-9).all()
    assert (worst[fresh] >= curtailed[fresh] - 1e-9).all()
    assert (frame["reserve_kw"] > 0).any()
    offered = fresh & (frame["reserve_kw"] > 0).to_numpy()
    assert (worst[offered].max(axis=1) > served[offered].max(axis=1)).all()


def _office_offered_kwh(frame: pd.DataFrame) -> float:
    """Σ reserve_kw × 0.5 h over weekday periods starting 08:00 … 17:30 (local time)."""
    index = pd.DatetimeIndex(frame.index).tz_convert("Asia/Singapore")
    office = (index.dayofweek < 5) & (index.hour >= 8) & (index.hour < 18)
    return float(frame["reserve_kw"].to_numpy()[office].sum() * 0.5)


def _check_stress_settlement(frame: pd.DataFrame, summary: dict[str, Any]) -> None:
    """Issue 25's done-when figures that hold on any window (see docs/explanation/il_events.md)."""
    for column in ("il_baseline_power_kw", "il_delivered_kw", "il_shortfall_kw"):
        assert column in frame.columns
    activated = frame["il_activated"].to_numpy(bool)
    recomputed = float(
        np.nansum(np.maximum(frame["il_baseline_power_kw"] - frame["power_kw"], 0.0)[activated])
        * 0.5
    )
    assert recomputed == pytest.approx(summary["il_delivered_metered_kwh"], rel=0.01)
    offered = float((frame["reserve_kw"].to_numpy()[activated]).sum() * 0.5)
    assert summary["il_offered_kwh"] == pytest.approx(offered)
    assert summary["il_delivered_metered_kwh"] >= 0.95 * summary["il_offered_kwh"]
    # delivery capped at the offer, period by period, is the offer less the shortfall (the
    # stress week at 48.5 SGD/MWh: 89 % of the offer, docs/explanation/il_events.md)
    capped = np.minimum(frame["il_delivered_kw"], frame["reserve_kw"]).to_numpy()[activated]
    assert capped.sum() * 0.5 == pytest.approx(
        summary["il_offered_kwh"] - summary["il_shortfall_kwh"], abs=1e-9
    )
    for key in ("il_shortfall_kwh", "il_penalty_sgd", "il_delivered_counterfactual_kwh"):
        assert np.isfinite(summary[key])
    # market timing: every activated period with reserve committed for it curtails
    committed = activated & (frame["reserve_kw"].to_numpy() > 0)
    within = committed & ~frame["il_beyond_model"].to_numpy(bool)
    assert frame["il_curtailed"].to_numpy(bool)[within].all()


def test_two_stress_days_are_settled_against_metered_power(tmp_path: Path) -> None:
    """The shorter default check of the done-when figures (two weekdays, an activation each)."""
    cfg = with_overrides(preset("rmpc", start=START, days=2.0), {"activation.mode": "stress"})
    result = run_simulation(cfg, tmp_path, progress=False)
    assert result.frame["il_activated"].sum() >= 2
    _check_stress_settlement(result.frame, result.summary)


def test_stress_week_meets_issue_25s_done_when(tmp_path: Path) -> None:
    """Issue 25's done-when case: ``rmpc``, 5 days from 2014-03-03, stress activations, on
    the RC plant. Measured (docs/explanation/il_events.md, 2026-12-05): 13 activated periods,
    offered in them 4.44 kWh, delivered capped at the offer 98 % (0.07 kWh short in one period), the
    plant's counterfactual 138 %, offered in weekday office hours 36.8 kWh (≥ 36); with the
    plan paid q·r and the offers cut afterwards (``plan_visible_offers`` off) 25.5 kWh and
    90 %. Planned with the design curves, the RC plant's own equations (``power_model =
    "design"``); with office5's power model fitted to the RC plant's meter (the default) the
    delivery was 93 % of 5.49 kWh offered when measured (2026-12-06).

    Office-hours offers are graded against issue 25's 36 kWh (70 % of the 51.5 kWh the
    controller of then offered on the plant of then). Issue 55's damper rule (outdoor air
    only while occupied: a cheaper night for the plant and the LP) moved them to 35.67 kWh
    (measured 2026-12-06 on 1067dca; 35.63 with the night plan margin at 0, so the margin
    is not what moved them): 1 % short of 36 on another plant, so the bound here is 35 kWh,
    the same 2 % margin below the measurement as before."""
    cfg = with_overrides(
        preset("rmpc", start=START, days=5.0),
        {"activation.mode": "stress", "power_model": "design"},
    )
    result = run_simulation(cfg, tmp_path, progress=False)
    frame, summary = result.frame, result.summary
    assert frame["il_activated"].sum() >= 4
    _check_stress_settlement(frame, summary)
    assert summary["il_offered_kwh"] > 0.0 and frame["il_curtailed"].any()
    activated = frame["il_activated"].to_numpy(bool)
    capped = np.minimum(frame["il_delivered_kw"], frame["reserve_kw"]).to_numpy()[activated]
    assert capped.sum() * 0.5 >= 0.95 * summary["il_offered_kwh"]
    assert summary["il_delivered_counterfactual_kwh"] >= 0.98 * summary["il_offered_kwh"]
    assert _office_offered_kwh(frame) >= 35.0  # see the docstring: was 36 before the damper


class _BaselineRecorder(StubPlanner):
    """The stub planner, recording the baselines the loop tells it."""

    def __init__(self, flow_max: np.ndarray, steps: int) -> None:
        super().__init__(flow_max, steps)
        self.ahead: list[np.ndarray | None] = []

    def act(self, inputs: PeriodInputs) -> Action:
        if inputs.locked is None:
            ahead = inputs.baseline_ahead_kw
            self.ahead.append(None if ahead is None else np.array(ahead))
        return super().act(inputs)


@pytest.mark.parametrize("rule", ["pre-event", "similar-days"])
def test_the_loop_tells_the_controller_the_coming_similar_days_baselines(rule: str) -> None:
    """Under similar-days the controller learns the baseline of periods k … k + g before
    they start (what the settlement will use, from earlier weekdays' metered power): NaN on
    the run's first day, Monday's power on Tuesday; under pre-event nothing."""
    cfg = with_overrides(
        preset("nmpc", start=START, days=1.125),
        {"activation.mode": "never", "reserve.il_baseline": rule},
    )
    setup = prepare(cfg)
    recorder = _BaselineRecorder(np.asarray(setup.building.hvac.flow_max_kg_s), 6)
    loop = ClosedLoop(setup, recorder)
    while loop.k < loop.steps:
        loop.step()
    if rule == "pre-event":
        assert all(ahead is None for ahead in recorder.ahead)
        return
    # every step a plan sizes an offer for: the committed g = 2 and the event plan's D + R = 6
    steps = cfg.reserve.ahead_offer_steps
    assert steps == 6
    power = loop.frame()["power_kw"].to_numpy()
    assert all(a is not None and len(a) == steps for a in recorder.ahead)
    assert all(np.isnan(a).all() for a in recorder.ahead[: 48 - steps])  # type: ignore[arg-type]
    for k in range(48, loop.steps):
        np.testing.assert_allclose(recorder.ahead[k], power[k - 48 : k - 48 + steps])
