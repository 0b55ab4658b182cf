"""Solar geometry over periods and irradiance on tilted surfaces (transposition).

Period-averaged geometry
------------------------
Weather irradiance is a period *mean* (EPW: the energy of an hour; :func:`weather_30min
<hvacflex.data.weather.weather_30min>`: of a half-hour), so the sun's position at the
period midpoint is the wrong geometry for the hours around sunrise and sunset: at the
midpoint the sun may be below the horizon while the period has sun, or barely above it
while the period's mean beam came from a higher sun. :func:`period_sun` therefore samples
the apparent sun position at ``subsamples`` instants per period (the midpoints of equal
sub-intervals; pvlib's NREL SPA) and keeps, per period, the sunlit fraction ``f`` (share
of samples with apparent zenith < 90°), the mean of ``max(cos θz, 0)`` and the
samples themselves. Integrals over the period replace point values (Duffie & Beckman,
*Solar Engineering of Thermal Processes*, §2.14: the hourly beam ratio is a ratio of
integrals; NREL SAM takes the sun position at the midpoint of the sunlit part of sunrise
and sunset hours for the same reason).

Transposition (:func:`surface_irradiance_components`)
-----------------------------------------------------
With ``G``, ``B_n``, ``D`` the period means of GHI, DNI and DHI [W/m²] (zero-sun time
included):

* beam: the DNI while the sun is up is ``B_n / f``, so the surface receives on average
  ``B_n · mean(L · max(cos θ, 0)) / f`` (``L`` = sun up at the sample, θ the incidence
  angle on the surface);
* sky diffuse: Hay–Davies (``pvlib.irradiance.haydavies``) with the anisotropy index
  ``(B_n / f) / E₀`` and the beam ratio ``R_b = mean(L cos⁺θ) / max(mean(L cos θz),
  f · cos 85°)`` — the ratio of integrals, with the horizontal projection limited as the
  Perez (1990) sky model limits its circumsolar term, ``b = max(cos 85°, cos θz)``
  (pvlib's ``perez``; EnergyPlus's sky radiance model is Perez 1990);
  without the limit, a period whose sun stays just above the horizon divides the
  circumsolar diffuse by ≈ 0.02;
* ground-reflected: ``pvlib.irradiance.get_ground_diffuse`` with albedo :data:`ALBEDO`.

The functions take a :class:`SolarSite` (anything with latitude, longitude and elevation,
e.g. :class:`hvacflex.data.weather.EpwLocation`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pandas as pd

from hvacflex.errors import DataError

ALBEDO = 0.2
"""Ground reflectance used for façade irradiance (urban/grass ground) [-]."""

SUBSAMPLES_PER_PERIOD = 6
"""Sun positions sampled per period (5 min apart in a 30-min period)."""

CIRCUMSOLAR_MIN_COS_ZENITH = math.cos(math.radians(85.0))
"""Lower limit of the (sunlit-time mean) cos θz dividing the circumsolar diffuse [-]: the
limit of the Perez (1990) sky model's circumsolar term, b = max(cos 85°, cos θz), as in
pvlib's ``perez``."""

HORIZON_ZENITH_DEG = 90.0
"""Apparent zenith of the horizon [°]: the sun is up below it."""


class SolarSite(Protocol):
    """A site on the Earth: what the solar geometry needs."""

    @property
    def latitude_deg(self) -> float:
        """North positive [°]."""

    @property
    def longitude_deg(self) -> float:
        """East positive [°]."""

    @property
    def elevation_m(self) -> float:
        """Above sea level [m]."""

    def __hash__(self) -> int:
        """Sites key the cache of sun geometry."""


_TRANSPOSED_COLUMNS = ("dni_w_per_m2", "ghi_w_per_m2", "dhi_w_per_m2")
"""The weather columns the transposition reads (with the index: the key of its disk cache)."""


