"""``serve openadr-ven``: the VEN's answers and its record (no VTN), and, end to end, an
openleadr VTN on 127.0.0.1 driving a registered building through the VEN, with and without
mutual TLS, on the 2014 calendar by a clock offset and on a live service at real times.

The VEN talks to the service over HTTP only, so what it does does not depend on the
service's database: each end-to-end test runs on one of them (:data:`ON_SQLITE`,
:data:`ON_POSTGRESQL`), and between them they cover both; the service's storage is tested on
both databases by the service's own tests (``make_db_url``)."""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from openadr_events import (
    HALF_HOUR,
    T0,
    RecordingService,
    make_plan,
    make_signal,
    make_ven,
)
from openadr_vtn import LoopbackVtn, TlsFiles
from service_fixtures import SERVE, free_port, operator_key_for, registration

from hvacflex.errors import InputError
from hvacflex.service.openadr import OPT_IN, OPT_OUT, VenConfig
from hvacflex.service.openadr_mapping import PERIOD, RESERVE_OFFER_MIN_KW
from hvacflex.service.replay import Client

ON_SQLITE = pytest.mark.parametrize("make_db_url", ["sqlite"], indirect=True)
"""An end-to-end test run on the service's SQLite database only (see the module's note)."""
ON_POSTGRESQL = pytest.mark.parametrize("make_db_url", ["postgresql"], indirect=True)
"""An end-to-end test run on the service's PostgreSQL database only (skipped without one)."""


def test_an_event_with_a_signal_the_service_cannot_carry_out_is_opted_out(tmp_path: Path) -> None:
    service = RecordingService(make_plan([1.0, 1.0]))
    event = {
        "event_descriptor": {"event_id": "e1", "event_status": "far"},
        "event_signals": [
            make_signal("ELECTRICITY_PRICE", "price", [0.1]),
            make_signal("CHARGE_STATE", "level", [1.0]),
        ],
    }
    assert make_ven(service, tmp_path).handle_event(event) == OPT_OUT
    # the price was still posted (each signal is carried out on its own)
    assert [r[1] for r in service.requests] == ["/v1/signals/prices"]
    dispatch = {
        "event_descriptor": {"event_id": "e2", "event_status": "far"},
        "event_signals": [make_signal("LOAD_DISPATCH", "delta", [5.0, 5.0])],
        "targets": [{"resource_id": "b1"}],
    }
    service.requests.clear()
    assert make_ven(service, tmp_path).handle_event(dispatch) == OPT_IN
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


def test_without_openleadr_the_ven_names_the_extra_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hvacflex.errors import ConfigError
    from hvacflex.service.openadr import openadr_client

    monkeypatch.setitem(sys.modules, "openleadr", None)  # import openleadr → ImportError
    with pytest.raises(ConfigError) as raised:
        openadr_client(make_ven(RecordingService(make_plan([1.0])), tmp_path))
    assert raised.value.hint == 'pip install -e ".[openadr]" (in the hvacflex clone)'


def test_the_note_says_what_a_utility_would_still_need_and_how_far_the_adapter_is() -> None:
    text = (Path(__file__).resolve().parents[2] / "docs" / "guide" / "service.md").read_text()
    note = text.split("### What a utility would still need", 1)[1].split("\n## ", 1)[0]
    for needed in ("**Certification.**", "**EiOpt.**", "**OpenADR 3.0**", "**How far the adapter"):
        assert needed in note, needed
    for mapped in ("`ELECTRICITY_PRICE`", "`DEMAND_CHARGE`", "`LOAD_DISPATCH`", "`SIMPLE`"):
        assert mapped in text.split("### Mapping", 1)[1], mapped  # the mapping table
    assert "## Live mode: real dates" in text and "`--clock-offset DURATION`" in text


@pytest.mark.parametrize(
    ("extra", "field", "reason"),
    [
        (["--building", "b1", "--clock-offset", "soon"], "--clock-offset", "not a duration"),
        (["--building", "b1"], "--vtn-url", "did not register"),  # no VTN at that port
        ([], "--url", "cannot reach the service"),  # the buildings are asked of the service
        (["--building", "b1", "--db", "nope://x"], "db", "not a database URL"),
    ],
    ids=["offset", "no-vtn", "no-service", "db"],
)
def test_the_command_exits_2_naming_the_option(
    extra: list[str], field: str, reason: str, tmp_path: Path
) -> None:
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
            "--db",
            f"sqlite:///{tmp_path / 'ven.db'}",
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


