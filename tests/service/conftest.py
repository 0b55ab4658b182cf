"""Service fixtures: an in-process app with two buildings, and real servers (uvicorn
subprocesses on 127.0.0.1) — on SQLite and, where ``HVACFLEX_TEST_POSTGRES_URL`` names a
PostgreSQL database (``.ci/run`` always sets it), on PostgreSQL too: every test that takes
``make_db_url`` (or a fixture built on it) runs once per database."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from service_fixtures import (
    POSTGRES_ENV,
    START,
    UNLIMITED,
    Server,
    Service,
    drop_postgres_database,
    free_port,
    new_postgres_database,
    registration,
)

from hvacflex.service.app import create_app
from hvacflex.service.keys import create_key


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def make_db_url(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Callable[[str], str]]:
    """A factory of fresh, empty databases of one kind: ``make(name) → URL`` (a new one
    at every call)."""
    if request.param == "sqlite":
        yield lambda name: f"sqlite:///{tmp_path_factory.mktemp(name) / name}.db"
        return
    import os

    base = os.environ.get(POSTGRES_ENV)
    if not base:
        pytest.skip(f"{POSTGRES_ENV} is not set (.ci/run starts a PostgreSQL cluster and sets it)")
    made: list[str] = []

    def make(_name: str) -> str:
        url = new_postgres_database(base)
        made.append(url)
        return url

    yield make
    for url in made:
        drop_postgres_database(base, url)


def _service(db_url: str, registrations: list[dict[str, Any]]) -> Iterator[Service]:
    """An app on ``db_url`` with the buildings of ``registrations`` registered."""
    app = create_app(db_url, route_limits=UNLIMITED)
    with app.state.sessions() as session, session.begin():
        operator_key = create_key(session, "operator")
    client = TestClient(app)
    keys: dict[str, str] = {}
    nodes: list[str] = []
    for body in registrations:
        response = client.post("/v1/buildings", json=body, headers={"X-API-Key": operator_key})
        assert response.status_code == 201, response.text
        keys[body["building_id"]] = response.json()["payload"]["key"]
        nodes = response.json()["payload"]["nodes"]
    yield Service(client, operator_key, keys, nodes, db_url)
    client.close()
    app.state.planner.shutdown()
    app.state.engine.dispose()


@pytest.fixture(scope="module")
def service(make_db_url: Callable[[str], str]) -> Iterator[Service]:
    """An app with two registered buildings, ``b1`` and ``b2`` (one day each)."""
    yield from _service(make_db_url("service"), [registration("b1"), registration("b2")])


@pytest.fixture
def planned_service(make_db_url: Callable[[str], str]) -> Iterator[Service]:
    """A fresh app with ``b1`` and ``b2`` registered, each planned on a measurement at
    12:00: plans to aggregate whatever the module's other tests did before."""
    services = _service(make_db_url("planned"), [registration("b1"), registration("b2")])
    service = next(services)
    try:
        body = {"time": f"{START}T12:00", "node_temperatures_degc": [25.0] * len(service.nodes)}
        for building, key in service.keys.items():
            measured = service.client.post(
                f"/v1/buildings/{building}/measurements?wait_s=10",
                json=body,
                headers=service.headers(key),
            )
            assert measured.status_code == 200, measured.text
        yield service
    finally:
        next(services, None)  # closes the client and the app


@pytest.fixture(scope="module")
def offering_service(make_db_url: Callable[[str], str]) -> Iterator[Service]:
    """An app with one building, ``c1``, whose offers are decided at each period's start
    (``reserve.commit_ahead_periods = 0``), so that the first period measured already offers."""
    body = registration("c1", **{"reserve.commit_ahead_periods": 0})
    yield from _service(make_db_url("offering"), [body])


@pytest.fixture
def server_factory(make_db_url: Callable[[str], str], tmp_path: Path) -> Iterator[Any]:
    servers: list[Server] = []

    def make(name: str = "service") -> Server:
        server = Server(make_db_url(f"{tmp_path.name}-{name}"), free_port())
        servers.append(server)
        return server

    yield make
    for server in servers:
        server.stop()
