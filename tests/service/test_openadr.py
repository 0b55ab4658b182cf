"""``serve openadr-ven``: the OpenADR 2.0b mapping (hand-computed cases) and, end to end, an
openleadr VTN on 127.0.0.1 driving a registered building through the VEN, with and without
mutual TLS."""

from __future__ import annotations

import os
import subprocess
import tempfile
import time
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from openadr_vtn import LoopbackVtn, TlsFiles
from service_fixtures import SERVE, free_port, operator_key_for, registration

from hvacflex.errors import InputError
from hvacflex.service.openadr import (
    OPT_IN,
    OPT_OUT,
    EventRefused,
    OpenAdrVen,
    VenConfig,
    activation_runs,
    decide_dispatch,
    demand_charge_sgd_per_kw,
    dispatched_periods,
    energy_prices,
    event_buildings,
    to_service_time,
    to_vtn_time,
)
from hvacflex.service.replay import Client

T0 = datetime(2026, 12, 1, 12, 0, tzinfo=UTC)
"""A real (VTN) time; with OFFSET it is 2014-03-03 09:30 Singapore time."""
SERVICE_T0 = pd.Timestamp("2014-03-03T09:30+08:00")
OFFSET = SERVICE_T0 - pd.Timestamp(T0)
HALF_HOUR = timedelta(minutes=30)


def _signal(name: str, kind: str, payloads: list[float], **extra: Any) -> dict[str, Any]:
    intervals = [
        {"dtstart": T0 + j * HALF_HOUR, "duration": HALF_HOUR, "signal_payload": p}
        for j, p in enumerate(payloads)
    ]
    return {"signal_name": name, "signal_type": kind, "intervals": intervals, **extra}


def _plan(reserve_kw: list[float]) -> dict[str, Any]:
    times = [
        (SERVICE_T0 + j * pd.Timedelta(minutes=30)).isoformat() for j in range(len(reserve_kw))
    ]
    return {"horizon_time": times, "horizon_reserve_kw": reserve_kw}


def test_the_clock_offset_maps_vtn_times_onto_the_2014_calendar_and_back() -> None:
    assert OFFSET == pd.Timestamp("2014-03-03T01:30Z") - pd.Timestamp("2026-12-01T12:00Z")
    assert to_service_time(T0, OFFSET) == SERVICE_T0
    assert to_vtn_time("2014-03-03T09:30:00+08:00", OFFSET) == T0
    assert to_vtn_time("2014-03-03T10:00:00", OFFSET) == T0 + HALF_HOUR  # no offset: Singapore


def test_prices_in_sgd_per_kwh_become_sgd_per_mwh_per_period() -> None:
    start, prices = energy_prices(_signal("ELECTRICITY_PRICE", "price", [0.1, 0.25]), OFFSET)
    assert start == SERVICE_T0
    assert prices == pytest.approx([100.0, 250.0])
    # an interval of an hour is two periods; a scale of milli multiplies by 1e-3
    signal = _signal("ENERGY_PRICE", "price", [120.0], measurement={"unit": "SGD", "scale": "m"})
    signal["intervals"][0]["duration"] = timedelta(hours=1)
    assert energy_prices(signal, OFFSET) == (SERVICE_T0, pytest.approx([120.0, 120.0]))


@pytest.mark.parametrize(
    ("signal", "reason"),
    [
        (_signal("ELECTRICITY_PRICE", "priceRelative", [0.1]), "only absolute prices"),
        (_signal("ELECTRICITY_PRICE", "price", [0.1], measurement={"unit": "USD"}), "USD"),
        (
            {
                **_signal("ELECTRICITY_PRICE", "price", [0.1]),
                "intervals": [
                    {"dtstart": T0, "duration": HALF_HOUR, "signal_payload": 0.1},
                    {"dtstart": T0 + 2 * HALF_HOUR, "duration": HALF_HOUR, "signal_payload": 0.1},
                ],
            },
            "gaps",
        ),
        (
            {
                **_signal("ELECTRICITY_PRICE", "price", [0.1]),
                "intervals": [
                    {"dtstart": T0, "duration": timedelta(minutes=15), "signal_payload": 0.1}
                ],
            },
            "30-min",
        ),
    ],
    ids=["relative", "currency", "gap", "15-min"],
)
def test_prices_the_service_cannot_take_are_refused(signal: dict[str, Any], reason: str) -> None:
    with pytest.raises(EventRefused, match=reason):
        energy_prices(signal, OFFSET)


