"""EnergyPlus input (IDF) text: read, check and adapt a model for one hvacflex run.

An IDF file is a sequence of objects ``Class, field, field, …;`` with ``!`` comments to the
end of a line; class names and most references are case-insensitive. This module keeps the
text as it is (comments, layout) and replaces or removes whole objects by their character
span, so a user's file stays readable after hvacflex adapts it:

* the version must be 25.2 (the engine's; there are no transition programs in the wheel);
* ``RunPeriod`` becomes the run's dates and calendar year (one run period; weather-file
  holidays and daylight saving off; the IDF's ``RunPeriodControl:SpecialDays`` are kept);
* ``Timestep`` becomes the requested number of zone time steps per hour;
* ``RunPeriodControl:DaylightSavingTime`` is removed with a warning (Singapore has none);
* optionally the site becomes Singapore Changi: ``Site:Location``, the two
  ``SizingPeriod:DesignDay`` from the Singapore EPW's design conditions (ASHRAE 2021,
  heating 99.6 %, cooling 0.4 %) and ``Site:GroundTemperature:BuildingSurface``
  (data PROVENANCE §5), so EnergyPlus autosizes the plant for Singapore.

The weather file is checked to cover every day of the run (:func:`check_weather_covers`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.constants import VALID_TIMESTEPS_PER_HOUR
from hvacflex.energyplus.api import ENERGYPLUS_VERSION
from hvacflex.errors import DataError, InputError
from hvacflex.paths import resolve_idf

SINGAPORE_LOCATION = "Singapore Changi Intl AP (hvacflex)", 1.37, 103.98, 8.0, 15.0
"""Name, latitude [°N], longitude [°E], time zone [h from UTC], elevation [m]."""

SINGAPORE_GROUND_TEMP_DEGC = 26.0
"""Monthly ``Site:GroundTemperature:BuildingSurface`` for Singapore [°C] (PROVENANCE §5)."""

SINGAPORE_PRESSURE_PA = 101145.0
"""Barometric pressure of the Singapore design days [Pa] (EPW DESIGN CONDITIONS)."""

SINGAPORE_DESIGN_DAYS = (
    # name, month, day, day type, max dry bulb [°C], daily range [K], wet bulb [°C]
    ("Singapore Ann Htg 99.6% Condns DB", 1, 21, "WinterDesignDay", 23.3, 0.0, 23.3),
    ("Singapore Ann Clg .4% Condns DB=>MWB", 5, 21, "SummerDesignDay", 33.2, 5.8, 26.3),
)
"""The Singapore EPW header's design conditions (coldest month 1, hottest month 5)."""


@dataclass(frozen=True)
class IdfObject:
    """One object of an IDF text.

    Attributes
    ----------
    class_name : the object's class as written (compare with :meth:`is_a`).
    fields : the fields after the class name, stripped (``""`` for an empty field).
    start, end : character span of the object in the text (``end`` is after its ``;``).
    line : 1-based line of the class name.
    """

    class_name: str
    fields: tuple[str, ...]
    start: int
    end: int
    line: int

    def is_a(self, class_name: str) -> bool:
        """Whether this object is of class ``class_name`` (case-insensitive)."""
        return self.class_name.lower() == class_name.lower()

    def field(self, index: int) -> str:
        """Field ``index`` (0 = the first after the class name), ``""`` when absent."""
        return self.fields[index] if index < len(self.fields) else ""


