"""The service's feeder limit schedule: the latest constant limit
(``POST /v1/signals/feeder-limit``, signal ``feeder_limit``) lowered by the limit windows in
force (``POST /v1/signals/feeder-limits``, signal ``feeder_limit_windows``; the OpenADR
VEN's capacity-limit events), applied as a fleet file's ``[[feeder_limits]]``
(:func:`hvacflex.fleet.limit_windows.limit_schedule_kw`).

Windows posted under an ``event_id`` replace those posted before under the same id (an
empty list cancels them); windows posted without one stay in force.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
from sqlalchemy import select
from sqlalchemy.orm import Session

from hvacflex.fleet.limit_windows import limit_schedule_kw, limit_window
from hvacflex.fleet.schema import FeederLimitWindowSpec
from hvacflex.service.db import Signal

CONSTANT_KIND = "feeder_limit"
WINDOWS_KIND = "feeder_limit_windows"


def windows_in_force(session: Session) -> list[FeederLimitWindowSpec]:
    """Every stored window in force, in the order posted (the latest post of each
    ``event_id`` replaces its earlier ones)."""
    rows = session.scalars(
        select(Signal).where(Signal.kind == WINDOWS_KIND).order_by(Signal.id)
    ).all()
    bodies = [json.loads(row.body_json) for row in rows]
    latest: dict[str, int] = {}
    for i, body in enumerate(bodies):
        if body.get("event_id") is not None:
            latest[str(body["event_id"])] = i
    windows: list[FeederLimitWindowSpec] = []
    for i, body in enumerate(bodies):
        event_id = body.get("event_id")
        if event_id is not None and latest[str(event_id)] != i:
            continue
        windows += [
            limit_window(w, field=f"signal {rows[i].id}.windows[{j}]")
            for j, w in enumerate(body["windows"])
        ]
    return windows


def constant_limit_kw(session: Session) -> float:
    """The latest constant feeder limit [kW] (inf: none posted)."""
    row = session.scalars(
        select(Signal).where(Signal.kind == CONSTANT_KIND).order_by(Signal.id.desc()).limit(1)
    ).first()
    return math.inf if row is None else float(json.loads(row.body_json)["limit_kw"])


def schedule_kw(session: Session, index: pd.DatetimeIndex) -> np.ndarray:
    """(T,) the feeder limit in force at each period start of ``index`` [kW] (inf: none)."""
    return limit_schedule_kw(constant_limit_kw(session), windows_in_force(session), index)


def schedule_at(
    constant_kw: float, windows: list[FeederLimitWindowSpec], times: list[str]
) -> np.ndarray:
    """(T,) the limit in force at each of the ISO period starts ``times`` [kW] (inf: none),
    from the constant limit ``constant_kw`` [kW] and the ``windows``."""
    index = pd.DatetimeIndex([pd.Timestamp(t) for t in times])
    return limit_schedule_kw(constant_kw, windows, index)


def as_optional(limit_kw: np.ndarray) -> list[float | None]:
    """Limits [kW] as JSON values: None where no limit holds (inf)."""
    return [float(v) if math.isfinite(v) else None for v in limit_kw]
