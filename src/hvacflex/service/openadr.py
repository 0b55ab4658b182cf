"""OpenADR 2.0b: hvacflex as the site (VEN) a utility's or aggregator's VTN dispatches.

``hvacflex serve openadr-ven`` runs :func:`run_ven`: an openleadr ``OpenADRClient`` that
registers with the VTN, polls it for events and answers them through the service's HTTP API
with the operator key (:class:`~hvacflex.service.replay.Client`), by the mapping of
:mod:`hvacflex.service.openadr_mapping` (signals → prices, φ, activations; the clock offset).
It keeps a record (:mod:`hvacflex.service.openadr_store`) of its answers, the activations it
posted and their settlement against metered power, so a restarted VEN neither answers an
event twice nor forgets what to end when the VTN cancels a dispatch.

Opt responses (``oadrCreatedEvent``; one per event, as 2.0b has it): price and demand-charge
events are opted in when the service stored the signal (optOut when it refused it: a time it
cannot plan, a currency other than SGD, a relative price). A dispatch is opted in when at
least one of its target buildings offered reserve (``horizon_reserve_kw`` of its latest plan
> :data:`RESERVE_OFFER_MIN_KW`) in *every* dispatched period; only those buildings are
activated. A building whose offer covers only some of the periods (a partial offer) is not
activated at all: an IL event of the service is one contiguous curtailment of the locked
plan, and a 2.0b opt covers a whole event, so the VEN cannot accept part of one. When no
target building offered the whole dispatch, the VEN opts out and posts no activation. Every
building a dispatch is refused for (no offer, a partial offer, a dispatch already over) goes
to the service with the reason (``POST /v1/activations/refused``, audited as
``activation_refused``); an accepted one is audited as ``activation``.

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

Reports go out at the interval the VTN asked for, and only with data
(:class:`ReportSender`): at most one report per report request and agreed interval (the
larger of its sampling interval and report-back duration); none while the building has no
measurement or plan (an empty report crashes openleadr's VTN); the metered power once per
interval, and a plan's horizon only when it differs from the one last sent for that request
(a new plan), not the whole horizon again at every sample.
"""

from __future__ import annotations

import asyncio
import logging
import math
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex.constants import PERIOD, TIMEZONE
from hvacflex.errors import ConfigError, HvacflexError, InputError
from hvacflex.service.openadr_mapping import (
    DEMAND_SIGNALS,
    DISPATCH_SIGNALS,
    OPT_IN,
    OPT_OUT,
    PRICE_SIGNALS,
    EventRefused,
    activation_runs,
    capacity_key,
    capacity_limit_windows,
    decide_dispatch,
    demand_charge_sgd_per_kw,
    dispatched_periods,
    energy_prices,
    event_buildings,
    is_capacity_limit,
    offered_reserve_kw,
    signals_of,
    to_service_time,
    to_vtn_time,
)
from hvacflex.service.openadr_store import (
    ActivationRun,
    EventRecord,
    SettledPeriod,
    VenStore,
    building_periods,
    default_ven_db_url,
    settle_building,
)
from hvacflex.service.replay import Client, check_service_url

logger = logging.getLogger("hvacflex.service.openadr")

METER_HISTORY_PERIODS = 1000
"""Measurements the VEN reads back to settle a dispatch (the service's largest page)."""
SETTLE_EVERY_S = 10.0
"""How often the running VEN settles the dispatches whose meters have passed their end [s]."""
TELEMETRY_REPORT = "hvacflex-telemetry"
FORECAST_REPORT = "hvacflex-forecast"
REPORT_DURATION = timedelta(hours=24)
"""The data a report can cover (openleadr's report ``duration``)."""
SAMPLING_MIN, SAMPLING_MAX = timedelta(seconds=1), PERIOD.to_pytimedelta()
"""Sampling intervals the VEN accepts from the VTN's report requests."""
REFUSAL_REASON_MAX_CHARS = 1000
"""The longest reason the service records for a refused dispatch."""
SAME_INTERVAL_SHARE = 0.5
"""A report request sampled again within this share of its agreed interval of the last
report sent (a scheduler's duplicate, a second job after re-registration) sends nothing."""


