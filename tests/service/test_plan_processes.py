"""Planning in worker processes (``hvacflex.service.plan_processes``): the plans equal those
made in the server's threads, each building stays in its process, an error travels back, a
process that dies is replaced and the plan still made, and reads do not wait for a plan."""

from __future__ import annotations

import os
import pickle
import signal
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from service_fixtures import START, UNLIMITED, registration

from hvacflex.errors import InputError
from hvacflex.service.app import create_app
from hvacflex.service.keys import create_key
from hvacflex.service.plan_processes import (
    MAX_NICENESS,
    PLAN_NICENESS,
    PlanProcesses,
    _run,
    shares_processes,
)

PERIODS = ("00:00", "00:30")
BUILDINGS = ("q1",)


def _app(url: str, plan_processes: int) -> tuple[Any, TestClient, dict[str, str], list[str]]:
    app = create_app(url, route_limits=UNLIMITED, plan_processes=plan_processes)
    with app.state.sessions() as session, session.begin():
        operator = create_key(session, "operator")
    client = TestClient(app)
    keys = {"operator": operator}
    nodes: list[str] = []
    for building_id in BUILDINGS:
        response = client.post(
            "/v1/buildings", json=registration(building_id), headers={"X-API-Key": operator}
        )
        assert response.status_code == 201, response.text
        keys[building_id] = response.json()["payload"]["key"]
        nodes = response.json()["payload"]["nodes"]
    return app, client, keys, nodes


def _measure(
    client: TestClient, keys: dict[str, str], nodes: list[str], building_id: str, i: int
) -> Any:
    body = {
        "time": f"{START}T{PERIODS[i]}",
        "node_temperatures_degc": [24.0 + 0.3 * i] * len(nodes),
        "previous_power_kw": None if i == 0 else 20.0 + 5 * i,
    }
    return client.post(
        f"/v1/buildings/{building_id}/measurements?wait_s=10",
        json=body,
        headers={"X-API-Key": keys[building_id]},
    )


@pytest.fixture
def in_processes(
    make_db_url: Callable[[str], str],
) -> Iterator[tuple[Any, TestClient, dict[str, str], list[str]]]:
    """An app planning in one worker process, building ``q1``."""
    app, client, keys, nodes = _app(make_db_url("processes"), 1)
    yield app, client, keys, nodes
    client.close()
    app.state.planner.shutdown()
    app.state.engine.dispose()


def _plans(client: TestClient, keys: dict[str, str], nodes: list[str]) -> list[dict[str, Any]]:
    plans = []
    for i in range(len(PERIODS)):
        for building_id in BUILDINGS:
            response = _measure(client, keys, nodes, building_id, i)
            assert response.status_code == 200, response.text
            plans.append(response.json()["payload"])
    return plans


def test_plans_in_a_process_equal_plans_in_threads_and_a_dead_process_is_replaced(
    in_processes: tuple[Any, TestClient, dict[str, str], list[str]],
    make_db_url: Callable[[str], str],
) -> None:
    app, client, keys, nodes = in_processes
    planner = app.state.planner
    assert isinstance(planner.plans, PlanProcesses)
    in_process = _plans(client, keys, nodes)
    threaded_app, threaded, threaded_keys, _ = _app(make_db_url("threads"), 0)
    try:
        assert threaded_app.state.planner.plans is threaded_app.state.runtime
        in_threads = _plans(threaded, threaded_keys, nodes)
    finally:
        threaded.close()
        threaded_app.state.planner.shutdown()
        threaded_app.state.engine.dispose()
    for a, b in zip(in_process, in_threads, strict=True):
        assert (a["building_id"], a["period"], a["revision"]) == (
            b["building_id"],
            b["period"],
            b["revision"],
        )
        assert a["objective_sgd"] == pytest.approx(b["objective_sgd"], rel=1e-6, abs=1e-6)
        assert a["flow_kg_s"] == pytest.approx(b["flow_kg_s"], rel=1e-5, abs=1e-6)
    # kill the planning process: the next plan is made by a new one, from the stored state
    ((pid, niceness),) = planner.plans.start()
    assert pid != os.getpid()
    assert niceness == min(os.nice(0) + PLAN_NICENESS, MAX_NICENESS)  # below the server
    os.kill(pid, signal.SIGKILL)
    time.sleep(0.5)
    response = client.post(
        "/v1/clock", json={"time": f"{START}T01:00"}, headers={"X-API-Key": keys["operator"]}
    )
    assert response.status_code == 200, response.text
    plans = response.json()["payload"]["plans"]
    assert [(p["building_id"], p["period"], p["trigger"]) for p in plans] == [("q1", 2, "boundary")]
    assert planner.plans.start()[0][0] != pid


def test_each_building_stays_in_its_process_the_least_loaded_first() -> None:
    processes = PlanProcesses("sqlite:///unused.db", 2)
    try:
        assert [processes.process_of(b) for b in ("a", "b", "c", "a", "b")] == [0, 1, 0, 0, 1]
    finally:
        processes.shutdown()  # no process was started


@pytest.mark.parametrize("niceness", [-1, 20])
def test_a_niceness_outside_0_to_19_is_refused(niceness: int) -> None:
    with pytest.raises(ValueError, match=f"niceness must be in \\[0, 19\\], got {niceness}"):
        PlanProcesses("sqlite:///unused.db", 1, niceness=niceness)
    with pytest.raises(InputError, match="plan_niceness") as caught:
        create_app("sqlite://", plan_niceness=niceness)
    assert caught.value.field == "plan_niceness"


def test_serve_refuses_a_plan_niceness_outside_0_to_19() -> None:
    from typer.testing import CliRunner

    from hvacflex.cli import app as cli

    result = CliRunner().invoke(cli, ["serve", "--plan-niceness", "20"])
    assert result.exit_code == 2 and isinstance(result.exception, SystemExit)
    assert "--plan-niceness" in result.output and "Traceback" not in result.output


def test_an_error_that_cannot_travel_back_becomes_its_text(monkeypatch: Any) -> None:
    import hvacflex.service.plan_processes as module

    class Unpicklable(Exception):
        def __init__(self, a: str, b: str) -> None:
            super().__init__(f"{a} and {b}")

    class FakeRuntime:
        def plan_measurement(self, building_id: str, k: int, revision: int) -> None:
            raise Unpicklable("one", "two")

        def boundary_building(self, building_id: str, time: Any) -> None:
            raise InputError("must be a period", field="time", value="x")

        activation_building = boundary_building

    monkeypatch.setattr(module, "_RUNTIME", FakeRuntime())
    with pytest.raises(RuntimeError, match="Unpicklable: one and two"):
        _run("measurement", "b", (1, 1))
    with pytest.raises(InputError, match="must be a period") as caught:
        _run("boundary", "b", (None,))
    travelled = pickle.loads(pickle.dumps(caught.value))  # as it comes back to the server
    assert isinstance(travelled, InputError) and travelled.field == "time"  # → a 4xx
    assert str(travelled) == str(caught.value)


def test_only_a_database_in_memory_cannot_be_shared() -> None:
    assert shares_processes("sqlite:///some/file.db")
    assert shares_processes("postgresql+psycopg://u:p@127.0.0.1:5432/db")
    assert not shares_processes("sqlite://")
    assert not shares_processes("sqlite:///:memory:")
