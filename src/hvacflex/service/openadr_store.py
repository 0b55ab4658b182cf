"""The VEN's record: the OpenADR events it answered, what it activated, and the settlement.

``serve openadr-ven`` keeps its record in a database of the service's layer
(:mod:`hvacflex.service.db`, the same Alembic migrations; ``--db``, default an SQLite file
in the user data folder, :func:`default_ven_db_url`), so a restarted VEN

* answers an event it already answered (the same event id and modification number, which a
  VTN sends again to a VEN that registers anew) with the opt it gave, posting nothing again;
* still ends what a dispatch activated when the VTN cancels or modifies it later;
* settles every dispatch it accepted, once, when the building's meter has passed its end.

**Settlement** is the closed loop's (:mod:`hvacflex.settlement`, the ``pre-event`` rule):
per activated building and dispatched period k, metered ``P_k`` is the ``previous_power_kw``
the building posted with its measurement of period k + 1; the baseline ``B`` is the metered
power of the period before each run of consecutive activated periods; delivered ``D_k =
max(0, B − P_k)``, shortfall ``S_k = max(0, R_k − D_k)`` with ``R_k`` the reserve the
building's plan offered for k when the VEN accepted the dispatch. A period without a meter
reading (or without one before the run) shows no delivery. A dispatch is settled once the
building has posted a measurement at or after the end of its last activated period.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from sqlalchemy import select
from sqlalchemy.engine import Engine

from hvacflex.constants import PERIOD, TIMEZONE
from hvacflex.paths import check_output_dir, user_data_dir
from hvacflex.service.db import (
    OpenAdrEvent,
    OpenAdrSettlement,
    open_database,
    session_factory,
    utcnow,
)
from hvacflex.settlement import delivered_kw, pre_event_baseline_kw, shortfall_kw

VEN_DB_FILENAME = "openadr-ven.db"
"""The VEN's record by default: this SQLite file in the user data folder
(:func:`hvacflex.paths.user_data_dir`), whichever folder the VEN is started from."""


def default_ven_db_url() -> str:
    """``sqlite:///<user data folder>/openadr-ven.db``, the folder created if missing.

    Raises
    ------
    InputError : the folder cannot be created or written (field ``--db``).
    """
    folder = check_output_dir(user_data_dir(), "--db")
    return f"sqlite:///{folder / VEN_DB_FILENAME}"


@dataclass(frozen=True)
class ActivationRun:
    """Consecutive activated periods [start, end) of the buildings named (service time)."""

    start: pd.Timestamp
    end: pd.Timestamp
    building_ids: tuple[str, ...]

    def periods(self) -> list[pd.Timestamp]:
        """The period starts of the run."""
        return [self.start + j * PERIOD for j in range((self.end - self.start) // PERIOD)]


@dataclass(frozen=True)
class EventRecord:
    """The VEN's answer to one event (its latest version).

    ``offers_kw``: building → period start (ISO, service time) → reserve offered [kW] by the
    plan the dispatch was accepted on.
    """

    event_id: str
    modification_number: int
    event_status: str
    opt: str
    reason: str = ""
    runs: tuple[ActivationRun, ...] = ()
    offers_kw: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    settled: bool = False


@dataclass(frozen=True)
class SettledPeriod:
    """One activated period of one building, settled against metered power [kW]; NaN
    where there was no meter reading (metered) or none before the run (baseline)."""

    building_id: str
    period_start: pd.Timestamp
    reserve_kw: float
    metered_kw: float
    baseline_kw: float
    delivered_kw: float
    shortfall_kw: float


def _runs_json(runs: Iterable[ActivationRun]) -> str:
    return json.dumps(
        [[r.start.isoformat(), r.end.isoformat(), list(r.building_ids)] for r in runs]
    )


def _runs(text: str) -> tuple[ActivationRun, ...]:
    return tuple(
        ActivationRun(
            pd.Timestamp(a).tz_convert(TIMEZONE), pd.Timestamp(b).tz_convert(TIMEZONE), tuple(ids)
        )
        for a, b, ids in json.loads(text)
    )


def _optional(value: float) -> float | None:
    return None if math.isnan(value) else float(value)


class VenStore:
    """The record of one VEN (by name) in a database of the service's layer."""

    def __init__(self, engine: Engine, ven_name: str) -> None:
        self.engine = engine
        self.ven_name = ven_name
        self.sessions = session_factory(engine)

    @staticmethod
    def open(url: str, ven_name: str) -> VenStore:
        """The record on the database at ``url``, migrated to the newest schema.

        Raises
        ------
        InputError : the database cannot be opened (:func:`~hvacflex.service.db.open_database`).
        """
        return VenStore(open_database(url), ven_name)

    def get(self, event_id: str) -> EventRecord | None:
        """The recorded answer to ``event_id``, or None."""
        with self.sessions() as session:
            row = session.scalars(
                select(OpenAdrEvent).where(
                    OpenAdrEvent.ven_name == self.ven_name, OpenAdrEvent.event_id == event_id
                )
            ).first()
            return None if row is None else _record(row)

    def save(self, record: EventRecord) -> None:
        """Record ``record`` as the event's latest version (committed when this returns)."""
        with self.sessions() as session, session.begin():
            row = session.scalars(
                select(OpenAdrEvent).where(
                    OpenAdrEvent.ven_name == self.ven_name,
                    OpenAdrEvent.event_id == record.event_id,
                )
            ).first()
            if row is None:
                row = OpenAdrEvent(ven_name=self.ven_name, event_id=record.event_id)
                session.add(row)
            row.modification_number = record.modification_number
            row.event_status = record.event_status
            row.opt = record.opt
            row.reason = record.reason
            row.runs_json = _runs_json(record.runs)
            row.offers_json = json.dumps({b: dict(o) for b, o in record.offers_kw.items()})
            row.settled = record.settled
            row.updated_at = utcnow()

    def events(self) -> list[EventRecord]:
        """Every recorded event, in the order first answered."""
        with self.sessions() as session:
            rows = session.scalars(
                select(OpenAdrEvent)
                .where(OpenAdrEvent.ven_name == self.ven_name)
                .order_by(OpenAdrEvent.id)
            )
            return [_record(row) for row in rows]

    def unsettled(self) -> list[EventRecord]:
        """The events with activation runs not settled yet."""
        return [r for r in self.events() if r.runs and not r.settled]

    def store_settlement(self, event_id: str, periods: Iterable[SettledPeriod]) -> None:
        """Store the settled periods of ``event_id`` and mark it settled (one transaction)."""
        with self.sessions() as session, session.begin():
            for p in periods:
                session.add(
                    OpenAdrSettlement(
                        ven_name=self.ven_name,
                        event_id=event_id,
                        building_id=p.building_id,
                        period_start=p.period_start.isoformat(),
                        reserve_kw=p.reserve_kw,
                        metered_kw=_optional(p.metered_kw),
                        baseline_kw=_optional(p.baseline_kw),
                        delivered_kw=p.delivered_kw,
                        shortfall_kw=p.shortfall_kw,
                    )
                )
            row = session.scalars(
                select(OpenAdrEvent).where(
                    OpenAdrEvent.ven_name == self.ven_name, OpenAdrEvent.event_id == event_id
                )
            ).one()
            row.settled = True

    def settlement(self, event_id: str) -> list[SettledPeriod]:
        """The settled periods of ``event_id`` (by building, then period)."""
        with self.sessions() as session:
            rows = session.scalars(
                select(OpenAdrSettlement)
                .where(
                    OpenAdrSettlement.ven_name == self.ven_name,
                    OpenAdrSettlement.event_id == event_id,
                )
                .order_by(OpenAdrSettlement.building_id, OpenAdrSettlement.period_start)
            )
            return [
                SettledPeriod(
                    r.building_id,
                    pd.Timestamp(r.period_start),
                    r.reserve_kw,
                    math.nan if r.metered_kw is None else r.metered_kw,
                    math.nan if r.baseline_kw is None else r.baseline_kw,
                    r.delivered_kw,
                    r.shortfall_kw,
                )
                for r in rows
            ]