def test_a_demand_charge_is_one_phi() -> None:
    assert demand_charge_sgd_per_kw(_signal("DEMAND_CHARGE", "price", [3.5, 3.5])) == 3.5
    with pytest.raises(EventRefused, match="one φ"):
        demand_charge_sgd_per_kw(_signal("DEMAND_CHARGE", "price", [3.5, 4.0]))


def test_dispatched_periods_and_their_activation_runs() -> None:
    periods = dispatched_periods(_signal("SIMPLE", "level", [1, 2, 0, 1]), OFFSET)
    half = pd.Timedelta(minutes=30)
    assert periods == [SERVICE_T0, SERVICE_T0 + half, SERVICE_T0 + 3 * half]
    assert activation_runs(periods) == [
        (SERVICE_T0, SERVICE_T0 + 2 * half),
        (SERVICE_T0 + 3 * half, SERVICE_T0 + 4 * half),
    ]


def test_only_buildings_that_offered_every_dispatched_period_are_activated() -> None:
    periods = dispatched_periods(_signal("LOAD_DISPATCH", "delta", [5.0, 5.0]), OFFSET)
    plans = {
        "full": _plan([2.0, 3.0, 0.0]),
        "partial": _plan([2.0, 0.0, 4.0]),
        "none": None,
    }
    decision = decide_dispatch(periods, plans)
    assert decision.activated == ("full",)
    assert decision.opt == OPT_IN
    assert "1 period(s): 2014-03-03T10:00:00+08:00" in decision.refused["partial"]
    assert "2 period(s)" in decision.refused["none"]
    partial_only = decide_dispatch(periods, {"partial": plans["partial"]})
    assert partial_only.activated == () and partial_only.opt == OPT_OUT


def test_an_event_targets_the_named_buildings_else_all() -> None:
    ours = ("b1", "b2")
    assert event_buildings({"targets": [{"resource_id": "b2"}]}, ours) == ("b2",)
    assert event_buildings({"targets": [{"ven_id": "ven-1"}]}, ours) == ours
    assert event_buildings({"targets": [{"resource_id": "elsewhere"}]}, ours) == ()


class _RecordingService(Client):
    """A service client that records the requests and answers a fixed plan."""

    def __init__(self, plan: dict[str, Any]) -> None:
        super().__init__("http://127.0.0.1:1", "key")
        self.plan = plan
        self.requests: list[tuple[str, str, Any]] = []

    def call(self, method: str, path: str, body: Any = None) -> Any:
        self.requests.append((method, path, body))
        return self.plan if method == "GET" else {}


def _ven(service: Client, buildings: tuple[str, ...] = ("b1",)) -> OpenAdrVen:
    config = VenConfig(
        "http://127.0.0.1:9/OpenADR2/Simple/2.0b",
        "site-1",
        "http://127.0.0.1:8000",
        "key",
        buildings,
        OFFSET,
    )
    return OpenAdrVen(config, service, clock=lambda: T0)


