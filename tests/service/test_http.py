"""The service's HTTP plumbing on a bare app: the envelope, the error handlers, the body
limit and the audit (the routes' own behaviour is tested through the whole service in
``test_service_api.py``)."""

import threading
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from pydantic import BaseModel
from sqlalchemy import select, text
from sqlalchemy.exc import DataError, IntegrityError, OperationalError
from sqlalchemy.orm import Session, sessionmaker

from hvacflex.errors import InputError
from hvacflex.service.db import AuditEntry, open_database, session_factory
from hvacflex.service.http import (
    MAX_BODY_BYTES,
    PACKAGE_DIR,
    BodyLimitAndAudit,
    add_error_handlers,
    field_name,
    public_message,
)
from hvacflex.service.keys import RateLimitedError
from hvacflex.service.runtime import NotFoundError
from hvacflex.sim.step import ConflictError


class _Body(BaseModel):
    prices: list[float]


def _app(tmp_path: Path) -> tuple[TestClient, sessionmaker[Session]]:
    app = FastAPI()
    add_error_handlers(app)
    errors: dict[str, Exception] = {
        "input": InputError("must be > 0", field="power_kw", value=-1.0),
        "conflict": ConflictError("another measurement is stored for this period"),
        "missing": NotFoundError("no building 'b9'"),
        "limited": RateLimitedError(2.2),
        "bug": KeyError("secret detail"),
        "data": DataError("INSERT …", {}, ValueError("secret value \x00")),
        "integrity": IntegrityError("INSERT …", {}, ValueError("secret row")),
        "operational": OperationalError("SELECT 1", {}, ConnectionError("secret host")),
    }

    @app.get("/raise/{kind}")
    def raise_(kind: str) -> None:
        raise errors[kind]

    @app.post("/echo")
    def echo(body: _Body) -> dict[str, int]:
        return {"n": len(body.prices)}

    sessions = session_factory(open_database(f"sqlite:///{tmp_path / 'http.db'}"))
    app.add_middleware(BodyLimitAndAudit, sessions=sessions)
    return TestClient(app, raise_server_exceptions=False), sessions


@pytest.mark.parametrize(
    ("location", "name"),
    [
        (("body", "prices", 0), "prices[0]"),
        (("body", "zones", 2, "temp_degc"), "zones[2].temp_degc"),
        (("query", "period"), "query.period"),
        (("body",), "body"),
        ((), "body"),
    ],
)
def test_field_name_is_the_field_a_client_wrote(location: tuple[object, ...], name: str) -> None:
    assert field_name(location) == name


def test_public_message_names_files_without_server_paths() -> None:
    error = InputError("cannot read", source="/srv/hvacflex/data/b1/building.toml", field="zones")
    assert public_message(error).startswith("building.toml: field 'zones': cannot read")
    shipped = InputError(f"not found in {PACKAGE_DIR}/resources/buildings")
    assert str(PACKAGE_DIR) not in public_message(shipped)
    assert "hvacflex/resources/buildings" in public_message(shipped)


def test_every_error_is_an_envelope_with_its_status(tmp_path: Path) -> None:
    client, _ = _app(tmp_path)
    answers = {kind: client.get(f"/raise/{kind}") for kind in ("input", "conflict", "missing")}
    assert {kind: r.status_code for kind, r in answers.items()} == {
        "input": 422,
        "conflict": 409,
        "missing": 404,
    }
    named = answers["input"].json()
    assert named["status"] == 422 and named["payload"] == [
        {"field": "power_kw", "message": named["message"]}
    ]
    limited = client.get("/raise/limited")
    assert limited.status_code == 429 and limited.headers["Retry-After"] == "3"
    bug = client.get("/raise/bug")
    assert bug.status_code == 500 and bug.json()["message"] == "internal error (KeyError)"
    assert "secret" not in bug.text  # nothing of a server error's detail leaks


