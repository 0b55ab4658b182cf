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
* Irradiances keep each hour's energy: the hour's mean is split between its two halves in
  proportion to ``max(cos θz, 0)`` at the halves' midpoints (θz the solar zenith angle), so
  the hourly mean is preserved exactly and no beam falls in a half-hour when the sun is below
  the horizon (a half-hour gets at most twice the hour's mean). Where the sun is below the
  horizon at both midpoints the hour's value is split equally.
* Humidity ratio follows from the period's dew point and pressure.

EPW files hold a typical year assembled from different years; :func:`weather_30min` maps the
calendar (month, day, hour) onto the requested ``year`` (29 February of a leap year repeats
28 February).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.errors import DataError

TIMEZONE = "Asia/Singapore"

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

# (0-based EPW field index, column name, EPW "missing" code or None)
_EPW_FIELDS: tuple[tuple[int, str, float | None], ...] = (
    (6, "outdoor_temp_degc", 99.9),
    (7, "dewpoint_degc", 99.9),
    (8, "relative_humidity_percent", 999.0),
    (9, "pressure_pa", 999999.0),
    (13, "ghi_w_per_m2", 9999.0),
    (14, "dni_w_per_m2", 9999.0),
    (15, "dhi_w_per_m2", 9999.0),
    (21, "wind_speed_m_s", 999.0),
)
_STATE_COLUMNS = (
    "outdoor_temp_degc",
    "dewpoint_degc",
    "relative_humidity_percent",
    "pressure_pa",
    "wind_speed_m_s",
)
_IRRADIANCE_COLUMNS = ("ghi_w_per_m2", "dni_w_per_m2", "dhi_w_per_m2")

ALBEDO = 0.2
"""Ground reflectance used for façade irradiance (urban/grass ground) [-]."""

SKY_DIFFUSE_MODEL = "haydavies"
"""pvlib sky-diffuse transposition model (anisotropic, needs extraterrestrial DNI)."""

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


def _bad_header(path: Path, line: int, message: str, value: object) -> DataError:
    return DataError(
        message,
        source=path,
        line=line,
        value=value,
        hint=f"an EPW file starts with 8 header lines: {', '.join(EPW_HEADER_KEYWORDS)}",
    )


def _parse_header(path: Path, lines: list[str]) -> EpwLocation:
    if len(lines) < len(EPW_HEADER_KEYWORDS):
        raise _bad_header(path, len(lines) + 1, "truncated EPW header", len(lines))
    for i, keyword in enumerate(EPW_HEADER_KEYWORDS):
        if not lines[i].upper().startswith(keyword):
            raise _bad_header(path, i + 1, f"bad EPW header: expected '{keyword}'", lines[i][:40])
    loc = lines[0].split(",")
    try:
        latitude, longitude, tz_offset, elevation = (float(v) for v in loc[6:10])
    except ValueError:
        raise _bad_header(
            path, 1, "bad EPW LOCATION line: latitude, longitude, time zone, elevation", loc[6:10]
        ) from None
    if len(loc) < 10 or not (-90 <= latitude <= 90 and -180 <= longitude <= 180):
        raise _bad_header(path, 1, "bad EPW LOCATION line", lines[0][:80])
    ground: tuple[float, ...] = ()
    g = lines[3].split(",")
    if len(g) >= 18 and int(float(g[1] or 0)) >= 1:
        try:
            ground = tuple(float(v) for v in g[6:18])
        except ValueError:
            ground = ()
    name = loc[1].strip() or path.stem
    return EpwLocation(latitude, longitude, tz_offset, elevation, name, ground)


@functools.lru_cache(maxsize=4)
def _read_epw_cached(path_str: str) -> tuple[pd.DataFrame, EpwLocation]:
    path = Path(path_str)
    try:
        text = path.read_text(encoding="latin-1")
    except FileNotFoundError:
        raise DataError(
            "weather file not found", source=path, hint="give the path to an .epw file"
        ) from None
    lines = text.splitlines()
    n_header = len(EPW_HEADER_KEYWORDS)
    location = _parse_header(path, lines[:n_header])
    data_lines = lines[n_header:]
    while data_lines and not data_lines[-1].strip():
        data_lines.pop()
    rows = [ln.split(",") for ln in data_lines]
    needed = max(i for i, _, _ in _EPW_FIELDS) + 1
    for i, row in enumerate(rows):
        if len(row) < needed:
            raise DataError(
                f"EPW data row has {len(row)} fields, at least {needed} are needed",
                source=path,
                line=n_header + i + 1,
                value=data_lines[i][:60],
                hint="the file looks truncated or damaged; re-download it",
            )
    if len(rows) not in (EPW_HOURS_PER_YEAR, EPW_HOURS_PER_YEAR + 24):
        raise DataError(
            f"EPW file has {len(rows)} hourly rows, expected {EPW_HOURS_PER_YEAR}",
            source=path,
            line=n_header + len(rows),
            value=len(rows),
            hint="the file looks truncated; hvacflex needs a whole year of hourly rows",
        )
    columns: dict[str, np.ndarray] = {}
    for index, name in ((0, "source_year"), (1, "month"), (2, "day"), (3, "hour")):
        columns[name] = _numeric_field(path, rows, index, name, n_header, None).astype(int)
    for index, name, missing in _EPW_FIELDS:
        columns[name] = _numeric_field(path, rows, index, name, n_header, missing)
    frame = pd.DataFrame(columns)
    leap = (frame["month"] == 2) & (frame["day"] == 29)
    frame = frame.loc[~leap].reset_index(drop=True)
    bad_hour = ~frame["hour"].between(1, 24)
    if bad_hour.any() or len(frame) != EPW_HOURS_PER_YEAR:
        i = int(np.flatnonzero(bad_hour.to_numpy())[0]) if bad_hour.any() else 0
        raise DataError(
            "EPW hours must run 1…24 over 365 days",
            source=path,
            line=n_header + i + 1,
            field="hour",
            value=int(frame["hour"].iloc[i]),
            hint="the file is not a standard hourly EPW",
        )
    return frame, location


def _numeric_field(
    path: Path, rows: list[list[str]], index: int, name: str, n_header: int, missing: float | None
) -> np.ndarray:
    values = pd.to_numeric(pd.Series([r[index] for r in rows]).str.strip(), errors="coerce")
    array = values.to_numpy(dtype=float)
    bad = np.isnan(array)
    if missing is not None:
        bad |= array >= missing
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise DataError(
            f"missing or non-numeric EPW field ({int(bad.sum())} row(s))",
            source=path,
            line=n_header + i + 1,
            field=f"{name} (field {index})",
            value=rows[i][index],
            hint="hvacflex needs dry bulb, dew point, RH, pressure, GHI, DNI, DHI and wind in "
            "every row; fill the gaps (e.g. with the Elements or a weather converter)",
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
        (hour means [W/m²]) and ``wind_speed_m_s`` [m/s]. A 29 February is dropped.
    location : :class:`EpwLocation`.

    Raises
    ------
    DataError
        for a bad header, a truncated file, or a missing / non-numeric field (with line).
    """
    frame, location = _read_epw_cached(str(Path(path).resolve()))
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
    t = np.asarray(temp_degc, dtype=float) + 273.15
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


def _cos_zenith(times_utc: pd.DatetimeIndex, location: EpwLocation) -> np.ndarray:
    """max(cos θz, 0) at the given instants (pvlib solar position, apparent zenith)."""
    import pvlib

    position = pvlib.solarposition.get_solarposition(
        times_utc, location.latitude_deg, location.longitude_deg, altitude=location.elevation_m
    )
    zenith = np.asarray(position["apparent_zenith"], dtype=float)
    result: np.ndarray = np.maximum(np.cos(np.radians(zenith)), 0.0)
    return result


def year_index(year: int, tz: str = TIMEZONE) -> pd.DatetimeIndex:
    """All 30-min period starts of ``year`` in ``tz`` (17,520 or 17,568 periods)."""
    return pd.date_range(
        pd.Timestamp(year=year, month=1, day=1, tz=tz),
        pd.Timestamp(year=year + 1, month=1, day=1, tz=tz),
        freq="30min",
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
    second_half = (np.mod(hours_mid, 1.0) > 0.5).astype(int)
    # Solar geometry at both half-hour midpoints of each hour bucket (UTC instants).
    hour_start_utc = local.floor("h") - offset  # start of the period's LST hour, in UTC
    first_mid = (hour_start_utc + pd.Timedelta(minutes=15)).tz_localize("UTC")
    second_mid = (hour_start_utc + pd.Timedelta(minutes=45)).tz_localize("UTC")
    w1 = _cos_zenith(first_mid, location)
    w2 = _cos_zenith(second_mid, location)
    total = w1 + w2
    mine = np.where(second_half == 1, w2, w1)
    factor = np.where(total > 0, 2.0 * mine / np.where(total > 0, total, 1.0), 1.0)
    for column in _IRRADIANCE_COLUMNS:
        hourly = epw[column].to_numpy(dtype=float)
        out[column] = hourly[bucket] * factor
    out["humidity_ratio_kg_per_kg"] = humidity_ratio_kg_per_kg(
        out["dewpoint_degc"], out["pressure_pa"]
    )
    out["ground_temp_degc"] = _ground_temp(location, hours_mid, epw)
    return pd.DataFrame(out, index=index)


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


def surface_column_name(azimuth_deg: float, tilt_deg: float) -> str:
    """Column name of a surface's irradiance; equals the disturbance channel name."""
    return f"solar_az{azimuth_deg:g}_tilt{tilt_deg:g}_w_per_m2"


def surface_irradiance_w_per_m2(
    weather: pd.DataFrame,
    location: EpwLocation,
    surfaces: Sequence[tuple[float, float]],
    *,
    albedo: float = ALBEDO,
    model: str = SKY_DIFFUSE_MODEL,
) -> pd.DataFrame:
    """Total irradiance on tilted surfaces (beam + sky diffuse + ground-reflected).

    Solar position (pvlib, apparent zenith) is taken at each period's midpoint; the
    transposition is ``pvlib.irradiance.get_total_irradiance`` with the ``model`` sky-diffuse
    model, extraterrestrial DNI and ground ``albedo``. DNI is set to zero while the sun is
    below the horizon at the midpoint.

    Parameters
    ----------
    weather : frame on a regular tz-aware index of period starts with ``ghi_w_per_m2``,
        ``dni_w_per_m2``, ``dhi_w_per_m2`` [W/m², period means] (from :func:`weather_30min`).
    location : the site.
    surfaces : (azimuth_deg, tilt_deg) per surface: azimuth clockwise from north
        (90 = east-facing, 180 = south-facing), tilt from horizontal (90 = wall, 0 = roof).

    Returns
    -------
    (T, len(surfaces)) DataFrame [W/m², ≥ 0], one column per surface named
    ``solar_az{azimuth}_tilt{tilt}_w_per_m2`` (the disturbance channel names).
    """
    import pvlib

    index = weather.index
    if not isinstance(index, pd.DatetimeIndex) or index.tz is None or len(index) < 2:
        raise DataError(
            "weather must be on a tz-aware index of at least two period starts",
            field="weather.index",
            value=type(index).__name__,
            hint="use the frame returned by weather_30min",
        )
    step = index[1] - index[0]
    mid = index + step / 2
    position = pvlib.solarposition.get_solarposition(
        mid, location.latitude_deg, location.longitude_deg, altitude=location.elevation_m
    )
    zenith = position["apparent_zenith"].to_numpy()
    azimuth = position["azimuth"].to_numpy()
    dni = np.where(zenith < 90.0, weather["dni_w_per_m2"].to_numpy(dtype=float), 0.0)
    ghi = weather["ghi_w_per_m2"].to_numpy(dtype=float)
    dhi = weather["dhi_w_per_m2"].to_numpy(dtype=float)
    dni_extra = pvlib.irradiance.get_extra_radiation(mid).to_numpy()
    airmass = pvlib.atmosphere.get_relative_airmass(zenith)
    out: dict[str, np.ndarray] = {}
    for surface_azimuth, surface_tilt in surfaces:
        if not (0.0 <= surface_tilt <= 180.0) or not math.isfinite(surface_azimuth):
            raise DataError(
                "bad surface orientation",
                field="surfaces",
                value=(surface_azimuth, surface_tilt),
                hint="azimuth in degrees clockwise from north, tilt 0…180° from horizontal",
            )
        total = pvlib.irradiance.get_total_irradiance(
            surface_tilt,
            surface_azimuth,
            zenith,
            azimuth,
            dni,
            ghi,
            dhi,
            dni_extra=dni_extra,
            airmass=airmass,
            albedo=albedo,
            model=model,
        )
        poa = np.nan_to_num(np.asarray(total["poa_global"], dtype=float), nan=0.0)
        out[surface_column_name(surface_azimuth, surface_tilt)] = np.maximum(poa, 0.0)
    return pd.DataFrame(out, index=index)
