"""OpenADR 2.0b signals as the service's requests: the VEN's mapping, pure functions.

What :class:`~hvacflex.service.openadr.OpenAdrVen` does with each signal of an event:

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
``LOAD_DISPATCH`` of       ``POST /v1/signals/feeder-limits``: a    kW; with an item base
signal type ``setpoint``   feeder limit window per run of periods   ``powerReal`` in W, × its SI
(a capacity limit)         with the same limit, under the event's   scale ÷ 1000 (``k`` scale:
                           and signal's ids (a new version          the payload is kW)
                           replaces them, a cancel removes them)
========================  =======================================  ==============================

A ``LOAD_DISPATCH`` signal of type ``setpoint`` tells the load not to exceed the payload in
each interval (OpenADR 2.0b's load setpoint); the service takes it as the feeder's capacity
limit over the interval, like a fleet file's ``[[feeder_limits]]`` window. Every other
``LOAD_DISPATCH`` (``delta``, ``level``) is an IL dispatch.

Event times are real times. A service in live mode (``hvacflex serve --live``) plans on
real dates, so the offset is 0; a service on the calendar of its shipped data (2014) is
driven by a ``clock_offset`` added to every event time before it reaches the service and
subtracted from every service time the VEN reports (:func:`to_service_time`,
:func:`to_vtn_time`). It must be a whole number of 30-min periods, so a VTN's
period-aligned intervals stay aligned.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import pandas as pd

from hvacflex.constants import PERIOD, TIMEZONE
from hvacflex.errors import HvacflexError

KWH_PER_MWH = 1000.0
RESERVE_OFFER_MIN_KW = 1e-3
"""Smallest planned reserve [kW] that counts as an offer for a period."""
SERVICE_CURRENCY = "SGD"
PRICE_SIGNALS = ("ELECTRICITY_PRICE", "ENERGY_PRICE")
DEMAND_SIGNALS = ("DEMAND_CHARGE",)
DISPATCH_SIGNALS = ("LOAD_DISPATCH", "SIMPLE", "simple")
CAPACITY_SIGNALS = ("LOAD_DISPATCH",)
CAPACITY_TYPES = ("setpoint",)
"""A capacity limit: a load setpoint, the most the load may draw per interval."""
W_PER_KW = 1000.0
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


class EventRefused(HvacflexError):
    """An event the VEN cannot carry out as sent (it opts out; the reason is logged)."""


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
    return (local + clock_offset).tz_convert(TIMEZONE)


def to_vtn_time(text: str, clock_offset: pd.Timedelta) -> datetime:
    """A service time (ISO text) as the real UTC time the VTN sees."""
    stamp = pd.Timestamp(text)
    if stamp.tzinfo is None:
        stamp = stamp.tz_localize(TIMEZONE)
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


def offered_reserve_kw(plan: dict[str, Any] | None) -> dict[pd.Timestamp, float]:
    """Period start (service time) → the reserve a plan offers [kW], over its horizon."""
    if plan is None:
        return {}
    return {
        pd.Timestamp(t).tz_convert(TIMEZONE): float(r)
        for t, r in zip(plan["horizon_time"], plan["horizon_reserve_kw"], strict=False)
        if r is not None
    }


def offered_periods(plan: dict[str, Any] | None) -> set[pd.Timestamp]:
    """The periods (service time) in which a plan offers reserve (> RESERVE_OFFER_MIN_KW)."""
    return {t for t, r in offered_reserve_kw(plan).items() if r > RESERVE_OFFER_MIN_KW}


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


def signals_of(event: dict[str, Any]) -> list[dict[str, Any]]:
    """The signals of a parsed event (openleadr gives a list or a dict holding one)."""
    signals = event.get("event_signals") or []
    if isinstance(signals, dict):
        signals = signals.get("event_signals") or []
    return list(signals)


def is_capacity_limit(event_signal: dict[str, Any]) -> bool:
    """Whether a signal is a capacity limit (``LOAD_DISPATCH`` of type ``setpoint``)."""
    return (
        event_signal.get("signal_name") in CAPACITY_SIGNALS
        and event_signal.get("signal_type") in CAPACITY_TYPES
    )


def capacity_key(event_id: str, event_signal: dict[str, Any], i: int) -> str:
    """The id a capacity signal's windows are stored under: the event's and the signal's
    (its ``signal_id``, else its position), so a new version of the event replaces them."""
    return f"{event_id}/{event_signal.get('signal_id') or i}"[:128]


def capacity_limit_windows(
    event_signal: dict[str, Any], clock_offset: pd.Timedelta
) -> list[dict[str, Any]]:
    """A capacity-limit signal as feeder limit windows in service time: one window
    ``{start, end, limit_kw}`` (ISO date-times, kW) per run of consecutive periods with the
    same limit.

    Raises
    ------
    EventRefused : an item base that is not a power in W, a limit ≤ 0, or intervals not
        on whole 30-min periods.
    """
    unit = (event_signal.get("measurement") or {}).get("unit")
    if unit not in (None, "W"):
        raise EventRefused(f"a capacity limit in {unit!r}: send the payload in kW or W")
    to_kw = 1.0 if unit is None else 1.0 / W_PER_KW
    series = period_values(signal_intervals(event_signal, clock_offset)) * to_kw
    if not (series > 0).all():
        raise EventRefused(f"capacity limits {sorted(set(series[series <= 0]))} kW: must be > 0")
    windows: list[dict[str, Any]] = []
    for start, limit_kw in zip(series.index, series.to_numpy(), strict=True):
        last = windows[-1] if windows else None
        if last is not None and last["end"] == start.isoformat() and last["limit_kw"] == limit_kw:
            last["end"] = (start + PERIOD).isoformat()
        else:
            end = (start + PERIOD).isoformat()
            windows.append({"start": start.isoformat(), "end": end, "limit_kw": float(limit_kw)})
    return windows