def parse_idf(text: str, source: str | Path) -> tuple[IdfObject, ...]:
    """Split an IDF text into its objects.

    Raises
    ------
    InputError
        naming the file and line when an object is not closed by ``;`` or the text holds no
        object at all.
    """
    objects: list[IdfObject] = []
    code: list[str] = []
    start: int | None = None
    start_line = 0
    offset = 0
    for number, line in enumerate(text.splitlines(keepends=True), start=1):
        body = line.split("!", 1)[0]
        column = 0
        while True:
            end = body.find(";", column)
            piece = body[column:] if end < 0 else body[column:end]
            if piece.strip() and start is None:
                start = offset + column + (len(piece) - len(piece.lstrip()))
                start_line = number
            code.append(piece)
            if end < 0:
                break
            if start is None:
                raise InputError(
                    "a ';' closes an empty object",
                    source=source,
                    line=number,
                    hint="remove the stray ';'",
                )
            tokens = [t.strip() for t in "".join(code).split(",")]
            objects.append(
                IdfObject(tokens[0], tuple(tokens[1:]), start, offset + end + 1, start_line)
            )
            code, start, column = [], None, end + 1
        offset += len(line)
    if start is not None:
        raise InputError(
            "the last object is not closed by ';'",
            source=source,
            line=start_line,
            value="".join(code).strip()[:60],
            hint="the file looks truncated; end every object with ';'",
        )
    if not objects:
        raise InputError(
            "the file holds no EnergyPlus object",
            source=source,
            hint="give an EnergyPlus 25.2 .idf file",
        )
    return tuple(objects)


def read_idf(path: str | Path, field: str = "plant.idf") -> str:
    """The text of an IDF file: a path, or a shipped model's name (``5ZoneAirCooled``;
    :func:`hvacflex.paths.resolve_idf`).

    Raises
    ------
    InputError
        when the file is missing (naming ``field`` and the shipped models), a folder, or not
        text.
    """
    file = resolve_idf(path, field)
    try:
        return file.read_text(encoding="utf-8", errors="strict")
    except UnicodeDecodeError:
        try:
            return file.read_text(encoding="latin-1")
        except OSError as error:  # pragma: no cover - unreadable after the is_file check
            raise InputError(f"IDF file unreadable: {error}", source=file) from None


def objects_of(objects: tuple[IdfObject, ...], class_name: str) -> list[IdfObject]:
    """The objects of class ``class_name`` (case-insensitive), in file order."""
    return [obj for obj in objects if obj.is_a(class_name)]


def check_version(objects: tuple[IdfObject, ...], source: str | Path) -> None:
    """Refuse an IDF not written for EnergyPlus 25.2.

    Raises
    ------
    InputError
        naming the file, the ``Version`` field and the version found.
    """
    versions = objects_of(objects, "Version")
    if not versions:
        raise InputError(
            "the IDF has no Version object",
            source=source,
            field="Version",
            hint=f"add 'Version,{ENERGYPLUS_VERSION};' to an IDF written for EnergyPlus "
            f"{ENERGYPLUS_VERSION}",
        )
    found = versions[0].field(0)
    parts = found.split(".")
    if parts[:2] != ENERGYPLUS_VERSION.split("."):
        raise InputError(
            f"the IDF is written for EnergyPlus {found}, hvacflex runs EnergyPlus "
            f"{ENERGYPLUS_VERSION}",
            source=source,
            line=versions[0].line,
            field="Version",
            value=found,
            hint="convert it with EnergyPlus's IDFVersionUpdater (not part of the wheel; it "
            f"ships with the full EnergyPlus installer) to {ENERGYPLUS_VERSION}",
        )


def zone_names(objects: tuple[IdfObject, ...]) -> tuple[str, ...]:
    """The names of the IDF's ``Zone`` objects, as written."""
    return tuple(obj.field(0) for obj in objects_of(objects, "Zone"))


def match_zones(
    wanted: tuple[str, ...],
    available: tuple[str, ...],
    source: str | Path,
    field: str,
    where: str = "the building's energyplus_zone",
) -> tuple[str, ...]:
    """The IDF's spelling of each zone name in ``wanted``, matched case-insensitively
    (``where``: what the error's hint tells the user to correct).

    Raises
    ------
    InputError
        naming the first zone the IDF lacks and listing the IDF's zones.
    """
    lookup = {name.lower(): name for name in available}
    for name in wanted:
        if name.lower() not in lookup:
            raise InputError(
                "the IDF has no such zone",
                source=source,
                field=field,
                value=name,
                hint=f"its zones are {list(available)}; name one (case does not matter) in {where}",
            )
    return tuple(lookup[name.lower()] for name in wanted)


