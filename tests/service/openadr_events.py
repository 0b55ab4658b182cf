"""Events, plans and a recording service client for the VEN's tests (no VTN, no service)."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex.service.openadr import OpenAdrVen, VenConfig
from hvacflex.service.replay import Client

T0 = datetime(2026, 12, 1, 12, 0, tzinfo=UTC)
"""A real (VTN) time; with OFFSET it is 2014-03-03 09:30 Singapore time."""
SERVICE_T0 = pd.Timestamp("2014-03-03T09:30+08:00")
OFFSET = SERVICE_T0 - pd.Timestamp(T0)
HALF_HOUR = timedelta(minutes=30)


def make_signal(name: str, kind: str, payloads: list[float], **extra: Any) -> dict[str, Any]:
    intervals = [
        {"dtstart": T0 + j * HALF_HOUR, "duration": HALF_HOUR, "signal_payload": p}
        for j, p in enumerate(payloads)
    ]
    return {"signal_name": name, "signal_type": kind, "intervals": intervals, **extra}


def make_plan(reserve_kw: list[float]) -> dict[str, Any]:
    times = [
        (SERVICE_T0 + j * pd.Timedelta(minutes=30)).isoformat() for j in range(len(reserve_kw))
    ]
    return {"horizon_time": times, "horizon_reserve_kw": reserve_kw}


class RecordingService(Client):
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


def make_ven(
    service: Client,
    folder: Path,
    buildings: tuple[str, ...] = ("b1",),
    clock: Any = lambda: T0,
) -> OpenAdrVen:
    """A VEN (no VTN) on ``service`` with its record in ``folder``/ven.db."""
    config = VenConfig(
        "http://127.0.0.1:9/OpenADR2/Simple/2.0b",
        "site-1",
        "http://127.0.0.1:8000",
        "key",
        buildings,
        OFFSET,
        db_url=f"sqlite:///{folder / 'ven.db'}",
    )
    return OpenAdrVen(config, service, clock=clock)
