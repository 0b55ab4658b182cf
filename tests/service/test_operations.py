"""Operations: /v1/metrics (Prometheus text), the JSON access log, stale buildings left out
of the aggregate bid, and the checks `serve` runs before it starts."""

from __future__ import annotations

import json
import logging
import socket
import ssl
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from service_fixtures import START
from sqlalchemy import update

from hvacflex.errors import InputError
from hvacflex.service.app import create_app
from hvacflex.service.db import Measurement
from hvacflex.service.keys import create_key
from hvacflex.service.operations import (
    ACCESS_LOGGER,
    LATENCY_BUCKETS_S,
    JsonFormatter,
    check_listen_address,
    check_plain_http,
    check_tls,
    is_loopback,
    service_url,
    stale_buildings,
    tls_minimum_version,
)

STALE_AFTER_S = 600.0


def _room(building_id: str) -> dict[str, Any]:
    return {
        "building_id": building_id,
        "building": {"name": "room1"},
        "scenario": {"preset": "rmpc", "start": START, "days": 1},
    }


@pytest.fixture(scope="module")
def fleet(make_db_url: Callable[[str], str]) -> tuple[TestClient, dict[str, str], Any]:
    """Two room1 buildings, each with a plan of period 0."""
    app = create_app(make_db_url("ops"), stale_after_s=STALE_AFTER_S)
    with app.state.sessions() as session, session.begin():
        operator = create_key(session, "operator")
    client = TestClient(app)
    headers = {"X-API-Key": operator}
    keys: dict[str, str] = {}
    for building_id in ("r1", "r2"):
        registered = client.post("/v1/buildings", json=_room(building_id), headers=headers)
        assert registered.status_code == 201, registered.text
        keys[building_id] = registered.json()["payload"]["key"]
        nodes = registered.json()["payload"]["nodes"]
        measured = client.post(
            f"/v1/buildings/{building_id}/measurements?wait_s=10",
            json={"time": f"{START}T00:00", "node_temperatures_degc": [24.0] * len(nodes)},
            headers={"X-API-Key": keys[building_id]},
        )
        assert measured.status_code == 200, measured.text
    keys["operator"] = operator
    return client, keys, app


def _metrics(client: TestClient) -> dict[str, float]:
    response = client.get("/v1/metrics")
    assert response.status_code == 200
    assert response.headers["content-type"].startswith("text/plain; version=0.0.4")
    values: dict[str, float] = {}
    for line in response.text.splitlines():
        if line and not line.startswith("#"):
            name, value = line.rsplit(" ", 1)
            values[name] = float(value)
    return values


def test_a_stale_building_is_left_out_of_the_bid(fleet: Any) -> None:
    client, keys, app = fleet
    headers = {"X-API-Key": keys["operator"]}
    both = client.get("/v1/bid", headers=headers).json()["payload"]
    assert both["stale_buildings"] == [] and len(both["buildings"]) == 2
    alone = client.get("/v1/buildings/r2/plan", headers=headers).json()["payload"]
    old = datetime.now(UTC) - timedelta(seconds=STALE_AFTER_S + 60)
    with app.state.sessions() as session, session.begin():
        session.execute(
            update(Measurement).where(Measurement.building_id == "r1").values(received_at=old)
        )
    with app.state.sessions() as session:
        assert stale_buildings(session, STALE_AFTER_S) == ["r1"]
        assert stale_buildings(session, STALE_AFTER_S, now=old) == []
    bid = client.get("/v1/bid", headers=headers).json()
    assert bid["payload"]["stale_buildings"] == ["r1"]
    assert [b["building_id"] for b in bid["payload"]["buildings"]] == ["r2"]
    assert "1 stale left out" in bid["message"]
    expected = [r or 0.0 for r in alone["horizon_reserve_kw"]]
    assert bid["payload"]["reserve_kw"] == pytest.approx(expected, rel=1e-12)
    metrics = _metrics(client)
    assert metrics["hvacflex_stale_buildings"] == 1.0
    assert metrics["hvacflex_buildings"] == 2.0
    with app.state.sessions() as session, session.begin():
        session.execute(
            update(Measurement)
            .where(Measurement.building_id == "r1")
            .values(received_at=datetime.now(UTC))
        )