def test_an_event_with_a_signal_the_service_cannot_carry_out_is_opted_out() -> None:
    service = _RecordingService(_plan([1.0, 1.0]))
    event = {
        "event_descriptor": {"event_id": "e1", "event_status": "far"},
        "event_signals": [
            _signal("ELECTRICITY_PRICE", "price", [0.1]),
            _signal("CHARGE_STATE", "level", [1.0]),
        ],
    }
    assert _ven(service).handle_event(event) == OPT_OUT
    # the price was still posted (each signal is carried out on its own)
    assert [r[1] for r in service.requests] == ["/v1/signals/prices"]
    dispatch = {
        "event_descriptor": {"event_id": "e2", "event_status": "far"},
        "event_signals": [_signal("LOAD_DISPATCH", "delta", [5.0, 5.0])],
        "targets": [{"resource_id": "b1"}],
    }
    service.requests.clear()
    assert _ven(service).handle_event(dispatch) == OPT_IN
    posted = [r[2] for r in service.requests if r[0] == "POST"]
    assert posted == [
        {"event": "start", "time": "2014-03-03T09:30:00+08:00", "building_ids": ["b1"]},
        {"event": "end", "time": "2014-03-03T10:30:00+08:00", "building_ids": ["b1"]},
    ]


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"vtn_url": "ftp://vtn"}, "--vtn-url"),
        ({"service_url": "nope"}, "--url"),
        ({"clock_offset": pd.Timedelta(minutes=10)}, "--clock-offset"),
        ({"cert": Path("ven.pem")}, "--cert"),
        ({"cert": Path("ven.pem"), "key": Path("ven.key")}, "--ca"),
    ],
)
def test_bad_settings_are_refused_naming_the_option(change: dict[str, Any], field: str) -> None:
    settings: dict[str, Any] = {
        "vtn_url": "http://127.0.0.1:9",
        "ven_name": "site-1",
        "service_url": "http://127.0.0.1:8000",
        "operator_key": "key",
    }
    with pytest.raises(InputError) as raised:
        VenConfig(**{**settings, **change})
    assert raised.value.field == field


@pytest.mark.parametrize(
    ("extra", "field", "reason"),
    [
        (["--building", "b1", "--clock-offset", "soon"], "--clock-offset", "not a duration"),
        (["--building", "b1"], "--vtn-url", "did not register"),  # no VTN at that port
        ([], "--url", "cannot reach the service"),  # the buildings are asked of the service
    ],
    ids=["offset", "no-vtn", "no-service"],
)
def test_the_command_exits_2_naming_the_option(extra: list[str], field: str, reason: str) -> None:
    vtn_url = f"http://127.0.0.1:{free_port()}/OpenADR2/Simple/2.0b"
    service_url = f"http://127.0.0.1:{free_port()}"
    done = subprocess.run(
        [
            *SERVE,
            "openadr-ven",
            "--vtn-url",
            vtn_url,
            "--ven-name",
            "v",
            "--url",
            service_url,
            *extra,
        ],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "HVACFLEX_KEY": "hvf_0_x"},
    )
    assert done.returncode == 2, done.stderr
    error = done.stderr.strip().splitlines()[-1]
    assert error.startswith(f"error: field '{field}'") and reason in error, error
    assert "Traceback" not in done.stderr


# -- end to end --------------------------------------------------------------------------
MEASURED_POWER_KW = 42.0
PRICES_SGD_PER_KWH = [0.10, 0.25, 0.40, 0.15]
PHI_SGD_PER_KW = 3.5
E2E_T0 = pd.Timestamp("2014-03-03T15:30+08:00")
"""The first period the VTN signals (office5 under rmpc offers reserve 15:30–17:30)."""