@dataclass(frozen=True)
class VenConfig:
    """The adapter's settings (validated at the edge, by :meth:`__post_init__`).

    ``clock_offset``: added to event times to get service times [a multiple of 30 min].
    ``cert``/``key``: the VEN's certificate and key (PEM) for mutual TLS and signed
    messages; ``ca``: the CA that signed the VTN's certificate (needed with ``cert``).
    ``vtn_fingerprint``: the VTN's certificate fingerprint, to check its signatures.
    ``db_url``: the database of the VEN's record (its answers, activations, settlement);
    None: an SQLite file in the user data folder (:func:`~hvacflex.service.openadr_store.
    default_ven_db_url`), never the folder the VEN is started from.
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
    db_url: str | None = None
    """The VEN's record (:mod:`~hvacflex.service.openadr_store`); None: the default file."""

    def record_url(self) -> str:
        """``db_url``, or the default file in the user data folder (created there)."""
        return self.db_url or default_ven_db_url()

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
class SignalOutcome:
    """What carrying out one signal gave: the opt, and for a dispatch the runs posted, the
    reserve the activated buildings offered (building → period ISO → kW) and why others
    were left out."""

    opt: str
    runs: tuple[ActivationRun, ...] = ()
    offers_kw: dict[str, dict[str, float]] = field(default_factory=dict)
    reason: str = ""