def _run_period_text(start_date: pd.Timestamp, end_date: pd.Timestamp) -> str:
    return (
        "RunPeriod,\n"
        "    hvacflex run,            !- Name\n"
        f"    {start_date.month},  !- Begin Month\n"
        f"    {start_date.day},  !- Begin Day of Month\n"
        f"    {start_date.year},  !- Begin Year\n"
        f"    {end_date.month},  !- End Month\n"
        f"    {end_date.day},  !- End Day of Month\n"
        f"    {end_date.year},  !- End Year\n"
        "    ,                        !- Day of Week for Start Day (from the year)\n"
        "    No,                      !- Use Weather File Holidays and Special Days\n"
        "    No,                      !- Use Weather File Daylight Saving Period\n"
        "    No,                      !- Apply Weekend Holiday Rule\n"
        "    Yes,                     !- Use Weather File Rain Indicators\n"
        "    Yes,                     !- Use Weather File Snow Indicators\n"
        "    No;                      !- Treat Weather as Actual\n"
    )


def _singapore_site_text() -> list[str]:
    name, latitude, longitude, zone, elevation = SINGAPORE_LOCATION
    texts = [
        f"Site:Location,\n    {name},\n    {latitude},\n    {longitude},\n    {zone},\n"
        f"    {elevation};\n",
        "Site:GroundTemperature:BuildingSurface,"
        + ",".join([f"{SINGAPORE_GROUND_TEMP_DEGC:g}"] * 12)
        + ";\n",
    ]
    for title, month, day, day_type, dry_bulb, day_range, wet_bulb in SINGAPORE_DESIGN_DAYS:
        texts.append(
            f"SizingPeriod:DesignDay,\n    {title},\n    {month},\n    {day},\n    {day_type},\n"
            f"    {dry_bulb},\n    {day_range},\n    ,\n    ,\n    Wetbulb,\n    {wet_bulb},\n"
            f"    ,\n    ,\n    ,\n    ,\n    {SINGAPORE_PRESSURE_PA:g},\n    0.0,\n    0,\n"
            "    No,\n    No,\n    No,\n    ASHRAEClearSky,\n    ,\n    ,\n    ,\n    ,\n"
            f"    {1.0 if day_type == 'SummerDesignDay' else 0.0};\n"
        )
    return texts


@dataclass(frozen=True)
class PreparedIdf:
    """An IDF adapted for one run.

    Attributes
    ----------
    text : the IDF text EnergyPlus runs.
    objects : its objects (parsed from ``text``).
    zone_names : the IDF's zone names, as written.
    notes : what was changed, one sentence each (e.g. a removed daylight-saving object).
    """

    text: str
    objects: tuple[IdfObject, ...]
    zone_names: tuple[str, ...]
    notes: tuple[str, ...]


