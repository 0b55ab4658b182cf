"""Running the service: Prometheus metrics, structured (JSON) logs and stale buildings.

``GET /v1/metrics`` answers in the Prometheus text exposition format (version 0.0.4):

* ``hvacflex_http_requests_total{method, route, status}`` — requests answered;
* ``hvacflex_http_request_duration_seconds{method, route}`` — a histogram of latencies [s];
* ``hvacflex_plans_total{trigger}`` and ``hvacflex_solver_failures_total`` (plans where the
  solver gave no plan and the controller's fallback ran) — counted from the stored plans;
* ``hvacflex_buildings``, ``hvacflex_stale_buildings`` — registered buildings and those whose
  measurements stopped arriving (:func:`stale_buildings`).

``route`` is the route's template (``/v1/buildings/{building_id}/plan``), never the raw path,
so the label set stays bounded. Every request is logged as one JSON line on the
``hvacflex.service.access`` logger (:class:`JsonFormatter`). ``hvacflex serve`` checks its
address and TLS files here before it starts (:func:`check_listen_address`,
:func:`check_tls`).
"""

from __future__ import annotations

import bisect
import ipaddress
import json
import logging
import re
import socket
import ssl
import threading
import time
from collections.abc import Awaitable, Callable, MutableMapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from hvacflex.errors import InputError
from hvacflex.service.db import BuildingRow, Measurement, PlanRow

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

LATENCY_BUCKETS_S = (0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0)
"""Upper bounds of the latency histogram's buckets [s] (plus +Inf)."""
DEFAULT_STALE_AFTER_S = 3600.0
"""A building with no measurement for this long is stale (two missed 30-min periods) [s]."""
ACCESS_LOGGER = "hvacflex.service.access"
UNMATCHED_ROUTE = "unmatched"
"""The ``route`` label of a request no route matched (404s of unknown paths)."""
PROMETHEUS_CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"


@dataclass
class _Histogram:
    counts: list[int] = field(default_factory=lambda: [0] * (len(LATENCY_BUCKETS_S) + 1))
    total_s: float = 0.0
    n: int = 0


class RequestMetrics:
    """Request counts and latencies in memory (since the process started), thread-safe."""

    def __init__(self) -> None:
        self._requests: dict[tuple[str, str, int], int] = {}
        self._latency: dict[tuple[str, str], _Histogram] = {}
        self._lock = threading.Lock()

    def observe(self, method: str, route: str, status: int, duration_s: float) -> None:
        """Count one request answered with ``status`` after ``duration_s`` [s]."""
        with self._lock:
            key = (method, route, status)
            self._requests[key] = self._requests.get(key, 0) + 1
            histogram = self._latency.setdefault((method, route), _Histogram())
            histogram.counts[bisect.bisect_left(LATENCY_BUCKETS_S, duration_s)] += 1
            histogram.total_s += duration_s
            histogram.n += 1

    def lines(self) -> list[str]:
        """The request families in the Prometheus text format."""
        with self._lock:
            requests = sorted(self._requests.items())
            latency = sorted(
                (k, _Histogram(list(h.counts), h.total_s, h.n)) for k, h in self._latency.items()
            )
        out = [
            "# HELP hvacflex_http_requests_total HTTP requests answered.",
            "# TYPE hvacflex_http_requests_total counter",
        ]
        for (method, route, status), n in requests:
            labels = _labels(method=method, route=route, status=str(status))
            out.append(f"hvacflex_http_requests_total{labels} {n}")
        out += [
            "# HELP hvacflex_http_request_duration_seconds Time to answer a request.",
            "# TYPE hvacflex_http_request_duration_seconds histogram",
        ]
        name = "hvacflex_http_request_duration_seconds"
        for (method, route), histogram in latency:
            cumulative = 0
            for bound, count in zip([*LATENCY_BUCKETS_S, None], histogram.counts, strict=True):
                cumulative += count
                le = "+Inf" if bound is None else f"{bound:g}"
                out.append(
                    f"{name}_bucket{_labels(method=method, route=route, le=le)} {cumulative}"
                )
            labels = _labels(method=method, route=route)
            out.append(f"{name}_sum{labels} {histogram.total_s:.6f}")
            out.append(f"{name}_count{labels} {histogram.n}")
        return out


def _escape(value: str) -> str:
    """A label value with the text format's escapes (backslash, newline, double quote)."""
    return value.replace("\\", "\\\\").replace("\n", "\\n").replace('"', '\\"')


def _labels(**labels: str) -> str:
    """``{a="x",b="y"}``."""
    return "{" + ",".join(f'{k}="{_escape(v)}"' for k, v in labels.items()) + "}"


def _as_utc(value: datetime) -> datetime:
    """A stored time as aware UTC (SQLite returns naive UTC times)."""
    return value.replace(tzinfo=UTC) if value.tzinfo is None else value.astimezone(UTC)


