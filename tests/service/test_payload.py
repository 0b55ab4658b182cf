"""The plan payload: a Decision as the service's JSON (horizon and IL columns)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from hvacflex.control.base import Action, EventPlan
from hvacflex.service.payload import event_columns, finite, finite_list, horizon_columns
from hvacflex.sim.events import PeriodOutcome, Role
from hvacflex.sim.step import Decision, DecisionStatus

INDEX = pd.date_range("2014-03-03", periods=4, freq="30min", tz="Asia/Singapore")
C = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def _action(**kw: object) -> Action:
    values: dict[str, object] = {
        "flow_kg_s": np.array([1.0, 2.0]),
        "reserve_flow_kg_s": np.array([0.5, 0.0]),
        "reserve_kw": 1.5,
        "planned_power_kw": 12.0,
        "status": "optimal",
        "fallback": False,
        "solve_time_s": 0.01,
        "planned_slack_max_k": 0.0,
        "delta_max_k": 0.3,
        "predicted_served_degc": np.array([24.0, 25.0]),
        "predicted_curtailed_degc": np.array([24.5, 25.0]),
    }
    values.update(kw)
    return Action(**values)  # type: ignore[arg-type]


def _decision(role: Role, action: Action, locked: tuple[EventPlan, int] | None) -> Decision:
    outcome = PeriodOutcome(role is Role.EVENT_LOCKED, False, True, 1.0, math.nan)
    applied = action.flow_kg_s - action.reserve_flow_kg_s
    return Decision(action, DecisionStatus.LOCKED, role, outcome, applied, None, locked)


def test_json_has_no_nan() -> None:
    assert finite(math.nan) is None and finite(math.inf) is None and finite(2.0) == 2.0
    assert finite_list(np.array([[1.0, math.nan]])) == [1.0, None]


def test_a_locked_period_reports_the_rest_of_the_locked_plan() -> None:
    plan = EventPlan(
        flow_kg_s=np.ones((3, 2)),
        reserve_flow_kg_s=np.zeros((3, 2)),
        served_power_kw=np.array([10.0, 11.0, 12.0]),
        reserve_kw=np.array([1.0, 2.0, 3.0]),
        predicted_served_degc=np.array([[24.0, 25.0], [24.1, 25.1], [24.2, 25.2]]),
        predicted_curtailed_degc=np.zeros((3, 2)),
    )
    decision = _decision(Role.EVENT_LOCKED, _action(), (plan, 1))
    columns = horizon_columns(decision, None, C, INDEX, horizon=4)
    assert columns["objective_sgd"] is None
    assert columns["horizon_power_kw"] == [11.0, 12.0]
    assert columns["horizon_reserve_kw"] == [2.0, 3.0]
    assert columns["horizon_temp_degc"] == [[24.1, 25.1], [24.2, 25.2]]
    assert columns["horizon_time"] == [t.isoformat() for t in INDEX[:2]]


def test_a_period_without_a_plan_reports_its_one_step_and_the_il_columns() -> None:
    decision = _decision(Role.SERVED, _action(planned_power_kw=math.nan), None)
    columns = horizon_columns(decision, None, C, INDEX, horizon=4)
    assert columns["horizon_power_kw"] == [None]
    assert columns["horizon_reserve_kw"] == [1.5]
    il = event_columns(decision, activated=False)
    assert il["il_role"] == "served" and il["il_activated"] is False
    assert il["il_allowance_k"] == 1.0 and il["il_reference_power_kw"] is None
    assert il["applied_flow_kg_s"] == [0.5, 2.0]