def prepare_idf(
    text: str,
    source: str | Path,
    *,
    start_date: pd.Timestamp,
    end_date: pd.Timestamp,
    timesteps_per_hour: int,
    singapore_site: bool = True,
) -> PreparedIdf:
    """Adapt an IDF text for a run from ``start_date`` to ``end_date`` (whole days, inclusive).

    Parameters
    ----------
    text : the IDF text (version 25.2).
    source : where it came from (named in errors).
    start_date, end_date : first and last day of the run (local dates).
    timesteps_per_hour : zone time steps per hour, one of :data:`VALID_TIMESTEPS_PER_HOUR`.
    singapore_site : replace location, design days and ground temperatures by Singapore's.

    Raises
    ------
    InputError
        for a malformed IDF, another version, no ``Zone``, or a bad ``timesteps_per_hour``.
    """
    if timesteps_per_hour not in VALID_TIMESTEPS_PER_HOUR:
        raise InputError(
            "EnergyPlus zone time steps must divide the 30-min period",
            field="plant.timesteps_per_hour",
            value=timesteps_per_hour,
            hint=f"use one of {list(VALID_TIMESTEPS_PER_HOUR)}",
        )
    objects = parse_idf(text, source)
    check_version(objects, source)
    zones = zone_names(objects)
    if not zones:
        raise InputError(
            "the IDF has no Zone object",
            source=source,
            field="Zone",
            hint="give an IDF with at least one conditioned zone",
        )
    replaced = {"runperiod", "timestep", "runperiodcontrol:daylightsavingtime"}
    if singapore_site:
        replaced |= {
            "site:location",
            "sizingperiod:designday",
            "site:groundtemperature:buildingsurface",
        }
    notes: list[str] = []
    pieces: list[str] = []
    position = 0
    for obj in objects:
        kind = obj.class_name.lower()
        if kind not in replaced:
            continue
        if kind == "runperiodcontrol:daylightsavingtime":
            notes.append(
                f"removed RunPeriodControl:DaylightSavingTime (line {obj.line}): "
                "Singapore has no daylight saving"
            )
        pieces += [text[position : obj.start], f"! (hvacflex replaced a {obj.class_name})"]
        position = obj.end
    pieces.append(text[position:])
    pieces += [
        "\n! ---- added by hvacflex for this run ----\n",
        _run_period_text(start_date, end_date),
        f"Timestep,{timesteps_per_hour};\n",
    ]
    if singapore_site:
        pieces += _singapore_site_text()
    for note in notes:
        warnings.warn(f"{source}: {note}", UserWarning, stacklevel=2)
    new_text = "".join(pieces)
    return PreparedIdf(new_text, parse_idf(new_text, source), zones, tuple(notes))


def check_weather_covers(
    epw_path: str | Path, start_date: pd.Timestamp, end_date: pd.Timestamp
) -> None:
    """Check that the EPW file has hourly rows for every day of the run.

    Raises
    ------
    DataError
        when the file is missing or lacks a day of the run (naming the first missing day;
        a 29 February counts: EnergyPlus would skip it and the run would end a day early).
    """
    path = Path(epw_path)
    if not path.is_file():
        raise DataError(
            "weather file not found",
            source=path,
            field="data.weather_file",
            hint="give the path to an .epw file",
        )
    with path.open(encoding="latin-1") as handle:
        lines = handle.read().splitlines()
    try:
        start = next(i for i, ln in enumerate(lines) if ln.upper().startswith("DATA PERIODS"))
    except StopIteration:
        raise DataError(
            "no DATA PERIODS header line: not an EPW file",
            source=path,
            field="data.weather_file",
            hint="give an EnergyPlus .epw file",
        ) from None
    rows = [ln.split(",", 4) for ln in lines[start + 1 :] if ln.strip()]
    try:
        days = {(int(r[1]), int(r[2])) for r in rows if len(r) > 3}
    except ValueError:
        raise DataError(
            "an EPW data row has a non-numeric month or day",
            source=path,
            field="data.weather_file",
            hint="the file looks damaged",
        ) from None
    wanted = pd.date_range(start_date.normalize(), end_date.normalize(), freq="D")
    missing = [d for d in wanted if (d.month, d.day) not in days]
    if missing:
        covered = sorted(days)
        span = (
            f"{covered[0][1]}/{covered[0][0]} … {covered[-1][1]}/{covered[-1][0]}"
            if covered
            else "no day"
        )
        raise DataError(
            f"the weather file does not cover the run: it has no rows for "
            f"{missing[0]:%d %B} ({len(missing)} of {len(wanted)} days missing; it covers "
            f"{span} (day/month), {int(np.ceil(len(rows) / 24))} days)",
            source=path,
            field="data.weather_file",
            value=str(missing[0].date()),
            hint="give a weather file with every day of the run (a whole-year EPW; a leap day "
            "needs a leap-year file: EnergyPlus skips a 29 February its weather lacks), or "
            "move the scenario's start and days into the file's period",
        )