@dataclass(frozen=True)
class PeriodSun:
    """The sun over each of T periods, sampled at S instants per period.

    Attributes
    ----------
    zenith_deg : (T, S) apparent zenith at the samples [°].
    azimuth_deg : (T, S) solar azimuth at the samples, clockwise from north [°].
    sunlit_fraction : (T,) share of the period the sun is above the horizon [-].
    mean_cos_zenith : (T,) period mean of max(cos θz, 0) [-].
    dni_extra_w_per_m2 : (T,) extraterrestrial normal irradiance at the period midpoint
        [W/m²].
    """

    zenith_deg: np.ndarray
    azimuth_deg: np.ndarray
    sunlit_fraction: np.ndarray
    mean_cos_zenith: np.ndarray
    dni_extra_w_per_m2: np.ndarray

    def mean_cos_incidence(self, azimuth_deg: float, tilt_deg: float) -> np.ndarray:
        """(T,) period mean of max(cos θ, 0) on a surface while the sun is up [-] (zero-sun
        samples count as 0).

        Parameters
        ----------
        azimuth_deg : surface azimuth, clockwise from north [°].
        tilt_deg : surface tilt from horizontal [°].
        """
        import pvlib

        cos_incidence = np.asarray(
            pvlib.irradiance.aoi_projection(
                tilt_deg, azimuth_deg, self.zenith_deg, self.azimuth_deg
            ),
            dtype=float,
        )
        lit = self.zenith_deg < HORIZON_ZENITH_DEG
        result: np.ndarray = np.where(lit, np.maximum(cos_incidence, 0.0), 0.0).mean(axis=1)
        return result