def test_metrics_count_requests_latencies_and_plans(fleet: Any) -> None:
    client, keys, _ = fleet
    headers = {"X-API-Key": keys["operator"]}
    before = _metrics(client)
    route = 'method="GET",route="/v1/buildings/{building_id}/plan"'
    ok = f'hvacflex_http_requests_total{{{route},status="200"}}'
    for _ in range(3):
        assert client.get("/v1/buildings/r1/plan", headers=headers).status_code == 200
    assert client.get("/v1/no-such-route").status_code == 404
    after = _metrics(client)
    assert after[ok] - before.get(ok, 0.0) == 3.0
    assert after['hvacflex_http_requests_total{method="GET",route="unmatched",status="404"}'] >= 1
    name = "hvacflex_http_request_duration_seconds"
    count = after[f"{name}_count{{{route}}}"]
    assert after[f'{name}_bucket{{{route},le="+Inf"}}'] == count >= 3
    buckets = [after[f'{name}_bucket{{{route},le="{b:g}"}}'] for b in LATENCY_BUCKETS_S]
    assert buckets == sorted(buckets) and buckets[-1] <= count
    assert 0.0 < after[f"{name}_sum{{{route}}}"] < count * LATENCY_BUCKETS_S[-1]
    assert after['hvacflex_plans_total{trigger="measurement"}'] == 2.0
    assert after["hvacflex_solver_failures_total"] == 0.0


def test_every_request_is_logged_as_json(fleet: Any, caplog: pytest.LogCaptureFixture) -> None:
    client, keys, _ = fleet
    with caplog.at_level(logging.INFO, logger=ACCESS_LOGGER):
        client.get("/v1/buildings/r2", headers={"X-API-Key": keys["r2"]})
    records = [r for r in caplog.records if r.name == ACCESS_LOGGER]
    assert len(records) == 1
    line = json.loads(JsonFormatter().format(records[0]))
    assert line["message"] == "request" and line["level"] == "info"
    assert line["route"] == "/v1/buildings/{building_id}" and line["path"] == "/v1/buildings/r2"
    assert line["status"] == 200 and line["duration_s"] > 0
    assert line["key_id"] == keys["r2"].split("_")[1]
    assert datetime.fromisoformat(line["time"]).tzinfo is not None


def test_the_listen_address_is_checked_before_start() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(InputError, match=r"cannot listen on 127\.0\.0\.1"):
            check_listen_address("127.0.0.1", port)
    check_listen_address("127.0.0.1", port)  # free again
    for host in ("999.1.1.1", "1.2.3", "no such host.invalid"):
        with pytest.raises(InputError) as info:
            check_listen_address(host, 8000)
        assert info.value.field == "--host"


def test_tls_needs_both_files_that_load(tmp_path: Path) -> None:
    assert check_tls(None, None) is False
    (tmp_path / "cert.pem").write_text("not a certificate")
    (tmp_path / "key.pem").write_text("not a key")
    with pytest.raises(InputError, match="needs both"):
        check_tls(tmp_path / "cert.pem", None)
    with pytest.raises(InputError, match="no such file"):
        check_tls(tmp_path / "missing.pem", tmp_path / "key.pem")
    with pytest.raises(InputError, match="not a PEM certificate"):
        check_tls(tmp_path / "cert.pem", tmp_path / "key.pem")


def test_plain_http_only_on_loopback_unless_told() -> None:
    for host in ("127.0.0.1", "127.0.0.2", "localhost"):
        assert is_loopback(host), host
        check_plain_http(host, tls=False, insecure_http=False)
    assert is_loopback("::1") or not socket.has_ipv6
    for host in ("0.0.0.0", "::", "192.0.2.1", "no such host.invalid"):
        assert not is_loopback(host), host
        with pytest.raises(InputError, match="in clear") as info:
            check_plain_http(host, tls=False, insecure_http=False)
        assert "--insecure-http" in str(info.value) and "--ssl-certfile" in str(info.value)
        check_plain_http(host, tls=True, insecure_http=False)  # TLS: keys are encrypted
        check_plain_http(host, tls=False, insecure_http=True)  # told: a TLS proxy in front


def test_tls_minimum_versions() -> None:
    assert tls_minimum_version("1.2") is ssl.TLSVersion.TLSv1_2
    assert tls_minimum_version("1.3") is ssl.TLSVersion.TLSv1_3
    for bad in ("1.1", "1.0", "tls1.3", ""):
        with pytest.raises(InputError, match=r"1\.2, 1\.3") as info:
            tls_minimum_version(bad)
        assert info.value.field == "--ssl-min-version"


def test_service_url() -> None:
    assert service_url("127.0.0.1", 8000, tls=False) == "http://127.0.0.1:8000/"
    assert service_url("::1", 8443, tls=True) == "https://[::1]:8443/"
