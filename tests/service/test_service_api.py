"""The service API in process: envelope, registration, the loop's triggers, validation."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest
from service_fixtures import START, Service, registration
from sqlalchemy import inspect
from sqlalchemy.engine import make_url

from hvacflex.paths import resolve_building
from hvacflex.service.app import create_app
from hvacflex.service.http import MAX_BODY_BYTES


def _measure(service: Service, building_id: str, time: str, temp: float = 25.0) -> Any:
    body = {"time": time, "node_temperatures_degc": [temp] * len(service.nodes)}
    return service.client.post(
        f"/v1/buildings/{building_id}/measurements?wait_s=10",
        json=body,
        headers=service.headers(service.keys[building_id]),
    )


def test_health_needs_no_key_and_uses_the_envelope(service: Service) -> None:
    response = service.client.get("/v1/health")
    assert response.status_code == 200
    body = response.json()
    assert set(body) == {"status", "message", "payload"}
    assert body["payload"]["database"] == make_url(service.db_url).get_backend_name()


def test_openapi_is_published_with_every_route_under_v1(service: Service) -> None:
    schema = service.client.get("/v1/openapi.json").json()
    assert schema["paths"]
    assert all(path.startswith("/v1/") for path in schema["paths"])
    assert "X-API-Key" in str(schema["components"]["securitySchemes"])


def test_the_openapi_preset_enum_is_every_preset(service: Service) -> None:
    from hvacflex.config.presets import PRESETS

    schema = service.client.get("/v1/openapi.json").json()
    preset = schema["components"]["schemas"]["ScenarioSettings"]["properties"]["preset"]
    assert preset["enum"] == list(PRESETS)
    body = registration("p1")
    body["scenario"]["preset"] = "no-such-preset"
    response = service.client.post(
        "/v1/buildings", json=body, headers=service.headers(service.operator_key)
    )
    assert response.status_code == 422 and "rmpc-ppp" in response.text


def test_migrations_create_the_schema(make_db_url: Callable[[str], str]) -> None:
    url = make_db_url("fresh")
    app = create_app(url)
    tables = set(inspect(app.state.engine).get_table_names())
    assert {"alembic_version", "api_keys", "plans", "measurements", "audit"} <= tables
    again = create_app(url)  # a second start is a no-op upgrade
    assert set(inspect(again.state.engine).get_table_names()) == tables
    for started in (app, again):
        started.state.planner.shutdown()
        started.state.engine.dispose()


def test_migrations_are_packaged() -> None:
    from setuptools import find_packages

    packages = find_packages("src")
    assert "hvacflex.service.migrations" in packages
    assert "hvacflex.service.migrations.versions" in packages


@pytest.mark.parametrize(
    ("settings", "field"),
    [
        ({"data.weather_file": "/etc/passwd"}, "scenario.settings.data.weather_file"),
        ({"usep_source": "/tmp/prices"}, "scenario.settings.usep_source"),
        ({"reserve_source": "x.csv"}, "scenario.settings.reserve_source"),
        ({"activation.file": "a.csv"}, "scenario.settings.activation.file"),
        ({"activation.mode": "file"}, "scenario.settings.activation.mode"),
        ({"building": "/tmp/b.toml"}, "scenario.settings.building"),
        ({"plant.idf": "/etc/passwd"}, "scenario.settings.plant.idf"),
        ({"plant.kind": "energyplus"}, "scenario.settings.plant.kind"),
        (
            {
                "uncertainty.calibrate": {
                    "train": "2014-02-01..2014-02-07",
                    "prediction_errors": "/x",
                }
            },
            "scenario.settings.uncertainty.calibrate",
        ),
        ({"no_such_setting": 1}, "scenario.settings.no_such_setting"),
        ({"horizon_steps": 100_000}, "scenario.settings.controller.horizon_steps"),
        ({"controller.time_limit_s": 1e6}, "scenario.settings.controller.time_limit_s"),
    ],
)
def test_registration_refuses_server_files(
    service: Service, settings: dict[str, Any], field: str
) -> None:
    response = service.client.post(
        "/v1/buildings", json=registration("bad", **settings), headers=service.op()
    )
    assert response.status_code == 422
    assert field in response.json()["message"]


def test_only_settings_that_name_no_file_are_accepted() -> None:
    from hvacflex.config import SCENARIO_PATH_KEYS
    from hvacflex.config.reference import table_docs
    from hvacflex.service.runtime import accepted_setting

    settings = {
        f"{table.path}.{key.key}" if table.path else key.key
        for table in table_docs()
        for key in table.keys
    }
    names_a_file = {".".join(p) for p in SCENARIO_PATH_KEYS} | {"building", "plant.idf"}
    assert names_a_file <= settings
    assert not any(accepted_setting(path) for path in names_a_file)
    assert not accepted_setting("uncertainty.calibrate")  # prediction_errors is a file
    assert not any(accepted_setting(path) for path in settings if path.startswith("plant."))
    accepted = {path for path in settings if accepted_setting(path)}
    assert {"controller.peak_price_sgd_per_kw", "reserve.event_allowance_k", "seed"} <= accepted
    assert {"uncertainty.relative", "activation.mode", "comfort.occupied_degc"} <= accepted


def test_registration_validates_content(service: Service) -> None:
    body = registration("bad")
    body["building"] = {"toml": "zones = ["}
    response = service.client.post("/v1/buildings", json=body, headers=service.op())
    assert response.status_code == 422 and "building.toml" in response.json()["message"]
    body["building"] = {"description": {"zones": []}}
    response = service.client.post("/v1/buildings", json=body, headers=service.op())
    assert response.status_code == 422
    body = registration("bad", days=0)
    response = service.client.post("/v1/buildings", json=body, headers=service.op())
    assert response.status_code == 422 and "scenario.days" in response.json()["message"]
    response = service.client.post("/v1/buildings", json=registration("b1"), headers=service.op())
    assert response.status_code == 409


def test_measurement_plans_and_is_idempotent(service: Service) -> None:
    first = _measure(service, "b1", f"{START}T00:00")
    assert first.status_code == 200, first.text
    plan = first.json()["payload"]
    assert plan["period"] == 0 and plan["status"] == "optimal" and not plan["fallback"]
    assert len(plan["horizon_reserve_kw"]) == 48 and len(plan["horizon_temp_degc"]) == 48
    again = _measure(service, "b1", f"{START}T00:00")
    assert again.status_code == 200
    assert again.json()["payload"]["revision"] == plan["revision"]
    other = _measure(service, "b1", f"{START}T00:00", temp=26.0)
    assert other.status_code == 409 and "'time'" in other.json()["message"]


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"time": f"{START}T00:10"}, "time"),
        ({"time": "2015-06-01T00:00"}, "time"),
        ({"node_temperatures_degc": [25.0]}, "node_temperatures_degc"),
        ({"previous_power_kw": -1.0}, "previous_power_kw"),
        ({"previous_delivered_flow_kg_s": [0.5]}, "previous_delivered_flow_kg_s"),
        ({"previous_delivered_flow_kg_s": [0.5, 1e6, 0.5, 0.5, 0.5]}, "delivered_flow_kg_s[1]"),
        ({"extra": 1}, "extra"),
    ],
)
def test_measurement_errors_name_the_field(
    service: Service, body: dict[str, Any], field: str
) -> None:
    full = {"time": f"{START}T01:00", "node_temperatures_degc": [25.0] * len(service.nodes)}
    full.update(body)
    response = service.client.post(
        "/v1/buildings/b2/measurements", json=full, headers=service.headers(service.keys["b2"])
    )
    assert response.status_code == 422
    assert field in response.json()["message"]


def test_out_of_range_temperature_names_the_element(service: Service) -> None:
    temps = [25.0] * len(service.nodes)
    temps[2] = 150.0
    response = service.client.post(
        "/v1/buildings/b2/measurements",
        json={"time": f"{START}T01:00", "node_temperatures_degc": temps},
        headers=service.headers(service.keys["b2"]),
    )
    assert response.status_code == 422
    assert "node_temperatures_degc[2]" in response.json()["message"]


def test_bodies_are_size_limited(service: Service) -> None:
    big = b'{"x": "' + b"a" * (MAX_BODY_BYTES + 10) + b'"}'
    response = service.client.post(
        "/v1/signals/prices",
        content=big,
        headers={**service.op(), "Content-Type": "application/json"},
    )
    assert response.status_code == 413
    assert response.json()["status"] == 413


def test_prices_change_the_plan(service: Service) -> None:
    base = _measure(service, "b2", f"{START}T02:00").json()["payload"]
    prices = {"start": f"{START}T02:30", "energy_price_sgd_per_mwh": [4000.0] * 47}
    response = service.client.post("/v1/signals/prices", json=prices, headers=service.op())
    assert response.status_code == 200
    dear = _measure(service, "b2", f"{START}T02:30").json()["payload"]
    assert dear["objective_sgd"] > 2 * base["objective_sgd"]
    assert dear["horizon_energy_price_sgd_per_mwh"][:47] == [4000.0] * 47
    assert base["horizon_energy_price_sgd_per_mwh"][1] != 4000.0
    bad = {"start": f"{START}T02:30", "energy_price_sgd_per_mwh": [1e9]}
    response = service.client.post("/v1/signals/prices", json=bad, headers=service.op())
    assert response.status_code == 422 and "energy_price_sgd_per_mwh[0]" in response.text
    # later plans use the shipped prices again where the override does not reach
    reset = {"start": f"{START}T02:30", "energy_price_sgd_per_mwh": [0.0] * 47}
    service.client.post("/v1/signals/prices", json=reset, headers=service.op())


def test_activation_changes_the_plan_at_once(offering_service: Service) -> None:
    service = offering_service
    # a plan with reserve: price the reserve high over the horizon
    prices = {
        "start": f"{START}T08:00",
        "energy_price_sgd_per_mwh": [100.0] * 48,
        "reserve_price_sgd_per_mwh": [3000.0] * 48,
    }
    service.client.post("/v1/signals/prices", json=prices, headers=service.op())
    plan = _measure(service, "c1", f"{START}T10:00", temp=24.5).json()["payload"]
    assert plan["reserve_kw"] > 0, plan
    start = service.client.post(
        "/v1/activations",
        json={"event": "start", "time": f"{START}T10:05", "building_ids": ["c1"]},
        headers=service.op(),
    )
    assert start.status_code == 200, start.text
    (changed,) = start.json()["payload"]["plans"]
    assert changed["il_activated"] and changed["revision"] == plan["revision"] + 1
    curtailed = [u - r for u, r in zip(plan["flow_kg_s"], plan["reserve_flow_kg_s"], strict=True)]
    assert changed["applied_flow_kg_s"] == pytest.approx(curtailed)
    read = service.client.get("/v1/buildings/c1/plan", headers=service.headers(service.keys["c1"]))
    assert read.json()["payload"]["il_activated"]
    end = service.client.post(
        "/v1/activations",
        json={"event": "end", "time": f"{START}T10:20", "building_ids": ["c1"]},
        headers=service.op(),
    )
    (restored,) = end.json()["payload"]["plans"]
    assert not restored["il_activated"]
    assert restored["applied_flow_kg_s"] == pytest.approx(plan["flow_kg_s"])
    unknown = service.client.post(
        "/v1/activations",
        json={"event": "start", "time": f"{START}T10:00", "building_ids": ["nope"]},
        headers=service.op(),
    )
    assert unknown.status_code == 404 and "building_ids[0]" in unknown.json()["message"]


def test_clock_boundary_plans_on_the_latest_measurement(service: Service) -> None:
    response = service.client.post(
        "/v1/clock", json={"time": f"{START}T12:00"}, headers=service.op()
    )
    assert response.status_code == 200
    plans = {p["building_id"]: p for p in response.json()["payload"]["plans"]}
    assert set(plans) == {"b1", "b2"}
    assert all(p["trigger"] == "boundary" and p["period"] == 24 for p in plans.values())
    again = service.client.post("/v1/clock", json={"time": f"{START}T12:10"}, headers=service.op())
    assert again.json()["payload"]["plans"] == []  # period 24 is planned already


def test_aggregate_bid_and_feeder_limit(planned_service: Service) -> None:
    service = planned_service
    service.client.post("/v1/signals/feeder-limit", json={"limit_kw": 1e-3}, headers=service.op())
    bid = service.client.get("/v1/bid", headers=service.op()).json()["payload"]
    plans = service.client.get("/v1/plans", headers=service.op()).json()["payload"]["plans"]
    assert {b["building_id"] for b in bid["buildings"]} == {"b1", "b2"}
    expected = sum(p["horizon_reserve_kw"][0] or 0.0 for p in plans)
    assert bid["reserve_kw"][0] == pytest.approx(expected)
    assert bid["feeder_limit_kw"] == 1e-3 and bid["feeder_limit_exceeded"]
    service.client.post("/v1/signals/feeder-limit", json={"limit_kw": 1e6}, headers=service.op())
    assert not service.client.get("/v1/bid", headers=service.op()).json()["payload"][
        "feeder_limit_exceeded"
    ]


def test_feeder_limit_windows_make_the_schedule_the_bid_is_checked_against(
    planned_service: Service,
) -> None:
    service = planned_service
    op = service.op()
    post = service.client.post
    assert post("/v1/signals/feeder-limit", json={"limit_kw": 1e6}, headers=op).status_code == 200
    daily = {"start": "12:00", "end": "13:00", "limit_kw": 500.0}
    once = {"start": f"{START}T12:30", "end": f"{START}T14:00", "limit_kw": 2e-3}
    response = post("/v1/signals/feeder-limits", json={"windows": [daily]}, headers=op)
    assert response.status_code == 200, response.text
    body = {"windows": [once], "event_id": "evt-1"}
    assert post("/v1/signals/feeder-limits", json=body, headers=op).status_code == 200

    def schedule() -> dict[str, float | None]:
        answer = service.client.get(
            "/v1/feeder-limits", params={"start": f"{START}T11:30", "periods": 6}, headers=op
        ).json()["payload"]
        return dict(zip((t[11:16] for t in answer["time"]), answer["limit_kw"], strict=True))

    assert schedule() == {
        "11:30": 1e6,
        "12:00": 500.0,
        "12:30": 2e-3,  # both windows: the tighter
        "13:00": 2e-3,
        "13:30": 2e-3,
        "14:00": 1e6,
    }
    bid = service.client.get("/v1/bid", headers=op).json()["payload"]
    by_time = dict(zip(bid["time"], bid["feeder_limit_schedule_kw"], strict=True))
    in_window = [t for t in bid["time"] if f"{START}T12:30" <= t[:16] < f"{START}T14:00"]
    assert in_window and all(by_time[t] == 2e-3 for t in in_window)
    assert bid["feeder_limit_exceeded"]  # the plans draw more than 2 W there
    # the event's windows replaced (none: cancelled); the window without an id stays
    body = {"windows": [], "event_id": "evt-1"}
    assert post("/v1/signals/feeder-limits", json=body, headers=op).status_code == 200
    assert set(schedule().values()) == {1e6, 500.0}
    assert not service.client.get("/v1/bid", headers=op).json()["payload"]["feeder_limit_exceeded"]
    audit = service.client.get("/v1/audit", headers=op).json()["payload"]
    assert "feeder_limit_windows" in [a["action"] for a in audit]
    # bad windows: the field named
    bad = post(
        "/v1/signals/feeder-limits",
        json={"windows": [{"start": "11:00", "end": "10:00", "limit_kw": 1.0}]},
        headers=op,
    )
    assert bad.status_code == 422 and "windows" in bad.text
    empty = post("/v1/signals/feeder-limits", json={"windows": []}, headers=op)
    assert empty.status_code in (400, 422) and "event_id" in empty.text
    odd = service.client.get("/v1/feeder-limits", params={"start": f"{START}T09:10"}, headers=op)
    assert odd.status_code in (400, 422) and "period start" in odd.text


def test_peak_price_enters_the_plan(service: Service) -> None:
    before = _measure(service, "b2", f"{START}T13:00").json()["payload"]
    service.client.post(
        "/v1/signals/peak-price", json={"peak_price_sgd_per_kw": 50.0}, headers=service.op()
    )
    after = _measure(service, "b2", f"{START}T13:30").json()["payload"]
    service.client.post(
        "/v1/signals/peak-price", json={"peak_price_sgd_per_kw": 0.0}, headers=service.op()
    )
    assert max(after["horizon_power_kw"]) < max(before["horizon_power_kw"])
    assert after["peak_price_sgd_per_kw"] == 50.0
    assert before["peak_price_sgd_per_kw"] != 50.0


def test_measurements_are_listed_with_their_metered_power(service: Service) -> None:
    response = service.client.post("/v1/buildings", json=registration("m1"), headers=service.op())
    key = response.json()["payload"]["key"]
    for when, power_kw in ((f"{START}T00:00", None), (f"{START}T00:30", 37.5)):
        body = {
            "time": when,
            "node_temperatures_degc": [25.0] * len(service.nodes),
            "previous_power_kw": power_kw,
        }
        measured = service.client.post(
            "/v1/buildings/m1/measurements?wait_s=10", json=body, headers={"X-API-Key": key}
        )
        assert measured.status_code == 200, measured.text
    listed = service.client.get("/v1/buildings/m1/measurements", headers=service.op())
    records = listed.json()["payload"]
    assert [(r["period"], r["time"], r["previous_power_kw"]) for r in records] == [
        (1, "2014-03-03T00:30:00+08:00", 37.5),
        (0, "2014-03-03T00:00:00+08:00", None),
    ]
    newest = service.client.get("/v1/buildings/m1/measurements?limit=1", headers={"X-API-Key": key})
    assert [r["period"] for r in newest.json()["payload"]] == [1]


def test_every_mutating_request_is_audited(service: Service) -> None:
    service.client.post("/v1/signals/peak-price", json={"peak_price_sgd_per_kw": 0.0})  # 401
    records = service.client.get("/v1/audit?limit=1000", headers=service.op()).json()["payload"]
    assert records[0]["status_code"] == 401 and records[0]["key_id"] is None
    methods = {r["method"] for r in records}
    assert methods == {"POST"}
    roles = {r["role"] for r in records}
    assert {"operator", "building"} <= roles


def test_a_refused_dispatch_is_recorded_and_audited_with_its_reason(service: Service) -> None:
    body = {
        "time": "2014-03-03T17:00+08:00",
        "building_ids": ["b1"],
        "reason": "b1 not activated (no reserve offered at 17:00)",
        "event_id": "d1",
    }
    answer = service.client.post("/v1/activations/refused", json=body, headers=service.op())
    assert answer.status_code == 200, answer.json()
    assert answer.json()["payload"]["kind"] == "activation_refused"
    unknown = {**body, "building_ids": ["nope"]}
    missing = service.client.post("/v1/activations/refused", json=unknown, headers=service.op())
    assert missing.status_code == 404 and missing.json()["message"].startswith("field")
    activation = {"event": "end", "time": "2014-03-03T18:00+08:00", "building_ids": ["b1"]}
    assert service.client.post("/v1/activations", json=activation, headers=service.op()).is_success
    records = service.client.get("/v1/audit?limit=3", headers=service.op()).json()["payload"]
    assert [(r["action"], r["status_code"]) for r in records] == [
        ("activation", 200),
        ("activation_refused", 404),
        ("activation_refused", 200),
    ]
    assert "no reserve offered at 17:00" in records[2]["body_head"]


@pytest.mark.parametrize(
    ("method", "path", "action"),
    [
        ("POST", "/v1/activations", "activation"),
        ("POST", "/v1/activations/refused", "activation_refused"),
        ("POST", "/v1/buildings/b1/measurements", "measurement"),
        ("POST", "/v1/buildings", "registration"),
        ("POST", "/v1/buildings/b1/plan", None),
        ("GET", "/v1/activations", None),
    ],
)
def test_audit_actions_name_the_routes(method: str, path: str, action: str | None) -> None:
    from hvacflex.service.app import audit_action

    assert audit_action(method, path) == action


def test_wall_clock_runs_the_boundary_trigger() -> None:
    from hvacflex.service.app import start_wall_clock

    class Probe:
        def __init__(self) -> None:
            self.times: list[Any] = []

        def boundary(self, time: Any) -> list[Any]:
            self.times.append(time)
            return []

    probe = Probe()
    stop = start_wall_clock(probe, poll_s=0.01)  # type: ignore[arg-type]
    deadline = time.monotonic() + 5
    while not probe.times and time.monotonic() < deadline:
        time.sleep(0.01)
    stop.set()
    assert len(probe.times) >= 1
    assert probe.times[0].minute in (0, 30) and probe.times[0].second == 0


def test_a_building_with_a_similar_days_baseline_registers_and_loads(
    make_db_url: Callable[[str], str],
) -> None:
    """``reserve.il_baseline = "similar-days"`` is a setting like any other: a building
    stored with it loads after a restart, and a new one registers (the service builds its
    baselines from the metered power posted, as ``simulate`` does from its plant's)."""
    import json

    from fastapi.testclient import TestClient

    from hvacflex.service.db import BuildingRow
    from hvacflex.service.keys import create_key
    from hvacflex.service.schemas import ScenarioSettings
    from hvacflex.tomlio import read_toml

    url = make_db_url("stored_similar_days")
    app = create_app(url)
    body = registration("old", **{"reserve.il_baseline": "similar-days"})
    with app.state.sessions() as session, session.begin():
        operator_key = create_key(session, "operator")
        session.add(
            BuildingRow(
                building_id="old",
                description_json=json.dumps(read_toml(resolve_building("office5"), what="b")),
                scenario_json=ScenarioSettings.model_validate(body["scenario"]).model_dump_json(),
                created_by="operator",
            )
        )
    app.state.planner.shutdown()
    app.state.engine.dispose()
    restarted = create_app(url)
    with TestClient(restarted) as client:
        headers = {"X-API-Key": operator_key}
        assert client.get("/v1/buildings/old", headers=headers).status_code == 200
        added = client.post("/v1/buildings", json={**body, "building_id": "new"}, headers=headers)
        assert added.status_code == 201, added.json()
    restarted.state.planner.shutdown()
    restarted.state.engine.dispose()


def test_offers_are_scaled_by_the_meter_the_building_posts(service: Service) -> None:
    """A building whose posted meter moves 0.5 kW per kW of its plans: once a few occupied
    periods were planned and metered, the service sizes its offers with ρ = 0.5 (the history
    lives in the stored control-step state); the plan says so in ``offer_meter_ratio``, the
    ρ of the offer committed for the period."""
    response = service.client.post("/v1/buildings", json=registration("rho"), headers=service.op())
    key = response.json()["payload"]["key"]
    planned: float | None = None
    ratios = []
    for step in range(16):  # 08:00 … 15:30
        hour, minute = divmod(8 * 60 + 30 * step, 60)
        body = {
            "time": f"{START}T{hour:02d}:{minute:02d}",
            "node_temperatures_degc": [25.0] * len(service.nodes),
            "previous_power_kw": None if planned is None else 5.0 + 0.5 * planned,
        }
        measured = service.client.post(
            "/v1/buildings/rho/measurements?wait_s=10", json=body, headers={"X-API-Key": key}
        )
        assert measured.status_code == 200, measured.text
        payload = measured.json()["payload"]
        planned = payload["planned_power_kw"]
        ratios.append(payload["offer_meter_ratio"])
    assert ratios[0] is None  # nothing committed for the first period planned
    assert ratios[2] == 1.0  # committed at 08:00, before any meter was read
    assert ratios[-1] == pytest.approx(0.5)
