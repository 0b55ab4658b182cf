"""OpenADR 2.0b: hvacflex as the site (VEN) a utility's or aggregator's VTN dispatches.

``hvacflex serve openadr-ven`` runs :func:`run_ven`: an openleadr ``OpenADRClient`` that
registers with the VTN, polls it for events and answers them through the service's HTTP API
with the operator key (:class:`~hvacflex.service.replay.Client`):

========================  =======================================  ==============================
OpenADR 2.0b signal        service request                          unit conversion
========================  =======================================  ==============================
``ELECTRICITY_PRICE``,     ``POST /v1/signals/prices``, one energy  currency/kWh → SGD/MWh (× 1000,
``ENERGY_PRICE``           price per 30-min period the intervals    times the item base's SI scale)
(signal type ``price``)    cover
``DEMAND_CHARGE``          ``POST /v1/signals/peak-price`` (φ)      currency/kW → SGD/kW (× scale)
``LOAD_DISPATCH``,         ``POST /v1/activations`` start/end per   payload > 0 marks an interval
``SIMPLE``                 run of dispatched periods, for each      dispatched; the amount is not
                           target building that offered reserve in  used (the service curtails the
                           every one of them                        reserve it offered)
========================  =======================================  ==============================

Event times are real times; the service plans on the calendar of its shipped data (2014).
``clock_offset`` is added to every event time before it reaches the service and subtracted
from every service time the VEN reports, so a test VTN can drive a 2014 scenario. It must
be a whole number of 30-min periods, so a VTN's period-aligned intervals stay aligned.

Opt responses (``oadrCreatedEvent``; one per event, as 2.0b has it): price and demand-charge
events are opted in when the service stored the signal (optOut when it refused it: a time it
cannot plan, a currency other than SGD, a relative price). A dispatch is opted in when at
least one of its target buildings offered reserve (``horizon_reserve_kw`` of its latest plan
> :data:`RESERVE_OFFER_MIN_KW`) in *every* dispatched period; only those buildings are
activated. A building whose offer covers only some of the periods (a partial offer) is not
activated at all: an IL event of the service is one contiguous curtailment of the locked
plan, and a 2.0b opt covers a whole event, so the VEN cannot accept part of one. When no
target building offered the whole dispatch, the VEN opts out and nothing is posted.

Reports (openleadr's VTN requests ``TELEMETRY_USAGE`` reports only, so all three are of that
name, told apart by report specifier, reading type and report type; per building, its id is
the resource id):

* ``hvacflex-telemetry`` — metered power (``Direct Read``, ``reading``, W scaled k = kW): the
  ``previous_power_kw`` of the building's latest measurement, at the start of the period it
  was metered in.
* ``hvacflex-forecast`` — planned power (``Projected``, ``usage``, kW) over the latest plan's
  horizon, and the reserve offer (``Projected``, ``upRegulationCapacityAvailable``, kW): the
  load reduction the building offers per period. 2.0b has no reserve-offer object; an
  ``EiOpt`` availability schedule says only *when* a resource is available, not how many kW,
  and openleadr's VTN does not serve ``EiOpt``. A projected capacity report carries kW per
  period, is standard 2.0b and reaches any VTN that takes telemetry reports.
"""

from __future__ import annotations

import asyncio
import logging
import math
import signal
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex.errors import ConfigError, HvacflexError, InputError
from hvacflex.service.replay import Client, check_service_url

logger = logging.getLogger("hvacflex.service.openadr")

PERIOD = pd.Timedelta(minutes=30)
"""The service's period; event intervals must start and end on its boundaries."""
KWH_PER_MWH = 1000.0
RESERVE_OFFER_MIN_KW = 1e-3
"""Smallest planned reserve [kW] that counts as an offer for a period."""
SERVICE_CURRENCY = "SGD"
PRICE_SIGNALS = ("ELECTRICITY_PRICE", "ENERGY_PRICE")
DEMAND_SIGNALS = ("DEMAND_CHARGE",)
DISPATCH_SIGNALS = ("LOAD_DISPATCH", "SIMPLE", "simple")
SI_SCALE = {
    "p": 1e-12,
    "n": 1e-9,
    "micro": 1e-6,
    "m": 1e-3,
    "c": 1e-2,
    "d": 1e-1,
    "none": 1.0,
    "k": 1e3,
    "M": 1e6,
    "G": 1e9,
    "T": 1e12,
}
"""OpenADR's SI scale codes (an item base's ``scale``) as factors."""
OPT_IN, OPT_OUT = "optIn", "optOut"
TELEMETRY_REPORT = "hvacflex-telemetry"
FORECAST_REPORT = "hvacflex-forecast"
REPORT_DURATION = timedelta(hours=24)
"""The data a report can cover (openleadr's report ``duration``)."""
SAMPLING_MIN, SAMPLING_MAX = timedelta(seconds=1), timedelta(minutes=30)
"""Sampling intervals the VEN accepts from the VTN's report requests."""