def period_sun(
    starts_utc: pd.DatetimeIndex,
    length: pd.Timedelta,
    site: SolarSite,
    subsamples: int = SUBSAMPLES_PER_PERIOD,
) -> PeriodSun:
    """Sample the sun over the periods ``[start, start + length)`` (see the module docstring).

    Parameters
    ----------
    starts_utc : (T,) tz-aware period starts.
    length : period length.
    site : the site.
    subsamples : S, sun positions per period (midpoints of S equal sub-intervals).

    Returns
    -------
    :class:`PeriodSun` (read-only arrays: they may be cached).
    """
    import pvlib

    step = length / subsamples
    offsets = np.array([(j + 0.5) * step.value for j in range(subsamples)], dtype="int64")
    starts_ns = starts_utc.tz_convert("UTC").as_unit("ns").asi8
    instants = pd.DatetimeIndex((starts_ns[:, None] + offsets[None, :]).ravel(), tz="UTC")
    position = pvlib.solarposition.get_solarposition(
        instants, site.latitude_deg, site.longitude_deg, altitude=site.elevation_m
    )
    shape = (len(starts_utc), subsamples)
    zenith = position["apparent_zenith"].to_numpy(dtype=float).reshape(shape)
    azimuth = position["azimuth"].to_numpy(dtype=float).reshape(shape)
    lit = zenith < HORIZON_ZENITH_DEG
    middle = pd.DatetimeIndex(starts_ns + length.value // 2, tz="UTC")
    arrays = (
        zenith,
        azimuth,
        lit.mean(axis=1),
        np.where(lit, np.cos(np.radians(zenith)), 0.0).mean(axis=1),
        np.asarray(pvlib.irradiance.get_extra_radiation(middle.day_of_year.to_numpy()), float),
    )
    for array in arrays:
        array.flags.writeable = False
    return PeriodSun(*arrays)


@functools.lru_cache(maxsize=16)
def _period_sun_cached(
    first_ns: int, periods: int, step_ns: int, site: SolarSite, subsamples: int
) -> PeriodSun:
    """:func:`period_sun` of a regular index, cached (shared by a fleet)."""
    starts = pd.date_range(
        pd.Timestamp(first_ns, tz="UTC"), periods=periods, freq=pd.Timedelta(step_ns, unit="ns")
    )
    return period_sun(starts, pd.Timedelta(step_ns, unit="ns"), site, subsamples)


def _sun_of(index: pd.Index, site: SolarSite) -> PeriodSun:
    """:func:`period_sun` of a weather index of period starts (length: its first step)."""
    if not isinstance(index, pd.DatetimeIndex) or index.tz is None or len(index) < 2:
        raise DataError(
            "weather must be on a tz-aware index of at least two period starts",
            field="weather.index",
            value=type(index).__name__,
            hint="use the frame returned by weather_30min",
        )
    stamps = index.as_unit("ns").asi8
    step_ns = int(stamps[1] - stamps[0])
    if bool(np.all(np.diff(stamps) == step_ns)):
        return _period_sun_cached(int(stamps[0]), len(index), step_ns, site, SUBSAMPLES_PER_PERIOD)
    return period_sun(index, pd.Timedelta(step_ns, unit="ns"), site)


def surface_column_name(azimuth_deg: float, tilt_deg: float) -> str:
    """Column name of a surface's irradiance; equals the disturbance channel name."""
    return f"solar_az{azimuth_deg:g}_tilt{tilt_deg:g}_w_per_m2"


@dataclass(frozen=True)
class SurfaceIrradiance:
    """Period-mean irradiance on one surface, by component.

    Attributes
    ----------
    beam_w_per_m2 : (T,) direct beam [W/m², ≥ 0].
    diffuse_w_per_m2 : (T,) sky diffuse + ground-reflected [W/m², ≥ 0].
    incidence_deg : (T,) the beam's effective incidence angle, arccos of the sunlit-time
        mean of max(cos θ, 0) [°]; 90 where the beam misses the surface or the sun is down.
    """

    beam_w_per_m2: np.ndarray
    diffuse_w_per_m2: np.ndarray
    incidence_deg: np.ndarray

    @property
    def total_w_per_m2(self) -> np.ndarray:
        """(T,) beam + diffuse [W/m²]."""
        result: np.ndarray = self.beam_w_per_m2 + self.diffuse_w_per_m2
        return result


def _check_surface(azimuth_deg: float, tilt_deg: float) -> None:
    if not (0.0 <= tilt_deg <= 180.0) or not math.isfinite(azimuth_deg):
        raise DataError(
            "bad surface orientation",
            field="surfaces",
            value=(azimuth_deg, tilt_deg),
            hint="azimuth in degrees clockwise from north, tilt 0…180° from horizontal",
        )


def _transpose(
    sun: PeriodSun,
    weather: pd.DataFrame,
    azimuth_deg: float,
    tilt_deg: float,
    albedo: float,
) -> SurfaceIrradiance:
    """Beam, Hay–Davies sky diffuse and ground-reflected irradiance on one surface."""
    import pvlib

    _check_surface(azimuth_deg, tilt_deg)
    fraction = sun.sunlit_fraction
    up = fraction > 0.0
    safe_fraction = np.where(up, fraction, 1.0)
    dni_sunlit = np.where(up, weather["dni_w_per_m2"].to_numpy(dtype=float) / safe_fraction, 0.0)
    ghi = weather["ghi_w_per_m2"].to_numpy(dtype=float)
    dhi = weather["dhi_w_per_m2"].to_numpy(dtype=float)
    cos_incidence = sun.mean_cos_incidence(azimuth_deg, tilt_deg)  # zero-sun time included
    beam = dni_sunlit * cos_incidence
    horizontal = np.maximum(sun.mean_cos_zenith, fraction * CIRCUMSOLAR_MIN_COS_ZENITH)
    ratio = np.where(up, cos_incidence / np.where(up, horizontal, 1.0), 0.0)
    sky = pvlib.irradiance.haydavies(
        tilt_deg,
        azimuth_deg,
        dhi,
        np.minimum(dni_sunlit, sun.dni_extra_w_per_m2),  # anisotropy index ≤ 1
        sun.dni_extra_w_per_m2,
        projection_ratio=ratio,
    )
    ground = pvlib.irradiance.get_ground_diffuse(tilt_deg, ghi, albedo=albedo)
    diffuse = np.nan_to_num(np.asarray(sky, dtype=float) + np.asarray(ground, dtype=float))
    mean_cos_sunlit = np.clip(cos_incidence / safe_fraction, 0.0, 1.0)
    return SurfaceIrradiance(
        beam_w_per_m2=np.maximum(beam, 0.0),
        diffuse_w_per_m2=np.maximum(diffuse, 0.0),
        incidence_deg=np.where(up, np.degrees(np.arccos(mean_cos_sunlit)), 90.0),
    )


def surface_irradiance_components(
    weather: pd.DataFrame,
    site: SolarSite,
    azimuth_deg: float,
    tilt_deg: float,
    *,
    albedo: float = ALBEDO,
) -> SurfaceIrradiance:
    """Beam and diffuse irradiance on one surface (see the module docstring).

    Parameters
    ----------
    weather : (T rows) frame on a tz-aware index of period starts with ``ghi_w_per_m2``,
        ``dni_w_per_m2``, ``dhi_w_per_m2`` [W/m², period means] (from
        :func:`hvacflex.data.weather.weather_30min`).
    site : the site.
    azimuth_deg : surface azimuth, clockwise from north (90 = east-facing) [°].
    tilt_deg : surface tilt from horizontal (90 = wall, 0 = roof) [°].
    albedo : ground reflectance [-].

    Returns
    -------
    :class:`SurfaceIrradiance` with (T,) arrays; its total equals the column of
    :func:`surface_irradiance_w_per_m2`.
    """
    return _transpose(_sun_of(weather.index, site), weather, azimuth_deg, tilt_deg, albedo)


def surface_irradiance_w_per_m2(
    weather: pd.DataFrame,
    site: SolarSite,
    surfaces: Sequence[tuple[float, float]],
    *,
    albedo: float = ALBEDO,
) -> pd.DataFrame:
    """Total irradiance on tilted surfaces (beam + sky diffuse + ground-reflected).

    Parameters
    ----------
    weather : frame as for :func:`surface_irradiance_components` (a regular index has its
        sun geometry cached).
    site : the site.
    surfaces : (azimuth_deg, tilt_deg) per surface: azimuth clockwise from north
        (90 = east-facing, 180 = south-facing), tilt from horizontal (90 = wall, 0 = roof).
    albedo : ground reflectance [-].

    Returns
    -------
    (T, len(surfaces)) DataFrame [W/m², ≥ 0], one column per surface named
    ``solar_az{azimuth}_tilt{tilt}_w_per_m2`` (the disturbance channel names).
    """
    from hvacflex.data.cache import cache_key, cached_frame

    def build() -> tuple[pd.DataFrame, dict[str, object]]:
        sun = _sun_of(weather.index, site)
        out = {
            surface_column_name(az, tilt): _transpose(sun, weather, az, tilt, albedo).total_w_per_m2
            for az, tilt in surfaces
        }
        return pd.DataFrame(out, index=weather.index), {}

    if not isinstance(weather.index, pd.DatetimeIndex) or len(weather.index) < 2:
        return build()[0]  # _sun_of names the problem
    site_key = (site.latitude_deg, site.longitude_deg, site.elevation_m)
    columns = [weather[c].to_numpy(dtype=float) for c in _TRANSPOSED_COLUMNS]
    key = cache_key(
        "surface_irradiance",
        [],
        [site_key, tuple(surfaces), albedo, SUBSAMPLES_PER_PERIOD, str(weather.index.dtype)],
        [weather.index.asi8, *columns],
    )
    frame, _ = cached_frame(key, build)
    return frame


def decompose_ghi(
    index: pd.DatetimeIndex, ghi_w_per_m2: np.ndarray, site: SolarSite
) -> tuple[np.ndarray, np.ndarray]:
    """DNI and DHI [W/m², period means] of a GHI series alone, by the Erbs et al. (1982)
    correlation (``pvlib.irradiance.erbs``) on each period's sunlit part: the sunlit mean
    ``G / f`` at the zenith whose cosine is the sunlit-time mean ``mean(L cos θz) / f``.

    Parameters
    ----------
    index : (T,) tz-aware period starts; ghi_w_per_m2 : (T,) period-mean GHI [W/m²].
    site : the site.

    Returns
    -------
    dni, dhi : (T,) period means, zero-sun time included, so that ``DHI + (DNI / f) ·
    mean(L cos θz) = GHI`` wherever the sun is up (0 where it is not).
    """
    import pvlib

    sun = _sun_of(index, site)
    fraction = sun.sunlit_fraction
    up = (fraction > 0.0) & (sun.mean_cos_zenith > 0.0)
    safe = np.where(up, fraction, 1.0)
    cos_zenith = np.where(up, sun.mean_cos_zenith / safe, 1.0)
    ghi_sunlit = np.where(up, np.asarray(ghi_w_per_m2, dtype=float) / safe, 0.0)
    day_of_year = (index + (index[1] - index[0]) / 2).day_of_year.to_numpy()  # at the middle
    parts = pvlib.irradiance.erbs(
        ghi_sunlit, np.degrees(np.arccos(np.clip(cos_zenith, 0.0, 1.0))), day_of_year
    )
    dhi_sunlit = np.clip(np.asarray(parts["dhi"], dtype=float), 0.0, ghi_sunlit)
    dni_sunlit = (ghi_sunlit - dhi_sunlit) / np.maximum(cos_zenith, CIRCUMSOLAR_MIN_COS_ZENITH)
    dni: np.ndarray = np.where(up, dni_sunlit * fraction, 0.0)
    dhi: np.ndarray = np.where(up, dhi_sunlit * fraction, 0.0)
    return dni, dhi