def test_without_db_the_record_lies_in_the_user_data_folder_not_the_working_one(
    tmp_path: Path,
) -> None:
    data = tmp_path / "xdg"
    done = subprocess.run(
        [
            *SERVE,
            "openadr-ven",
            "--vtn-url",
            f"http://127.0.0.1:{free_port()}/OpenADR2/Simple/2.0b",
            "--ven-name",
            "v",
            "--url",
            f"http://127.0.0.1:{free_port()}",
            "--building",
            "b1",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
        env={**os.environ, "HVACFLEX_KEY": "hvf_0_x", "XDG_DATA_HOME": str(data)},
    )
    assert done.returncode == 2, done.stderr  # no VTN there
    record = data / "hvacflex" / "openadr-ven.db"
    assert f"record sqlite:///{record}" in done.stderr
    assert record.is_file() and not list(tmp_path.glob("*.db"))


# -- end to end --------------------------------------------------------------------------
MEASURED_POWER_KW = 42.0
PRICES_SGD_PER_KWH = [0.10, 0.25, 0.40, 0.15]
PHI_SGD_PER_KW = 3.5
E2E_T0 = pd.Timestamp("2014-03-03T15:30+08:00")
"""The first period the VTN signals (office5 under rmpc offers reserve 17:00–18:30)."""


def _events(real0: datetime, dispatch_after: int = 1) -> list[dict[str, Any]]:
    """Price and demand-charge events from ``real0``, a two-period dispatch of b1
    ``dispatch_after`` periods later, and a SIMPLE event two days ahead."""

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
            "intervals": intervals(real0 + dispatch_after * HALF_HOUR, [5.0, 5.0]),
            "targets": [{"resource_id": "b1"}],
        },
        {  # two days ahead: beyond the plan's horizon, so no reserve offered → optOut
            "signal_name": "SIMPLE",
            "signal_type": "level",
            "intervals": intervals(real0 + timedelta(days=2), [1.0]),
        },
    ]


CAPACITY_LIMITS_KW = [300.0, 300.0, 250.0]
"""The feeder's capacity limit the VTN sends for the first three periods [kW]."""


def _capacity_limit(real0: datetime) -> dict[str, Any]:
    """A capacity limit from ``real0``: a load setpoint the site may not exceed [kW]."""
    return {
        "signal_name": "LOAD_DISPATCH",
        "signal_type": "setpoint",
        "intervals": [
            {"dtstart": real0 + j * HALF_HOUR, "duration": HALF_HOUR, "signal_payload": p}
            for j, p in enumerate(CAPACITY_LIMITS_KW)
        ],
    }


def _wait(condition: Any, timeout_s: float, what: str, log: Any) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.5)
    noise = ("report", "apscheduler", "number of intervals", "no callback found")
    lines = [
        line for line in _logged(log).splitlines() if not any(n in line.lower() for n in noise)
    ]
    tail = "\n".join(lines)[-4000:]
    raise AssertionError(f"{what} within {timeout_s} s; VEN log (reports left out):\n{tail}")


@dataclass
class _Site:
    """A service (``hvacflex serve``) with building b1 registered and measured at ``first``
    (default 2014-03-03 15:00; a live service on a real date)."""

    url: str
    operator_key: str
    operator: Client
    bems: Client
    nodes: int
    first: dict[str, Any]

    @staticmethod
    def start(
        server_factory: Any, first: str = "2014-03-03T15:00+08:00", live: bool = False
    ) -> _Site:
        server = server_factory()
        server.live = live
        server.start()
        operator_key = operator_key_for(server.db_url)
        operator = Client(server.url, operator_key)
        # a reserve price near the energy price, so that the plan offers reserve to dispatch
        body = registration("b1", days=2.0, **{"data.reserve_price_scale": 150.0})
        body["scenario"]["start"] = first[:10]
        registered = operator.call("POST", "/v1/buildings", body)
        site = _Site(
            server.url,
            operator_key,
            operator,
            Client(server.url, registered["key"]),
            len(registered["nodes"]),
            {},
        )
        site.first = site.measure(first, MEASURED_POWER_KW)
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
        self, vtn: LoopbackVtn, offset: pd.Timedelta, files: TlsFiles | None, record: Path
    ) -> tuple[subprocess.Popen[bytes], Any]:
        """``serve openadr-ven`` for b1 against ``vtn`` (a subprocess, its record in the
        SQLite file ``record``) and its log file."""
        command = [*SERVE, "openadr-ven", "--vtn-url", vtn.url, "--ven-name", "site-1"]
        command += ["--url", self.url, "--building", "b1", "--clock-offset", str(offset)]
        command += ["--db", f"sqlite:///{record}"]
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


