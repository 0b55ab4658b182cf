"""The service's limit schedule from ``[[feeder_limits]]`` windows
(``hvacflex.fleet.limit_windows``): the same windows give the same limits as a fleet file."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hvacflex.errors import InputError
from hvacflex.fleet.limit_windows import limit_schedule_kw, limit_window
from hvacflex.fleet.schema import fleet_from_dict
from hvacflex.paths import resolve_building
from hvacflex.tomlio import read_toml

INDEX = pd.date_range("2014-03-07T09:00", periods=48 * 2, freq="30min", tz="Asia/Singapore")
"""A Friday and a Saturday from 09:00."""


def test_windows_lower_the_limit_in_their_periods_the_tighter_holding() -> None:
    daily = limit_window({"start": "10:00", "end": "12:00", "limit_kw": 300.0}, field="w")
    once = limit_window(
        {"start": "2014-03-07T11:00", "end": "2014-03-07T13:00", "limit_kw": 250.0}, field="w"
    )
    limit = limit_schedule_kw(np.inf, [daily, once], INDEX)
    by_time = pd.Series(limit, index=INDEX)
    assert by_time["2014-03-07T09:30"] == np.inf  # before both
    assert by_time["2014-03-07T10:00"] == 300.0  # the daily window alone
    assert by_time["2014-03-07T11:30"] == 250.0  # both: the tighter
    assert by_time["2014-03-07T12:30"] == 250.0  # the one-off window alone
    assert by_time["2014-03-07T13:00"] == np.inf  # its end is not in it
    assert by_time["2014-03-08T10:00"] == np.inf  # Saturday: the daily window is weekdays
    assert (limit_schedule_kw(200.0, [daily], INDEX) == 200.0).all()  # a tighter base holds


def test_the_schedule_equals_the_fleet_files_limit_series() -> None:
    windows = [
        {"start": "10:00", "end": "17:00", "limit_kw": 300.0, "days": "all"},
        {"start": "2014-03-07T15:00", "end": "2014-03-08T11:00", "limit_kw": 120.0},
    ]
    office5 = read_toml(resolve_building("office5"), what="building")
    fleet = fleet_from_dict(
        {
            "name": "f",
            "feeder_limit_kw": 400.0,
            "feeder_limits": windows,
            "buildings": [{"name": "b1", "building": office5}],
        }
    )
    parsed = [limit_window(w, field="windows") for w in windows]
    np.testing.assert_array_equal(
        limit_schedule_kw(400.0, parsed, INDEX), fleet.limit_series_kw(INDEX)
    )


@pytest.mark.parametrize(
    ("window", "field"),
    [
        ({"start": "12:00", "end": "10:00", "limit_kw": 1.0}, "w"),
        ({"start": "10:00", "end": "12:00", "limit_kw": -1.0}, "w.limit_kw"),
        ({"start": "10:00", "end": "12:00"}, "w.limit_kw"),
    ],
)
def test_a_bad_window_is_refused_naming_the_field(window: dict[str, object], field: str) -> None:
    with pytest.raises(InputError) as caught:
        limit_window(window, field="w")
    assert caught.value.field == field
