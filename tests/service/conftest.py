"""Service fixtures: an in-process app on a temporary SQLite file with two buildings, and
real servers (uvicorn subprocesses on 127.0.0.1)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from service_fixtures import Server, Service, free_port, registration

from hvacflex.service.app import create_app
from hvacflex.service.keys import create_key


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """An app with two registered buildings, ``b1`` and ``b2`` (one day each)."""
    db = tmp_path_factory.mktemp("service") / "service.db"
    app = create_app(f"sqlite:///{db}")
    with app.state.sessions() as session, session.begin():
        operator_key = create_key(session, "operator")
    client = TestClient(app)
    keys: dict[str, str] = {}
    nodes: list[str] = []
    for building_id in ("b1", "b2"):
        response = client.post(
            "/v1/buildings", json=registration(building_id), headers={"X-API-Key": operator_key}
        )
        assert response.status_code == 201, response.text
        keys[building_id] = response.json()["payload"]["key"]
        nodes = response.json()["payload"]["nodes"]
    yield Service(client, operator_key, keys, nodes)
    client.close()


@pytest.fixture
def server_factory(tmp_path: Path) -> Iterator[Any]:
    servers: list[Server] = []

    def make(name: str = "service") -> Server:
        server = Server(f"sqlite:///{tmp_path / name}.db", free_port())
        servers.append(server)
        return server

    yield make
    for server in servers:
        server.stop()
