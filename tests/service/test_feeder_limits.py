"""The service's feeder limit schedule (``hvacflex.service.feeder_limits``): the latest
constant limit lowered by the windows in force; a window posted under an event id replaces
that event's earlier ones, an empty list cancels them."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.service import feeder_limits
from hvacflex.service.db import Signal, open_database, session_factory

INDEX = pd.date_range("2014-03-03T09:00", periods=6, freq="30min", tz="Asia/Singapore")
"""A Monday, 09:00–11:30."""


def _window(start: str, end: str, limit_kw: float) -> dict[str, Any]:
    return {"start": start, "end": end, "limit_kw": limit_kw}


def test_the_schedule_is_the_constant_limit_lowered_by_the_windows_in_force(
    tmp_path: Path,
) -> None:
    sessions = session_factory(open_database(f"sqlite:///{tmp_path / 'f.db'}"))

    def post(kind: str, body: dict[str, Any]) -> None:
        with sessions() as session, session.begin():
            session.add(Signal(kind=kind, body_json=json.dumps(body)))

    with sessions() as session:
        assert math.isinf(feeder_limits.constant_limit_kw(session))
        assert np.isinf(feeder_limits.schedule_kw(session, INDEX)).all()
    post(feeder_limits.CONSTANT_KIND, {"limit_kw": 900.0})
    post(feeder_limits.CONSTANT_KIND, {"limit_kw": 800.0})  # the latest holds
    post(feeder_limits.WINDOWS_KIND, {"windows": [_window("09:30", "10:30", 500.0)]})
    once = _window("2014-03-03T10:00", "2014-03-03T11:00", 300.0)
    post(feeder_limits.WINDOWS_KIND, {"windows": [once], "event_id": "e/1"})
    with sessions() as session:
        limit = feeder_limits.schedule_kw(session, INDEX)
    np.testing.assert_array_equal(limit, [800.0, 500.0, 300.0, 300.0, 800.0, 800.0])
    # a new version of the event replaces its window; a cancel removes it
    post(
        feeder_limits.WINDOWS_KIND,
        {"windows": [_window("2014-03-03T11:00", "2014-03-03T11:30", 100.0)], "event_id": "e/1"},
    )
    with sessions() as session:
        limit = feeder_limits.schedule_kw(session, INDEX)
    np.testing.assert_array_equal(limit, [800.0, 500.0, 500.0, 800.0, 100.0, 800.0])
    post(feeder_limits.WINDOWS_KIND, {"windows": [], "event_id": "e/1"})
    with sessions() as session:
        assert len(feeder_limits.windows_in_force(session)) == 1
        times = [t.isoformat() for t in INDEX]
        schedule = feeder_limits.schedule_at(800.0, feeder_limits.windows_in_force(session), times)
    np.testing.assert_array_equal(schedule, [800.0, 500.0, 500.0, 800.0, 800.0, 800.0])
    assert feeder_limits.as_optional(np.array([math.inf, 5.0])) == [None, 5.0]
