"""IL events in the service follow the closed loop's event model (docs/explanation/il_events.md): a
start locks the plan, locked periods run it without the solver, the end starts the recovery; the
event state survives a restart (it is stored with the controller's state)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from service_fixtures import START, registration

from hvacflex.config import preset
from hvacflex.service.app import create_app
from hvacflex.service.keys import create_key

RESERVE = preset("rmpc").reserve


@pytest.fixture(scope="module")
def app(make_db_url: Callable[[str], str]) -> Iterator[tuple[TestClient, str, str]]:
    """A fresh service with building ``e1`` (``rmpc``: D = 4, R = 2) and dear reserve."""
    application = create_app(make_db_url("events"))
    with application.state.sessions() as session, session.begin():
        operator_key = create_key(session, "operator")
    client = TestClient(application)
    op = {"X-API-Key": operator_key}
    # offers decided at each period's start (no commitment ahead), so that the first period
    # measured already offers: these tests are about the event's lock and recovery
    body = registration("e1", **{"reserve.commit_ahead_periods": 0})
    response = client.post("/v1/buildings", json=body, headers=op)
    assert response.status_code == 201, response.text
    prices = {
        "start": f"{START}T08:00",
        "energy_price_sgd_per_mwh": [100.0] * 48,
        "reserve_price_sgd_per_mwh": [3000.0] * 48,
    }
    assert client.post("/v1/signals/prices", json=prices, headers=op).status_code == 200
    yield client, operator_key, response.json()["payload"]["key"]
    client.close()


def _measure(client: TestClient, key: str, time: str, nodes: int) -> dict[str, Any]:
    body = {"time": time, "node_temperatures_degc": [24.5] * nodes}
    response = client.post(
        "/v1/buildings/e1/measurements?wait_s=10", json=body, headers={"X-API-Key": key}
    )
    assert response.status_code == 200, response.text
    plan: dict[str, Any] = response.json()["payload"]
    return plan


def _activation(client: TestClient, operator_key: str, event: str, time: str) -> Any:
    response = client.post(
        "/v1/activations",
        json={"event": event, "time": time, "building_ids": ["e1"]},
        headers={"X-API-Key": operator_key},
    )
    assert response.status_code == 200, response.text
    return response.json()["payload"]["plans"]


def _nodes(client: TestClient, key: str) -> int:
    info = client.get("/v1/buildings/e1", headers={"X-API-Key": key}).json()["payload"]
    return len(info["nodes"])


def _curtailed(plan: dict[str, Any]) -> list[float]:
    return [u - r for u, r in zip(plan["flow_kg_s"], plan["reserve_flow_kg_s"], strict=True)]


def test_event_start_locks_the_plan_end_starts_the_recovery(
    app: tuple[TestClient, str, str],
) -> None:
    client, operator_key, key = app
    nodes = len(
        client.get("/v1/buildings/e1", headers={"X-API-Key": key}).json()["payload"]["nodes"]
    )
    assert RESERVE.event_max_steps is not None and RESERVE.event_recovery_steps == 2
    served = _measure(client, key, f"{START}T10:00", nodes)
    assert served["il_role"] == "served" and not served["il_curtailed"]
    assert served["reserve_kw"] > 0, served

    # a start during the period re-plans it at once: the same plan, now locked and curtailed
    (started,) = _activation(client, operator_key, "start", f"{START}T10:05")
    assert started["il_role"] == "event-start" and started["il_curtailed"]
    assert started["revision"] == served["revision"] + 1
    assert started["objective_sgd"] == pytest.approx(served["objective_sgd"], rel=1e-9)
    assert started["applied_flow_kg_s"] == pytest.approx(_curtailed(served))
    assert started["il_reference_power_kw"] == pytest.approx(served["planned_power_kw"])
    assert started["il_allowance_k"] == RESERVE.event_allowance_k

    # a restart between periods: the event state comes back from the database
    client.app.state.runtime.evict("e1")  # type: ignore[attr-defined]
    locked = _measure(client, key, f"{START}T10:30", nodes)
    assert locked["il_role"] == "event-locked" and locked["il_curtailed"]
    assert locked["status"] == "event-plan" and locked["solve_time_s"] == 0.0
    assert locked["objective_sgd"] is None  # no optimisation: the locked plan's step 1
    assert locked["planned_power_kw"] == pytest.approx(served["horizon_power_kw"][1], rel=1e-6)
    assert locked["il_reference_power_kw"] == pytest.approx(locked["planned_power_kw"])
    assert locked["applied_flow_kg_s"] == pytest.approx(_curtailed(locked))
    assert locked["horizon_power_kw"][0] == pytest.approx(locked["planned_power_kw"])

    # the end re-plans the period at once: a fresh plan, the first recovery period
    (ended,) = _activation(client, operator_key, "end", f"{START}T10:40")
    assert ended["il_role"] == "served" and not ended["il_curtailed"]
    assert ended["status"] == "optimal" and ended["objective_sgd"] is not None
    # the recovery's decaying allowance: α·R/(R + 1) in its first period
    recovery_steps = RESERVE.event_recovery_steps
    assert ended["il_event_window"] and ended["il_allowance_k"] == pytest.approx(
        RESERVE.event_allowance_k * recovery_steps / (recovery_steps + 1)
    )
    assert ended["applied_flow_kg_s"] == pytest.approx(ended["flow_kg_s"])
    recovery = _measure(client, key, f"{START}T11:00", nodes)
    assert recovery["il_event_window"] and not recovery["il_curtailed"]
    after = _measure(client, key, f"{START}T11:30", nodes)
    assert not after["il_event_window"] and after["il_allowance_k"] == 0.0
    assert after["il_reference_power_kw"] is None


def test_event_longer_than_d_periods_is_beyond_the_model(app: tuple[TestClient, str, str]) -> None:
    client, operator_key, key = app
    nodes = len(
        client.get("/v1/buildings/e1", headers={"X-API-Key": key}).json()["payload"]["nodes"]
    )
    _activation(client, operator_key, "start", f"{START}T12:00")
    assert RESERVE.event_max_steps is not None
    roles = [
        _measure(client, key, f"{START}T{12 + i // 2:02d}:{30 * (i % 2):02d}", nodes)["il_role"]
        for i in range(RESERVE.event_max_steps + 1)
    ]
    assert roles == ["event-start"] + ["event-locked"] * (RESERVE.event_max_steps - 1) + [
        "beyond-model"
    ]
    _activation(client, operator_key, "end", f"{START}T15:00")


def test_plans_only_go_forward(app: tuple[TestClient, str, str]) -> None:
    client, _operator_key, key = app
    body = {"time": f"{START}T09:00", "node_temperatures_degc": [24.5] * _nodes(client, key)}
    response = client.post("/v1/buildings/e1/measurements", json=body, headers={"X-API-Key": key})
    assert response.status_code == 409 and "latest planned period" in response.json()["message"]


def test_output_feedback_building_holds_its_filter_through_the_event(
    app: tuple[TestClient, str, str],
) -> None:
    """``rmpc-output-feedback``: the filter reads the zones of the posted state; in locked
    periods the controller only holds (filter step, no solve), also across a restart."""
    client, operator_key, _key = app
    op = {"X-API-Key": operator_key}
    body = registration("k1")
    body["scenario"]["preset"] = "rmpc-output-feedback"
    response = client.post("/v1/buildings", json=body, headers=op)
    assert response.status_code == 201, response.text
    key, nodes = response.json()["payload"]["key"], len(response.json()["payload"]["nodes"])

    def measure(time: str) -> dict[str, Any]:
        payload = {"time": f"{START}T{time}", "node_temperatures_degc": [24.5] * nodes}
        answer = client.post(
            "/v1/buildings/k1/measurements?wait_s=10", json=payload, headers={"X-API-Key": key}
        )
        assert answer.status_code == 200, answer.text
        plan: dict[str, Any] = answer.json()["payload"]
        return plan

    assert measure("16:00")["status"] == "optimal"
    started = client.post(
        "/v1/activations",
        json={"event": "start", "time": f"{START}T16:00", "building_ids": ["k1"]},
        headers=op,
    )
    assert [p["il_role"] for p in started.json()["payload"]["plans"]] == ["event-start"]
    continued = measure("16:30")
    assert continued["il_role"] == "event-locked"
    client.app.state.runtime.evict("k1")  # type: ignore[attr-defined]
    locked = measure("17:00")
    assert locked["il_role"] == "event-locked" and locked["solve_time_s"] == 0.0
    client.post(
        "/v1/activations",
        json={"event": "end", "time": f"{START}T17:30", "building_ids": ["k1"]},
        headers=op,
    )
    recovery = measure("17:30")
    assert recovery["il_role"] == "served" and recovery["status"] == "optimal"
    # a recovery (and its allowance) follows only a real curtailment (reserve offered)
    event = [*started.json()["payload"]["plans"], continued, locked]
    assert recovery["il_event_window"] == any(plan["il_curtailed"] for plan in event)
