"""Helpers of the service tests: registration bodies, the in-process service, a real
server (``hvacflex serve`` subprocess on 127.0.0.1, a free port)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
import uuid
from dataclasses import dataclass
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url

START = "2014-03-03"
POSTGRES_ENV = "HVACFLEX_TEST_POSTGRES_URL"
"""A PostgreSQL URL whose role may create databases: the service tests run there too."""
SERVE = [sys.executable, "-m", "hvacflex.cli", "serve"]
UNLIMITED: dict[str, Any] = {}
"""``create_app(route_limits=UNLIMITED)``: no budget on the costly routes, for tests that
register many buildings or advance the clock quickly with one key (the budgets themselves
are tested in ``test_service_keys.py``)."""
UNLIMITED_OPTIONS = ["--register-limit", "1000000/1", "--clock-limit", "1000000/1"]
"""The same for ``hvacflex serve``."""
SERVE_TEST_OPTIONS = [*UNLIMITED_OPTIONS, "--plan-niceness", "0"]
"""The options the tests' servers run with: no route limits, and planning at the server's own
priority — at the default niceness (19) a test worker busy beside it on the same cores (``-n
2``) leaves the planners so little CPU that a plan misses the tests' waits (measured: a
measurement posted with ``wait_s=10`` answered without its plan)."""


def registration(building_id: str, days: float = 1.0, **settings: Any) -> dict[str, Any]:
    return {
        "building_id": building_id,
        "building": {"name": "office5"},
        "scenario": {"preset": "rmpc", "start": START, "days": days, "settings": settings},
    }


@dataclass
class Service:
    client: TestClient
    operator_key: str
    keys: dict[str, str]
    nodes: list[str]
    db_url: str = ""

    def headers(self, key: str | None) -> dict[str, str]:
        return {} if key is None else {"X-API-Key": key}

    def op(self) -> dict[str, str]:
        return self.headers(self.operator_key)


_RESERVED_PORTS: list[socket.socket] = []
"""The sockets that hold the ports :func:`free_port` gave out, for the life of the process."""


def app_with_building(url: str, building_id: str) -> tuple[TestClient, dict[str, str], Any, Any]:
    """A fresh app on ``url`` (no route budget) with building ``building_id`` registered
    (``rmpc``, office5, one day): its client, the keys by name (``operator`` and the
    building's), the registration's payload and the app. The caller closes the client and
    shuts the app's planner down."""
    from hvacflex.service.app import create_app
    from hvacflex.service.keys import create_key

    app = create_app(url, route_limits=UNLIMITED)
    with app.state.sessions() as session, session.begin():
        operator = create_key(session, "operator")
    client = TestClient(app)
    response = client.post(
        "/v1/buildings", json=registration(building_id), headers={"X-API-Key": operator}
    )
    assert response.status_code == 201, response.text
    payload = response.json()["payload"]
    return client, {"operator": operator, building_id: payload["key"]}, payload, app


def free_port() -> int:
    """A port on 127.0.0.1 that nobody listens on, held for this test process until it ends.

    A port that is only probed (bound to port 0, closed, its number returned) is free for
    anyone until the test's server binds it: another pytest-xdist worker's probe may be given
    the same number, or an outgoing connection (the VEN's polls, a database client) its
    ephemeral port, and the test then fails or talks to the other worker's server, depending
    on which test files run beside it. So the probing socket stays bound (not listening): no
    other probe and no outgoing connection gets the port, while the test's servers, which set
    ``SO_REUSEADDR`` as uvicorn and aiohttp do, may bind and listen on it, one after another.
    """
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))  # without SO_REUSEADDR: never a port some socket holds
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # the server's bind may share it
    _RESERVED_PORTS.append(sock)
    port: int = sock.getsockname()[1]
    return port


@dataclass
class Server:
    """``hvacflex serve`` in a subprocess."""

    db_url: str
    port: int
    process: subprocess.Popen[bytes] | None = None
    log: Any = None
    live: bool = False
    """Start it in live mode (``--live``: real dates)."""

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def start(self, timeout_s: float = 60.0) -> None:
        cmd = [*SERVE, "--db", self.db_url]
        cmd += ["--host", "127.0.0.1", "--port", str(self.port), *SERVE_TEST_OPTIONS]
        cmd += ["--live"] if self.live else []
        # the JSON log goes to a file: a pipe nobody reads would fill and block the server
        self.log = tempfile.TemporaryFile()
        self.process = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=self.log)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                self.log.seek(0)
                raise RuntimeError(f"server exited: {self.log.read()!r}")
            try:
                with urllib.request.urlopen(f"{self.url}/v1/health", timeout=2) as response:
                    if response.status == 200:
                        return
            except OSError:
                time.sleep(0.2)
        raise RuntimeError("server did not start")

    def kill9(self) -> None:
        assert self.process is not None
        os.kill(self.process.pid, signal.SIGKILL)
        self.process.wait(timeout=30)

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.kill9()


def operator_key_for(db_url: str) -> str:
    out = subprocess.run(
        [*SERVE, "key", "create", "--role", "operator", "--db", db_url],
        check=True,
        capture_output=True,
        text=True,
        timeout=120,
    )
    return out.stdout.strip().splitlines()[-1]


def new_postgres_database(base_url: str) -> str:
    """A new, empty database on the server of ``base_url`` (its role may create them)."""
    name = f"hvacflex_t_{uuid.uuid4().hex[:12]}"
    engine = create_engine(base_url, isolation_level="AUTOCOMMIT")
    with engine.connect() as connection:
        connection.execute(text(f'CREATE DATABASE "{name}"'))
    engine.dispose()
    return make_url(base_url).set(database=name).render_as_string(hide_password=False)


def drop_postgres_database(base_url: str, url: str) -> None:
    """Drop a database made by :func:`new_postgres_database` (closing its connections)."""
    name = make_url(url).database
    engine = create_engine(base_url, isolation_level="AUTOCOMMIT")
    with engine.connect() as connection:
        connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    engine.dispose()


def stored_plans(db_url: str) -> dict[tuple[str, int, int], Any]:
    """Every stored plan's objective by (building, period, revision), read with SQL."""
    engine = create_engine(db_url)
    with engine.connect() as connection:
        rows = connection.execute(
            text("SELECT building_id, period, revision, objective_sgd FROM plans")
        ).all()
    engine.dispose()
    return {(b, p, r): o for b, p, r, o in rows}
