"""The live calendar: real days → days of the 2014 price data (hand-checked cases)."""

from __future__ import annotations

import pandas as pd
import pytest

from hvacflex.data.calendar import live_price_index, price_day
from hvacflex.errors import DataError

TZ = "Asia/Singapore"
FIRST = pd.Timestamp("2014-01-01", tz=TZ)
LAST = pd.Timestamp("2014-12-31", tz=TZ)


def _day(text: str) -> pd.Timestamp:
    return pd.Timestamp(text, tz=TZ)


@pytest.mark.parametrize(
    ("real", "data", "why"),
    [
        # 2026-12-02 is a Wednesday; 2014-12-02 a Tuesday → one day later, Wed 2014-12-03
        ("2026-12-02", "2014-12-03", "same weekday, nearest to 2 December"),
        # Sat 2026-12-05; Fri 2014-12-05 → Sat 2014-12-06
        ("2026-12-05", "2014-12-06", "a Saturday stays a Saturday"),
        # Thu 2026-12-31; Wed 2014-12-31 → Thu 2015-01-01 is outside → a week earlier
        ("2026-12-31", "2014-12-25", "year end: a week back into the data"),
        # Fri 2027-01-01; Wed 2014-01-01 → Fri 2014-01-03 (inside)
        ("2027-01-01", "2014-01-03", "new year: two days later"),
        # Mon 2024-01-01; Wed 2014-01-01 → Mon 2013-12-30 is outside → a week later
        ("2024-01-01", "2014-01-06", "year start: a week forward into the data"),
        # Thu 2024-02-29 (leap day) anchored on Fri 2014-02-28 → Thu 2014-02-27
        ("2024-02-29", "2014-02-27", "leap day: anchored on 28 February"),
        # Fri 2024-03-01; Sat 2014-03-01 → Fri 2014-02-28
        ("2024-03-01", "2014-02-28", "after a leap day the shift changes"),
        ("2014-07-15", "2014-07-15", "a day the data cover is its own day"),
    ],
)
def test_a_real_day_takes_the_data_day_of_the_same_weekday_nearest_its_date(
    real: str, data: str, why: str
) -> None:
    mapped = price_day(_day(real), FIRST, LAST)
    assert mapped == _day(data), why
    assert mapped.day_of_week == _day(real).day_of_week
    assert FIRST <= mapped <= LAST


def test_every_day_of_a_leap_year_maps_into_the_data_on_its_weekday_within_a_week() -> None:
    for day in pd.date_range("2028-01-01", "2028-12-31", freq="D", tz=TZ):
        mapped = price_day(day, FIRST, LAST)
        assert FIRST <= mapped <= LAST and mapped.day_of_week == day.day_of_week
        assert abs((mapped - _anchor(day)).days) <= 7


def _anchor(day: pd.Timestamp) -> pd.Timestamp:
    """The day's month and day in 2014 (28 February for 29 February)."""
    return day.replace(year=2014, day=28 if (day.month, day.day) == (2, 29) else day.day)


def test_the_shift_is_constant_within_a_year_but_at_the_leap_day() -> None:
    days = pd.date_range("2028-01-01", "2028-12-28", freq="D", tz=TZ)  # before the year end
    shift = {day: (price_day(day, FIRST, LAST) - _anchor(day)).days for day in days}
    before = {s for d, s in shift.items() if d < _day("2028-02-29")}
    after = {s for d, s in shift.items() if d >= _day("2028-03-01")}
    assert len(before) == 1 and len(after) == 1 and before != after


def test_periods_keep_their_time_of_day_and_are_flagged_mapped() -> None:
    data = pd.date_range("2014-01-01", "2014-12-31 23:30", freq="30min", tz=TZ)
    real = pd.date_range("2026-12-02T23:00+08:00", periods=4, freq="30min")
    lookup, mapped = live_price_index(real, data)
    assert [t.isoformat() for t in lookup] == [
        "2014-12-03T23:00:00+08:00",
        "2014-12-03T23:30:00+08:00",
        "2014-12-04T00:00:00+08:00",  # Thu 2026-12-03 → Thu 2014-12-04
        "2014-12-04T00:30:00+08:00",
    ]
    assert mapped.tolist() == [True] * 4
    inside, flags = live_price_index(data[:3], data)
    assert inside.equals(data[:3]) and not flags.any()


def test_price_data_of_less_than_a_week_cannot_match_weekdays() -> None:
    with pytest.raises(DataError) as raised:
        price_day(_day("2026-12-02"), FIRST, FIRST + pd.Timedelta(days=5))
    assert raised.value.field == "data.calendar"