@pytest.mark.parametrize(
    ("make_db_url", "tls"),
    [("sqlite", True), ("postgresql", False)],
    ids=["sqlite-mutual-tls", "postgresql-http"],
    indirect=["make_db_url"],
)
def test_a_vtn_drives_a_building_through_the_ven(
    server_factory: Any, tmp_path: Path, tls: bool
) -> None:
    site = _Site.start(server_factory)
    operator_key, operator, first = site.operator_key, site.operator, site.first
    measure = site.measure
    reserve = dict(zip(first["horizon_time"], first["horizon_reserve_kw"], strict=False))
    # the first plan (15:00) offers at 17:00 and 17:30, which the VTN dispatches (measured:
    # since the plan is paid only for what the baselines see, not at 16:00–16:30)
    assert reserve["2014-03-03T17:00:00+08:00"] > 0 and reserve["2014-03-03T17:30:00+08:00"] > 0

    real0 = _next_half_hour()
    offset = E2E_T0 - pd.Timestamp(real0)
    files = TlsFiles.make(tmp_path) if tls else None
    events = [*_events(real0, dispatch_after=3), _capacity_limit(real0)]
    vtn = LoopbackVtn(free_port(), events, files, run_for_s=150.0)
    vtn.start()
    ven, log = site.start_ven(vtn, offset, files, tmp_path / "ven.db")
    wanted = ("b1.metered_power_kw", "b1.planned_power_kw", "b1.reserve_offer_kw")
    try:
        _wait(lambda: len(vtn.opts) == 5, 120, "five opt responses", log)
        _wait(lambda: all(vtn.values.get(r) for r in wanted), 60, "three reports", log)
    finally:
        ven.terminate()
        ven.wait(timeout=30)
        vtn.stop()
    assert vtn.registrations == 1
    price_id, demand_id, dispatch_id, simple_id, limit_id = vtn.event_ids
    assert vtn.opts == {
        price_id: OPT_IN,
        demand_id: OPT_IN,
        dispatch_id: OPT_IN,
        simple_id: OPT_OUT,
        limit_id: OPT_IN,
    }
    # the capacity limit reached the service's limit schedule (15:00 … 17:00 service time)
    start = (E2E_T0 - PERIOD).isoformat().replace("+", "%2B")
    schedule = operator.call("GET", f"/v1/feeder-limits?start={start}&periods=5")
    assert schedule["limit_kw"] == [None, *CAPACITY_LIMITS_KW, None]

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
        ("/v1/activations/refused", 1),
        ("/v1/signals/feeder-limits", 1),
    ):
        assert posted.count((path, 200)) == count, posted
    # the dispatch with offered reserve reached the service as activations; the one beyond
    # the horizon (no offer) was refused with its reason in the audit
    mine = [a for a in audit if a["key_id"] == key_id]
    assert [a["action"] for a in mine].count("activation") == 2
    (refused,) = [a for a in mine if a["action"] == "activation_refused"]
    assert "b1 not activated" in refused["body_head"] and simple_id in refused["body_head"]

    # the next plan uses the prices and φ; the dispatch activates 17:00, ends at 18:00
    second = measure("2014-03-03T15:30+08:00", 40.0)
    assert second["peak_price_sgd_per_kw"] == PHI_SGD_PER_KW
    assert first["peak_price_sgd_per_kw"] != PHI_SGD_PER_KW
    posted_prices = [1000.0 * p for p in PRICES_SGD_PER_KWH]
    assert second["horizon_energy_price_sgd_per_mwh"][:4] == pytest.approx(posted_prices)
    assert first["horizon_energy_price_sgd_per_mwh"][1:5] != pytest.approx(posted_prices)
    during = operator.call("POST", "/v1/clock", {"time": "2014-03-03T17:00+08:00"})["plans"]
    assert [(p["period"], p["il_activated"], p["il_role"]) for p in during] == [
        (34, True, "event-start")
    ]
    after = operator.call("POST", "/v1/clock", {"time": "2014-03-03T18:00+08:00"})["plans"]
    assert [(p["period"], p["il_activated"]) for p in after] == [(36, False)]


