"""Strict requests: no coercion, values the service cannot plan with refused with the allowed
range, every error (400, 404, 405, 413, 422, 429) in the envelope and in the OpenAPI schema,
no server paths in messages."""

from __future__ import annotations

from typing import Any

import pytest
from service_fixtures import START, Service

from hvacflex.service.app import plannable_span

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
            assert {"400", "404", "405", "413", "422"} <= codes, (method, path)
            if operation.get("security"):
                assert {"401", "403", "429"} <= codes, (method, path)
            ref = operation["responses"]["422"]["content"]["application/json"]["schema"]["$ref"]
            assert ref.endswith("/ErrorEnvelope"), (method, path)
    assert "HTTPValidationError" not in schema["components"]["schemas"]