def test_database_errors_are_enveloped_without_the_drivers_text(tmp_path: Path) -> None:
    client, _ = _app(tmp_path)
    answers = {k: client.get(f"/raise/{k}") for k in ("data", "integrity", "operational")}
    assert {k: r.status_code for k, r in answers.items()} == {
        "data": 422,
        "integrity": 409,
        "operational": 503,
    }
    kinds = {"data": "ValueError", "integrity": "ValueError", "operational": "ConnectionError"}
    for name, answer in answers.items():
        assert answer.json()["status"] == answer.status_code
        assert f"({kinds[name]})" in answer.json()["message"]
        assert "secret" not in answer.text  # the driver's text may quote stored data


def test_an_audit_the_database_refuses_is_logged_and_the_answer_goes_out(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    client, sessions = _app(tmp_path)
    with sessions() as session, session.begin():
        session.execute(text("DROP TABLE audit"))
    with caplog.at_level("ERROR", logger="hvacflex.service"):
        answer = client.post("/echo", json={"prices": [1.0]})
    assert answer.status_code == 200 and answer.json() == {"n": 1}
    assert any("audit row not written" in r.getMessage() for r in caplog.records)


def test_validation_errors_name_the_field_and_bad_json_is_400(tmp_path: Path) -> None:
    client, _ = _app(tmp_path)
    invalid = client.post("/echo", json={"prices": [1.0, "x"]})
    assert invalid.status_code == 422
    assert invalid.json()["message"].startswith("field 'prices[1]':")
    broken = client.post(
        "/echo", content=b"{not json", headers={"content-type": "application/json"}
    )
    assert broken.status_code == 400 and broken.json()["status"] == 400


def test_a_wrong_method_is_405_with_the_allowed_ones(tmp_path: Path) -> None:
    client, _ = _app(tmp_path)
    answer = client.get("/echo")
    assert answer.status_code == 405
    assert answer.headers["Allow"] == "POST"
    assert answer.json()["status"] == 405


def test_bodies_over_the_limit_are_refused_and_mutations_audited(tmp_path: Path) -> None:
    client, sessions = _app(tmp_path)
    too_big = client.post(
        "/echo",
        content=b" " * (MAX_BODY_BYTES + 1),
        headers={"content-type": "application/json"},
    )
    assert too_big.status_code == 413 and too_big.json()["status"] == 413
    assert client.post("/echo", json={"prices": [1.0, 2.0]}).json() == {"n": 2}
    client.get("/raise/input")  # a read: not audited
    with sessions() as session:
        rows = session.scalars(select(AuditEntry).order_by(AuditEntry.id)).all()
    assert [(r.method, r.path, r.status_code) for r in rows] == [
        ("POST", "/echo", 413),  # refused unread, audited all the same
        ("POST", "/echo", 200),
    ]
    assert rows[0].body_head == "" and rows[0].key_id is None
    assert rows[1].body_head == '{"prices":[1.0,2.0]}'


def test_the_audit_row_is_written_off_the_event_loop(tmp_path: Path) -> None:
    """A blocking commit (or a wait for a pooled connection) on the event loop would stall
    every request at once: the audit is written in the threadpool, before the answer."""
    app = FastAPI()
    threads: dict[str, int] = {}

    @app.post("/loop")
    async def on_loop() -> dict[str, bool]:
        threads["loop"] = threading.get_ident()
        return {"ok": True}

    sessions = session_factory(open_database(f"sqlite:///{tmp_path / 'loop.db'}"))

    class _Recording(BodyLimitAndAudit):
        def _audit(self, scope: Any, body: bytes, status: int) -> None:
            threads["audit"] = threading.get_ident()
            super()._audit(scope, body, status)

    app.add_middleware(_Recording, sessions=sessions)
    with TestClient(app) as client:
        assert client.post("/loop", json={}).status_code == 200
        too_big = client.post("/loop", content=b" " * (MAX_BODY_BYTES + 1))
    assert too_big.status_code == 413
    assert threads["audit"] != threads["loop"]
    with sessions() as session:
        statuses = [r.status_code for r in session.scalars(select(AuditEntry)).all()]
    assert sorted(statuses) == [200, 413]
