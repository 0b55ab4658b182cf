"""The service's live mode (``hvacflex serve --live``): buildings plan on real dates, the
typical-year weather and the prices of the mapped day of the 2014 data unless posted."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from fastapi.testclient import TestClient

from hvacflex.constants import PERIOD
from hvacflex.data.calendar import live_price_index
from hvacflex.data.market import load_usep
from hvacflex.paths import data_dir
from hvacflex.service.app import create_app
from hvacflex.service.keys import create_key

TZ = "Asia/Singapore"


def _app(db: Path, live: bool) -> tuple[Any, TestClient, str]:
    app = create_app(f"sqlite:///{db}", live=live)
    with app.state.sessions() as session, session.begin():
        key = create_key(session, "operator")
    return app, TestClient(app), key


@pytest.fixture
def live(tmp_path: Path) -> Iterator[tuple[TestClient, str]]:
    app, client, key = _app(tmp_path / "live.db", live=True)
    yield client, key
    client.close()
    app.state.planner.shutdown()
    app.state.engine.dispose()


def _registration(start: str, **settings: Any) -> dict[str, Any]:
    return {
        "building_id": "b1",
        "building": {"name": "office5"},
        "scenario": {"preset": "rmpc", "start": start, "days": 2, "settings": settings},
    }


def test_a_live_service_plans_now_on_the_mapped_prices_until_prices_are_posted(
    live: tuple[TestClient, str],
) -> None:
    client, key = live
    op = {"X-API-Key": key}
    now = pd.Timestamp.now(tz=TZ).floor("30min")
    registered = client.post("/v1/buildings", json=_registration(f"{now:%Y-%m-%d}"), headers=op)
    assert registered.status_code == 201, registered.text
    payload = registered.json()["payload"]
    building_key, nodes = payload["key"], len(payload["nodes"])
    info = client.get("/v1/buildings/b1", headers=op).json()["payload"]
    assert info["scenario"]["settings"]["data.calendar"] == "live"  # stored: a restart keeps it

    def measure(time: pd.Timestamp) -> dict[str, Any]:
        body = {"time": time.isoformat(), "node_temperatures_degc": [24.5] * nodes}
        path = "/v1/buildings/b1/measurements?wait_s=10"
        response = client.post(path, json=body, headers={"X-API-Key": building_key})
        assert response.status_code == 200, response.text
        plan: dict[str, Any] = response.json()["payload"]
        return plan

    first = measure(now)
    assert pd.Timestamp(first["time"]) == now
    horizon = pd.DatetimeIndex([pd.Timestamp(t) for t in first["horizon_time"]])
    usep = load_usep(data_dir() / "nems_usep_2014")["energy_price_sgd_per_mwh"]
    lookup, mapped = live_price_index(horizon, pd.DatetimeIndex(usep.index))
    assert mapped.all() and all(t.year == 2014 for t in lookup)
    assert first["horizon_energy_price_sgd_per_mwh"] == pytest.approx(usep.loc[lookup].tolist())

    # prices posted for today's next hour replace the fallback there
    nxt = now + pd.Timedelta(minutes=30)
    body = {"start": nxt.isoformat(), "energy_price_sgd_per_mwh": [321.0, 654.0]}
    assert client.post("/v1/signals/prices", json=body, headers=op).status_code == 200
    second = measure(nxt)
    assert second["horizon_energy_price_sgd_per_mwh"][:2] == [321.0, 654.0]
    assert second["horizon_energy_price_sgd_per_mwh"][2] == pytest.approx(usep.loc[lookup[3]])
    # activations and the clock on real times are taken
    start = {"event": "start", "time": nxt.isoformat(), "building_ids": ["b1"]}
    assert client.post("/v1/activations", json=start, headers=op).status_code == 200


def test_real_dates_are_refused_without_the_live_mode(tmp_path: Path) -> None:
    app, client, key = _app(tmp_path / "data.db", live=False)
    try:
        response = client.post(
            "/v1/buildings",
            json=_registration("2026-12-02", **{"data.calendar": "live"}),
            headers={"X-API-Key": key},
        )
        assert response.status_code == 422
        assert "scenario.settings.data.calendar" in response.text and "--live" in response.text
        prices = {"start": "2026-12-02T10:00+08:00", "energy_price_sgd_per_mwh": [100.0]}
        response = client.post("/v1/signals/prices", json=prices, headers={"X-API-Key": key})
        assert response.status_code == 422 and "outside the times" in response.text
    finally:
        client.close()
        app.state.planner.shutdown()
        app.state.engine.dispose()


def test_a_posted_outdoor_temperature_forecast_replaces_the_typical_year(
    live: tuple[TestClient, str],
) -> None:
    client, key = live
    op = {"X-API-Key": key}
    now = pd.Timestamp.now(tz=TZ).floor("30min")
    keys: dict[str, str] = {}
    nodes = 0
    for building_id in ("b1", "b2"):  # the same building twice
        body = _registration(f"{now:%Y-%m-%d}")
        body["building_id"] = building_id
        payload = client.post("/v1/buildings", json=body, headers=op).json()["payload"]
        keys[building_id], nodes = payload["key"], len(payload["nodes"])

    def plan(building_id: str) -> dict[str, Any]:
        body = {"time": now.isoformat(), "node_temperatures_degc": [24.5] * nodes}
        path = f"/v1/buildings/{building_id}/measurements?wait_s=10"
        response = client.post(path, json=body, headers={"X-API-Key": keys[building_id]})
        assert response.status_code == 200, response.text
        made: dict[str, Any] = response.json()["payload"]
        return made

    typical = plan("b1")
    hot = {"start": now.isoformat(), "outdoor_temp_degc": [40.0] * 49}
    assert client.post("/v1/signals/weather", json=hot, headers=op).status_code == 200
    posted = plan("b2")  # the same state and period, planned on the posted forecast
    # 40 °C outdoor air costs more coil power than the typical year's ~25–32 °C
    assert sum(posted["horizon_power_kw"]) > sum(typical["horizon_power_kw"]) + 10.0
    bad = {"start": now.isoformat(), "outdoor_temp_degc": [70.0]}
    response = client.post("/v1/signals/weather", json=bad, headers=op)
    assert response.status_code == 422 and "outdoor_temp_degc[0]" in response.text
    # the humidity beside it: stored and in force for its periods, the later post winning
    humid = {
        **hot,
        "outdoor_temp_degc": [31.0] * 2,
        "outdoor_humidity_ratio_kg_per_kg": [0.026] * 2,
    }
    assert client.post("/v1/signals/weather", json=humid, headers=op).status_code == 200
    app = client.app
    with app.state.sessions() as session:  # type: ignore[attr-defined]
        signals = app.state.runtime.signals(session)  # type: ignore[attr-defined]
    utc = now.tz_convert("UTC")
    assert signals.outdoor_humidity_ratio_kg_per_kg == {utc: 0.026, utc + PERIOD: 0.026}
    assert (
        signals.outdoor_temp_degc[utc] == 31.0
        and signals.outdoor_temp_degc[utc + 2 * PERIOD] == 40.0
    )
    # a humidity in g/kg instead of kg/kg is refused naming the entry
    slip = {**humid, "outdoor_humidity_ratio_kg_per_kg": [18.0]}
    response = client.post("/v1/signals/weather", json=slip, headers=op)
    assert response.status_code == 422 and "outdoor_humidity_ratio_kg_per_kg[0]" in response.text
