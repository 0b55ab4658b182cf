"""An IDF's schedules evaluated on given days, and when its cooling coils may run.

``Schedule:Compact`` (``Through: M/D`` blocks, ``For:`` day types, ``Until: HH:MM, value``
pairs) and ``Schedule:Constant`` are read as EnergyPlus reads them, on ordinary days: the
day types ``AllDays``, ``Weekdays``, ``Weekends``, ``Monday`` … ``Sunday`` and
``AllOtherDays`` match; ``Holiday``, the design days and the custom days never do (hvacflex
reads no holidays from an IDF). ``Interpolate:`` is ignored (the values step). Other
schedule classes (``Schedule:Year``, ``Schedule:File``) are not evaluated: None.

:func:`cooling_coil_available` and :func:`fan_available` tell, per day and 30-min period,
whether some cooling coil / some fan of the IDF is scheduled available — where ``hvacflex
identify fit --idf`` learns when an idle zone's air is fan-only (``hvacflex.identify.fit.
idle_air``: the fans run, the coil does not cool it).
"""

from __future__ import annotations

import datetime

import numpy as np
import numpy.typing as npt

from hvacflex.constants import PERIOD_S, PERIODS_PER_DAY
from hvacflex.energyplus.hvac import COOLING_COIL_CLASSES, FAN_CLASSES
from hvacflex.energyplus.idf import IdfObject, objects_of

DAY_NAMES = ("monday", "tuesday", "wednesday", "thursday", "friday", "saturday", "sunday")


def _matches(day_types: list[str], day: datetime.date, matched_before: bool) -> bool:
    weekday = day.weekday()
    for kind in day_types:
        if kind == "alldays" or kind == DAY_NAMES[weekday]:
            return True
        if kind == "weekdays" and weekday < 5:
            return True
        if kind == "weekends" and weekday >= 5:
            return True
        if kind == "allotherdays" and not matched_before:
            return True
    return False


def _minutes(text: str) -> int | None:
    hours, _, minutes = text.strip().partition(":")
    if not (hours.strip().isdigit() and minutes.strip().isdigit()):
        return None
    return int(hours) * 60 + int(minutes)


def _through(text: str) -> tuple[int, int] | None:
    month, _, day = text.strip().partition("/")
    if not (month.strip().isdigit() and day.strip().isdigit()):
        return None
    return int(month), int(day)


def _compact_day(fields: tuple[str, ...], day: datetime.date) -> list[tuple[int, float]] | None:
    """The ``(until minute, value)`` pairs in force on ``day``, or None (unreadable, or no
    ``For:`` matches)."""
    block_found, matched, chosen = False, False, None
    current: list[tuple[int, float]] | None = None
    tokens = list(fields[2:])
    i = 0
    while i < len(tokens):
        key, _, rest = tokens[i].partition(":")
        key = key.strip().lower()
        if key == "through":
            if block_found:
                break
            end = _through(rest)
            if end is None:
                return None
            block_found = end >= (day.month, day.day)
            matched = False
        elif key == "for" and block_found:
            current = None
            if not matched and _matches(rest.lower().split(), day, matched):
                matched, current = True, []
                chosen = current
        elif key == "until" and current is not None and i + 1 < len(tokens):
            minute = _minutes(rest)
            try:
                value = float(tokens[i + 1])
            except ValueError:
                return None
            if minute is None:
                return None
            current.append((minute, value))
            i += 1
        i += 1
    return chosen or None


def day_profile(
    objects: tuple[IdfObject, ...], name: str, day: datetime.date
) -> npt.NDArray[np.float64] | None:
    """(48,) the value of schedule ``name`` at the middle of each 30-min period of ``day``,
    or None: no ``Schedule:Compact`` / ``Schedule:Constant`` of that name, or one this
    module does not read."""
    for constant in objects_of(objects, "Schedule:Constant"):
        if constant.field(0).lower() == name.lower():
            try:
                return np.full(PERIODS_PER_DAY, float(constant.field(2)))
            except ValueError:
                return None
    for compact in objects_of(objects, "Schedule:Compact"):
        if compact.field(0).lower() != name.lower():
            continue
        pairs = _compact_day(compact.fields, day)
        if pairs is None:
            return None
        period_min = PERIOD_S / 60
        middles = (np.arange(PERIODS_PER_DAY) + 0.5) * period_min
        ends = np.array([minute for minute, _ in pairs])
        values = np.array([value for _, value in pairs])
        position = np.searchsorted(ends, middles, side="right")
        return np.asarray(values[np.minimum(position, len(values) - 1)], dtype=np.float64)
    return None


def cooling_coil_available(
    objects: tuple[IdfObject, ...], days: list[datetime.date]
) -> npt.NDArray[np.bool_] | None:
    """(D, 48) whether some cooling coil of the IDF (:data:`~hvacflex.energyplus.hvac.
    COOLING_COIL_CLASSES`) is scheduled available (value > 0) in each 30-min period of each
    of ``days``; a coil without a schedule is always available. None when the IDF has no such
    coil (ideal loads, ``HVACTemplate`` units not yet expanded) or a coil's schedule is not
    readable here."""
    return _some_available(objects, days, COOLING_COIL_CLASSES)


def fan_available(
    objects: tuple[IdfObject, ...], days: list[datetime.date]
) -> npt.NDArray[np.bool_] | None:
    """(D, 48) whether some supply fan of the IDF (:data:`~hvacflex.energyplus.hvac.
    FAN_CLASSES`) is scheduled available (value > 0) in each 30-min period of each of
    ``days`` (the reference small office's ``HVACOperationSchd``: working days 06:00–22:00,
    Saturday 06:00–18:00); a fan without a schedule is always available. None when the IDF
    has no such fan or a fan's schedule is not readable here. A night-cycle manager may run
    a fan outside its schedule, but then for a zone that calls: its air is the coil's."""
    return _some_available(objects, days, FAN_CLASSES)


def _some_available(
    objects: tuple[IdfObject, ...], days: list[datetime.date], classes: tuple[str, ...]
) -> npt.NDArray[np.bool_] | None:
    """(D, 48) whether some object of ``classes`` (availability schedule in field 1) is
    scheduled available; None: no such object, or an unreadable schedule."""
    names = [obj.field(1) for cls in classes for obj in objects_of(objects, cls)]
    if not names:
        return None
    out = np.zeros((len(days), PERIODS_PER_DAY), dtype=bool)
    for name in names:
        for d, day in enumerate(days):
            if not name:
                out[d] = True
                continue
            profile = day_profile(objects, name, day)
            if profile is None:
                return None
            out[d] |= profile > 0.0
    return out
