"""Planning off the request path (``hvacflex.service.planner``): a measurement is
acknowledged (202) with the revision its plan will have, reads answer while a plan is being
made, ``wait_s`` returns the plan, a building's jobs keep their order, and an acknowledged
measurement is planned after a restart — in process and with ``kill -9`` of a real server,
on every database of ``make_db_url``."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from service_fixtures import (
    START,
    app_with_building,
    operator_key_for,
    registration,
    stored_plans,
)
from sqlalchemy import func, select

from hvacflex.service.app import create_app
from hvacflex.service.db import Measurement
from hvacflex.service.replay import Client

READ_WAIT_LIMIT_S = 2.0
"""A read while a plan is held must answer well within this (it never waits for it)."""


class Gate:
    """Holds every measurement's plan of an app until opened (then plans, or fails)."""

    def __init__(self, app: Any, fail: bool = False) -> None:
        self.opened = threading.Event()
        self.entered = threading.Event()
        runtime = app.state.runtime
        real = runtime.plan_measurement

        def held(building_id: str, k: int, revision: int) -> dict[str, Any]:
            self.entered.set()
            self.opened.wait(timeout=120)
            if fail:
                raise RuntimeError("the server went away before planning")
            plan: dict[str, Any] = real(building_id, k, revision)
            return plan

        runtime.plan_measurement = held


@pytest.fixture
def served(
    make_db_url: Callable[[str], str],
) -> Iterator[tuple[TestClient, dict[str, str], list[str], Any, str]]:
    """A fresh app with building ``p1`` (``rmpc``, office5, one day)."""
    url = make_db_url("planner")
    client, keys, payload, app = app_with_building(url, "p1")
    yield client, keys, payload["nodes"], app, url
    client.close()
    app.state.planner.shutdown()
    app.state.engine.dispose()


def _body(time_of_day: str, nodes: list[str], temp_degc: float = 24.5) -> dict[str, Any]:
    return {"time": f"{START}T{time_of_day}", "node_temperatures_degc": [temp_degc] * len(nodes)}


def _post(client: TestClient, key: str, body: dict[str, Any], wait_s: float | None = None) -> Any:
    query = "" if wait_s is None else f"?wait_s={wait_s:g}"
    return client.post(
        f"/v1/buildings/p1/measurements{query}", json=body, headers={"X-API-Key": key}
    )


def test_acknowledged_at_once_reads_do_not_wait_and_wait_s_returns_the_plan(
    served: tuple[TestClient, dict[str, str], list[str], Any, str],
) -> None:
    client, keys, nodes, app, _url = served
    gate = Gate(app)
    body = _body("00:00", nodes)
    ack = _post(client, keys["p1"], body)
    assert ack.status_code == 202, ack.text
    assert ack.json()["status"] == 202
    assert ack.json()["payload"] == {
        "building_id": "p1",
        "period": 0,
        "time": "2014-03-03T00:00:00+08:00",
        "revision": 1,
    }
    assert gate.entered.wait(timeout=60)  # the worker is planning it now, held
    started = time.perf_counter()
    read = client.get("/v1/buildings/p1/plan", headers={"X-API-Key": keys["p1"]})
    assert time.perf_counter() - started < READ_WAIT_LIMIT_S
    assert read.status_code == 404 and read.json()["message"] == "no plan yet"
    again = _post(client, keys["p1"], body, wait_s=0.2)  # the same body, still planning
    assert again.status_code == 202 and again.json()["payload"]["revision"] == 1
    gate.opened.set()
    planned = _post(client, keys["p1"], body, wait_s=10)
    assert planned.status_code == 200, planned.text
    plan = planned.json()["payload"]
    assert (plan["period"], plan["revision"], plan["trigger"]) == (0, 1, "measurement")
    assert plan["status"] == "optimal"
    latest = client.get("/v1/buildings/p1/plan", headers={"X-API-Key": keys["p1"]})
    assert latest.json()["payload"]["objective_sgd"] == plan["objective_sgd"]