class OpenAdrVen:
    """The VEN's behaviour: events → service requests, service plans → reports, and its
    record (:class:`~hvacflex.service.openadr_store.VenStore`: answers, activations and
    their settlement, kept across restarts).

    Blocking HTTP calls to the service run in a worker thread (``asyncio.to_thread``) so
    the openleadr client's event loop keeps polling.
    """

    def __init__(
        self,
        config: VenConfig,
        service: Client | None = None,
        clock: Callable[[], datetime] = lambda: datetime.now(UTC),
        store: VenStore | None = None,
    ) -> None:
        self.config = config
        self.service = service or Client(config.service_url, config.operator_key)
        self.clock = clock
        self.store = store or VenStore.open(config.record_url(), config.ven_name)

    # -- events --------------------------------------------------------------------------
    async def on_event(self, event: dict[str, Any]) -> str:
        """openleadr's ``on_event`` (and ``on_update_event``): the opt for the event."""
        return await asyncio.to_thread(self.handle_event, event)

    def handle_event(self, event: dict[str, Any]) -> str:
        """Carry out every signal of ``event``; optIn only if every one was carried out.

        A version already answered (the same modification number, e.g. sent again after a
        restart) gets the recorded opt and changes nothing; a new version first ends what
        the earlier one activated and has not run yet.
        """
        descriptor = event.get("event_descriptor") or {}
        event_id = str(descriptor.get("event_id"))
        modification = int(descriptor.get("modification_number") or 0)
        status = str(descriptor.get("event_status") or "")
        known = self.store.get(event_id)
        if known is not None and known.modification_number == modification:
            logger.info(
                "event %s (version %d) answered before: %s", event_id, modification, known.opt
            )
            return known.opt
        try:
            kept = self._undo_activations(event_id, known)
        except HvacflexError as exc:
            logger.warning("event %s: activations not undone (the service: %s)", event_id, exc)
            return OPT_OUT
        if status == "cancelled":
            self._cancel_capacity_limits(event)
            logger.info("event %s cancelled (acknowledged)", event_id)
            self.store.save(replace(kept, modification_number=modification, event_status=status))
            return OPT_IN
        outcomes: list[SignalOutcome] = []
        for event_signal in signals_of(event):
            name = str(event_signal.get("signal_name"))
            try:
                outcomes.append(self._apply(name, event_signal, event))
            except EventRefused as exc:
                logger.warning("event %s, %s: opting out (%s)", event_id, name, exc)
                outcomes.append(SignalOutcome(OPT_OUT, reason=f"{name}: {exc}"))
            except HvacflexError as exc:  # the service refused it or could not be reached
                logger.warning("event %s, %s: opting out (the service: %s)", event_id, name, exc)
                outcomes.append(SignalOutcome(OPT_OUT, reason=f"{name}: the service: {exc}"))
        opt = OPT_IN if outcomes and all(o.opt == OPT_IN for o in outcomes) else OPT_OUT
        offers = {b: dict(o) for b, o in kept.offers_kw.items()}
        for outcome in outcomes:
            for building_id, periods in outcome.offers_kw.items():
                offers.setdefault(building_id, {}).update(periods)
        record = EventRecord(
            event_id,
            modification,
            status,
            opt,
            "; ".join(o.reason for o in outcomes if o.reason),
            kept.runs + tuple(r for o in outcomes for r in o.runs),
            offers,
        )
        self.store.save(record)
        logger.info("event %s: %s", event_id, opt)
        return opt

    def _apply(
        self, name: str, event_signal: dict[str, Any], event: dict[str, Any]
    ) -> SignalOutcome:
        offset = self.config.clock_offset
        if name in PRICE_SIGNALS:
            start, prices = energy_prices(event_signal, offset)
            body = {"start": start.isoformat(), "energy_price_sgd_per_mwh": prices}
            self.service.call("POST", "/v1/signals/prices", body)
            logger.info("prices of %d periods from %s stored", len(prices), start.isoformat())
            return SignalOutcome(OPT_IN)
        if name in DEMAND_SIGNALS:
            phi = demand_charge_sgd_per_kw(event_signal)
            self.service.call("POST", "/v1/signals/peak-price", {"peak_price_sgd_per_kw": phi})
            logger.info("peak-power price φ = %g SGD/kW stored", phi)
            return SignalOutcome(OPT_IN)
        if is_capacity_limit(event_signal):
            windows = capacity_limit_windows(event_signal, offset)
            body = {"windows": windows, "event_id": self._capacity_key(event, event_signal)}
            self.service.call("POST", "/v1/signals/feeder-limits", body)
            logger.info("feeder limit windows stored: %s", windows)
            return SignalOutcome(OPT_IN)
        if name in DISPATCH_SIGNALS:
            return self._dispatch(dispatched_periods(event_signal, offset), event)
        raise EventRefused(f"signal {name!r} has no meaning for the service")

    @staticmethod
    def _capacity_key(event: dict[str, Any], event_signal: dict[str, Any]) -> str:
        """The id the service stores a capacity signal's windows under."""
        event_id = str((event.get("event_descriptor") or {}).get("event_id"))
        return capacity_key(event_id, event_signal, signals_of(event).index(event_signal))

    def _cancel_capacity_limits(self, event: dict[str, Any]) -> None:
        """Remove the feeder limit windows of a cancelled event's capacity signals (a
        service that refuses or cannot be reached is logged; the cancel is acknowledged)."""
        for event_signal in signals_of(event):
            if not is_capacity_limit(event_signal):
                continue
            body = {"windows": [], "event_id": self._capacity_key(event, event_signal)}
            try:
                self.service.call("POST", "/v1/signals/feeder-limits", body)
            except HvacflexError as exc:
                logger.warning("feeder limit windows not removed (the service: %s)", exc)

    def _now(self) -> pd.Timestamp:
        """The current period start in service time (the VEN's clock + the offset)."""
        return to_service_time(self.clock(), self.config.clock_offset).floor(PERIOD)

    def _dispatch(self, periods: list[pd.Timestamp], event: dict[str, Any]) -> SignalOutcome:
        """Activate the buildings that offered every dispatched period from now on (a run
        already under way starts now; periods past are not asked of the plan)."""
        now = self._now()
        targets = event_buildings(event, self.config.building_ids)
        ahead = [t for t in periods if t >= now]
        if not ahead:
            why = "every dispatched period is over"
            self._record_refusal(event, list(targets), periods[0] if periods else now, why)
            raise EventRefused(why)
        periods = ahead
        plans = {b: self._latest_plan(b) for b in targets}
        decision = decide_dispatch(periods, plans)
        for building_id, reason in decision.refused.items():
            logger.warning("dispatch: %s not activated (%s)", building_id, reason)
        reason = "; ".join(f"{b} not activated ({r})" for b, r in decision.refused.items())
        if decision.refused:
            self._record_refusal(event, list(decision.refused), periods[0], reason)
        if not decision.activated:
            return SignalOutcome(OPT_OUT, reason=reason)
        runs = tuple(ActivationRun(a, b, decision.activated) for a, b in activation_runs(periods))
        for run in runs:
            for kind, at in (("start", run.start), ("end", run.end)):
                body = {
                    "event": kind,
                    "time": at.isoformat(),
                    "building_ids": list(decision.activated),
                }
                self.service.call("POST", "/v1/activations", body)
        logger.info("dispatch: %s activated", ", ".join(decision.activated))
        wanted = {t.isoformat() for t in periods}
        offers = {
            b: {
                t.isoformat(): float(r)
                for t, r in offered_reserve_kw(plans[b]).items()
                if t.isoformat() in wanted
            }
            for b in decision.activated
        }
        return SignalOutcome(OPT_IN, runs, offers, reason)

    def _record_refusal(
        self, event: dict[str, Any], building_ids: list[str], start: pd.Timestamp, reason: str
    ) -> None:
        """Tell the service which buildings a dispatch was refused for and why
        (``POST /v1/activations/refused``: its record and audit, ``activation_refused``);
        a service that refuses or cannot be reached is logged, the opt stands."""
        if not building_ids:
            return
        descriptor = event.get("event_descriptor") or {}
        body = {
            "time": start.isoformat(),
            "building_ids": sorted(building_ids),
            "reason": reason[:REFUSAL_REASON_MAX_CHARS],
            "event_id": str(descriptor.get("event_id"))[:128],
        }
        try:
            self.service.call("POST", "/v1/activations/refused", body)
        except HvacflexError as exc:
            logger.warning("dispatch refusal not recorded (the service: %s)", exc)

    def _undo_activations(self, event_id: str, known: EventRecord | None) -> EventRecord:
        """End the activations an earlier version of the event posted that have not ended
        yet: at the start of a run still ahead (posted later, the end wins within its
        period), else now. Returns the record with the runs (and offers) that ran, which
        are settled."""
        if known is None:
            return EventRecord(event_id, -1, "", OPT_IN)
        now = self._now()
        ran: list[ActivationRun] = []
        for run in known.runs:
            if run.end <= now:
                ran.append(run)
                continue
            body = {
                "event": "end",
                "time": max(run.start, now).isoformat(),
                "building_ids": list(run.building_ids),
            }
            self.service.call("POST", "/v1/activations", body)
            logger.info("event %s: activation from %s undone", event_id, run.start.isoformat())
            if run.start < now:
                ran.append(ActivationRun(run.start, now, run.building_ids))
        kept = {t.isoformat() for r in ran for t in r.periods()}
        offers = {
            b: {t: kw for t, kw in o.items() if t in kept} for b, o in known.offers_kw.items()
        }
        return replace(known, opt=OPT_IN, reason="", runs=tuple(ran), offers_kw=offers)

    # -- settlement ----------------------------------------------------------------------
    def settle_due(self) -> list[str]:
        """Settle every accepted dispatch whose buildings' meters have passed its end
        (:mod:`~hvacflex.service.openadr_store`); returns the event ids settled."""
        settled: list[str] = []
        for record in self.store.unsettled():
            periods: list[SettledPeriod] = []
            due = True
            for building_id in sorted({b for r in record.runs for b in r.building_ids}):
                activated = building_periods(record.runs, building_id)
                metered = self.metered_history(building_id)
                if not metered or max(metered) < activated[-1]:
                    due = False  # the meter has not passed the last activated period
                    break
                offers = record.offers_kw.get(building_id, {})
                reserve = {pd.Timestamp(t).tz_convert(TIMEZONE): kw for t, kw in offers.items()}
                periods += settle_building(building_id, activated, reserve, metered)
            if not due:
                continue
            self.store.store_settlement(record.event_id, periods)
            delivered = sum(p.delivered_kw for p in periods)
            short = sum(p.shortfall_kw for p in periods)
            logger.info(
                "event %s settled: %d period(s), delivered %.3f kW·periods, shortfall %.3f",
                record.event_id,
                len(periods),
                delivered,
                short,
            )
            settled.append(record.event_id)
        return settled

    def metered_history(self, building_id: str) -> dict[pd.Timestamp, float]:
        """Period start (service time) → metered power [kW] of the building's latest
        measurements (each carries the power of the period before it)."""
        records = self.service.call(
            "GET", f"/v1/buildings/{building_id}/measurements?limit={METER_HISTORY_PERIODS}"
        )
        return {
            pd.Timestamp(r["time"]).tz_convert(TIMEZONE) - PERIOD: float(r["previous_power_kw"])
            for r in records
            if r["previous_power_kw"] is not None
        }

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