def last_measurements(session: Session) -> dict[str, datetime]:
    """When each building's latest measurement arrived (aware UTC), by building id."""
    rows = session.execute(
        select(Measurement.building_id, func.max(Measurement.received_at)).group_by(
            Measurement.building_id
        )
    )
    return {building_id: _as_utc(at) for building_id, at in rows if at is not None}


def stale_buildings(
    session: Session, stale_after_s: float, now: datetime | None = None
) -> list[str]:
    """Buildings whose latest measurement arrived more than ``stale_after_s`` [s] before
    ``now`` (default: the wall clock), sorted. A building that never sent one has no plan
    and is not listed."""
    now = datetime.now(UTC) if now is None else _as_utc(now)
    return sorted(
        building_id
        for building_id, at in last_measurements(session).items()
        if (now - at).total_seconds() > stale_after_s
    )


def metrics_text(session: Session, requests: RequestMetrics, stale_after_s: float) -> str:
    """Every metric family in the Prometheus text format (ends with a newline)."""
    plans = session.execute(
        select(PlanRow.trigger, PlanRow.fallback, func.count()).group_by(
            PlanRow.trigger, PlanRow.fallback
        )
    ).all()
    by_trigger: dict[str, int] = {}
    failures = 0
    for trigger, fallback, n in plans:
        by_trigger[trigger] = by_trigger.get(trigger, 0) + int(n)
        failures += int(n) if fallback else 0
    buildings = session.scalar(select(func.count()).select_from(BuildingRow)) or 0
    stale = len(stale_buildings(session, stale_after_s))
    lines = requests.lines()
    lines += [
        "# HELP hvacflex_plans_total Plans stored, by what triggered them.",
        "# TYPE hvacflex_plans_total counter",
        *(f"hvacflex_plans_total{_labels(trigger=t)} {n}" for t, n in sorted(by_trigger.items())),
        "# HELP hvacflex_solver_failures_total Plans where the solver gave no plan (fallback).",
        "# TYPE hvacflex_solver_failures_total counter",
        f"hvacflex_solver_failures_total {failures}",
        "# HELP hvacflex_buildings Registered buildings.",
        "# TYPE hvacflex_buildings gauge",
        f"hvacflex_buildings {buildings}",
        "# HELP hvacflex_stale_buildings Buildings whose measurements stopped arriving.",
        "# TYPE hvacflex_stale_buildings gauge",
        f"hvacflex_stale_buildings {stale}",
    ]
    return "\n".join(lines) + "\n"


class JsonFormatter(logging.Formatter):
    """One JSON object per line: ``time`` (ISO, UTC), ``level``, ``logger``, ``message`` and
    the record's ``fields`` (a dict passed as ``extra={"fields": {...}}``)."""

    def format(self, record: logging.LogRecord) -> str:
        entry: dict[str, Any] = {
            "time": datetime.fromtimestamp(record.created, UTC).isoformat(timespec="milliseconds"),
            "level": record.levelname.lower(),
            "logger": record.name,
            "message": record.getMessage(),
        }
        entry.update(getattr(record, "fields", None) or {})
        if record.exc_info:
            entry["exception"] = self.formatException(record.exc_info)
        return json.dumps(entry, default=str)


def json_log_config(level: str = "INFO") -> dict[str, Any]:
    """A :func:`logging.config.dictConfig` (uvicorn's ``log_config``): the access log and
    uvicorn's own messages as JSON lines on standard error."""
    handler = {"class": "logging.StreamHandler", "formatter": "json", "stream": "ext://sys.stderr"}
    loggers = ("uvicorn", "uvicorn.error", ACCESS_LOGGER)
    return {
        "version": 1,
        "disable_existing_loggers": False,
        "formatters": {"json": {"()": JsonFormatter}},
        "handlers": {"json": handler},
        "loggers": {
            **{
                name: {"handlers": ["json"], "level": level, "propagate": False} for name in loggers
            },
            "uvicorn.access": {"handlers": [], "level": "WARNING", "propagate": False},
        },
    }


class ObserveRequests:
    """ASGI middleware: time every HTTP request, count it in :class:`RequestMetrics` and
    write one access-log line (method, route, path, status, duration, client, key id)."""

    def __init__(self, app: ASGIApp, metrics: RequestMetrics) -> None:
        self.app = app
        self.metrics = metrics
        self.log = logging.getLogger(ACCESS_LOGGER)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = time.perf_counter()
        status = {"code": 500}

        async def observed_send(message: Message) -> None:
            if message["type"] == "http.response.start":
                status["code"] = int(message["status"])
            await send(message)

        try:
            await self.app(scope, receive, observed_send)
        finally:
            duration_s = time.perf_counter() - started
            route = getattr(scope.get("route"), "path", None) or UNMATCHED_ROUTE
            method = str(scope["method"])
            self.metrics.observe(method, route, status["code"], duration_s)
            principal = scope.get("state", {}).get("principal")
            client = scope.get("client")
            fields = {
                "method": method,
                "route": route,
                "path": str(scope.get("path", ""))[:512],
                "status": status["code"],
                "duration_s": round(duration_s, 6),
                "client": client[0] if client else None,
                "key_id": getattr(principal, "key_id", None),
            }
            self.log.info("request", extra={"fields": fields})