class _TimedVtn(LoopbackVtn):
    """The loopback VTN, noting when each report of each rID arrived (monotonic s) and how
    many values it carried."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.arrivals: list[tuple[float, str, int]] = []

    def on_register_report(self, report: dict[str, Any]) -> list[tuple[str, Any, timedelta]]:
        requests = []
        for r_id, store, sampling in super().on_register_report(report):

            def timed(
                values: list[tuple[Any, float]], r_id: str = r_id, store: Any = store
            ) -> None:
                self.arrivals.append((time.monotonic(), r_id, len(values)))
                store(values)

            requests.append((r_id, timed, sampling))
        return requests

    def reports_of(self, r_id: str, since: float = 0.0) -> list[tuple[float, int]]:
        return [(t, n) for t, r, n in list(self.arrivals) if r == r_id and t >= since]


@ON_POSTGRESQL
def test_reports_wait_for_data_and_come_at_the_agreed_interval(
    server_factory: Any, tmp_path: Path
) -> None:
    """Before the building has a measurement and a plan the VEN sends no report (an empty
    one crashed the VTN); then metered power once per agreed interval (the VTN asks for
    1 s) and each plan's horizon once, not again at every sample."""
    server = server_factory()
    server.start()
    operator_key = operator_key_for(server.db_url)
    registered = Client(server.url, operator_key).call(
        "POST", "/v1/buildings", registration("b1", days=2.0)
    )
    site = _Site(
        server.url,
        operator_key,
        Client(server.url, operator_key),
        Client(server.url, registered["key"]),
        len(registered["nodes"]),
        {},
    )
    real0 = _next_half_hour()
    vtn = _TimedVtn(free_port(), [], run_for_s=150.0)
    vtn.start()
    ven, log = site.start_ven(vtn, E2E_T0 - pd.Timestamp(real0), None, tmp_path / "ven.db")
    wanted = ("b1.metered_power_kw", "b1.planned_power_kw", "b1.reserve_offer_kw")
    try:
        _wait(lambda: all(r in vtn.descriptions for r in wanted), 90, "the reports", log)
        time.sleep(4.0)  # four agreed intervals without data
        assert vtn.arrivals == []
        first = site.measure("2014-03-03T15:00+08:00", MEASURED_POWER_KW)
        since = time.monotonic()
        _wait(lambda: len(vtn.reports_of(wanted[0], since)) >= 6, 30, "six reports", log)
        window_s = time.monotonic() - since
        second = site.measure("2014-03-03T15:30+08:00", 40.0)  # a new plan: sent once more
        _wait(  # both of the new plan's reports (they need not arrive together under load)
            lambda: all(len(vtn.reports_of(r, since)) >= 2 for r in wanted[1:]),
            30,
            "the new plan",
            log,
        )
        time.sleep(2.0)
        assert ven.poll() is None
    finally:
        ven.terminate()
        ven.wait(timeout=30)
        vtn.stop()
    # one metered value per report, at most one report per agreed interval (1 s) from the
    # first measurement to the end (arrival times bunch under load, so the count is checked)
    metered = vtn.reports_of(wanted[0], since)
    assert all(n == 1 for _, n in metered)
    span_s = metered[-1][0] - since
    assert 6 <= len(metered) <= span_s + 2, (len(metered), span_s, window_s)
    for r_id in wanted[1:]:  # each plan's horizon once: two plans, two reports
        counts = [n for _, n in vtn.reports_of(r_id, since)]
        assert len(counts) == 2, counts
        assert counts[0] == len(first["horizon_time"])
        assert 0 < counts[1] <= len(second["horizon_time"])
    assert "Traceback" not in _logged(log)


@ON_SQLITE
def test_a_vtn_that_goes_away_and_comes_back_re_registers_the_ven(
    server_factory: Any, tmp_path: Path
) -> None:
    site = _Site.start(server_factory)
    real0 = _next_half_hour()
    offset = E2E_T0 - pd.Timestamp(real0)
    price, demand = _events(real0)[:2]
    port = free_port()
    before = LoopbackVtn(port, [price], run_for_s=150.0)
    before.start()
    ven, log = site.start_ven(before, offset, None, tmp_path / "ven.db")
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


def _dispatch(event_id: str, modification: int, status: str = "far") -> dict[str, Any]:
    """A dispatch of 09:30–10:30 service time (two periods) in version ``modification``."""
    return {
        "event_descriptor": {
            "event_id": event_id,
            "event_status": status,
            "modification_number": modification,
        },
        "event_signals": [make_signal("LOAD_DISPATCH", "delta", [5.0, 5.0])],
    }


def _posted(service: RecordingService) -> list[tuple[str, str]]:
    """The activation starts and ends posted since the last call (event, HH:MM)."""
    out = [
        (r[2]["event"], r[2]["time"][11:16])
        for r in service.requests
        if r[0] == "POST" and r[1] == "/v1/activations"
    ]
    service.requests.clear()
    return out


def _refusals(service: RecordingService) -> list[dict[str, Any]]:
    """The refused dispatches posted (bodies of ``POST /v1/activations/refused``)."""
    return [r[2] for r in service.requests if r[:2] == ("POST", "/v1/activations/refused")]


def test_a_cancelled_or_modified_dispatch_ends_what_it_activated(tmp_path: Path) -> None:
    service = RecordingService(make_plan([1.0, 1.0, 1.0]))
    now = {"t": T0 - HALF_HOUR}
    ven = make_ven(service, tmp_path, clock=lambda: now["t"])

    assert ven.handle_event(_dispatch("d1", 0)) == OPT_IN
    assert _posted(service) == [("start", "09:30"), ("end", "10:30")]
    # the same version again (a VTN's repeat) is answered as before and posts nothing
    assert ven.handle_event(_dispatch("d1", 0)) == OPT_IN
    assert _posted(service) == []
    # cancelled before it starts: an end at its start, posted later, wins in that period
    assert ven.handle_event(_dispatch("d1", 1, "cancelled")) == OPT_IN
    assert _posted(service) == [("end", "09:30")]
    assert ven.store.get("d1") is not None and ven.store.get("d1").runs == ()  # type: ignore[union-attr]
    # modified while it runs (10:00): ended now, then the new version is posted
    ven.handle_event(_dispatch("d1", 2))
    _posted(service)
    now["t"] = T0 + HALF_HOUR
    assert ven.handle_event(_dispatch("d1", 3)) == OPT_IN
    assert _posted(service) == [("end", "10:00"), ("start", "10:00"), ("end", "10:30")]
    # what ran (09:30–10:00) stays on the record with the new run, for the settlement
    record = ven.store.get("d1")
    assert record is not None
    assert [(r.start.strftime("%H:%M"), r.end.strftime("%H:%M")) for r in record.runs] == [
        ("09:30", "10:00"),
        ("10:00", "10:30"),
    ]
    # cancelled after it ended: nothing to undo; a dispatch entirely past is opted out,
    # and the service records why
    now["t"] = T0 + 4 * HALF_HOUR
    assert ven.handle_event(_dispatch("d1", 4, "cancelled")) == OPT_IN
    assert ven.handle_event(_dispatch("d1", 5)) == OPT_OUT
    assert _refusals(service) == [
        {
            "time": "2014-03-03T09:30:00+08:00",
            "building_ids": ["b1"],
            "reason": "every dispatched period is over",
            "event_id": "d1",
        }
    ]
    assert _posted(service) == []