class EventRefused(HvacflexError):
    """An event the VEN cannot carry out as sent (it opts out; the reason is logged)."""


@dataclass(frozen=True)
class VenConfig:
    """The adapter's settings (validated at the edge, by :meth:`__post_init__`).

    ``clock_offset``: added to event times to get service times [a multiple of 30 min].
    ``cert``/``key``: the VEN's certificate and key (PEM) for mutual TLS and signed
    messages; ``ca``: the CA that signed the VTN's certificate (needed with ``cert``).
    ``vtn_fingerprint``: the VTN's certificate fingerprint, to check its signatures.
    """

    vtn_url: str
    ven_name: str
    service_url: str
    operator_key: str
    building_ids: tuple[str, ...] = ()
    clock_offset: pd.Timedelta = field(default_factory=lambda: pd.Timedelta(0))
    cert: Path | None = None
    key: Path | None = None
    ca: Path | None = None
    vtn_fingerprint: str | None = None

    def __post_init__(self) -> None:
        check_service_url(self.service_url)
        if not self.vtn_url.startswith(("http://", "https://")):
            raise InputError(
                "not an http(s) URL",
                field="--vtn-url",
                value=self.vtn_url,
                hint="e.g. --vtn-url http://127.0.0.1:8080/OpenADR2/Simple/2.0b",
            )
        if not self.ven_name.strip():
            raise InputError("must not be empty", field="--ven-name", value=self.ven_name)
        if self.clock_offset % PERIOD != pd.Timedelta(0):
            raise InputError(
                "must be a whole number of 30-min periods",
                field="--clock-offset",
                value=str(self.clock_offset),
                hint='e.g. --clock-offset "-4656 days +01:30:00"',
            )
        if (self.cert is None) != (self.key is None):
            raise InputError(
                "give both --cert and --key, or neither", field="--cert", value=str(self.cert)
            )
        if self.cert is not None and self.ca is None:
            raise InputError(
                "a VEN with a certificate needs the CA of the VTN's certificate",
                field="--ca",
                hint="pass --ca CA.pem (openleadr checks the VTN against it)",
            )
        for name, path in (("--cert", self.cert), ("--key", self.key), ("--ca", self.ca)):
            if path is not None and not path.is_file():
                raise InputError("no such file", field=name, value=str(path))


def parse_clock_offset(text: str) -> pd.Timedelta:
    """``--clock-offset``: a duration as pandas reads it (``"-4656 days +01:30:00"``,
    ``"-111744h"``, ``"-6704460min"``, ``"0s"``).

    Raises
    ------
    InputError : not a duration.
    """
    try:
        return pd.Timedelta(text)
    except ValueError:
        raise InputError(
            "not a duration",
            field="--clock-offset",
            value=text,
            hint="e.g. '-4656 days +01:30:00', '-111744h' or '0s'",
        ) from None


@dataclass(frozen=True)
class SignalInterval:
    """One interval of an event signal, in service time."""

    start: pd.Timestamp
    duration: pd.Timedelta
    value: float


def to_service_time(stamp: datetime, clock_offset: pd.Timedelta) -> pd.Timestamp:
    """An OpenADR (real, tz-aware) time as service time (Singapore)."""
    local = pd.Timestamp(stamp)
    if local.tzinfo is None:
        local = local.tz_localize("UTC")
    return (local + clock_offset).tz_convert("Asia/Singapore")


def to_vtn_time(text: str, clock_offset: pd.Timedelta) -> datetime:
    """A service time (ISO text) as the real UTC time the VTN sees."""
    stamp = pd.Timestamp(text)
    if stamp.tzinfo is None:
        stamp = stamp.tz_localize("Asia/Singapore")
    converted: datetime = (stamp - clock_offset).tz_convert("UTC").to_pydatetime()
    return converted


