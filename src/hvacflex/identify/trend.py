"""The trend-data format: what a BMS export (or ``hvacflex identify collect``) gives the fit.

One CSV file, one row per sample on a regular time index, the columns of docs/guide/identify.md:

* ``time`` — the start of the sample's interval, ISO 8601 (with a UTC offset, or local time of
  the site, taken as :data:`hvacflex.constants.TIMEZONE`);
* per zone ``<zone>`` (the BMS / IDF name, any case): ``temp_<zone>_degc`` (required),
  ``supply_flow_<zone>_kg_s`` and ``supply_temp_<zone>_degc`` (both or neither),
  ``setpoint_<zone>_degc`` (optional);
* ``outdoor_temp_degc`` and ``ghi_w_per_m2`` (required), ``dni_w_per_m2``, ``dhi_w_per_m2``,
  ``outdoor_humidity_ratio_kg_per_kg`` (optional: the power model's moisture term);
* ``occupied`` (0…1: the occupancy flag, or the occupied share of the interval);
* ``hvac_power_kw`` and ``facility_power_kw`` (optional, metered electricity).

Every value is the mean over its interval ``[time, time + step)``. A step finer than 30 min
is resampled to 30-min means (the step must divide 30 min); a coarser one, a gap (a missing
row or an empty cell), a duplicate or a decreasing time, an unknown column and a value out of
its physical range are refused with an :class:`~hvacflex.errors.InputError` naming the file,
the line, the column, the value and the fix.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd

from hvacflex.constants import PERIOD, TIMEZONE
from hvacflex.errors import InputError

FloatArray = npt.NDArray[np.float64]


TIME_COLUMN = "time"
OUTDOOR_TEMP = "outdoor_temp_degc"
GHI = "ghi_w_per_m2"
DNI = "dni_w_per_m2"
DHI = "dhi_w_per_m2"
OUTDOOR_HUMIDITY = "outdoor_humidity_ratio_kg_per_kg"
OCCUPIED = "occupied"
HVAC_POWER = "hvac_power_kw"
FACILITY_POWER = "facility_power_kw"
REQUIRED_COLUMNS = (OUTDOOR_TEMP, GHI, OCCUPIED)
OPTIONAL_COLUMNS = (DNI, DHI, OUTDOOR_HUMIDITY, HVAC_POWER, FACILITY_POWER)

ZONE_COLUMN_PATTERNS = {
    "temp": re.compile(r"^temp_(.+)_degc$"),
    "supply_flow": re.compile(r"^supply_flow_(.+)_kg_s$"),
    "supply_temp": re.compile(r"^supply_temp_(.+)_degc$"),
    "setpoint": re.compile(r"^setpoint_(.+)_degc$"),
}
"""Per-zone column kinds; the zone name is the part between prefix and unit."""

TEMP_RANGE_DEGC = (-50.0, 70.0)
"""Plausible air temperatures [°C] (a value outside is a sensor fault or a unit slip)."""
RANGES: dict[str, tuple[float, float]] = {
    "temp": TEMP_RANGE_DEGC,
    "supply_temp": TEMP_RANGE_DEGC,
    "setpoint": TEMP_RANGE_DEGC,
    "supply_flow": (0.0, 1.0e4),
    OUTDOOR_TEMP: TEMP_RANGE_DEGC,
    GHI: (0.0, 1500.0),
    DNI: (0.0, 1500.0),
    DHI: (0.0, 1500.0),
    OUTDOOR_HUMIDITY: (0.0, 0.05),
    OCCUPIED: (0.0, 1.0),
    HVAC_POWER: (0.0, 1.0e6),
    FACILITY_POWER: (0.0, 1.0e6),
}
"""Valid range of each column (or column kind) in its unit."""


def zone_column(kind: str, zone: str) -> str:
    """The column of ``kind`` (``temp``, ``supply_flow``, ``supply_temp``, ``setpoint``)."""
    unit = "kg_s" if kind == "supply_flow" else "degc"
    return f"{kind}_{zone}_{unit}"


@dataclass(frozen=True)
class TrendData:
    """A validated trend file on the 30-min grid.

    Attributes
    ----------
    source : the file it was read from.
    frame : (T, columns) the 30-min means, index tz-aware period starts (:data:`TIMEZONE`).
    zones : (m,) the zone names as written in the file (order of first appearance).
    """

    source: str
    frame: pd.DataFrame
    zones: tuple[str, ...]

    @property
    def index(self) -> pd.DatetimeIndex:
        """(T,) period starts."""
        return pd.DatetimeIndex(self.frame.index)

    def zone_series(self, kind: str, zones: tuple[str, ...]) -> FloatArray | None:
        """(T, len(zones)) the ``kind`` columns of ``zones``; None when any zone lacks it."""
        columns = [zone_column(kind, z) for z in zones]
        if not all(c in self.frame.columns for c in columns):
            return None
        return self.frame[columns].to_numpy(dtype=np.float64)

    def has(self, column: str) -> bool:
        """Whether the file has ``column``."""
        return column in self.frame.columns

    def column(self, column: str) -> FloatArray:
        """(T,) one column."""
        return self.frame[column].to_numpy(dtype=np.float64)


def _classify(column: str, source: str) -> tuple[str, str | None]:
    """(kind, zone) of a column; zone None for a building-wide column."""
    if column in REQUIRED_COLUMNS or column in OPTIONAL_COLUMNS:
        return column, None
    for kind, pattern in ZONE_COLUMN_PATTERNS.items():
        match = pattern.match(column)
        if match:
            return kind, match.group(1)
    raise InputError(
        "unknown trend column",
        source=source,
        line=1,
        field=column,
        hint="columns are time, temp_<zone>_degc, supply_flow_<zone>_kg_s, "
        "supply_temp_<zone>_degc, setpoint_<zone>_degc, "
        + ", ".join((*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS))
        + " (docs/guide/identify.md)",
    )


def _parse_times(raw: pd.Series, source: str) -> pd.DatetimeIndex:
    parsed = pd.to_datetime(raw, errors="coerce", utc=False, format="ISO8601")
    bad = parsed.isna()
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(
            "not a time",
            source=source,
            line=i + 2,
            field=TIME_COLUMN,
            value=raw.iloc[i],
            hint="write ISO 8601, e.g. 2014-03-04T00:00:00+08:00",
        )
    index = pd.DatetimeIndex(parsed)
    if index.tz is None:
        return index.tz_localize(TIMEZONE)
    return index.tz_convert(TIMEZONE)


def _check_time_order(index: pd.DatetimeIndex, source: str) -> pd.Timedelta:
    """The regular step; duplicates, decreasing times and gaps refused."""
    if len(index) < 2:
        raise InputError(
            "a trend file needs at least two rows", source=source, hint="export more data"
        )
    steps = index[1:] - index[:-1]
    step = pd.Timedelta(steps.min())
    for i, delta in enumerate(steps):
        line = i + 3  # header + 1-based + the second row of the pair
        if delta == pd.Timedelta(0):
            raise InputError(
                "duplicate time",
                source=source,
                line=line,
                field=TIME_COLUMN,
                value=str(index[i + 1]),
                hint="keep one row per time (drop the repeated export rows)",
            )
        if delta < pd.Timedelta(0):
            raise InputError(
                "time goes backwards",
                source=source,
                line=line,
                field=TIME_COLUMN,
                value=str(index[i + 1]),
                hint="sort the rows by time",
            )
    for i, delta in enumerate(steps):
        if delta != step:
            raise InputError(
                f"gap in the time index: {delta} after the previous row, the step is {step}",
                source=source,
                line=i + 3,
                field=TIME_COLUMN,
                value=str(index[i + 1]),
                hint=f"fill the missing rows from {index[i] + step} (the fit needs a regular "
                "index), or cut the file at the gap",
            )
    period = PERIOD
    if step > period or period % step != pd.Timedelta(0):
        raise InputError(
            "the time step must divide 30 min",
            source=source,
            field=TIME_COLUMN,
            value=str(step),
            hint="export at 1, 5, 10, 15 or 30 min",
        )
    return step


def first_out_of_range(values: npt.NDArray[np.float64], kind: str) -> int | None:
    """The index of the first of ``values`` that is not finite or lies outside ``kind``'s
    range (:data:`RANGES`, the kind's unit); None when every value is in range."""
    low, high = RANGES[kind]
    bad = ~np.isfinite(values) | (values < low) | (values > high)
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def _check_values(frame: pd.DataFrame, kinds: dict[str, str], source: str) -> pd.DataFrame:
    numeric = frame.apply(pd.to_numeric, errors="coerce")
    for column in frame.columns:
        values = numeric[column].to_numpy(dtype=np.float64)
        low, high = RANGES[kinds[column]]
        i = first_out_of_range(values, kinds[column])
        if i is not None:
            raw = frame[column].iloc[i]
            empty = raw is None or (isinstance(raw, float) and np.isnan(raw)) or raw == ""
            hint = (
                "fill the gap (interpolate a short one) or cut the file there"
                if empty
                else f"valid values lie in [{low:g}, {high:g}] ({column}'s unit)"
            )
            raise InputError(
                "empty cell" if empty else "invalid value",
                source=source,
                line=i + 2,
                field=column,
                value=None if empty else raw,
                hint=hint,
            )
    result: pd.DataFrame = numeric.astype(np.float64)
    return result


def _check_zone_columns(zones: dict[str, set[str]], source: str) -> None:
    for zone, kinds in zones.items():
        if "temp" not in kinds:
            raise InputError(
                "a zone column without the zone's temperature",
                source=source,
                line=1,
                field=zone_column("temp", zone),
                hint="add the zone's air temperature column or drop its other columns",
            )
        if ("supply_flow" in kinds) != ("supply_temp" in kinds):
            missing = "supply_temp" if "supply_flow" in kinds else "supply_flow"
            raise InputError(
                "supply flow and supply temperature come together",
                source=source,
                line=1,
                field=zone_column(missing, zone),
                hint="add the column, or drop the other one (the fit then needs neither)",
            )


def _resample(frame: pd.DataFrame, step: pd.Timedelta, source: str) -> pd.DataFrame:
    period = PERIOD
    if step == period:
        return frame
    per_period = int(period / step)
    grouped = frame.resample(period, origin="start_day", label="left", closed="left")
    counts = grouped.size()
    means = grouped.mean()[counts == per_period]
    if means.empty:
        raise InputError(
            "no whole 30-min period in the file",
            source=source,
            field=TIME_COLUMN,
            hint="export at least one aligned 30-min period",
        )
    return means


def read_trend(path: str | Path) -> TrendData:
    """Read and validate a trend CSV (module docstring, docs/guide/identify.md).

    Returns
    -------
    The 30-min means, tz-aware (:data:`TIMEZONE`).

    Raises
    ------
    InputError
        for a missing file, a missing/unknown column, a bad time or value (file, line, column,
        value, fix), a gap, a duplicate, or a step that does not divide 30 min.
    """
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise InputError("trend file not found", source=source, hint="give a CSV file")
    try:
        raw = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(
            f"not a readable CSV: {exc}", source=source, hint="export the trend as CSV"
        ) from None
    for column in (TIME_COLUMN, *REQUIRED_COLUMNS):
        if column not in raw.columns:
            raise InputError(
                "missing required column",
                source=source,
                line=1,
                field=column,
                hint="see docs/guide/identify.md for the trend format",
            )
    kinds: dict[str, str] = {}
    zones: dict[str, set[str]] = {}
    for column in raw.columns:
        if column == TIME_COLUMN:
            continue
        kind, zone = _classify(column, source)
        kinds[column] = kind
        if zone is not None:
            zones.setdefault(zone, set()).add(kind)
    if not zones:
        raise InputError(
            "no zone temperature column",
            source=source,
            line=1,
            field="temp_<zone>_degc",
            hint="add one temp_<zone>_degc column per zone",
        )
    _check_zone_columns(zones, source)
    index = _parse_times(raw[TIME_COLUMN], source)
    step = _check_time_order(index, source)
    values = raw.drop(columns=[TIME_COLUMN]).replace("", np.nan)
    frame = _check_values(values, kinds, source)
    frame.index = index
    frame.index.name = TIME_COLUMN
    return TrendData(source=source, frame=_resample(frame, step, source), zones=tuple(zones))


def write_trend(frame: pd.DataFrame, path: str | Path) -> Path:
    """Write a trend frame (index: period starts; the columns of this format) as CSV."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = frame.copy()
    out.index = pd.DatetimeIndex(out.index).map(lambda t: t.isoformat())
    out.index.name = TIME_COLUMN
    out.to_csv(path, float_format="%.6g")
    return path