def test_a_capacity_limit_event_posts_its_windows_and_a_cancel_removes_them(
    tmp_path: Path,
) -> None:
    service = RecordingService(make_plan([0.0, 0.0]))  # no reserve: a limit needs none
    ven = make_ven(service, tmp_path, clock=lambda: T0 - HALF_HOUR)
    event = {
        "event_descriptor": {"event_id": "c1", "event_status": "far", "modification_number": 0},
        "event_signals": [make_signal("LOAD_DISPATCH", "setpoint", [300.0, 250.0])],
    }
    assert ven.handle_event(event) == OPT_IN
    posted = [r[2] for r in service.requests if r[:2] == ("POST", "/v1/signals/feeder-limits")]
    assert posted == [
        {
            "windows": [
                {
                    "start": "2014-03-03T09:30:00+08:00",
                    "end": "2014-03-03T10:00:00+08:00",
                    "limit_kw": 300.0,
                },
                {
                    "start": "2014-03-03T10:00:00+08:00",
                    "end": "2014-03-03T10:30:00+08:00",
                    "limit_kw": 250.0,
                },
            ],
            "event_id": "c1/0",
        }
    ]
    assert _posted(service) == []  # not an IL dispatch: no activation
    service.requests.clear()
    event["event_descriptor"] = {**event["event_descriptor"], "modification_number": 1}
    event["event_descriptor"]["event_status"] = "cancelled"
    assert ven.handle_event(event) == OPT_IN
    assert [r[1:] for r in service.requests if r[0] == "POST"] == [
        ("/v1/signals/feeder-limits", {"windows": [], "event_id": "c1/0"})
    ]


def test_a_restarted_ven_keeps_its_answers_and_ends_a_dispatch_cancelled_later(
    tmp_path: Path,
) -> None:
    service = RecordingService(make_plan([1.0, 1.0, 1.0]))
    first = make_ven(service, tmp_path, clock=lambda: T0 - HALF_HOUR)
    price = {
        "event_descriptor": {"event_id": "p1", "event_status": "far", "modification_number": 0},
        "event_signals": [make_signal("ELECTRICITY_PRICE", "priceRelative", [0.1])],
    }
    assert first.handle_event(_dispatch("d1", 0)) == OPT_IN
    assert first.handle_event(price) == OPT_OUT
    _posted(service)
    first.store.engine.dispose()
    # a new process on the same record: the VTN sends its events again after registration
    again = make_ven(service, tmp_path, clock=lambda: T0 - HALF_HOUR)
    assert again.handle_event(_dispatch("d1", 0)) == OPT_IN
    assert again.handle_event(price) == OPT_OUT
    assert service.requests == []  # nothing posted twice
    opted_out = again.store.get("p1")
    assert opted_out is not None and "only absolute prices" in opted_out.reason
    # the cancellation reaches the restarted VEN, which still knows what to end
    assert again.handle_event(_dispatch("d1", 1, "cancelled")) == OPT_IN
    assert _posted(service) == [("end", "09:30")]
    record = again.store.get("d1")
    assert record is not None and record.event_status == "cancelled" and record.runs == ()


class _MeteredService(RecordingService):
    """A recording service that also answers the building's measurements."""

    def __init__(self, plan: dict[str, Any], measurements: list[dict[str, Any]]) -> None:
        super().__init__(plan)
        self.measurements = measurements

    def call(self, method: str, path: str, body: Any = None) -> Any:
        if "/measurements" in path:
            return list(self.measurements)
        return super().call(method, path, body)