def _events(real0: datetime) -> list[dict[str, Any]]:
    def intervals(start: datetime, payloads: list[float]) -> list[dict[str, Any]]:
        return [
            {"dtstart": start + j * HALF_HOUR, "duration": HALF_HOUR, "signal_payload": p}
            for j, p in enumerate(payloads)
        ]

    return [
        {
            "signal_name": "ELECTRICITY_PRICE",
            "signal_type": "price",
            "intervals": intervals(real0, PRICES_SGD_PER_KWH),
        },
        {
            "signal_name": "DEMAND_CHARGE",
            "signal_type": "price",
            "intervals": [
                {"dtstart": real0, "duration": 4 * HALF_HOUR, "signal_payload": PHI_SGD_PER_KW}
            ],
        },
        {
            "signal_name": "LOAD_DISPATCH",
            "signal_type": "delta",
            "intervals": intervals(real0 + HALF_HOUR, [5.0, 5.0]),
            "targets": [{"resource_id": "b1"}],
        },
        {  # two days ahead: beyond the plan's horizon, so no reserve offered → optOut
            "signal_name": "SIMPLE",
            "signal_type": "level",
            "intervals": intervals(real0 + timedelta(days=2), [1.0]),
        },
    ]


def _wait(condition: Any, timeout_s: float, what: str, log: Any) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.5)
    log.seek(0)
    raise AssertionError(f"{what} within {timeout_s} s; VEN log:\n{log.read().decode()[-4000:]}")


@dataclass
class _Site:
    """A service (``hvacflex serve``) with building b1 registered and measured at 15:00."""

    url: str
    operator_key: str
    operator: Client
    bems: Client
    nodes: int
    first: dict[str, Any]

    @staticmethod
    def start(server_factory: Any) -> _Site:
        server = server_factory()
        server.start()
        operator_key = operator_key_for(server.db_url)
        operator = Client(server.url, operator_key)
        # a reserve price near the energy price, so that the plan offers reserve to dispatch
        scale = {"data.reserve_price_scale": 150.0}
        registered = operator.call("POST", "/v1/buildings", registration("b1", **scale))
        site = _Site(
            server.url,
            operator_key,
            operator,
            Client(server.url, registered["key"]),
            len(registered["nodes"]),
            {},
        )
        site.first = site.measure("2014-03-03T15:00+08:00", MEASURED_POWER_KW)
        return site

    def measure(self, time_text: str, power_kw: float) -> dict[str, Any]:
        body = {
            "time": time_text,
            "node_temperatures_degc": [24.0] * self.nodes,
            "previous_power_kw": power_kw,
        }
        plan: dict[str, Any] = self.bems.call(
            "POST", "/v1/buildings/b1/measurements?wait_s=10", body
        )
        return plan

    def start_ven(
        self, vtn: LoopbackVtn, offset: pd.Timedelta, files: TlsFiles | None
    ) -> tuple[subprocess.Popen[bytes], Any]:
        """``serve openadr-ven`` for b1 against ``vtn`` (a subprocess) and its log file."""
        command = [*SERVE, "openadr-ven", "--vtn-url", vtn.url, "--ven-name", "site-1"]
        command += ["--url", self.url, "--building", "b1", "--clock-offset", str(offset)]
        command += ["--stop-after-s", "150"]
        if files is not None:
            command += ["--cert", str(files.ven_cert), "--key", str(files.ven_key)]
            command += ["--ca", str(files.ca), "--vtn-fingerprint", str(vtn.fingerprint)]
        log = tempfile.TemporaryFile()
        env = {**os.environ, "HVACFLEX_KEY": self.operator_key}
        return subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=env), log


def _next_half_hour() -> datetime:
    now = pd.Timestamp.now(tz="UTC")
    start: datetime = (now.floor("30min") + pd.Timedelta(minutes=30)).to_pydatetime()
    return start


