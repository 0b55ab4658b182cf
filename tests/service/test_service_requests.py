"""Strict requests: no coercion, values the service cannot plan with refused with the allowed
range, every error (400, 404, 405, 413, 422, 429) in the envelope and in the OpenAPI schema,
no server paths in messages."""

from __future__ import annotations

import hashlib
import http.client
from typing import Any

import pytest
from service_fixtures import START, Service, operator_key_for
from sqlalchemy import create_engine, select

from hvacflex.service.app import plannable_span
from hvacflex.service.db import AuditEntry

ENVELOPE = {"status", "message", "payload"}


def _post(service: Service, path: str, body: Any) -> Any:
    response = service.client.post(path, json=body, headers=service.op())
    assert set(response.json()) == ENVELOPE
    assert response.json()["status"] == response.status_code
    return response


@pytest.mark.parametrize(
    ("path", "body", "field"),
    [
        ("/v1/signals/peak-price", {"peak_price_sgd_per_kw": False}, "peak_price_sgd_per_kw"),
        ("/v1/signals/peak-price", {"peak_price_sgd_per_kw": "1.5"}, "peak_price_sgd_per_kw"),
        ("/v1/signals/feeder-limit", {"limit_kw": True}, "limit_kw"),
        ("/v1/clock", {"time": 0}, "time"),
        ("/v1/activations", {"event": "start", "time": 1393804800}, "time"),
        (
            "/v1/signals/prices",
            {
                "start": START,
                "energy_price_sgd_per_mwh": [1.0],
                "reserve_price_sgd_per_mwh": [False],
            },
            "reserve_price_sgd_per_mwh[0]",
        ),
        ("/v1/signals/prices", {"start": START, "energy_price_sgd_per_mwh": [True]}, None),
    ],
)
def test_no_coercion(service: Service, path: str, body: Any, field: str | None) -> None:
    response = _post(service, path, body)
    assert response.status_code == 422, response.text
    if field is not None:
        assert f"field '{field}'" in response.json()["message"]
        assert response.json()["payload"][0]["field"] == field


def test_integers_are_numbers_and_iso_strings_are_times(service: Service) -> None:
    assert _post(service, "/v1/signals/feeder-limit", {"limit_kw": 5000}).status_code == 200
    assert _post(service, "/v1/clock", {"time": f"{START}T00:00+08:00"}).status_code == 200


@pytest.mark.parametrize(
    ("path", "body", "field"),
    [
        ("/v1/signals/prices", {"start": "2015-01-01", "energy_price_sgd_per_mwh": [1.0]}, "start"),
        (
            "/v1/signals/prices",
            {"start": "2013-12-31T23:30", "energy_price_sgd_per_mwh": [1.0]},
            "start",
        ),
        (
            "/v1/signals/prices",
            {"start": "2014-12-31T23:30", "energy_price_sgd_per_mwh": [1.0, 1.0]},
            "energy_price_sgd_per_mwh[1]",
        ),
        ("/v1/clock", {"time": "1970-01-01T00:00:00Z"}, "time"),
        ("/v1/activations", {"event": "end", "time": "2030-01-01"}, "time"),
    ],
)
def test_times_outside_the_price_data_are_refused_with_the_range(
    service: Service, path: str, body: Any, field: str
) -> None:
    first, last = plannable_span()
    assert (first.isoformat(), last.isoformat()) == (
        "2014-01-01T00:00:00+08:00",
        "2014-12-31T23:30:00+08:00",
    )
    response = _post(service, path, body)
    assert response.status_code == 422
    message = response.json()["message"]
    assert f"field '{field}'" in message and first.isoformat() in message, message


@pytest.mark.parametrize(
    "time", ["9999-01-01", "0001-01-01", "9999-12-31T23:59:59-12:00", "0001-01-01T00:00+14:00"]
)
def test_absurd_years_are_refused_by_the_schema(service: Service, time: str) -> None:
    for path, body, field in [
        ("/v1/signals/prices", {"start": time, "energy_price_sgd_per_mwh": [1.0]}, "start"),
        ("/v1/clock", {"time": time}, "time"),
        ("/v1/activations", {"event": "start", "time": time}, "time"),
    ]:
        response = _post(service, path, body)
        assert response.status_code == 422, (path, time, response.text)
        assert f"field '{field}'" in response.json()["message"]
        assert "1900–2199" in response.json()["message"]


def test_prices_beyond_the_cap_are_refused_with_the_cap(service: Service) -> None:
    for body, field, bound in [
        ({"energy_price_sgd_per_mwh": [1.0, 4500.01]}, "energy_price_sgd_per_mwh[1]", "4500"),
        ({"energy_price_sgd_per_mwh": [-4501.0]}, "energy_price_sgd_per_mwh[0]", "-4500"),
        (
            {"energy_price_sgd_per_mwh": [1.0], "reserve_price_sgd_per_mwh": [-1.0]},
            "reserve_price_sgd_per_mwh[0]",
            "0",
        ),
    ]:
        response = _post(service, "/v1/signals/prices", {"start": START, **body})
        assert response.status_code == 422
        assert f"field '{field}'" in response.json()["message"]
        assert response.json()["message"].rstrip().endswith(bound), response.json()["message"]


def test_unknown_paths_and_methods_answer_in_the_envelope(service: Service) -> None:
    missing = service.client.get("/v1/no-such-route", headers=service.op())
    assert missing.status_code == 404 and set(missing.json()) == ENVELOPE
    for method, path, allow in [
        ("OPTIONS", "/v1/buildings", "GET, POST"),
        ("DELETE", "/v1/buildings", "GET, POST"),
        ("PUT", "/v1/buildings/b1/plan", "GET"),
        ("GET", "/v1/clock", "POST"),
    ]:
        response = service.client.request(method, path, headers=service.op())
        assert response.status_code == 405, (method, path)
        assert response.headers["Allow"] == allow, (method, path)
        assert response.json() == {
            "status": 405,
            "message": "Method Not Allowed",
            "payload": None,
        }