def agreed_interval(granularity: timedelta | None, report_back: timedelta | None) -> timedelta:
    """The interval a report request is answered at: the larger of the VTN's sampling
    interval (granularity) and report-back duration (either may be absent; neither: one
    period). The VEN's data change once a period, so sampling finer than it reports adds
    nothing."""
    given = [d for d in (granularity, report_back) if d is not None and d > timedelta(0)]
    return max(given) if given else PERIOD.to_pytimedelta()


class ReportSender:
    """Answers the VTN's report requests for an openleadr client (replacing its
    ``update_report``, which openleadr's scheduler calls at each sample).

    Per report request: at most one report per :func:`agreed_interval`; no report without
    data; only the newest request of a report (after a re-registration); of the
    ``projected`` rIDs (the plan's horizon) only the (time, value) pairs that
    differ from those last sent for the request, so an unchanged plan is not sent again.
    ``clock`` is monotonic seconds.
    """

    def __init__(
        self, client: Any, projected: set[str], clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.client = client
        self.projected = projected
        self.clock = clock
        self.last_sent_s: dict[str, float] = {}
        self.sent: dict[tuple[str, str], dict[datetime, float]] = {}
        self.reports_sent = 0

    async def update_report(self, report_request_id: str) -> None:
        """Sample the request's rIDs and queue one report if the interval has passed since
        the last one and some value is new."""
        from openleadr import objects

        client = self.client
        request = next(
            (r for r in client.report_requests if r["report_request_id"] == report_request_id),
            None,
        )
        if request is None or self._superseded(request):
            return
        interval = agreed_interval(request["granularity"], request["report_back_duration"])
        now = self.clock()
        last = self.last_sent_s.get(report_request_id)
        if last is not None and now - last < SAME_INTERVAL_SHARE * interval.total_seconds():
            return
        specifier = request["report_specifier_id"]
        report = next((r for r in client.reports if r.report_specifier_id == specifier), None)
        if report is None:
            return
        intervals = []
        for r_id in request["r_ids"]:
            read = client.report_callbacks.get((specifier, r_id))
            if read is None:  # openleadr's VTN lists every rID under every request
                continue
            for dt, value in self.new_values(report_request_id, r_id, await read()):
                payload = objects.ReportPayload(r_id=r_id, value=value)
                intervals.append(objects.ReportInterval(dtstart=dt, report_payload=payload))
        if not intervals:
            return  # no report without data
        self.last_sent_s[report_request_id] = now
        self.reports_sent += 1
        await client.pending_reports.put(
            objects.Report(
                report_request_id=report_request_id,
                report_specifier_id=specifier,
                report_name=str(report.report_name).replace("METADATA_", ""),
                intervals=intervals,
                dtstart=min(i.dtstart for i in intervals),
            )
        )

    def _superseded(self, request: dict[str, Any]) -> bool:
        """Whether a later request asks for the same report (the VTN's request after a
        re-registration, which openleadr adds beside the old one and its job): the old one
        is then dropped, so the report does not go out twice per interval."""
        requests = self.client.report_requests
        later = requests[requests.index(request) + 1 :]
        if not any(r["report_specifier_id"] == request["report_specifier_id"] for r in later):
            return False
        if request.get("job") is not None:
            request["job"].remove()
        requests.remove(request)
        logger.info("report request %s superseded", request["report_request_id"])
        return True

    def new_values(
        self, request_id: str, r_id: str, values: list[tuple[datetime, float]]
    ) -> list[tuple[datetime, float]]:
        """The values to send now: all of a direct reading; of a projected rID those that
        differ from what this request last sent (which they then replace)."""
        if r_id not in self.projected:
            return list(values)
        sent = self.sent.setdefault((request_id, r_id), {})
        fresh = [(dt, value) for dt, value in values if sent.get(dt) != value]
        sent.update(fresh)
        return fresh


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
            hint='pip install -e ".[openadr]" (in the hvacflex clone)',
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
    projected: set[str] = set()
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
            if specifier == FORECAST_REPORT:
                projected.add(f"{building_id}.{what}")
    sender = ReportSender(client, projected)
    client.update_report = sender.update_report  # openleadr's scheduler calls it per sample
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
    store = VenStore.open(config.record_url(), config.ven_name)
    service = Client(config.service_url, config.operator_key)
    if not config.building_ids:
        config = replace(config, building_ids=tuple(service.call("GET", "/v1/buildings")))
        logger.info("buildings: %s", ", ".join(config.building_ids) or "none registered")
    ven = OpenAdrVen(config, service, store=store)
    client = openadr_client(ven)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await client.run()
    if client.registration_id is None:
        await client.stop()
        store.engine.dispose()
        raise InputError(
            "the VTN did not register this VEN",
            field="--vtn-url",
            value=config.vtn_url,
            hint="check that the VTN runs at that URL and accepts this --ven-name "
            "(and, with TLS, the certificate and CA); openleadr's log above has its reason",
        )
    settling = asyncio.create_task(_settle_periodically(ven, stop))
    try:
        await asyncio.wait_for(stop.wait(), timeout=stop_after_s)
    except TimeoutError:
        pass
    finally:
        stop.set()
        await settling
        logging.getLogger(SCHEDULER_LOGGER).addFilter(_STOPPING)  # once: the same object
        await client.stop()
        store.engine.dispose()


SCHEDULER_LOGGER = "apscheduler.executors.default"
"""The logger of openleadr's scheduler's jobs (polls, reports)."""


class _StoppingCancellations(logging.Filter):
    """Drops the scheduler's report of a job cancelled because the VEN is stopping: a poll or
    report in flight when SIGTERM came is cancelled when the event loop closes, which is
    expected, not an error (openleadr's ``stop`` does not wait for running jobs)."""

    def filter(self, record: logging.LogRecord) -> bool:
        error = record.exc_info[1] if record.exc_info else None
        return not isinstance(error, asyncio.CancelledError)


_STOPPING = _StoppingCancellations()


async def _settle_periodically(ven: OpenAdrVen, stop: asyncio.Event) -> None:
    """Settle the dispatches that are due every :data:`SETTLE_EVERY_S` until ``stop``."""
    while not stop.is_set():
        try:
            await asyncio.to_thread(ven.settle_due)
        except HvacflexError as exc:
            logger.warning("settlement postponed (the service: %s)", exc)
        try:
            await asyncio.wait_for(stop.wait(), timeout=SETTLE_EVERY_S)
        except TimeoutError:
            continue