def check_listen_address(host: str, port: int) -> None:
    """Check that the service can listen on ``host:port`` before it starts (a trial bind).

    Raises
    ------
    InputError : ``host`` is not an IP address or a name this machine resolves, or the
        address cannot be bound here (in use, not this machine's, not permitted).
    """
    if re.fullmatch(r"[0-9.]+", host):
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            raise InputError(
                "not an IPv4 address",
                field="--host",
                value=host,
                hint="e.g. --host 127.0.0.1 (this machine only) or --host 0.0.0.0 (all)",
            ) from None
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except (socket.gaierror, UnicodeError) as exc:
        raise InputError(
            f"not an address this machine resolves ({exc})",
            field="--host",
            value=host,
            hint="e.g. --host 127.0.0.1, --host 0.0.0.0 or --host ::1",
        ) from None
    family, kind, proto, _, address = infos[0]
    try:
        with socket.socket(family, kind, proto) as trial:
            trial.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            trial.bind(address)
    except OSError as exc:
        raise InputError(
            f"cannot listen on {host}:{port} ({exc.strerror or exc})",
            field="--host/--port",
            value=f"{host}:{port}",
            hint="choose a free --port, or an address of this machine for --host",
        ) from None


def check_tls(certfile: Path | None, keyfile: Path | None) -> bool:
    """Whether the service runs TLS: both files given and loadable, or neither.

    Raises
    ------
    InputError : only one of the two given, a file missing or unreadable, or the pair not a
        PEM certificate (chain) and its private key.
    """
    if certfile is None and keyfile is None:
        return False
    if certfile is None or keyfile is None:
        raise InputError(
            "TLS needs both --ssl-certfile and --ssl-keyfile",
            field="--ssl-keyfile" if keyfile is None else "--ssl-certfile",
            hint="see docs/guide/service.md, 'TLS', for a local CA recipe",
        )
    for name, path in (("--ssl-certfile", certfile), ("--ssl-keyfile", keyfile)):
        if not path.is_file():
            raise InputError("no such file", field=name, value=str(path))
    try:
        ssl.create_default_context(ssl.Purpose.CLIENT_AUTH).load_cert_chain(certfile, keyfile)
    except (ssl.SSLError, OSError) as exc:
        raise InputError(
            f"not a PEM certificate and its private key ({exc})",
            field="--ssl-certfile",
            value=str(certfile),
            hint="see docs/guide/service.md, 'TLS', for a local CA recipe",
        ) from None
    return True


TLS_MINIMUM_VERSIONS: dict[str, ssl.TLSVersion] = {
    "1.2": ssl.TLSVersion.TLSv1_2,
    "1.3": ssl.TLSVersion.TLSv1_3,
}
"""``--ssl-min-version``'s choices: the oldest TLS version the service accepts."""
DEFAULT_TLS_MINIMUM_VERSION = "1.2"


def tls_minimum_version(text: str) -> ssl.TLSVersion:
    """The :class:`ssl.TLSVersion` ``--ssl-min-version`` names.

    Raises
    ------
    InputError : not one of :data:`TLS_MINIMUM_VERSIONS`.
    """
    version = TLS_MINIMUM_VERSIONS.get(text.strip())
    if version is None:
        raise InputError(
            "not a TLS version the service offers",
            field="--ssl-min-version",
            value=text,
            hint=f"use one of {', '.join(TLS_MINIMUM_VERSIONS)}",
        )
    return version


def is_loopback(host: str) -> bool:
    """Whether every address ``host`` resolves to is this machine's loopback (127.0.0.0/8,
    ::1): only this machine can then reach the service. ``0.0.0.0``, ``::`` and names that
    resolve elsewhere are not; a name that does not resolve is not either."""
    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError):
        return False
    addresses = {info[4][0] for info in infos}
    return bool(addresses) and all(
        ipaddress.ip_address(str(a).split("%")[0]).is_loopback for a in addresses
    )


def check_plain_http(host: str, tls: bool, insecure_http: bool) -> None:
    """Refuse plain HTTP on an address other machines reach (API keys would travel in
    clear) unless ``insecure_http`` (``--insecure-http``: e.g. behind a TLS proxy).

    Raises
    ------
    InputError : naming ``--insecure-http`` and the TLS options.
    """
    if tls or insecure_http or is_loopback(host):
        return
    raise InputError(
        "plain HTTP on an address other machines reach: API keys would travel in clear",
        field="--host",
        value=host,
        hint="serve TLS with --ssl-certfile CERT.pem --ssl-keyfile KEY.pem "
        "(and --ssl-min-version), listen on 127.0.0.1, or pass --insecure-http when a "
        "TLS-terminating proxy in front of it carries the keys",
    )


def service_url(host: str, port: int, tls: bool) -> str:
    """``http(s)://HOST:PORT/`` (an IPv6 address in brackets)."""
    shown = f"[{host}]" if ":" in host else host
    return f"{'https' if tls else 'http'}://{shown}:{port}/"