@pytest.mark.parametrize("tls", [False, True], ids=["http", "mutual-tls"])
def test_a_vtn_drives_a_building_through_the_ven(
    server_factory: Any, tmp_path: Path, tls: bool
) -> None:
    site = _Site.start(server_factory)
    operator_key, operator, first = site.operator_key, site.operator, site.first
    measure = site.measure
    reserve = dict(zip(first["horizon_time"], first["horizon_reserve_kw"], strict=False))
    assert reserve["2014-03-03T16:00:00+08:00"] > 0 and reserve["2014-03-03T16:30:00+08:00"] > 0

    real0 = _next_half_hour()
    offset = E2E_T0 - pd.Timestamp(real0)
    files = TlsFiles.make(tmp_path) if tls else None
    vtn = LoopbackVtn(free_port(), _events(real0), files, run_for_s=150.0)
    vtn.start()
    ven, log = site.start_ven(vtn, offset, files)
    wanted = ("b1.metered_power_kw", "b1.planned_power_kw", "b1.reserve_offer_kw")
    try:
        _wait(lambda: len(vtn.opts) == 4, 120, "four opt responses", log)
        _wait(lambda: all(vtn.values.get(r) for r in wanted), 60, "three reports", log)
    finally:
        ven.terminate()
        ven.wait(timeout=30)
        vtn.stop()
    assert vtn.registrations == 1
    price_id, demand_id, dispatch_id, simple_id = vtn.event_ids
    assert vtn.opts == {
        price_id: OPT_IN,
        demand_id: OPT_IN,
        dispatch_id: OPT_IN,
        simple_id: OPT_OUT,
    }

    # the VTN's reports: metered power at the start of the period it was metered in (14:30),
    # and the planned power and reserve offer of the latest plan (still `first`)
    assert vtn.descriptions["b1.metered_power_kw"]["reading_type"] == "Direct Read"
    assert vtn.descriptions["b1.reserve_offer_kw"]["reading_type"] == "Projected"
    assert vtn.descriptions["b1.reserve_offer_kw"]["report_type"] == "upRegulationCapacityAvailable"
    assert vtn.descriptions["b1.planned_power_kw"]["resource_id"] == "b1"
    metered_at = real0 - 2 * HALF_HOUR
    assert (metered_at, MEASURED_POWER_KW) in vtn.values["b1.metered_power_kw"]
    for r_id, column in (
        ("b1.planned_power_kw", "horizon_power_kw"),
        ("b1.reserve_offer_kw", "horizon_reserve_kw"),
    ):
        expected = [
            (real0 + (j - 1) * HALF_HOUR, pytest.approx(v, abs=1e-9))
            for j, v in enumerate(first[column])
        ]
        assert vtn.values[r_id][: len(expected)] == expected

    # the audit: the VEN's requests, with the operator's key
    key_id = operator_key.split("_")[1]
    audit = operator.call("GET", "/v1/audit")
    posted = [(a["path"], a["status_code"]) for a in audit if a["key_id"] == key_id]
    for path, count in (
        ("/v1/signals/prices", 1),
        ("/v1/signals/peak-price", 1),
        ("/v1/activations", 2),
    ):
        assert posted.count((path, 200)) == count, posted

    # the next plan uses the prices and φ; the dispatch activates 16:00, ends at 17:00
    second = measure("2014-03-03T15:30+08:00", 40.0)
    assert second["peak_price_sgd_per_kw"] == PHI_SGD_PER_KW
    assert first["peak_price_sgd_per_kw"] != PHI_SGD_PER_KW
    posted_prices = [1000.0 * p for p in PRICES_SGD_PER_KWH]
    assert second["horizon_energy_price_sgd_per_mwh"][:4] == pytest.approx(posted_prices)
    assert first["horizon_energy_price_sgd_per_mwh"][1:5] != pytest.approx(posted_prices)
    during = operator.call("POST", "/v1/clock", {"time": "2014-03-03T16:00+08:00"})["plans"]
    assert [(p["period"], p["il_activated"], p["il_role"]) for p in during] == [
        (32, True, "event-start")
    ]
    after = operator.call("POST", "/v1/clock", {"time": "2014-03-03T17:00+08:00"})["plans"]
    assert [(p["period"], p["il_activated"]) for p in after] == [(34, False)]