def signal_intervals(
    event_signal: dict[str, Any], clock_offset: pd.Timedelta
) -> list[SignalInterval]:
    """The intervals of a parsed event signal (openleadr's dict), in service time, with their
    payloads scaled by the signal's item base (``measurement.scale``).

    Raises
    ------
    EventRefused : an interval that does not start and end on a 30-min boundary, or a
        payload that is not a finite number.
    """
    scale = SI_SCALE.get(str((event_signal.get("measurement") or {}).get("scale") or "none"), 1.0)
    out: list[SignalInterval] = []
    for interval in event_signal.get("intervals") or []:
        start = to_service_time(interval["dtstart"], clock_offset)
        duration = pd.Timedelta(interval["duration"])
        if start != start.floor(PERIOD) or duration <= pd.Timedelta(0) or duration % PERIOD:
            raise EventRefused(
                f"interval {start.isoformat()} + {duration} is not whole 30-min periods"
            )
        value = float(interval["signal_payload"])
        if not math.isfinite(value):
            raise EventRefused(f"interval {start.isoformat()}: payload {value} is not finite")
        out.append(SignalInterval(start, duration, value * scale))
    if not out:
        raise EventRefused("the signal has no intervals")
    return out


def period_values(intervals: Iterable[SignalInterval]) -> pd.Series:
    """Each interval's value on every 30-min period it covers (service time), in order."""
    values: dict[pd.Timestamp, float] = {}
    for interval in intervals:
        for j in range(interval.duration // PERIOD):
            values[interval.start + j * PERIOD] = interval.value
    return pd.Series(values, dtype=float).sort_index()


def _check_currency(event_signal: dict[str, Any]) -> None:
    unit = (event_signal.get("measurement") or {}).get("unit")
    if unit not in (None, SERVICE_CURRENCY):
        raise EventRefused(f"prices in {unit}; the service plans in {SERVICE_CURRENCY}")


def _check_price_type(event_signal: dict[str, Any]) -> None:
    kind = event_signal.get("signal_type")
    if kind != "price":
        raise EventRefused(
            f"signal type {kind!r}: only absolute prices (signal type 'price') are mapped"
        )


def energy_prices(
    event_signal: dict[str, Any], clock_offset: pd.Timedelta
) -> tuple[pd.Timestamp, list[float]]:
    """An ``ELECTRICITY_PRICE``/``ENERGY_PRICE`` signal as the service's prices: the first
    period start and one energy price per consecutive period [SGD/MWh] (payload in
    currency/kWh × 1000).

    Raises
    ------
    EventRefused : not signal type ``price``, a currency other than SGD, or gaps between
        the intervals.
    """
    _check_price_type(event_signal)
    _check_currency(event_signal)
    series = period_values(signal_intervals(event_signal, clock_offset))
    expected = pd.date_range(series.index[0], periods=len(series), freq=PERIOD)
    if not series.index.equals(expected):
        raise EventRefused("the price intervals leave gaps")
    return series.index[0], [float(v) * KWH_PER_MWH for v in series]


def demand_charge_sgd_per_kw(event_signal: dict[str, Any]) -> float:
    """A ``DEMAND_CHARGE`` signal as φ [SGD/kW] (payload in currency/kW).

    The service has one φ, not a schedule: it is set at once, from the next plan on.

    Raises
    ------
    EventRefused : not a ``price`` signal, a currency other than SGD, or intervals with
        different charges.
    """
    _check_price_type(event_signal)
    _check_currency(event_signal)
    values = {i.value for i in signal_intervals(event_signal, pd.Timedelta(0))}
    if len(values) != 1:
        raise EventRefused(f"demand charges {sorted(values)}: the service takes one φ")
    return values.pop()


def dispatched_periods(
    event_signal: dict[str, Any], clock_offset: pd.Timedelta
) -> list[pd.Timestamp]:
    """The 30-min periods (service time) of a dispatch signal whose payload is > 0."""
    series = period_values(signal_intervals(event_signal, clock_offset))
    return [pd.Timestamp(t) for t in series.index[series.to_numpy() > 0]]


def activation_runs(periods: Iterable[pd.Timestamp]) -> list[tuple[pd.Timestamp, pd.Timestamp]]:
    """Consecutive periods as (start, end) activation pairs; ``end`` is the end of the last."""
    runs: list[tuple[pd.Timestamp, pd.Timestamp]] = []
    for t in sorted(periods):
        if runs and runs[-1][1] == t:
            runs[-1] = (runs[-1][0], t + PERIOD)
        else:
            runs.append((t, t + PERIOD))
    return runs


def offered_periods(plan: dict[str, Any] | None) -> set[pd.Timestamp]:
    """The periods (service time) in which a plan offers reserve (> RESERVE_OFFER_MIN_KW)."""
    if plan is None:
        return set()
    return {
        pd.Timestamp(t).tz_convert("Asia/Singapore")
        for t, r in zip(plan["horizon_time"], plan["horizon_reserve_kw"], strict=False)
        if r is not None and r > RESERVE_OFFER_MIN_KW
    }


@dataclass(frozen=True)
class DispatchDecision:
    """What the VEN does with a dispatch: the buildings activated and why the others not."""

    activated: tuple[str, ...]
    refused: dict[str, str]

    @property
    def opt(self) -> str:
        return OPT_IN if self.activated else OPT_OUT


def decide_dispatch(
    periods: list[pd.Timestamp], plans: dict[str, dict[str, Any] | None]
) -> DispatchDecision:
    """Activate each building whose latest plan offers reserve in every dispatched period;
    a building with a partial offer (or none) is left out, with the periods it lacks."""
    activated: list[str] = []
    refused: dict[str, str] = {}
    if not periods:
        return DispatchDecision((), {b: "no period dispatched (all payloads 0)" for b in plans})
    for building_id, plan in plans.items():
        missing = sorted(set(periods) - offered_periods(plan))
        if missing:
            shown = ", ".join(t.isoformat() for t in missing[:4])
            refused[building_id] = f"no reserve offered for {len(missing)} period(s): {shown}"
        else:
            activated.append(building_id)
    return DispatchDecision(tuple(activated), refused)


def event_buildings(event: dict[str, Any], building_ids: tuple[str, ...]) -> tuple[str, ...]:
    """The buildings an event targets: those named as resource ids, else all of the VEN's."""
    named = [
        str(t["resource_id"])
        for t in event.get("targets") or []
        if t.get("resource_id") is not None
    ]
    chosen = tuple(b for b in building_ids if b in named)
    return chosen if named else building_ids


def _signals(event: dict[str, Any]) -> list[dict[str, Any]]:
    signals = event.get("event_signals") or []
    if isinstance(signals, dict):
        signals = signals.get("event_signals") or []
    return list(signals)


class OpenAdrVen:
    """The VEN's behaviour: events → service requests, service plans → reports.

    Blocking HTTP calls to the service run in a worker thread (``asyncio.to_thread``) so
    the openleadr client's event loop keeps polling.
    """

    def __init__(
        self,
        config: VenConfig,
        service: Client | None = None,
        clock: Callable[[], datetime] = lambda: datetime.now(UTC),
    ) -> None:
        self.config = config
        self.service = service or Client(config.service_url, config.operator_key)
        self.clock = clock
        self.activations: dict[str, list[tuple[pd.Timestamp, pd.Timestamp, tuple[str, ...]]]] = {}
        """Per dispatch event id: the activation runs posted and their buildings (memory)."""

    # -- events --------------------------------------------------------------------------
    async def on_event(self, event: dict[str, Any]) -> str:
        """openleadr's ``on_event`` (and ``on_update_event``): the opt for the event."""
        return await asyncio.to_thread(self.handle_event, event)

    def handle_event(self, event: dict[str, Any]) -> str:
        """Carry out every signal of ``event``; optIn only if every one was carried out."""
        event_id = str(event.get("event_descriptor", {}).get("event_id"))
        try:
            self._undo_activations(event_id)  # a modified or cancelled event replaces them
        except HvacflexError as exc:
            logger.warning("event %s: activations not undone (the service: %s)", event_id, exc)
            return OPT_OUT
        if event.get("event_descriptor", {}).get("event_status") == "cancelled":
            logger.info("event %s cancelled (acknowledged)", event_id)
            return OPT_IN
        opts: list[str] = []
        for event_signal in _signals(event):
            name = str(event_signal.get("signal_name"))
            try:
                opts.append(self._apply(name, event_signal, event))
            except EventRefused as exc:
                logger.warning("event %s, %s: opting out (%s)", event_id, name, exc)
                opts.append(OPT_OUT)
            except HvacflexError as exc:  # the service refused it or could not be reached
                logger.warning("event %s, %s: opting out (the service: %s)", event_id, name, exc)
                opts.append(OPT_OUT)
        opt = OPT_IN if opts and all(o == OPT_IN for o in opts) else OPT_OUT
        logger.info("event %s: %s", event_id, opt)
        return opt

    def _apply(self, name: str, event_signal: dict[str, Any], event: dict[str, Any]) -> str:
        offset = self.config.clock_offset
        if name in PRICE_SIGNALS:
            start, prices = energy_prices(event_signal, offset)
            body = {"start": start.isoformat(), "energy_price_sgd_per_mwh": prices}
            self.service.call("POST", "/v1/signals/prices", body)
            logger.info("prices of %d periods from %s stored", len(prices), start.isoformat())
            return OPT_IN
        if name in DEMAND_SIGNALS:
            phi = demand_charge_sgd_per_kw(event_signal)
            self.service.call("POST", "/v1/signals/peak-price", {"peak_price_sgd_per_kw": phi})
            logger.info("peak-power price φ = %g SGD/kW stored", phi)
            return OPT_IN
        if name in DISPATCH_SIGNALS:
            return self._dispatch(dispatched_periods(event_signal, offset), event)
        raise EventRefused(f"signal {name!r} has no meaning for the service")

    def _now(self) -> pd.Timestamp:
        """The current period start in service time (the VEN's clock + the offset)."""
        return to_service_time(self.clock(), self.config.clock_offset).floor(PERIOD)

    def _dispatch(self, periods: list[pd.Timestamp], event: dict[str, Any]) -> str:
        """Activate the buildings that offered every dispatched period from now on (a run
        already under way starts now; periods past are not asked of the plan)."""
        now = self._now()
        periods = [t for t in periods if t >= now]
        if not periods:
            raise EventRefused("every dispatched period is over")
        targets = event_buildings(event, self.config.building_ids)
        plans = {b: self._latest_plan(b) for b in targets}
        decision = decide_dispatch(periods, plans)
        for building_id, reason in decision.refused.items():
            logger.warning("dispatch: %s not activated (%s)", building_id, reason)
        if decision.activated:
            runs = activation_runs(periods)
            event_id = str(event.get("event_descriptor", {}).get("event_id"))
            self.activations[event_id] = [(a, b, decision.activated) for a, b in runs]
            for start, end in runs:
                for kind, time in (("start", start), ("end", end)):
                    body = {
                        "event": kind,
                        "time": time.isoformat(),
                        "building_ids": list(decision.activated),
                    }
                    self.service.call("POST", "/v1/activations", body)
            logger.info("dispatch: %s activated", ", ".join(decision.activated))
        return decision.opt

    def _undo_activations(self, event_id: str) -> None:
        """End the activations a dispatch posted that have not ended yet: at the start of
        a run still ahead (posted later, the end wins within its period), else now."""
        now = self._now()
        for start, end, buildings in self.activations.pop(event_id, []):
            if end <= now:
                continue
            body = {
                "event": "end",
                "time": max(start, now).isoformat(),
                "building_ids": list(buildings),
            }
            self.service.call("POST", "/v1/activations", body)
            logger.info("event %s: activation from %s undone", event_id, start.isoformat())

    def _latest_plan(self, building_id: str) -> dict[str, Any] | None:
        try:
            plan: dict[str, Any] = self.service.call("GET", f"/v1/buildings/{building_id}/plan")
        except HvacflexError as exc:
            logger.warning("no plan of %s (%s)", building_id, exc)
            return None
        return plan

    # -- reports -------------------------------------------------------------------------
    def metered_power(self, building_id: str) -> list[tuple[datetime, float]]:
        """The building's latest metered power [kW] at the start of its period (VTN time)."""
        records = self.service.call("GET", f"/v1/buildings/{building_id}/measurements?limit=1")
        out: list[tuple[datetime, float]] = []
        for record in records:
            if record["previous_power_kw"] is not None:
                metered_at = pd.Timestamp(record["time"]) - PERIOD
                out.append(
                    (
                        to_vtn_time(metered_at.isoformat(), self.config.clock_offset),
                        float(record["previous_power_kw"]),
                    )
                )
        return out

    def forecast(self, building_id: str, column: str) -> list[tuple[datetime, float]]:
        """A horizon column of the building's latest plan (``horizon_power_kw`` or
        ``horizon_reserve_kw``) [kW] per period start (VTN time)."""
        plan = self._latest_plan(building_id)
        if plan is None:
            return []
        return [
            (to_vtn_time(t, self.config.clock_offset), float(v))
            for t, v in zip(plan["horizon_time"], plan[column], strict=False)
            if v is not None
        ]

    async def _report(self, read: Callable[[], list[tuple[datetime, float]]]) -> Any:
        try:
            return await asyncio.to_thread(read)
        except HvacflexError as exc:
            logger.warning("report skipped (the service: %s)", exc)
            return []


def openadr_client(ven: OpenAdrVen) -> Any:
    """The openleadr ``OpenADRClient`` of ``ven``: its event handlers and, per building, the
    telemetry and forecast reports (module docstring).

    Raises
    ------
    ConfigError : openleadr is not installed.
    """
    try:
        from openleadr import OpenADRClient, enums, objects
    except ImportError:
        raise ConfigError(
            "openleadr is not installed",
            field="serve openadr-ven",
            hint='pip install "hvacflex[openadr]"',
        ) from None
    config = ven.config
    client = OpenADRClient(
        ven_name=config.ven_name,
        vtn_url=config.vtn_url,
        cert=None if config.cert is None else str(config.cert),
        key=None if config.key is None else str(config.key),
        ca_file=None if config.ca is None else str(config.ca),
        vtn_fingerprint=config.vtn_fingerprint,
        show_fingerprint=False,
    )
    client.add_handler("on_event", ven.on_event)
    client.add_handler("on_update_event", ven.on_event)
    rate = objects.SamplingRate(min_period=SAMPLING_MIN, max_period=SAMPLING_MAX, on_change=False)
    for building_id in config.building_ids:
        reports = (
            (
                TELEMETRY_REPORT,
                "metered_power_kw",
                enums.READING_TYPE.DIRECT_READ,
                enums.REPORT_TYPE.READING,
                lambda b=building_id: ven.metered_power(b),
            ),
            (
                FORECAST_REPORT,
                "planned_power_kw",
                enums.READING_TYPE.PROJECTED,
                enums.REPORT_TYPE.USAGE,
                lambda b=building_id: ven.forecast(b, "horizon_power_kw"),
            ),
            (
                FORECAST_REPORT,
                "reserve_offer_kw",
                enums.READING_TYPE.PROJECTED,
                enums.REPORT_TYPE.UP_REGULATION_CAPACITY_AVAILABLE,
                lambda b=building_id: ven.forecast(b, "horizon_reserve_kw"),
            ),
        )
        for specifier, what, reading_type, report_type, read in reports:

            async def callback(read: Callable[[], list[tuple[datetime, float]]] = read) -> Any:
                return await ven._report(read)

            client.add_report(
                callback,
                resource_id=building_id,
                measurement="REAL_POWER",
                unit="W",
                scale="k",
                report_specifier_id=specifier,
                r_id=f"{building_id}.{what}",
                reading_type=reading_type,
                report_type=report_type,
                report_duration=REPORT_DURATION,
                sampling_rate=rate,
            )
    return client


async def run_ven(config: VenConfig, *, stop_after_s: float | None = None) -> None:
    """Run the VEN until SIGINT/SIGTERM (or ``stop_after_s`` [s]), then stop it cleanly.

    Raises
    ------
    InputError : ``stop_after_s`` is not a positive number, or the VTN did not register
        the VEN.
    """
    if stop_after_s is not None and not (math.isfinite(stop_after_s) and stop_after_s > 0):
        raise InputError("must be > 0 s", field="--stop-after-s", value=stop_after_s)
    service = Client(config.service_url, config.operator_key)
    if not config.building_ids:
        config = replace(config, building_ids=tuple(service.call("GET", "/v1/buildings")))
        logger.info("buildings: %s", ", ".join(config.building_ids) or "none registered")
    client = openadr_client(OpenAdrVen(config, service))
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await client.run()
    if client.registration_id is None:
        await client.stop()
        raise InputError(
            "the VTN did not register this VEN",
            field="--vtn-url",
            value=config.vtn_url,
            hint="check that the VTN runs at that URL and accepts this --ven-name "
            "(and, with TLS, the certificate and CA); openleadr's log above has its reason",
        )
    try:
        await asyncio.wait_for(stop.wait(), timeout=stop_after_s)
    except TimeoutError:
        pass
    finally:
        await client.stop()