@pytest.mark.parametrize(
    "body",
    [b"\xff\xfe{}", b'{"time": ', b"[" * 100_000 + b"]" * 100_000, b'{"time": "\xe9"}'],
    ids=["not-utf8", "truncated", "deeply-nested", "latin1-inside"],
)
def test_bodies_that_are_not_json_get_400_in_the_envelope(service: Service, body: bytes) -> None:
    response = service.client.post(
        "/v1/clock", content=body, headers={**service.op(), "Content-Type": "application/json"}
    )
    assert response.status_code == 400, response.text
    assert set(response.json()) == ENVELOPE and response.json()["status"] == 400


def test_messages_name_no_server_path(service: Service) -> None:
    body = {
        "building_id": "late",
        "building": {"name": "office5"},
        "scenario": {"preset": "rmpc", "start": "2030-01-01", "days": 1},
    }
    response = _post(service, "/v1/buildings", body)
    assert response.status_code == 422
    message = response.json()["message"]
    assert "outside the USEP price data" in message and "2014-01-01" in message
    assert "/" not in message.split("(got")[0], message
    assert "site-packages" not in response.text and "/src/" not in response.text


def test_every_error_is_in_the_openapi_schema(service: Service) -> None:
    schema = service.client.get("/v1/openapi.json").json()
    for path, operations in schema["paths"].items():
        for method, operation in operations.items():
            codes = set(operation["responses"])
            assert {"400", "404", "405", "413", "422", "503"} <= codes, (method, path)
            if operation.get("security"):
                assert {"401", "403", "429"} <= codes, (method, path)
            ref = operation["responses"]["422"]["content"]["application/json"]["schema"]["$ref"]
            assert ref.endswith("/ErrorEnvelope"), (method, path)
    assert "HTTPValidationError" not in schema["components"]["schemas"]


BAD_PAYLOADS = {
    "nul": b"\x00",
    "nul-ff-garbage": b"\x00\xff garbage",
    "invalid-utf8": b"\xff\xfe{}",
    "json-nul-in-string": b'{"time": "2014-03-03T08:00:00+08:00\\u0000"}',
    "json-lone-surrogate": b'{"time": "\\ud800"}',
}
"""Bodies PostgreSQL cannot store as text as they are (NUL, bytes that are not UTF-8, a
lone surrogate), each answered and audited on every database."""


def _latest_audit(db_url: str) -> AuditEntry:
    engine = create_engine(db_url)
    try:
        with engine.connect() as connection:
            row = connection.execute(
                select(AuditEntry).order_by(AuditEntry.id.desc()).limit(1)
            ).one()
    finally:
        engine.dispose()
    return row  # type: ignore[return-value]


@pytest.mark.parametrize("body", BAD_PAYLOADS.values(), ids=BAD_PAYLOADS.keys())
@pytest.mark.parametrize("route", ["measurement", "clock"])
def test_bad_payloads_are_refused_and_audited_on_every_database(
    service: Service, route: str, body: bytes
) -> None:
    path, key = (
        ("/v1/buildings/b1/measurements", service.keys["b1"])
        if route == "measurement"
        else ("/v1/clock", service.operator_key)
    )
    headers = {**service.headers(key), "Content-Type": "application/json"}
    response = service.client.post(path, content=body, headers=headers)
    assert response.status_code in (400, 422), response.text
    assert set(response.json()) == ENVELOPE and response.json()["status"] == response.status_code
    row = _latest_audit(service.db_url)
    assert row.path == path and row.status_code == response.status_code
    assert row.body_sha256 == hashlib.sha256(body).hexdigest()
    assert "\x00" not in row.body_head
    if body.startswith(b"\x00"):
        assert row.body_head.startswith("\\x00"), row.body_head  # escaped, still visible
    if b"\xff" in body:
        assert "\\xff" in row.body_head, row.body_head
    assert service.client.get("/v1/health").status_code == 200


def test_a_nul_in_the_path_is_answered_on_every_database(service: Service) -> None:
    missing = service.client.get("/v1/buildings/b%00x", headers=service.op())
    assert missing.status_code == 404, missing.text
    assert set(missing.json()) == ENVELOPE
    headers = {**service.headers(service.keys["b1"]), "Content-Type": "application/json"}
    other = service.client.post("/v1/buildings/b%00x/measurements", content=b"{}", headers=headers)
    assert other.status_code in (403, 422), other.text
    row = _latest_audit(service.db_url)
    assert row.path == "/v1/buildings/b\\x00x/measurements"


def test_a_bad_payload_keeps_the_connection_of_a_real_server(server_factory: Any) -> None:
    server = server_factory("nul")
    server.start()
    operator = operator_key_for(server.db_url)
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
    try:
        connection.request(
            "POST",
            "/v1/clock",
            body=BAD_PAYLOADS["nul-ff-garbage"],
            headers={"X-API-Key": operator, "Content-Type": "application/json"},
        )
        refused = connection.getresponse()
        assert refused.status == 400 and refused.getheader("content-type") == "application/json"
        assert b'"status":400' in refused.read().replace(b" ", b"")
        socket_before = connection.sock
        assert socket_before is not None  # the server kept the connection open
        connection.request("GET", "/v1/health")
        health = connection.getresponse()
        assert health.status == 200, health.read()
        health.read()
        assert connection.sock is socket_before  # answered on the same connection
    finally:
        connection.close()
        server.stop()
