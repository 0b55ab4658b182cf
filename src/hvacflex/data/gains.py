"""Office schedules, internal heat gains and the comfort band.

Schedules
---------
Hourly fractions (0…1) of the design densities for people, lighting and plug loads, one
profile for working days and one for non-working days (Saturdays, Sundays and Singapore
public holidays, from the ``holidays`` package, observed days included). The default,
:data:`DEFAULT_OFFICE_SCHEDULE`, is the office profile of the ASHRAE Standard 90.1 User's
Manual (Appendix G schedules: weekday, and Sunday/holiday for non-working days). Entry ``h``
of a profile applies to ``[h:00, h+1:00)`` local time; a 30-min period takes the value of
the hour it lies in.

Occupied hours (the band of comfort constraints) are 08:00–18:00 on working days by default.

Internal gains
--------------
Sensible gain of a zone at period k [W]::

    q_int = A / a_p · q_p · f_people(k) + A · q_light · f_light(k) + A · q_plug · f_plug(k)

with ``A`` the floor area [m²], ``a_p`` the floor area per person [m²/person], ``q_p`` the
sensible heat per person [W/person], ``q_light``, ``q_plug`` the design densities [W/m²]. All
lighting and plug power is counted as sensible heat to the zone air at once; latent heat from
people is accounted for in the coil power through the humidity ratio, not here.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hvacflex.constants import TIMEZONE
from hvacflex.errors import ConfigError, DataError

HOURS_PER_DAY = 24


def _profile(*pairs: tuple[int, float]) -> tuple[float, ...]:
    """Expand ``(hour_from, value)`` breakpoints into 24 hourly values."""
    out = []
    for hour in range(HOURS_PER_DAY):
        value = 0.0
        for start, v in pairs:
            if hour >= start:
                value = v
        out.append(value)
    return tuple(out)


@dataclass(frozen=True)
class OfficeSchedule:
    """Hourly fractions of design densities, by hour of day ``[h, h+1)`` local time.

    Attributes
    ----------
    people_workday, lighting_workday, equipment_workday : (24,) fractions 0…1 on working days.
    people_offday, lighting_offday, equipment_offday : (24,) fractions on weekends/holidays.
    occupied_hours : (start, end) local hours of the occupied comfort band on working days.
    country : ISO code of the public-holiday calendar (``holidays`` package).
    """

    people_workday: tuple[float, ...]
    lighting_workday: tuple[float, ...]
    equipment_workday: tuple[float, ...]
    people_offday: tuple[float, ...]
    lighting_offday: tuple[float, ...]
    equipment_offday: tuple[float, ...]
    occupied_hours: tuple[int, int] = (8, 18)
    country: str = "SG"

    def __post_init__(self) -> None:
        for name in (
            "people_workday",
            "lighting_workday",
            "equipment_workday",
            "people_offday",
            "lighting_offday",
            "equipment_offday",
        ):
            values = getattr(self, name)
            if len(values) != HOURS_PER_DAY or not all(0.0 <= v <= 1.0 for v in values):
                raise ConfigError(
                    "a schedule needs 24 hourly fractions between 0 and 1",
                    source="OfficeSchedule",
                    field=name,
                    value=values,
                    hint="entry h applies to [h:00, h+1:00) local time",
                )
        start, end = self.occupied_hours
        if not 0 <= start < end <= HOURS_PER_DAY:
            raise ConfigError(
                "occupied hours must satisfy 0 ≤ start < end ≤ 24",
                source="OfficeSchedule",
                field="occupied_hours",
                value=self.occupied_hours,
            )


DEFAULT_OFFICE_SCHEDULE = OfficeSchedule(
    # ASHRAE 90.1 User's Manual office schedules, converted from hour-ending to hour-starting.
    people_workday=_profile((6, 0.1), (7, 0.2), (8, 0.95), (12, 0.5), (13, 0.95), (17, 0.3),
                            (18, 0.1), (22, 0.05)),
    lighting_workday=_profile((0, 0.05), (5, 0.1), (7, 0.3), (8, 0.9), (12, 0.8), (13, 0.9),
                              (17, 0.5), (18, 0.3), (20, 0.2), (22, 0.1), (23, 0.05)),
    equipment_workday=_profile((0, 0.4), (8, 0.9), (12, 0.8), (13, 0.9), (17, 0.5), (18, 0.4)),
    people_offday=_profile((6, 0.05), (18, 0.0)),
    lighting_offday=_profile((0, 0.05)),
    equipment_offday=_profile((0, 0.3)),
)  # fmt: skip
"""Default office schedule (ASHRAE 90.1 User's Manual, office: weekday and Sunday/holiday)."""


@dataclass(frozen=True)
class ComfortBand:
    """Comfort bounds [°C] while occupied and unoccupied (docs/explanation/model.md §3: 23–26 and
    20–30 °C)."""

    occupied_degc: tuple[float, float] = (23.0, 26.0)
    unoccupied_degc: tuple[float, float] = (20.0, 30.0)

    def __post_init__(self) -> None:
        for name in ("occupied_degc", "unoccupied_degc"):
            low, high = getattr(self, name)
            if not low < high:
                raise ConfigError(
                    "comfort band needs lower < upper",
                    source="ComfortBand",
                    field=name,
                    value=(low, high),
                    hint="e.g. (23.0, 26.0) °C",
                )


@functools.lru_cache(maxsize=16)
def _holiday_dates(country: str, years: tuple[int, ...]) -> frozenset[np.datetime64]:
    """The public holidays of ``country`` in ``years``, from the ``holidays`` package, kept in
    the disk cache (:mod:`hvacflex.data.cache`, keyed by the package's version): importing
    ``holidays`` and its country calendars takes ≈ 0.1 s of every start."""
    from importlib import metadata

    from hvacflex.data.cache import cache_key, cached_frame

    def build() -> tuple[pd.DataFrame, dict[str, object]]:
        import holidays

        calendar = holidays.country_holidays(country, years=list(years))
        return pd.DataFrame(index=pd.DatetimeIndex(sorted(calendar), name="date")), {}

    version = metadata.version("holidays")
    frame, _ = cached_frame(cache_key("holidays", [], [country, years, version]), build)
    return frozenset(frame.index.to_numpy().astype("datetime64[D]"))


def _local_index(index: pd.DatetimeIndex) -> pd.DatetimeIndex:
    if not isinstance(index, pd.DatetimeIndex):
        raise DataError(
            "schedules need a DatetimeIndex of period starts",
            field="index",
            value=type(index).__name__,
            hint="use a tz-aware 30-min index (Asia/Singapore)",
        )
    return index.tz_convert(TIMEZONE) if index.tz is not None else index


def working_day_mask(
    index: pd.DatetimeIndex, schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE
) -> np.ndarray:
    """(T,) bool: the period falls on a working day (Mon–Fri, not a public holiday)."""
    local = _local_index(index)
    days = local.normalize().tz_localize(None).to_numpy().astype("datetime64[D]")
    years = tuple(sorted(set(local.year)))
    holiday_days = np.array(sorted(_holiday_dates(schedule.country, years)), dtype="datetime64[D]")
    weekday = np.asarray(local.day_of_week) < 5
    result: np.ndarray = weekday & ~np.isin(days, holiday_days)
    return result


def office_schedule(
    index: pd.DatetimeIndex, schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE
) -> pd.DataFrame:
    """Schedule fractions per period.

    Parameters
    ----------
    index : (T,) period starts (tz-aware; converted to Singapore local time).
    schedule : the hourly profiles.

    Returns
    -------
    (T, 3) DataFrame on ``index`` with ``people_fraction``, ``lighting_fraction``,
    ``equipment_fraction`` (0…1).
    """
    local = _local_index(index)
    hour = np.asarray(local.hour)
    work = working_day_mask(index, schedule)
    columns = {}
    for name in ("people", "lighting", "equipment"):
        workday = np.asarray(getattr(schedule, f"{name}_workday"))
        offday = np.asarray(getattr(schedule, f"{name}_offday"))
        columns[f"{name}_fraction"] = np.where(work, workday[hour], offday[hour])
    return pd.DataFrame(columns, index=index)


def occupied_mask(
    index: pd.DatetimeIndex, schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE
) -> np.ndarray:
    """(T,) bool: the period starts within the occupied hours of a working day."""
    local = _local_index(index)
    hours = np.asarray(local.hour) + np.asarray(local.minute) / 60.0
    start, end = schedule.occupied_hours
    result: np.ndarray = working_day_mask(index, schedule) & (hours >= start) & (hours < end)
    return result


def zone_internal_gains_w(
    index: pd.DatetimeIndex,
    floor_area_m2: float,
    occupancy_m2_per_person: float,
    sensible_w_per_person: float,
    lighting_w_per_m2: float,
    equipment_w_per_m2: float,
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
) -> np.ndarray:
    """Sensible internal heat gain of one zone per period (see the module docstring).

    Parameters
    ----------
    index : (T,) period starts.
    floor_area_m2 : zone floor area [m²].
    occupancy_m2_per_person : floor area per person at full occupancy [m²/person].
    sensible_w_per_person : sensible heat per person [W/person].
    lighting_w_per_m2, equipment_w_per_m2 : design power densities [W/m²].
    schedule : hourly fractions.

    Returns
    -------
    (T,) sensible gain [W], ≥ 0.
    """
    values = {
        "floor_area_m2": floor_area_m2,
        "sensible_w_per_person": sensible_w_per_person,
        "lighting_w_per_m2": lighting_w_per_m2,
        "equipment_w_per_m2": equipment_w_per_m2,
    }
    for name, value in values.items():
        if not np.isfinite(value) or value < 0:
            raise ConfigError("must be a finite number ≥ 0", field=name, value=value)
    if not np.isfinite(occupancy_m2_per_person) or occupancy_m2_per_person <= 0:
        raise ConfigError(
            "must be > 0",
            field="occupancy_m2_per_person",
            value=occupancy_m2_per_person,
            hint="offices have about 10 m² per person",
        )
    fractions = office_schedule(index, schedule)
    people_w = floor_area_m2 / occupancy_m2_per_person * sensible_w_per_person
    result: np.ndarray = (
        people_w * fractions["people_fraction"].to_numpy()
        + floor_area_m2 * lighting_w_per_m2 * fractions["lighting_fraction"].to_numpy()
        + floor_area_m2 * equipment_w_per_m2 * fractions["equipment_fraction"].to_numpy()
    )
    return result


def comfort_bounds_degc(
    index: pd.DatetimeIndex,
    n_zones: int,
    occupied: tuple[float, float] = (23.0, 26.0),
    unoccupied: tuple[float, float] = (20.0, 30.0),
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
) -> tuple[np.ndarray, np.ndarray]:
    """Comfort band per period and zone.

    Row k is the band in force from the start of period k (the instant ``index[k]``):
    ``occupied`` while :func:`occupied_mask` is true, ``unoccupied`` otherwise.

    Returns
    -------
    lower, upper : (T, n_zones) bounds [°C].
    """
    band = ComfortBand((occupied[0], occupied[1]), (unoccupied[0], unoccupied[1]))
    if n_zones < 1:
        raise ConfigError("need at least one zone", field="n_zones", value=n_zones)
    occ = occupied_mask(index, schedule)
    lower = np.where(occ, band.occupied_degc[0], band.unoccupied_degc[0])
    upper = np.where(occ, band.occupied_degc[1], band.unoccupied_degc[1])
    return (
        np.repeat(lower[:, None], n_zones, axis=1),
        np.repeat(upper[:, None], n_zones, axis=1),
    )