def test_an_accepted_dispatch_is_settled_on_metered_power_once_the_meter_has_passed_it(
    tmp_path: Path,
) -> None:
    # offered 2.0 and 3.0 kW for 09:30 and 10:00 (service time); metered 40 kW at 09:00
    # (the pre-event baseline), 37.5 kW at 09:30, 39.0 kW at 10:00
    plan = make_plan([2.0, 3.0, 1.0])
    measurements = [{"time": "2014-03-03T09:30:00+08:00", "previous_power_kw": 40.0}]
    service = _MeteredService(plan, measurements)
    ven = make_ven(service, tmp_path, clock=lambda: T0 - HALF_HOUR)
    assert ven.handle_event(_dispatch("d1", 0)) == OPT_IN
    assert ven.settle_due() == []  # the meter has not passed the dispatch
    measurements.insert(0, {"time": "2014-03-03T10:00:00+08:00", "previous_power_kw": 37.5})
    assert ven.settle_due() == []
    measurements.insert(0, {"time": "2014-03-03T10:30:00+08:00", "previous_power_kw": 39.0})
    assert ven.settle_due() == ["d1"]
    assert ven.settle_due() == []  # once
    settled = make_ven(service, tmp_path).store.settlement("d1")  # kept across a restart
    assert [(p.period_start.strftime("%H:%M"), p.reserve_kw, p.metered_kw) for p in settled] == [
        ("09:30", 2.0, 37.5),
        ("10:00", 3.0, 39.0),
    ]
    assert [p.baseline_kw for p in settled] == [40.0, 40.0]
    assert [p.delivered_kw for p in settled] == pytest.approx([2.5, 1.0])  # 40 − metered
    assert [p.shortfall_kw for p in settled] == pytest.approx([0.0, 2.0])  # offer − delivered


def test_a_signal_the_service_refuses_is_opted_out(tmp_path: Path) -> None:
    from hvacflex.service.replay import ServiceError

    class Refusing(RecordingService):
        def call(self, method: str, path: str, body: Any = None) -> Any:
            super().call(method, path, body)
            raise ServiceError(422, "field 'start': outside the times the service can plan")

    service = Refusing(make_plan([1.0]))
    event = {
        "event_descriptor": {"event_id": "p1", "event_status": "far"},
        "event_signals": [make_signal("ELECTRICITY_PRICE", "price", [0.1])],
    }
    assert make_ven(service, tmp_path).handle_event(event) == OPT_OUT
    assert [r[1] for r in service.requests] == ["/v1/signals/prices"]


def _logged(log: Any) -> str:
    """What the VEN has logged so far."""
    log.seek(0)
    text: str = log.read().decode()
    return text


def _offered_pair(plan: dict[str, Any]) -> pd.Timestamp:
    """The first period after the plan's own from which it offers reserve in two periods."""
    reserve = plan["horizon_reserve_kw"]
    for j in range(1, len(reserve) - 1):
        if min(reserve[j], reserve[j + 1]) > RESERVE_OFFER_MIN_KW:
            return pd.Timestamp(plan["horizon_time"][j])
    raise AssertionError(f"the plan offers no two consecutive periods: {reserve}")


@ON_SQLITE
def test_a_live_service_at_real_times_and_a_restarted_ven_that_keeps_its_dispatch(
    server_factory: Any, tmp_path: Path
) -> None:
    # a live service; the building measured at noon on the next Wednesday but one (real
    # dates, no clock offset: the VTN's times are the service's)
    today = pd.Timestamp.now(tz="Asia/Singapore").normalize()
    day = today + pd.Timedelta(days=7 + (2 - today.day_of_week) % 7)
    site = _Site.start(server_factory, f"{day:%Y-%m-%d}T12:00+08:00", live=True)
    start = _offered_pair(site.first)
    real0 = start.tz_convert("UTC").to_pydatetime()
    price, _, dispatch, _ = _events(real0 - HALF_HOUR)
    vtn = LoopbackVtn(free_port(), [price, dispatch], run_for_s=240.0)
    vtn.start()
    record = tmp_path / "ven.db"
    offset = pd.Timedelta(0)
    ven, log = site.start_ven(vtn, offset, None, record)
    restarted: subprocess.Popen[bytes] | None = None
    price_id, dispatch_id = vtn.event_ids

    def activations() -> list[dict[str, Any]]:
        listed: list[dict[str, Any]] = site.operator.call("GET", "/v1/activations")
        return listed

    try:
        _wait(lambda: len(vtn.opts) == 2, 120, "two opt responses", log)
        assert vtn.opts == {price_id: OPT_IN, dispatch_id: OPT_IN}
        ven.kill()  # no clean stop: the record is committed before an opt is sent
        ven.wait(timeout=30)
        restarted, log = site.start_ven(vtn, offset, None, record)
        # at registration the VTN sends its events again; both are answered from the record
        answered = "answered before: optIn"
        _wait(lambda: _logged(log).count(answered) == 2, 120, "the events answered again", log)
        vtn.cancel(dispatch_id)  # a new version of the dispatch, status cancelled
        _wait(lambda: len(activations()) == 3, 120, "the cancellation's end", log)
        assert "cancelled (acknowledged)" in _logged(log)
    finally:
        for process in (ven, restarted):
            if process is not None and process.poll() is None:
                process.terminate()
                process.wait(timeout=30)
        vtn.stop()
    assert vtn.registrations == 2

    # the prices were posted once (the restarted VEN answered them from its record); the
    # dispatch's start and end by the first VEN, the end at its start by the restarted one
    key_id = site.operator_key.split("_")[1]
    audit = site.operator.call("GET", "/v1/audit")
    posted = [(a["path"], a["status_code"]) for a in audit if a["key_id"] == key_id]
    assert posted.count(("/v1/signals/prices", 200)) == 1, posted
    assert posted.count(("/v1/activations", 200)) == 3, posted
    times = [(a["event"], pd.Timestamp(a["time"])) for a in reversed(activations())]
    assert times == [("start", start), ("end", start + 2 * PERIOD), ("end", start)]
    # the next plan at the dispatch's start uses the posted price and is not activated
    plan = site.measure(start.isoformat(), 40.0)
    assert not plan["il_activated"]
    assert plan["horizon_energy_price_sgd_per_mwh"][0] == pytest.approx(
        1000.0 * PRICES_SGD_PER_KWH[1]
    )


