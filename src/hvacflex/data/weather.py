"""Weather from EnergyPlus EPW files, resampled to 30 min, and solar irradiance on façades.

EPW conventions
---------------
An EPW file has 8 header lines (``LOCATION``, ``DESIGN CONDITIONS``, ``TYPICAL/EXTREME
PERIODS``, ``GROUND TEMPERATURES``, ``HOLIDAYS/DAYLIGHT SAVINGS``, ``COMMENTS 1``,
``COMMENTS 2``, ``DATA PERIODS``) and 8,760 hourly rows in local standard time. The row for
hour ``h`` (1…24) describes the hour ``[h−1, h)``:

* state variables (dry-bulb and dew-point temperature, relative humidity, pressure, wind) are
  readings at the instant ``h:00``;
* irradiances (GHI, DNI, DHI) are energies over ``[h−1, h)`` in Wh/m², i.e. mean W/m².

Resampling to 30-min periods ``[t, t+30 min)`` (:func:`weather_30min`)
----------------------------------------------------------------------
* State variables are interpolated linearly between the hourly instants and evaluated at the
  period midpoint ``t + 15 min``; for a piecewise-linear signal that *is* the period mean.
* Irradiances keep each hour's energy: the two halves of an hour average to the hour's
  mean. GHI and DHI (horizontal) are shared between the halves in proportion to the
  integral of ``max(cos θz, 0)`` over each half, DNI (normal to the beam) in proportion to
  each half's sunlit time (θz the apparent solar zenith, sampled as in
  :func:`hvacflex.data.solar.period_sun`). So no beam falls in a half-hour the sun is
  below the horizon, and the DNI of a sunrise hour is the DNI while the sun is up, not
  twice the hour's mean. Where the sun is below the horizon over a whole hour its values
  are split equally.
* The sky's horizontal infrared (an hour mean, like the irradiances) applies to both halves
  of its hour.
* Humidity ratio follows from the period's dew point and pressure.

EPW files hold a typical year assembled from different years; :func:`weather_30min` maps the
calendar (month, day, hour) onto the requested ``year`` (29 February of a leap year repeats
28 February).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.constants import PERIOD, PERIOD_FREQ, TIMEZONE
from hvacflex.data.solar import period_sun
from hvacflex.errors import DataError
from hvacflex.units import KELVIN_OFFSET

EPW_HEADER_KEYWORDS = (
    "LOCATION",
    "DESIGN CONDITIONS",
    "TYPICAL/EXTREME PERIODS",
    "GROUND TEMPERATURES",
    "HOLIDAYS/DAYLIGHT SAVINGS",
    "COMMENTS 1",
    "COMMENTS 2",
    "DATA PERIODS",
)
EPW_HOURS_PER_YEAR = 8760

EPW_FIELDS_PER_ROW = 35
"""Fields in an EPW data row (EnergyPlus Auxiliary Programs, "EnergyPlus Weather File (EPW)
Data Dictionary")."""


@dataclass(frozen=True)
class EpwField:
    """One numeric field of an EPW data row that hvacflex reads, with its valid range.

    Attributes
    ----------
    index : 0-based position in the row.
    column : column name in the frame :func:`read_epw` returns.
    name : field name in the EPW data dictionary.
    unit : unit of the field.
    minimum, maximum : physical range (inclusive) [unit].
    missing : the EPW "missing" code: a value ≥ it means "no data" (None: the field has
        none).
    required : a missing or out-of-range value is an error (True), or NaN in the frame
        (False: a field only some buildings need, refused where it is used).
    """

    index: int
    column: str
    name: str
    unit: str
    minimum: float
    maximum: float
    missing: float | None
    required: bool = True


IRRADIANCE_MAX_WH_PER_M2 = 1500.0
"""Upper bound of an hourly irradiance [Wh/m²]: above the solar constant (≈ 1,361 W/m²) with
margin for cloud enhancement; the EPW dictionary gives only the minimum 0."""

EPW_FIELDS: tuple[EpwField, ...] = (
    # Ranges and missing codes from the EPW data dictionary (EnergyPlus Auxiliary Programs,
    # ch. 2): dry bulb and dew point -70 < T < 70 °C (missing 99.9), RH 0…110 % (999),
    # station pressure 31,000 < p < 120,000 Pa (999999), irradiances ≥ 0 Wh/m² (9999),
    # wind speed 0…40 m/s (999). Date fields have no missing code.
    EpwField(0, "source_year", "Year", "-", 1.0, 9999.0, None),
    EpwField(1, "month", "Month", "-", 1.0, 12.0, None),
    EpwField(2, "day", "Day", "-", 1.0, 31.0, None),
    EpwField(3, "hour", "Hour", "h", 1.0, 24.0, None),
    EpwField(6, "outdoor_temp_degc", "Dry Bulb Temperature", "°C", -70.0, 70.0, 99.9),
    EpwField(7, "dewpoint_degc", "Dew Point Temperature", "°C", -70.0, 70.0, 99.9),
    EpwField(8, "relative_humidity_percent", "Relative Humidity", "%", 0.0, 110.0, 999.0),
    EpwField(9, "pressure_pa", "Atmospheric Station Pressure", "Pa", 31000.0, 120000.0, 999999.0),
    EpwField(
        12,
        "sky_infrared_w_per_m2",
        "Horizontal Infrared Radiation Intensity",
        "Wh/m²",
        0.0,
        IRRADIANCE_MAX_WH_PER_M2,
        9999.0,
        required=False,
    ),
    EpwField(
        13,
        "ghi_w_per_m2",
        "Global Horizontal Radiation",
        "Wh/m²",
        0.0,
        IRRADIANCE_MAX_WH_PER_M2,
        9999.0,
    ),
    EpwField(
        14,
        "dni_w_per_m2",
        "Direct Normal Radiation",
        "Wh/m²",
        0.0,
        IRRADIANCE_MAX_WH_PER_M2,
        9999.0,
    ),
    EpwField(
        15,
        "dhi_w_per_m2",
        "Diffuse Horizontal Radiation",
        "Wh/m²",
        0.0,
        IRRADIANCE_MAX_WH_PER_M2,
        9999.0,
    ),
    EpwField(21, "wind_speed_m_s", "Wind Speed", "m/s", 0.0, 40.0, 999.0),
)
"""The fields hvacflex reads, with the physical range every value must lie in. The sky's
infrared (field 13) is optional: a missing, non-numeric or out-of-range value is NaN, refused
only for a building that needs it (exterior surfaces with a thermal emissivity: the
``sky_longwave`` channel, :mod:`hvacflex.data.weather_channels`)."""

TIMEZONE_RANGE_H = (-12.0, 14.0)
"""Valid offsets of local standard time from UTC [h] (the EPW dictionary says −12…+12; real
zones reach +14)."""

ELEVATION_RANGE_M = (-1000.0, 9999.9)
"""Valid site elevations [m] (EPW data dictionary)."""

GROUND_TEMP_RANGE_DEGC = (-70.0, 70.0)
"""Valid monthly ground temperatures [°C] (same range as the dry bulb)."""

DEWPOINT_ABOVE_DRY_BULB_TOLERANCE_K = 0.1
"""How far the dew point may exceed the dry bulb [K]: one unit of the EPW's resolution
(0.1 °C), for converters that round the two fields from different sources. Beyond it the
row is refused (air cannot hold more water than saturates it). The shipped files have no
row with the dew point above the dry bulb."""

DIFFUSE_ABOVE_GLOBAL_TOLERANCE_WH_PER_M2 = 1.0
"""How far the diffuse horizontal may exceed the global horizontal irradiance [Wh/m²]: one
unit of the EPW's resolution, for fields rounded independently (GHI = DHI + DNI·cos θz ≥
DHI). The shipped files have no row with DHI above GHI."""

NIGHT_ELEVATION_TOLERANCE_DEG = 1.0
"""An hour is night when the sun's apparent elevation stays below −this [°] at its start,
middle and end; a night hour must have zero GHI and DNI. The margin covers the sun
position of the check (taken for a fixed non-leap year, :data:`SUN_CHECK_YEAR`, while a
typical year's hours come from different years: ≤ 0.4° of declination), the uncertain
refraction at the horizon (≈ 0.5°) and stamps rounded to the minute. Sunrise and sunset
hours always have the sun above the horizon for part of the hour and so are never night.
In the shipped files the lowest sun with irradiance is 0.25° above the horizon (Denver
TMY3, DNI) and 2.45° (Singapore TMYx)."""

SUN_CHECK_YEAR = 2001
"""Non-leap year whose sun positions the night check uses for the typical year's rows."""

_STATE_COLUMNS = (
    "outdoor_temp_degc",
    "dewpoint_degc",
    "relative_humidity_percent",
    "pressure_pa",
    "wind_speed_m_s",
)
_IRRADIANCE_COLUMNS = ("ghi_w_per_m2", "dni_w_per_m2", "dhi_w_per_m2")

MOLAR_MASS_RATIO_WATER_AIR = 0.621945
"""Ratio of the molar masses of water vapour and dry air [-] (ASHRAE Fundamentals ch. 1)."""


@dataclass(frozen=True)
class EpwLocation:
    """Site of an EPW file (from its ``LOCATION`` and ``GROUND TEMPERATURES`` lines).

    Attributes
    ----------
    latitude_deg : north positive [°].
    longitude_deg : east positive [°].
    tz_offset_h : offset of the file's local standard time from UTC [h].
    elevation_m : above sea level [m].
    name : station name.
    ground_temp_monthly_degc : (12,) undisturbed ground temperature at the shallowest depth the
        file lists, January…December [°C]; empty if the file has none.
    """

    latitude_deg: float
    longitude_deg: float
    tz_offset_h: float
    elevation_m: float
    name: str
    ground_temp_monthly_degc: tuple[float, ...] = ()


def _bad_header(path: str | Path, line: int, message: str, value: object) -> DataError:
    return DataError(
        message,
        source=path,
        line=line,
        value=value,
        hint=f"an EPW file starts with 8 header lines: {', '.join(EPW_HEADER_KEYWORDS)}",
    )


def _header_number(
    path: str | Path,
    line: int,
    fields: list[str],
    index: int,
    what: str,
    valid: tuple[float, float],
) -> float:
    """Field ``index`` of header line ``line`` as a finite number inside ``valid``."""
    text = fields[index] if index < len(fields) else ""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    low, high = valid
    if not (math.isfinite(value) and low <= value <= high):
        raise DataError(
            f"must be a number in [{low:g}, {high:g}]",
            source=path,
            line=line,
            field=what,
            value=text.strip()[:40],
            hint="the EPW header looks damaged; re-download the file",
        )
    return value


def _parse_header(path: str | Path, lines: list[str]) -> EpwLocation:
    if len(lines) < len(EPW_HEADER_KEYWORDS):
        raise _bad_header(path, len(lines) + 1, "truncated EPW header", len(lines))
    for i, keyword in enumerate(EPW_HEADER_KEYWORDS):
        if not lines[i].upper().startswith(keyword):
            raise _bad_header(path, i + 1, f"bad EPW header: expected '{keyword}'", lines[i][:40])
    loc = lines[0].split(",")
    if len(loc) < 10:
        raise _bad_header(
            path,
            1,
            f"bad EPW LOCATION line: {len(loc)} fields, 10 are needed (city, region, country, "
            "source, WMO, latitude, longitude, time zone, elevation)",
            lines[0][:80],
        )
    latitude = _header_number(path, 1, loc, 6, "LOCATION latitude [°]", (-90.0, 90.0))
    longitude = _header_number(path, 1, loc, 7, "LOCATION longitude [°]", (-180.0, 180.0))
    tz_offset = _header_number(path, 1, loc, 8, "LOCATION time zone [h]", TIMEZONE_RANGE_H)
    elevation = _header_number(path, 1, loc, 9, "LOCATION elevation [m]", ELEVATION_RANGE_M)
    ground: tuple[float, ...] = ()
    g = lines[3].split(",")
    depths = 0.0
    if len(g) > 1 and g[1].strip():
        depths = _header_number(path, 4, g, 1, "GROUND TEMPERATURES depths", (0.0, 1000.0))
    if depths >= 1:
        if len(g) < 18:
            raise _bad_header(
                path,
                4,
                f"GROUND TEMPERATURES line has {len(g)} fields, at least 18 are needed for "
                "one depth",
                lines[3][:80],
            )
        ground = tuple(
            _header_number(
                path, 4, g, i, f"GROUND TEMPERATURES month {i - 5} [°C]", GROUND_TEMP_RANGE_DEGC
            )
            for i in range(6, 18)
        )
    name = loc[1].strip() or Path(path).stem
    return EpwLocation(latitude, longitude, tz_offset, elevation, name, ground)


@functools.lru_cache(maxsize=4)
def _read_epw_cached(
    path_str: str, stamp: tuple[int, int] | None = None
) -> tuple[pd.DataFrame, EpwLocation]:
    path = Path(path_str)
    try:
        text = path.read_text(encoding="latin-1")
    except FileNotFoundError:
        raise DataError(
            "weather file not found",
            source=path,
            hint="give the path to an .epw file ([data] weather_file in a scenario file)",
        ) from None
    except IsADirectoryError:
        raise DataError(
            "weather file is a folder", source=path, hint="give the path to an .epw file"
        ) from None
    return parse_epw_text(text, path)


def parse_epw_text(
    text: str, source: str | Path, *, hours: int = EPW_HOURS_PER_YEAR
) -> tuple[pd.DataFrame, EpwLocation]:
    """Parse the text of an EPW file (see :func:`read_epw`).

    Parameters
    ----------
    text : the whole file.
    source : where the text came from (named in errors).
    hours : number of hourly rows expected after a 29 February is dropped: 8,760 for a
        file; fewer checks a file cut after its first ``hours`` rows (tests).

    Returns
    -------
    The hourly frame and the location, as :func:`read_epw`.
    """
    lines = text.splitlines()
    n_header = len(EPW_HEADER_KEYWORDS)
    location = _parse_header(source, lines[:n_header])
    data_lines = lines[n_header:]
    while data_lines and not data_lines[-1].strip():
        data_lines.pop()
    rows = [ln.split(",") for ln in data_lines]
    for i, row in enumerate(rows):
        if len(row) != EPW_FIELDS_PER_ROW:
            few = len(row) < EPW_FIELDS_PER_ROW
            raise DataError(
                f"EPW data row has too {'few' if few else 'many'} fields: {len(row)}, an EPW "
                f"row has {EPW_FIELDS_PER_ROW}",
                source=source,
                line=n_header + i + 1,
                value=data_lines[i][:60],
                hint=f"a field (comma) was {'deleted' if few else 'added'} or the line was cut; "
                "the file looks damaged, re-download it",
            )
    if len(rows) not in (hours, hours + 24) or (hours < EPW_HOURS_PER_YEAR and len(rows) != hours):
        raise DataError(
            f"EPW file has {len(rows)} hourly rows, expected {hours}",
            source=source,
            line=n_header + len(rows),
            value=len(rows),
            hint="the file looks truncated or has extra lines; hvacflex needs a whole year of "
            "hourly rows",
        )
    columns: dict[str, np.ndarray] = {
        spec.column: _numeric_field(source, rows, spec, n_header) for spec in EPW_FIELDS
    }
    for name in ("source_year", "month", "day", "hour"):
        columns[name] = columns[name].astype(int)
    frame = pd.DataFrame(columns)
    frame["line"] = np.arange(n_header + 1, n_header + 1 + len(frame))
    leap = (frame["month"] == 2) & (frame["day"] == 29)
    frame = frame.loc[~leap].reset_index(drop=True)
    if len(frame) != hours:
        raise DataError(
            f"EPW file has {len(frame)} hourly rows besides 29 February, expected {hours}",
            source=source,
            value=len(frame),
            hint="a leap-year file has 8,784 rows with all of 29 February",
        )
    _check_calendar(source, frame, hours)
    _check_consistency(source, frame, location)
    return frame.drop(columns="line"), location


def _check_calendar(source: str | Path, frame: pd.DataFrame, hours: int) -> None:
    """Row i must be hour i of the year: (month, day, hour) run 1 Jan 1 … 31 Dec 24."""
    starts = pd.date_range("2001-01-01", periods=hours, freq="h")  # a non-leap year
    expected = np.stack([starts.month, starts.day, starts.hour + 1], axis=1)
    actual = frame[["month", "day", "hour"]].to_numpy()
    wrong = np.flatnonzero((actual != expected).any(axis=1))
    if len(wrong):
        i = int(wrong[0])
        month, day, hour = (int(v) for v in actual[i])
        raise DataError(
            f"EPW rows must run hour by hour from 1 January hour 1 to 31 December hour 24; "
            f"expected month {expected[i, 0]}, day {expected[i, 1]}, hour {expected[i, 2]}",
            source=source,
            line=int(frame["line"].iloc[i]),
            field="month, day, hour",
            value=(month, day, hour),
            hint="a line is missing, repeated or out of order; the file is not a standard "
            "hourly EPW",
        )


def _field_name(column: str) -> str:
    spec = next(f for f in EPW_FIELDS if f.column == column)
    return f"{spec.column} ({spec.name}, field {spec.index + 1})"


def _refuse_rows(
    source: str | Path, frame: pd.DataFrame, bad: np.ndarray, column: str, message: str, hint: str
) -> None:
    """Raise a DataError naming the first row where ``bad`` holds, if any."""
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise DataError(
            f"{message} ({int(bad.sum())} row(s))",
            source=source,
            line=int(frame["line"].iloc[i]),
            field=_field_name(column),
            value=float(frame[column].iloc[i]),
            hint=hint,
        )


def night_hours(location: EpwLocation, hours: int) -> np.ndarray:
    """(hours,) True for the hours of the typical year that are night at ``location``: the
    sun's apparent elevation below −:data:`NIGHT_ELEVATION_TOLERANCE_DEG` at the hour's
    start, middle and end (row i covers hour i of :data:`SUN_CHECK_YEAR`, local standard
    time)."""
    import pvlib

    starts_lst = pd.date_range(
        pd.Timestamp(year=SUN_CHECK_YEAR, month=1, day=1), periods=hours, freq="h"
    )
    starts_utc = starts_lst - pd.Timedelta(hours=location.tz_offset_h)
    instants = pd.DatetimeIndex(
        np.concatenate([starts_utc + pd.Timedelta(minutes=m) for m in (0, 30, 60)])
    ).tz_localize("UTC")
    position = pvlib.solarposition.get_solarposition(
        instants, location.latitude_deg, location.longitude_deg, altitude=location.elevation_m
    )
    elevation = position["apparent_elevation"].to_numpy(dtype=float).reshape(3, hours)
    result: np.ndarray = elevation.max(axis=0) < -NIGHT_ELEVATION_TOLERANCE_DEG
    return result


def _check_consistency(source: str | Path, frame: pd.DataFrame, location: EpwLocation) -> None:
    """Refuse rows whose fields contradict each other: dew point above dry bulb, diffuse
    above global, irradiance at night (tolerances: the constants above)."""
    excess = frame["dewpoint_degc"].to_numpy() - frame["outdoor_temp_degc"].to_numpy()
    _refuse_rows(
        source,
        frame,
        np.round(excess, 6) > DEWPOINT_ABOVE_DRY_BULB_TOLERANCE_K,  # 0.1-K steps, no float noise
        "dewpoint_degc",
        f"dew point above the dry bulb by more than {DEWPOINT_ABOVE_DRY_BULB_TOLERANCE_K:g} K",
        "the dew point cannot exceed the dry-bulb temperature; the file is damaged or its "
        "columns are swapped",
    )
    diffuse_excess = frame["dhi_w_per_m2"].to_numpy() - frame["ghi_w_per_m2"].to_numpy()
    _refuse_rows(
        source,
        frame,
        diffuse_excess > DIFFUSE_ABOVE_GLOBAL_TOLERANCE_WH_PER_M2,
        "dhi_w_per_m2",
        "diffuse horizontal above global horizontal irradiance by more than "
        f"{DIFFUSE_ABOVE_GLOBAL_TOLERANCE_WH_PER_M2:g} Wh/m²",
        "global = diffuse + beam ≥ diffuse; the file is damaged or its columns are swapped",
    )
    night = night_hours(location, len(frame))
    for column in ("ghi_w_per_m2", "dni_w_per_m2"):
        _refuse_rows(
            source,
            frame,
            night & (frame[column].to_numpy() > 0.0),
            column,
            f"irradiance while the sun is below the horizon (more than "
            f"{NIGHT_ELEVATION_TOLERANCE_DEG:g}° below it all hour)",
            "the file's hours or its LOCATION (longitude, time zone) are wrong: EPW hours are "
            "local standard time, hour h covering [h−1, h)",
        )


def _numeric_field(
    source: str | Path, rows: list[list[str]], spec: EpwField, n_header: int
) -> np.ndarray:
    """Field ``spec`` of every row as floats, checked against its range and missing code."""
    texts = pd.Series([r[spec.index] for r in rows], dtype=object).str.strip()
    array = pd.to_numeric(texts, errors="coerce").to_numpy(dtype=float)
    if not spec.required:
        assert spec.missing is not None
        array = array.copy()  # to_numpy may return a read-only view
        bad = ~np.isfinite(array) | (array >= spec.missing)
        array[bad | (array < spec.minimum) | (array > spec.maximum)] = np.nan
        return array
    where = f"{spec.column} ({spec.name}, field {spec.index + 1})"
    checks: list[tuple[np.ndarray, str, str]] = [
        (
            ~np.isfinite(array),
            "missing or non-numeric EPW field",
            "hvacflex needs dry bulb, dew point, RH, pressure, GHI, DNI, DHI and wind in every "
            "row; fill the gaps (e.g. with the Elements or a weather converter)",
        )
    ]
    if spec.missing is not None:
        checks.append(
            (
                array >= spec.missing,
                f"EPW missing-value code (≥ {spec.missing:g}) where a value is needed",
                "fill the gaps in the file (e.g. with the Elements or a weather converter)",
            )
        )
    checks.append(
        (
            (array < spec.minimum) | (array > spec.maximum),
            f"outside the physical range {spec.minimum:g}…{spec.maximum:g} {spec.unit}",
            "the file looks damaged; re-download it",
        )
    )
    if spec.missing is None:  # date fields
        checks.append((array != np.round(array), "must be a whole number", "the file is damaged"))
    for bad, message, hint in checks:
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise DataError(
                f"{message} ({int(bad.sum())} row(s))",
                source=source,
                line=n_header + i + 1,
                field=where,
                value=rows[i][spec.index],
                hint=hint,
            )
    return array


def read_epw(path: str | Path) -> tuple[pd.DataFrame, EpwLocation]:
    """Read an EnergyPlus weather (EPW) file.

    Parameters
    ----------
    path : the ``.epw`` file.

    Returns
    -------
    hourly : (8760 rows) DataFrame, row i = i-th hour of the year, with ``source_year``,
        ``month``, ``day``, ``hour`` (1…24, the row covers [hour−1, hour) local standard time),
        ``outdoor_temp_degc`` [°C], ``dewpoint_degc`` [°C], ``relative_humidity_percent``
        [%], ``pressure_pa`` [Pa], ``ghi_w_per_m2``, ``dni_w_per_m2``, ``dhi_w_per_m2``
        (hour means [W/m²]), ``sky_infrared_w_per_m2`` (the sky's horizontal infrared, hour
        means [W/m²]; NaN where the file has none) and ``wind_speed_m_s`` [m/s]. A 29
        February is dropped.
    location : :class:`EpwLocation`.

    Raises
    ------
    DataError
        naming line and field for a bad header (location, time zone, elevation, ground
        temperatures), a row with too few or too many fields, a truncated file, rows out of
        calendar order, a missing, non-numeric, missing-coded or out-of-range value (ranges
        in :data:`EPW_FIELDS`), or fields that contradict each other: dew point above dry
        bulb, diffuse above global, GHI or DNI while the sun is below the horizon (tolerances
        :data:`DEWPOINT_ABOVE_DRY_BULB_TOLERANCE_K`,
        :data:`DIFFUSE_ABOVE_GLOBAL_TOLERANCE_WH_PER_M2`,
        :data:`NIGHT_ELEVATION_TOLERANCE_DEG`).
    """
    resolved = Path(path).resolve()
    try:
        stat = resolved.stat()
        stamp: tuple[int, int] | None = (stat.st_mtime_ns, stat.st_size)
    except OSError:
        stamp = None
    frame, location = _read_epw_cached(str(resolved), stamp)
    return frame.copy(), location


def saturation_pressure_pa(temp_degc: np.ndarray) -> np.ndarray:
    """Saturation pressure of water vapour over liquid water (ASHRAE Fundamentals 2017, ch. 1,
    eq. 6, Hyland–Wexler; valid 0–200 °C).

    Parameters
    ----------
    temp_degc : (T,) temperature [°C].

    Returns
    -------
    (T,) saturation pressure [Pa].
    """
    t = np.asarray(temp_degc, dtype=float) + KELVIN_OFFSET
    ln_p = (
        -5.8002206e3 / t
        + 1.3914993
        - 4.8640239e-2 * t
        + 4.1764768e-5 * t**2
        - 1.4452093e-8 * t**3
        + 6.5459673 * np.log(t)
    )
    result: np.ndarray = np.exp(ln_p)
    return result


def humidity_ratio_kg_per_kg(dewpoint_degc: np.ndarray, pressure_pa: np.ndarray) -> np.ndarray:
    """Humidity ratio of moist air from dew point and total pressure.

    ``W = 0.621945 · p_w / (p − p_w)`` with ``p_w`` the saturation pressure at the dew point
    (:func:`saturation_pressure_pa`; ASHRAE Fundamentals ch. 1, eqs. 22 and 38).

    Parameters
    ----------
    dewpoint_degc : (T,) dew-point temperature [°C].
    pressure_pa : (T,) total (barometric) pressure [Pa].

    Returns
    -------
    (T,) humidity ratio [kg water / kg dry air].
    """
    vapour_pa = saturation_pressure_pa(dewpoint_degc)
    pressure = np.asarray(pressure_pa, dtype=float)
    result: np.ndarray = MOLAR_MASS_RATIO_WATER_AIR * vapour_pa / (pressure - vapour_pa)
    return result


def year_index(year: int, tz: str = TIMEZONE) -> pd.DatetimeIndex:
    """All 30-min period starts of ``year`` in ``tz`` (17,520 or 17,568 periods)."""
    return pd.date_range(
        pd.Timestamp(year=year, month=1, day=1, tz=tz),
        pd.Timestamp(year=year + 1, month=1, day=1, tz=tz),
        freq=PERIOD_FREQ,
        inclusive="left",
        name="time",
    )


def weather_30min(
    epw: pd.DataFrame, location: EpwLocation, year: int = 2014, *, tz: str = TIMEZONE
) -> pd.DataFrame:
    """Map a typical-year EPW onto ``year`` on 30-min periods (see the module docstring).

    Parameters
    ----------
    epw : hourly frame from :func:`read_epw`.
    location : its :class:`EpwLocation` (for solar geometry and the time zone of the file).
    year : calendar year to map the typical year onto.
    tz : time zone of the returned index (the file's own local standard time is honoured).

    Returns
    -------
    DataFrame on the period starts of ``year`` (tz-aware, 30 min) with ``outdoor_temp_degc``
    [°C], ``dewpoint_degc`` [°C], ``relative_humidity_percent`` [%], ``pressure_pa`` [Pa],
    ``ghi_w_per_m2``, ``dni_w_per_m2``, ``dhi_w_per_m2`` [W/m², period means],
    ``sky_infrared_w_per_m2`` [W/m², the hour's mean; NaN where the file has none],
    ``wind_speed_m_s`` [m/s], ``humidity_ratio_kg_per_kg`` [kg/kg] and ``ground_temp_degc``
    [°C] (the file's monthly ground temperatures interpolated between mid-months; the
    annual-mean dry bulb if the file has none).
    """
    index = year_index(year, tz)
    offset = pd.Timedelta(hours=location.tz_offset_h)
    # Wall clock of the file's local standard time at each period start.
    start_lst = (index.tz_convert("UTC").tz_localize(None) + offset).to_numpy()
    # Hours since 1 Jan 00:00 of the typical year (non-leap calendar), at the period midpoint.
    ref = pd.Timestamp(year=year, month=1, day=1).to_datetime64()
    minutes = (start_lst - ref) / np.timedelta64(1, "m") + 15.0
    local = pd.DatetimeIndex(start_lst)
    # Leap year: 29 Feb repeats 28 Feb and every later day moves back one day.
    minutes = minutes - np.where(local.is_leap_year & (local.day_of_year > 59), 24 * 60, 0)
    hours_mid = minutes / 60.0
    n = EPW_HOURS_PER_YEAR
    # State variables: EPW row i is the instant (i + 1) h; wrap around the typical year.
    instants = np.arange(n + 2, dtype=float)  # instant j h, j = 0 … n + 1
    out: dict[str, np.ndarray] = {}
    for column in _STATE_COLUMNS:
        hourly = epw[column].to_numpy(dtype=float)
        values = np.concatenate(([hourly[-1]], hourly, [hourly[0]]))  # instants 0 … n + 1
        out[column] = np.interp(np.mod(hours_mid, n), instants, values)
    # Irradiance: hour bucket i covers [i, i + 1) h of the typical year.
    bucket = np.floor(np.mod(hours_mid, n)).astype(int)
    second_half = np.mod(hours_mid, 1.0) > 0.5
    first_share, second_share = _half_hour_shares(local.floor("h") - offset, location)
    for column in _IRRADIANCE_COLUMNS:
        share = np.where(second_half, second_share[column], first_share[column])
        out[column] = epw[column].to_numpy(dtype=float)[bucket] * share
    out["sky_infrared_w_per_m2"] = epw["sky_infrared_w_per_m2"].to_numpy(dtype=float)[bucket]
    out["humidity_ratio_kg_per_kg"] = humidity_ratio_kg_per_kg(
        out["dewpoint_degc"], out["pressure_pa"]
    )
    out["ground_temp_degc"] = _ground_temp(location, hours_mid, epw)
    return pd.DataFrame(out, index=index)


def _half_hour_shares(
    hour_start_utc: pd.DatetimeIndex, location: EpwLocation
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Factors sharing an hour's mean irradiance between its halves (see the module docstring).

    Parameters
    ----------
    hour_start_utc : (T,) tz-naive UTC start of the file's local-standard-time hour of each
        period.
    location : the site.

    Returns
    -------
    first, second : the factors of the first and second half-hour, each a dict irradiance
        column → (T,) array; the two halves' factors average to 1.
    """
    hours, inverse = np.unique(hour_start_utc.as_unit("ns").asi8, return_inverse=True)
    half = PERIOD
    starts = pd.DatetimeIndex(hours, tz="UTC")
    suns = (period_sun(starts, half, location), period_sun(starts + half, half, location))
    result: tuple[dict[str, np.ndarray], dict[str, np.ndarray]] = ({}, {})
    horizontal = [sun.mean_cos_zenith for sun in suns]
    sunlit = [sun.sunlit_fraction for sun in suns]
    for column, weights in (
        ("ghi_w_per_m2", horizontal),
        ("dhi_w_per_m2", horizontal),
        ("dni_w_per_m2", sunlit),
    ):
        total = weights[0] + weights[1]
        positive = total > 0
        for i in (0, 1):
            share = np.where(positive, 2.0 * weights[i] / np.where(positive, total, 1.0), 1.0)
            result[i][column] = share[inverse]
    return result


def _ground_temp(location: EpwLocation, hours_mid: np.ndarray, epw: pd.DataFrame) -> np.ndarray:
    if len(location.ground_temp_monthly_degc) != 12:
        return np.full(len(hours_mid), float(epw["outdoor_temp_degc"].mean()))
    days_in_month = np.array([31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31], dtype=float)
    mid_month_h = (np.cumsum(days_in_month) - days_in_month / 2.0) * 24.0
    result: np.ndarray = np.interp(
        np.mod(hours_mid, EPW_HOURS_PER_YEAR),
        mid_month_h,
        np.asarray(location.ground_temp_monthly_degc),
        period=EPW_HOURS_PER_YEAR,
    )
    return result


@functools.lru_cache(maxsize=8)
def _weather_year(path: str, year: int) -> tuple[pd.DataFrame, EpwLocation]:
    """:func:`weather_30min` of the EPW at ``path`` on ``year``, from the disk cache
    (:mod:`hvacflex.data.cache`) when this file, year and code built it before."""
    from hvacflex.data.cache import cache_key, cached_frame

    def build() -> tuple[pd.DataFrame, dict[str, Any]]:
        epw, location = read_epw(path)
        return weather_30min(epw, location, year), dataclasses.asdict(location)

    try:
        key = cache_key("weather_30min", [path], [year, TIMEZONE])
    except OSError:  # unreadable: read_epw names the file and the fix
        frame, extra = build()
    else:
        frame, extra = cached_frame(key, build)
    location = EpwLocation(
        latitude_deg=float(extra["latitude_deg"]),
        longitude_deg=float(extra["longitude_deg"]),
        tz_offset_h=float(extra["tz_offset_h"]),
        elevation_m=float(extra["elevation_m"]),
        name=str(extra["name"]),
        ground_temp_monthly_degc=tuple(float(t) for t in extra["ground_temp_monthly_degc"]),
    )
    return frame, location


def weather_on(index: pd.DatetimeIndex, path: Path) -> tuple[pd.DataFrame, EpwLocation]:
    """The 30-min weather (:func:`weather_30min`) of the EPW at ``path`` on ``index`` (tz-aware
    period starts; the typical year is mapped onto each calendar year the index touches),
    and the file's location."""
    resolved = str(path.resolve())
    local = index.tz_convert(TIMEZONE)
    years = sorted(set(local.year))
    parts = [_weather_year(resolved, y)[0] for y in years]
    location = _weather_year(resolved, years[0])[1]
    full = pd.concat(parts) if len(parts) > 1 else parts[0]
    return full.loc[local], location
