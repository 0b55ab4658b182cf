"""The live calendar: real dates mapped onto the days of the price data.

A scenario with ``[data] calendar = "live"`` (the service's live mode, ``hvacflex serve
--live``) plans on real dates, say 2026-12-02, while the shipped market data hold 2014. The
weather needs no mapping: the typical year is laid onto any calendar year already
(:func:`hvacflex.data.weather.weather_on`: same month, day and time; 29 February repeats 28
February), and so do the office schedule and its public holidays (of the real year). The
prices are mapped day by day:

* a day the price data cover is its own day (a user's price files for the real dates);
* any other day ``d`` takes the day of the data year (the year of the data's last day,
  2014 for the shipped data) **with the same weekday nearest to the same month and day**:
  the anchor ``a`` = (data year, month of d, day of d; 28 February for 29 February), moved
  by ``((weekday(d) − weekday(a) + 3) mod 7) − 3`` days (−3 … +3), so weekdays meet weekdays
  and weekends weekends, never more than three days off the season;
* **year ends**: where that day falls outside the data (the last days of December moved
  into January of the next year, or the first days of January into the year before), it
  moves by whole weeks back into the data (a week earlier or later), keeping the weekday;
* **leap days**: 29 February is anchored on 28 February; within one real year the shift is
  constant (d and its anchor advance together) except that it changes once after 29
  February of a leap year and at each 1 January, where the mapped days jump by up to a week.

Each period keeps its time of day (Singapore has no daylight saving). A period's price is
``mapped`` when its day is not its own day in the data (``energy_price_extrapolated``).
Public holidays are not aligned: a real holiday takes a working day's prices, and a 2014
holiday (Chinese New Year, 31 January – 1 February 2014) lends its low prices to the real
day mapped onto it.
"""

from __future__ import annotations

from typing import Literal, get_args

import numpy as np
import pandas as pd

from hvacflex.errors import DataError

Calendar = Literal["data", "live"]
CALENDARS: tuple[str, ...] = get_args(Calendar)
"""``[data] calendar``: ``"data"`` (every period inside the price data) or ``"live"``."""

DAYS_PER_WEEK = 7
MAX_WEEKDAY_SHIFT_DAYS = 3
"""The most a mapped day moves off its anchor to meet the weekday [days]."""


def price_day(day: pd.Timestamp, first_day: pd.Timestamp, last_day: pd.Timestamp) -> pd.Timestamp:
    """The day of the price data whose prices a real ``day`` takes (module docstring).

    Parameters
    ----------
    day : a real day (midnight, tz-aware or naive like the others).
    first_day, last_day : the first and the last day the price data cover (midnight).

    Raises
    ------
    DataError : the price data cover less than a week (no weekday can be matched).
    """
    if first_day <= day <= last_day:
        return day
    if (last_day - first_day).days + 1 < DAYS_PER_WEEK:
        raise DataError(
            "the price data cover less than a week: the live calendar cannot match weekdays",
            field="data.calendar",
            value=f"{first_day:%Y-%m-%d} … {last_day:%Y-%m-%d}",
            hint="give price files of at least one whole week, or use calendar = 'data'",
        )
    year = last_day.year
    month_day = (2, 28) if (day.month, day.day) == (2, 29) else (day.month, day.day)
    anchor = day.replace(year=year, month=month_day[0], day=month_day[1])
    shift = (day.day_of_week - anchor.day_of_week + MAX_WEEKDAY_SHIFT_DAYS) % DAYS_PER_WEEK
    mapped = anchor + pd.Timedelta(days=shift - MAX_WEEKDAY_SHIFT_DAYS)
    week = pd.Timedelta(days=DAYS_PER_WEEK)
    while mapped > last_day:
        mapped -= week
    while mapped < first_day:
        mapped += week
    return mapped


def live_price_index(
    index: pd.DatetimeIndex, data_index: pd.DatetimeIndex
) -> tuple[pd.DatetimeIndex, np.ndarray]:
    """Where each real period of ``index`` finds its price in data on ``data_index``.

    Parameters
    ----------
    index : (T,) real period starts (tz-aware).
    data_index : the price data's period starts (tz-aware, local time of the data).

    Returns
    -------
    (T,) the data's period starts to read (in the data's time zone), and (T,) bool: the
    period's day is mapped (not its own day in the data).
    """
    local = index.tz_convert(data_index.tz)
    first_day = data_index.min().normalize()
    last_day = data_index.max().normalize()
    days = local.normalize()
    mapping = {day: price_day(day, first_day, last_day) for day in days.unique()}
    source = pd.DatetimeIndex([mapping[day] for day in days])
    lookup = source + (local - days)
    return pd.DatetimeIndex(lookup, name=index.name), np.asarray(source != days)