# -- dispatches refused, the record's default place, reports -------------------------------
def test_a_dispatch_without_offered_reserve_is_refused_with_the_reason_at_the_service(
    tmp_path: Path,
) -> None:
    """b1 offers 09:30 only, b2 both periods: b2 is activated, b1 refused (a partial offer),
    and the service gets the refusal with the periods b1 lacked."""

    class TwoPlans(RecordingService):
        def call(self, method: str, path: str, body: Any = None) -> Any:
            if method == "GET" and path == "/v1/buildings/b1/plan":
                return make_plan([1.0, 0.0])
            return super().call(method, path, body)

    service = TwoPlans(make_plan([1.0, 1.0]))
    ven = make_ven(service, tmp_path, buildings=("b1", "b2"))
    assert ven.handle_event(_dispatch("d1", 0)) == OPT_IN
    (refusal,) = _refusals(service)
    assert refusal["building_ids"] == ["b1"] and refusal["event_id"] == "d1"
    assert "b1 not activated" in refusal["reason"] and "10:00" in refusal["reason"]
    assert _posted(service) == [("start", "09:30"), ("end", "10:30")]  # b2's activation
    # no building offers: opted out, nothing activated, every refused building recorded
    service.plan = make_plan([0.0, 0.0])
    assert ven.handle_event(_dispatch("d2", 0)) == OPT_OUT
    assert [r["building_ids"] for r in _refusals(service)] == [["b1", "b2"]]
    assert _posted(service) == []


def test_a_refusal_the_service_cannot_take_leaves_the_opt(tmp_path: Path) -> None:
    class Refusing(RecordingService):
        def call(self, method: str, path: str, body: Any = None) -> Any:
            if path == "/v1/activations/refused":
                raise InputError("no such building", field="building_ids[0]")
            return super().call(method, path, body)

    service = Refusing(make_plan([0.0, 0.0]))
    assert make_ven(service, tmp_path).handle_event(_dispatch("d1", 0)) == OPT_OUT


def test_a_port_given_out_stays_ours_until_the_test_s_server_takes_it() -> None:
    """The shared state between test files running side by side: the ports. A port
    :func:`free_port` gave out is not given to anyone else (a plain bind or a probe of
    another worker fails to get it), yet a server that sets SO_REUSEADDR (uvicorn, aiohttp)
    binds it, and another after it; nobody listening, a connection is refused."""
    import socket

    port = free_port()
    with socket.socket() as other, pytest.raises(OSError):
        other.bind(("127.0.0.1", port))
    for _ in range(200):  # other probes are given other ports
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            assert probe.getsockname()[1] != port
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection(("127.0.0.1", port), timeout=5).close()
    for _ in range(2):  # a server, stopped, and another on the same port
        with socket.socket() as server:
            server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            server.bind(("127.0.0.1", port))
            server.listen()
            with socket.create_connection(("127.0.0.1", port), timeout=5):
                accepted, _ = server.accept()
                accepted.close()
    assert free_port() != port


def test_the_record_defaults_to_the_user_data_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    monkeypatch.chdir(tmp_path)
    config = VenConfig("http://127.0.0.1:9", "site-1", "http://127.0.0.1:8000", "key")
    assert config.db_url is None
    expected = tmp_path / "data" / "hvacflex" / "openadr-ven.db"
    assert config.record_url() == f"sqlite:///{expected}"
    assert expected.parent.is_dir() and not list(tmp_path.glob("*.db"))  # not the cwd
    ven = make_ven(RecordingService(make_plan([1.0])), tmp_path)  # an explicit --db is kept
    assert str(ven.store.engine.url) == f"sqlite:///{tmp_path / 'ven.db'}"
    (tmp_path / "blocked").write_text("a file where the folder should be")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "blocked"))
    with pytest.raises(InputError) as raised:
        config.record_url()
    assert raised.value.field == "--db"