def test_a_vtn_that_goes_away_and_comes_back_re_registers_the_ven(server_factory: Any) -> None:
    site = _Site.start(server_factory)
    real0 = _next_half_hour()
    offset = E2E_T0 - pd.Timestamp(real0)
    price, demand = _events(real0)[:2]
    port = free_port()
    before = LoopbackVtn(port, [price], run_for_s=150.0)
    before.start()
    ven, log = site.start_ven(before, offset, None)
    after: LoopbackVtn | None = None
    try:
        _wait(lambda: before.opts == {before.event_ids[0]: OPT_IN}, 120, "the price opt", log)
        before.stop()
        time.sleep(3.0)  # the VEN polls a VTN that is not there (and logs it)
        after = LoopbackVtn(port, [demand], run_for_s=150.0)  # a fresh VTN: it knows no VEN
        after.start()
        vtn = after
        _wait(lambda: vtn.opts == {vtn.event_ids[0]: OPT_IN}, 60, "the demand opt", log)
        assert ven.poll() is None, "the VEN must survive the VTN's absence"
    finally:
        ven.terminate()
        ven.wait(timeout=30)
        before.stop()
        if after is not None:
            after.stop()
    assert after is not None and after.registrations == 1  # re-registered on the VTN's request
    key_id = site.operator_key.split("_")[1]
    audit = site.operator.call("GET", "/v1/audit")
    posted = [(a["path"], a["status_code"]) for a in audit if a["key_id"] == key_id]
    assert ("/v1/signals/prices", 200) in posted and ("/v1/signals/peak-price", 200) in posted


def test_a_cancelled_or_modified_dispatch_ends_what_it_activated() -> None:
    service = _RecordingService(_plan([1.0, 1.0, 1.0]))
    now = {"t": T0 - HALF_HOUR}
    ven = OpenAdrVen(_ven(service).config, service, clock=lambda: now["t"])
    dispatch = {
        "event_descriptor": {"event_id": "d1", "event_status": "far"},
        "event_signals": [_signal("LOAD_DISPATCH", "delta", [5.0, 5.0])],
    }
    cancelled = {**dispatch, "event_descriptor": {"event_id": "d1", "event_status": "cancelled"}}

    def posted() -> list[tuple[str, str]]:
        out = [(r[2]["event"], r[2]["time"][11:16]) for r in service.requests if r[0] == "POST"]
        service.requests.clear()
        return out

    assert ven.handle_event(dispatch) == OPT_IN
    assert posted() == [("start", "09:30"), ("end", "10:30")]
    # cancelled before it starts: an end at its start, posted later, wins in that period
    assert ven.handle_event(cancelled) == OPT_IN
    assert posted() == [("end", "09:30")]
    # modified while it runs (10:00): ended now, then the new version is posted
    ven.handle_event(dispatch)
    posted()
    now["t"] = T0 + HALF_HOUR
    assert ven.handle_event(dispatch) == OPT_IN
    assert posted() == [("end", "10:00"), ("start", "10:00"), ("end", "10:30")]
    # cancelled after it ended: nothing to undo; a dispatch entirely past is opted out
    now["t"] = T0 + 4 * HALF_HOUR
    assert ven.handle_event(cancelled) == OPT_IN
    assert ven.handle_event(dispatch) == OPT_OUT
    assert posted() == []


def test_a_signal_the_service_refuses_is_opted_out() -> None:
    from hvacflex.service.replay import ServiceError

    class Refusing(_RecordingService):
        def call(self, method: str, path: str, body: Any = None) -> Any:
            super().call(method, path, body)
            raise ServiceError(422, "field 'start': outside the times the service can plan")

    service = Refusing(_plan([1.0]))
    event = {
        "event_descriptor": {"event_id": "p1", "event_status": "far"},
        "event_signals": [_signal("ELECTRICITY_PRICE", "price", [0.1])],
    }
    assert _ven(service).handle_event(event) == OPT_OUT
    assert [r[1] for r in service.requests] == ["/v1/signals/prices"]