def test_the_same_body_posted_at_once_is_one_measurement(
    served: tuple[TestClient, dict[str, str], list[str], Any, str],
) -> None:
    """A BEMS that retries while its first request is in flight: 6 posts of one body at the
    same instant are one stored measurement, all acknowledged with the same revision."""
    client, keys, nodes, app, _url = served
    body = _body("00:00", nodes)
    barrier = threading.Barrier(6)
    answers: list[Any] = []

    def post() -> None:
        barrier.wait(timeout=30)
        answers.append(_post(client, keys["p1"], body))

    threads = [threading.Thread(target=post) for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    assert sorted(a.status_code for a in answers)[-1] <= 202, [a.text for a in answers]
    assert {a.json()["payload"]["revision"] for a in answers} == {1}
    with app.state.sessions() as session:
        count = session.scalar(select(func.count(Measurement.id)))
    assert count == 1


def test_wait_s_is_bounded(served: tuple[TestClient, dict[str, str], list[str], Any, str]) -> None:
    client, keys, nodes, _app, _url = served
    response = _post(client, keys["p1"], _body("00:00", nodes), wait_s=11)
    assert response.status_code == 422 and "wait_s" in response.json()["message"]


def test_the_acknowledged_revision_follows_a_boundary_plan(
    served: tuple[TestClient, dict[str, str], list[str], Any, str],
) -> None:
    """A boundary plan of period 1 (revision 1, on the measurement of period 0) comes first;
    the measurement of period 1 is acknowledged as revision 2 and planned as it."""
    client, keys, nodes, _app, _url = served
    assert _post(client, keys["p1"], _body("00:00", nodes), wait_s=10).status_code == 200
    op = {"X-API-Key": keys["operator"]}
    clock = client.post("/v1/clock", json={"time": f"{START}T00:30"}, headers=op)
    assert clock.status_code == 200
    boundary = clock.json()["payload"]["plans"]
    assert [(p["period"], p["revision"], p["trigger"]) for p in boundary] == [(1, 1, "boundary")]
    ack = _post(client, keys["p1"], _body("00:30", nodes))
    assert ack.status_code in (200, 202)
    assert ack.json()["payload"]["revision"] == 2
    plan = _post(client, keys["p1"], _body("00:30", nodes), wait_s=10).json()["payload"]
    assert (plan["period"], plan["revision"], plan["trigger"]) == (1, 2, "measurement")


def test_a_boundary_waits_behind_the_buildings_measurement(
    served: tuple[TestClient, dict[str, str], list[str], Any, str],
) -> None:
    """The clock of period 2 arrives while the measurement of period 1 is being planned:
    the boundary job runs after it (as when plans were made on the request), so period 1
    is planned on its measurement and period 2 on the same state, with no conflict."""
    client, keys, nodes, app, _url = served
    assert _post(client, keys["p1"], _body("00:00", nodes), wait_s=10).status_code == 200
    gate = Gate(app)
    assert _post(client, keys["p1"], _body("00:30", nodes, 24.8)).status_code == 202
    assert gate.entered.wait(timeout=60)
    answers: dict[str, Any] = {}

    def clock() -> None:
        answers["clock"] = client.post(
            "/v1/clock", json={"time": f"{START}T01:00"}, headers={"X-API-Key": keys["operator"]}
        )

    thread = threading.Thread(target=clock)
    thread.start()
    time.sleep(0.5)
    assert "clock" not in answers  # it waits for the plans it triggers
    gate.opened.set()
    thread.join(timeout=120)
    boundary = answers["clock"].json()["payload"]["plans"]
    assert [(p["period"], p["trigger"]) for p in boundary] == [(2, "boundary")]
    measured = client.get("/v1/buildings/p1/plan?period=1", headers={"X-API-Key": keys["p1"]})
    assert measured.json()["payload"]["trigger"] == "measurement"


def test_an_acknowledged_measurement_is_planned_after_a_restart(
    served: tuple[TestClient, dict[str, str], list[str], Any, str],
) -> None:
    """The first app never plans (its worker dies before); a second app on the same
    database plans the acknowledged measurement at start-up, as the revision promised."""
    client, keys, nodes, app, url = served
    gate = Gate(app, fail=True)
    body = _body("00:00", nodes)
    ack = _post(client, keys["p1"], body)
    assert ack.status_code == 202
    assert gate.entered.wait(timeout=60)
    restarted = create_app(url)
    try:
        second = TestClient(restarted)
        deadline = time.monotonic() + 120
        plan = None
        while plan is None and time.monotonic() < deadline:
            read = second.get("/v1/buildings/p1/plan?period=0", headers={"X-API-Key": keys["p1"]})
            plan = read.json()["payload"] if read.status_code == 200 else None
            time.sleep(0.1)
        assert plan is not None, "the acknowledged measurement was not planned after restart"
        assert (plan["revision"], plan["trigger"]) == (
            ack.json()["payload"]["revision"],
            "measurement",
        )
        repeated = second.post(
            "/v1/buildings/p1/measurements?wait_s=10", json=body, headers={"X-API-Key": keys["p1"]}
        )
        assert repeated.status_code == 200 and repeated.json()["payload"]["revision"] == 1
    finally:
        gate.opened.set()
        restarted.state.planner.shutdown()
        restarted.state.engine.dispose()


BUILDINGS = 4
PERIODS = 8


def test_kill9_during_writes_loses_no_acknowledged_measurement(server_factory: Any) -> None:
    """``kill -9`` while 4 buildings post measurements (no wait): after a restart every
    acknowledged measurement is stored and planned with the revision it was promised."""
    server = server_factory("kill")
    server.start()
    operator = Client(server.url, operator_key_for(server.db_url))
    keys: dict[str, str] = {}
    nodes = 0
    for i in range(BUILDINGS):
        body = registration(f"k{i}")
        body["building"] = {"name": "room1"}
        registered = operator.call("POST", "/v1/buildings", body)
        keys[f"k{i}"], nodes = registered["key"], len(registered["nodes"])
    acknowledged: list[tuple[str, int, int, dict[str, Any]]] = []
    lock = threading.Lock()

    def post(building_id: str) -> None:
        client = Client(server.url, keys[building_id])
        for k in range(PERIODS):
            stamp = f"{START}T{k // 2:02d}:{30 * (k % 2):02d}"
            body = {"time": stamp, "node_temperatures_degc": [24.0 + 0.1 * k] * nodes}
            try:
                status, payload = client.call_status(
                    "POST", f"/v1/buildings/{building_id}/measurements", body
                )
            except Exception:  # the server is gone
                return
            with lock:
                acknowledged.append((building_id, k, int(payload["revision"]), body))
            assert status in (200, 202)

    threads = [threading.Thread(target=post, args=(b,)) for b in keys]
    for thread in threads:
        thread.start()
    deadline = time.monotonic() + 60
    while len(acknowledged) < BUILDINGS * PERIODS // 2 and time.monotonic() < deadline:
        time.sleep(0.005)
    server.kill9()
    for thread in threads:
        thread.join(timeout=60)
    assert BUILDINGS * PERIODS // 2 <= len(acknowledged)

    server.start()
    for building_id, k, revision, body in acknowledged:
        client = Client(server.url, keys[building_id])
        status, plan = client.call_status(
            "POST", f"/v1/buildings/{building_id}/measurements?wait_s=10", body
        )
        assert status == 200, (building_id, k)
        assert (plan["period"], plan["revision"], plan["trigger"]) == (k, revision, "measurement")
    stored = stored_plans(server.db_url)
    assert all((b, k, r) in stored for b, k, r, _ in acknowledged)
