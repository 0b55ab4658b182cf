"""The service's own pages: self-hosted, out of the schema, and the dashboard in a real
headless Chromium (register a building, post a measurement, see its plan on the page)."""

from __future__ import annotations

import os
import re
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pandas as pd
import pytest
import uvicorn
from service_fixtures import START, Service, free_port, registration

from hvacflex.service.app import create_app
from hvacflex.service.dashboard import CONTENT_SECURITY_POLICY, page_html
from hvacflex.service.keys import create_key

SVG_NAMESPACE = "http://www.w3.org/2000/svg"
"""The one absolute URL in the dashboard's script: a name, never requested."""


@pytest.mark.parametrize("path", ["/", "/v1/docs"])
def test_pages_are_self_hosted(service: Service, path: str) -> None:
    response = service.client.get(path)
    assert response.status_code == 200
    assert response.headers["content-type"].startswith("text/html")
    assert response.headers["content-security-policy"] == CONTENT_SECURITY_POLICY
    text = response.text.replace(SVG_NAMESPACE, "")
    assert not re.search(r"https?://|//cdn|swagger", text, flags=re.IGNORECASE)
    assert '<link rel="icon" href="data:,">' in text  # no favicon request (a 404)


def test_pages_stay_out_of_the_schema_and_activations_are_listed(service: Service) -> None:
    paths = service.client.get("/v1/openapi.json").json()["paths"]
    assert "/" not in paths and "/v1/docs" not in paths
    assert "/v1/activations" in paths
    listed = service.client.get("/v1/activations", headers=service.op())
    assert listed.status_code == 200 and isinstance(listed.json()["payload"], list)
    refused = service.client.get("/v1/activations", headers=service.headers(service.keys["b1"]))
    assert refused.status_code == 403


def test_dashboard_asks_for_the_key_in_the_page() -> None:
    page = page_html("dashboard.html")
    assert 'type="password"' in page and '"X-API-Key": operatorKey' in page
    assert "location" not in page and "?key" not in page  # never read from / put in a URL


@pytest.fixture
def live_service(tmp_path: Path) -> Iterator[tuple[str, str]]:
    """A real uvicorn server in a thread on a free port, and its operator key."""
    app = create_app(f"sqlite:///{tmp_path / 'page.db'}")
    with app.state.sessions() as session, session.begin():
        operator_key = create_key(session, "operator")
    port = free_port()
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="error"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started and time.monotonic() < deadline:
        time.sleep(0.05)
    assert server.started
    yield f"http://127.0.0.1:{port}", operator_key
    server.should_exit = True
    thread.join(timeout=10)


def test_dashboard_in_headless_chromium(chromium: Any, live_service: tuple[str, str]) -> None:
    url, operator_key = live_service
    # a browser elsewhere, on a 12-hour clock: the page still shows the buildings' time
    page = chromium.new_page(
        viewport={"width": 1280, "height": 900}, timezone_id="America/New_York", locale="en-US"
    )
    errors: list[str] = []
    requests: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("request", lambda r: requests.append(r.url))
    page.goto(f"{url}/", wait_until="load")
    page.fill("#key", operator_key)
    page.click("button[type=submit]")
    page.wait_for_selector("text=No building registered.")

    op = {"X-API-Key": operator_key}
    with httpx.Client(base_url=url, timeout=60) as client:
        registered = client.post("/v1/buildings", json=registration("b1"), headers=op)
        assert registered.status_code == 201, registered.text
        key, nodes = registered.json()["payload"]["key"], registered.json()["payload"]["nodes"]
        measured = client.post(
            "/v1/buildings/b1/measurements?wait_s=10",
            json={"time": f"{START}T08:00", "node_temperatures_degc": [25.0] * len(nodes)},
            headers={"X-API-Key": key},
        )
        assert measured.status_code == 200, measured.text
        limit = client.post("/v1/signals/feeder-limit", json={"limit_kw": 25.0}, headers=op)
        assert limit.status_code == 200, limit.text

    # the page refreshes by itself: the plan, its chart and the bid appear without a reload
    page.wait_for_selector('[data-building="b1"] svg.chart', timeout=30_000)
    assert f"b1: plan of period 16 ({START} 08:00 Asia/Singapore)" in page.inner_text("#buildings")
    assert page.locator('[data-building="b1"] svg.temperatures path').count() == 5  # zones
    assert "feeder limit of 25.0 kW" in page.inner_text("#bid")
    assert page.locator("#bid svg.chart").count() == 1
    audit = page.inner_text("#audit")
    assert "/v1/buildings/b1/measurements" in audit and "/v1/signals/feeder-limit" in audit
    # one clock: the buildings' zone, named, 24-hour; the audit's UTC records converted
    text = page.inner_text("main")
    assert "All times are the buildings' local time, Asia/Singapore (UTC+08:00)" in text
    assert not re.search(r"\b(AM|PM)\b", text) and "(UTC)" not in text
    assert "at (Asia/Singapore)" in audit
    now_sgt = pd.Timestamp.now(tz="Asia/Singapore")
    stamps = re.findall(r"\d{4}-\d\d-\d\d \d\d:\d\d", audit)
    assert stamps and all(
        abs((pd.Timestamp(s, tz="Asia/Singapore") - now_sgt).total_seconds()) < 600 for s in stamps
    )  # the audit's UTC times shown in Singapore time, not 8 h off
    assert errors == []
    assert all(r.startswith(url) or r.startswith("data:") for r in requests), requests
    assert not any(operator_key in r for r in requests)
    shots = os.environ.get("HVACFLEX_SCREENSHOT_DIR")
    if shots:
        page.screenshot(path=str(Path(shots) / "service_dashboard.png"), full_page=True)
    page.close()