def _record(row: OpenAdrEvent) -> EventRecord:
    return EventRecord(
        event_id=row.event_id,
        modification_number=row.modification_number,
        event_status=row.event_status,
        opt=row.opt,
        reason=row.reason,
        runs=_runs(row.runs_json),
        offers_kw=json.loads(row.offers_json),
        settled=row.settled,
    )


def building_periods(runs: Iterable[ActivationRun], building_id: str) -> list[pd.Timestamp]:
    """The activated periods of ``building_id`` over ``runs``, in order, each once."""
    return sorted({t for r in runs if building_id in r.building_ids for t in r.periods()})


def settle_building(
    building_id: str,
    periods: list[pd.Timestamp],
    reserve_kw: Mapping[pd.Timestamp, float],
    metered_kw: Mapping[pd.Timestamp, float],
) -> list[SettledPeriod]:
    """Settle a building's activated ``periods`` (module docstring).

    Parameters
    ----------
    building_id : the building.
    periods : its activated period starts (service time), sorted.
    reserve_kw : period start → reserve offered [kW] (0 where absent).
    metered_kw : period start → metered power [kW] (NaN where absent).

    Returns
    -------
    One :class:`SettledPeriod` per activated period, in order.
    """
    if not periods:
        return []
    first, last = periods[0] - PERIOD, periods[-1]
    index = pd.date_range(first, last, freq=PERIOD)
    activated = np.asarray(index.isin(periods), dtype=bool)
    power = np.array([metered_kw.get(t, math.nan) for t in index], dtype=float)
    reserve = np.array([reserve_kw.get(t, 0.0) for t in index], dtype=float)
    baseline = pre_event_baseline_kw(power, activated)
    delivered = delivered_kw(baseline, power, activated)
    short = shortfall_kw(reserve, delivered, activated)
    return [
        SettledPeriod(
            building_id,
            index[k],
            float(reserve[k]),
            float(power[k]),
            float(baseline[k]),
            float(delivered[k]),
            float(short[k]),
        )
        for k in np.flatnonzero(activated).tolist()
    ]