class _FakeClient:
    """What :class:`ReportSender` reads of an openleadr client: the VTN's report requests,
    the VEN's reports, the read callbacks and the queue of reports to send."""

    def __init__(self, readings: dict[str, list[tuple[datetime, float]]]) -> None:
        from openleadr import objects

        self.readings = readings
        self.report_requests = [
            {
                "report_request_id": "rq-t",
                "report_specifier_id": "hvacflex-telemetry",
                "granularity": timedelta(seconds=10),
                "report_back_duration": timedelta(seconds=10),
                "r_ids": ["b1.metered_power_kw", "b1.planned_power_kw"],
            },
            {
                "report_request_id": "rq-f",
                "report_specifier_id": "hvacflex-forecast",
                "granularity": timedelta(seconds=10),
                "report_back_duration": timedelta(seconds=10),
                "r_ids": ["b1.planned_power_kw"],
            },
        ]
        self.reports = [
            objects.Report(report_specifier_id=s, report_name="METADATA_TELEMETRY_USAGE")
            for s in ("hvacflex-telemetry", "hvacflex-forecast")
        ]

        async def read(r_id: str) -> list[tuple[datetime, float]]:
            return list(self.readings.get(r_id, []))

        self.report_callbacks = {
            ("hvacflex-telemetry", "b1.metered_power_kw"): lambda: read("b1.metered_power_kw"),
            ("hvacflex-forecast", "b1.planned_power_kw"): lambda: read("b1.planned_power_kw"),
        }
        self.pending_reports: asyncio.Queue[Any] = asyncio.Queue()

    def sent(self) -> list[tuple[str, list[tuple[str, float]]]]:
        """The reports queued since the last call: (request, [(r_id, value)])."""
        out = []
        while not self.pending_reports.empty():
            report = self.pending_reports.get_nowait()
            values = [(i.report_payload.r_id, i.report_payload.value) for i in report.intervals]
            out.append((report.report_request_id, values))
        return out


def test_reports_only_with_data_once_per_agreed_interval_and_a_plan_once() -> None:
    from hvacflex.service.openadr import ReportSender, agreed_interval

    assert agreed_interval(timedelta(seconds=10), timedelta(minutes=1)) == timedelta(minutes=1)
    assert agreed_interval(None, None) == timedelta(minutes=30)
    t = datetime(2026, 12, 1, 12, 0, tzinfo=UTC)
    client = _FakeClient({})
    now = {"s": 0.0}
    sender = ReportSender(client, {"b1.planned_power_kw"}, clock=lambda: now["s"])

    def sample(second: float) -> list[tuple[str, list[tuple[str, float]]]]:
        now["s"] = second
        for request in ("rq-t", "rq-f"):
            asyncio.run(sender.update_report(request))
        return client.sent()

    assert sample(0.0) == []  # no measurement, no plan: no report at all
    client.readings["b1.metered_power_kw"] = [(t, 42.0)]
    client.readings["b1.planned_power_kw"] = [(t, 40.0), (t + HALF_HOUR, 41.0)]
    # the rID the VTN lists under the telemetry request without a callback there is skipped
    assert sample(10.0) == [
        ("rq-t", [("b1.metered_power_kw", 42.0)]),
        ("rq-f", [("b1.planned_power_kw", 40.0), ("b1.planned_power_kw", 41.0)]),
    ]
    assert sample(12.0) == []  # a second sample within the interval (a duplicate job)
    assert sample(20.0) == [("rq-t", [("b1.metered_power_kw", 42.0)])]  # the plan is unchanged
    client.readings["b1.planned_power_kw"] = [(t + HALF_HOUR, 39.5), (t + 2 * HALF_HOUR, 41.0)]
    assert sample(30.0) == [
        ("rq-t", [("b1.metered_power_kw", 42.0)]),
        ("rq-f", [("b1.planned_power_kw", 39.5), ("b1.planned_power_kw", 41.0)]),
    ]
    assert sender.reports_sent == 5
    # re-registered: the VTN asks for the telemetry again; the old request is dropped
    client.report_requests.append({**client.report_requests[0], "report_request_id": "rq-t2"})
    now["s"] = 40.0
    for request in ("rq-t", "rq-t2"):
        asyncio.run(sender.update_report(request))
    assert client.sent() == [("rq-t2", [("b1.metered_power_kw", 42.0)])]
    assert [r["report_request_id"] for r in client.report_requests] == ["rq-f", "rq-t2"]


def test_a_job_cancelled_as_the_ven_stops_is_not_logged_as_an_error() -> None:
    """SIGTERM while a poll or report is in flight: the event loop's end cancels the job and
    apscheduler logs it with a traceback; the VEN's stopping filter drops exactly those
    records (a job's other errors still reach the log). A test of this file failed in CI
    when the VEN was terminated mid-report (2026-12-07)."""
    import logging

    from hvacflex.service.openadr import _StoppingCancellations

    def record(error: BaseException) -> logging.LogRecord:
        try:
            raise error
        except BaseException:
            return logging.LogRecord(
                "apscheduler.executors.default",
                logging.ERROR,
                __file__,
                1,
                'Job "poll" raised an exception',
                None,
                sys.exc_info(),
            )

    stopping = _StoppingCancellations()
    assert not stopping.filter(record(asyncio.CancelledError()))
    assert stopping.filter(record(RuntimeError("the VTN answered 500")))
    plain = logging.LogRecord("x", logging.INFO, __file__, 1, "Job executed", None, None)
    assert stopping.filter(plain)
