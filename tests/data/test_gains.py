"""Office schedules, public holidays, internal gains and comfort bounds."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from hvacflex.data import gains
from hvacflex.data.cache import CACHE_DIR_ENV
from hvacflex.data.gains import (
    DEFAULT_OFFICE_SCHEDULE,
    ComfortBand,
    OfficeSchedule,
    comfort_bounds_degc,
    occupied_mask,
    office_schedule,
    working_day_mask,
    zone_internal_gains_w,
)
from hvacflex.errors import ConfigError

TZ = "Asia/Singapore"


def _day(date: str) -> pd.DatetimeIndex:
    return pd.date_range(date, periods=48, freq="30min", tz=TZ)


def test_singapore_2014_holidays_are_off_days() -> None:
    year = pd.date_range("2014-01-01", "2015-01-01", freq="30min", tz=TZ, inclusive="left")
    work = working_day_mask(year).reshape(-1, 48)[:, 0]
    # 261 weekdays in 2014, minus 9 public holidays on weekdays (incl. observed 6 Oct;
    # 1 Feb and 9 Aug fell on Saturdays, 5 Oct on a Sunday)
    assert work.sum() == 252
    for holiday in ("2014-01-01", "2014-01-31", "2014-04-18", "2014-05-01", "2014-05-13",
                    "2014-07-28", "2014-10-06", "2014-10-22", "2014-12-25"):  # fmt: skip
        assert not working_day_mask(_day(holiday)).any(), holiday
    assert working_day_mask(_day("2014-01-02")).all()
    assert not working_day_mask(_day("2014-01-04")).any()  # Saturday


def test_gains_follow_schedule_by_hand() -> None:
    index = _day("2014-01-02")  # Thursday
    gains = zone_internal_gains_w(index, 100.0, 10.0, 75.0, 10.0, 12.0)
    # 10:00: people 0.95·10·75 + lights 0.9·1000 + plugs 0.9·1200
    assert gains[20] == pytest.approx(0.95 * 750 + 900 + 1080)
    # 03:00: nobody, lights 5 %, plugs 40 %
    assert gains[6] == pytest.approx(0.05 * 1000 + 0.4 * 1200)
    # 12:30 lunch: people 0.5, lights 0.8, plugs 0.8
    assert gains[25] == pytest.approx(0.5 * 750 + 800 + 960)
    holiday = zone_internal_gains_w(_day("2014-01-01"), 100.0, 10.0, 75.0, 10.0, 12.0)
    assert holiday[20] == pytest.approx(0.05 * 750 + 0.05 * 1000 + 0.3 * 1200)
    assert gains.shape == (48,)


def test_schedule_fractions_and_occupancy() -> None:
    index = _day("2014-01-02")
    fractions = office_schedule(index)
    assert list(fractions.columns) == ["people_fraction", "lighting_fraction", "equipment_fraction"]
    assert ((fractions >= 0) & (fractions <= 1)).all().all()
    occupied = occupied_mask(index)
    assert occupied.sum() == 20  # 08:00–18:00
    assert occupied[16] and not occupied[15] and occupied[35] and not occupied[36]
    assert not occupied_mask(_day("2014-01-05")).any()  # Sunday


def test_comfort_bounds() -> None:
    index = _day("2014-01-02")
    lower, upper = comfort_bounds_degc(index, 3)
    assert lower.shape == upper.shape == (48, 3)
    assert (lower[16:36] == 23.0).all() and (upper[16:36] == 26.0).all()
    assert (lower[:16] == 20.0).all() and (upper[36:] == 30.0).all()
    lower, upper = comfort_bounds_degc(index, 1, occupied=(22.0, 25.0), unoccupied=(18.0, 32.0))
    assert lower[20, 0] == 22.0 and upper[0, 0] == 32.0
    with pytest.raises(ConfigError, match="lower < upper"):
        comfort_bounds_degc(index, 1, occupied=(26.0, 23.0))
    with pytest.raises(ConfigError):
        ComfortBand(unoccupied_degc=(30.0, 30.0))


def test_schedule_validation() -> None:
    with pytest.raises(ConfigError, match="24 hourly fractions"):
        OfficeSchedule(*(DEFAULT_OFFICE_SCHEDULE.people_workday[:23],) * 6)
    with pytest.raises(ConfigError, match="occupancy_m2_per_person"):
        zone_internal_gains_w(_day("2014-01-02"), 100.0, 0.0, 75.0, 10.0, 12.0)
    assert np.isclose(sum(DEFAULT_OFFICE_SCHEDULE.people_workday), 9.2)


def test_holidays_are_read_back_without_the_holidays_package(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The public holidays of a run's start-up come from the cache once stored: the same
    dates as the ``holidays`` package's, and ``holidays`` is not asked again."""
    import holidays

    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path))
    gains._holiday_dates.cache_clear()
    stored = gains._holiday_dates("SG", (2014, 2015))
    expected = {
        np.datetime64(day, "D") for day in holidays.country_holidays("SG", years=[2014, 2015])
    }
    assert stored == expected and np.datetime64("2014-08-09") in stored  # National Day

    def asked(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("the holidays package was asked again")

    monkeypatch.setattr(holidays, "country_holidays", asked)
    gains._holiday_dates.cache_clear()
    assert gains._holiday_dates("SG", (2014, 2015)) == stored
    gains._holiday_dates.cache_clear()
