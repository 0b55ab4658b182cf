"""Auth matrix: every route × no key / unknown key / wrong role / another building's key."""

from __future__ import annotations

from typing import Any

import pytest
from service_fixtures import START, Service

# (method, path template, roles allowed); {b} is the building the request concerns
ROUTES: list[tuple[str, str, set[str]]] = [
    ("POST", "/v1/buildings", {"operator"}),
    ("GET", "/v1/buildings", {"operator"}),
    ("GET", "/v1/buildings/{b}", {"operator", "own"}),
    ("POST", "/v1/buildings/{b}/measurements", {"own"}),
    ("GET", "/v1/buildings/{b}/measurements", {"operator", "own"}),
    ("GET", "/v1/buildings/{b}/plan", {"operator", "own"}),
    ("GET", "/v1/plans", {"operator"}),
    ("POST", "/v1/signals/prices", {"operator"}),
    ("POST", "/v1/signals/weather", {"operator"}),
    ("POST", "/v1/signals/peak-price", {"operator"}),
    ("POST", "/v1/signals/feeder-limit", {"operator"}),
    ("POST", "/v1/signals/feeder-limits", {"operator"}),
    ("GET", "/v1/feeder-limits", {"operator"}),
    ("POST", "/v1/activations", {"operator"}),
    ("GET", "/v1/activations", {"operator"}),
    ("POST", "/v1/activations/refused", {"operator"}),
    ("POST", "/v1/clock", {"operator"}),
    ("GET", "/v1/bid", {"operator"}),
    ("GET", "/v1/audit", {"operator"}),
]
OPEN_ROUTES = {("GET", "/v1/health"), ("GET", "/v1/metrics")}


def _body(service: Service, method: str, path: str) -> dict[str, Any] | None:
    if method != "POST":
        return None
    bodies: dict[str, dict[str, Any]] = {
        "/v1/buildings": {"building_id": "never", "building": {}, "scenario": {}},
        "/v1/buildings/{b}/measurements": {
            "time": f"{START}T05:00",
            "node_temperatures_degc": [25.0] * len(service.nodes),
        },
        "/v1/signals/prices": {"start": START, "energy_price_sgd_per_mwh": [1.0]},
        "/v1/signals/weather": {"start": START, "outdoor_temp_degc": [28.0]},
        "/v1/signals/peak-price": {"peak_price_sgd_per_kw": 0.0},
        "/v1/signals/feeder-limit": {"limit_kw": 1e6},
        "/v1/signals/feeder-limits": {"windows": [], "event_id": "auth-matrix"},
        "/v1/activations": {"event": "end", "time": START},
        "/v1/activations/refused": {"time": START, "building_ids": ["b1"], "reason": "none"},
        "/v1/clock": {"time": START},
    }
    return bodies[path]


def test_the_matrix_covers_every_route(service: Service) -> None:
    schema = service.client.get("/v1/openapi.json").json()
    published = {(m.upper(), p) for p, ops in schema["paths"].items() for m in ops}
    listed = {(m, p.replace("{b}", "{building_id}")) for m, p, _ in ROUTES}
    assert published == listed | OPEN_ROUTES
    for method, path in published - OPEN_ROUTES:
        assert schema["paths"][path][method.lower()].get("security"), (method, path)


@pytest.mark.parametrize(
    ("method", "path", "allowed"), ROUTES, ids=[f"{m} {p}" for m, p, _ in ROUTES]
)
@pytest.mark.parametrize("caller", ["none", "unknown", "operator", "own", "other"])
def test_auth_matrix(
    service: Service, method: str, path: str, allowed: set[str], caller: str
) -> None:
    keys = {
        "none": None,
        "unknown": "hvf_0123456789abcdef_not-a-real-secret",
        "operator": service.operator_key,
        "own": service.keys["b1"],
        "other": service.keys["b2"],
    }
    url = path.replace("{b}", "b1")
    response = service.client.request(
        method, url, json=_body(service, method, path), headers=service.headers(keys[caller])
    )
    body = response.json()
    assert set(body) == {"status", "message", "payload"}
    assert body["status"] == response.status_code
    if caller in ("none", "unknown"):
        assert response.status_code == 401, body
    elif caller in allowed or (caller == "other" and "{b}" not in path and "own" in allowed):
        assert response.status_code not in (401, 403), body
    else:
        assert response.status_code == 403, body
