"""The weather's channels of the disturbance vector, filled from a 30-min weather frame.

One home for what a channel of kind ``outdoor_temp``, ``ground_temp``, ``solar``,
``sky_longwave`` or ``window_solar_gain`` (``building/channels.py``) is in terms of the weather:
the simulation's data (:func:`hvacflex.data.forecast.load_exogenous`), the statistical weather
forecaster (:mod:`hvacflex.data.weather_forecast`) and the BESTEST validation all call
:func:`weather_channel_values`. The schedule's channels (``internal_gain``, ``constant``) are
not weather and are left to their callers.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.building.channels import DisturbanceChannel
from hvacflex.data.solar import (
    SolarSite,
    surface_irradiance_components,
    surface_irradiance_w_per_m2,
)
from hvacflex.errors import DataError
from hvacflex.units import KELVIN_OFFSET, STEFAN_BOLTZMANN_W_PER_M2K4

WEATHER_CHANNEL_KINDS = (
    "outdoor_temp",
    "ground_temp",
    "solar",
    "sky_longwave",
    "window_solar_gain",
)
"""Channel kinds that are weather."""

HEAT_GAIN_KINDS = ("solar", "window_solar_gain")
"""Weather channels that are irradiance or a gain from it (≥ 0 where forecast)."""


def sky_longwave_w_per_m2(
    outdoor_temp_degc: np.ndarray, sky_infrared_w_per_m2: np.ndarray
) -> np.ndarray:
    """Net long-wave loss of a horizontal black body at air temperature, σT⁴ − L↓ [W/m²].

    Parameters
    ----------
    outdoor_temp_degc : (T,) dry bulb [°C].
    sky_infrared_w_per_m2 : (T,) downwelling sky long-wave radiation on a horizontal plane
        (EPW field 13) [W/m²].
    """
    emitted = STEFAN_BOLTZMANN_W_PER_M2K4 * (np.asarray(outdoor_temp_degc) + KELVIN_OFFSET) ** 4
    result: np.ndarray = emitted - np.asarray(sky_infrared_w_per_m2, dtype=np.float64)
    return result


def weather_channel_values(
    channels: Sequence[DisturbanceChannel],
    weather: pd.DataFrame,
    site: SolarSite,
    *,
    source: str | Path = "weather",
) -> dict[int, np.ndarray]:
    """The weather channels' values on the weather frame's periods.

    Parameters
    ----------
    channels : (nd,) the building's disturbance channels.
    weather : (T rows) frame of :func:`hvacflex.data.weather.weather_30min` (or
        :func:`~hvacflex.data.weather.weather_on`).
    site : its location (solar geometry).
    source : the weather file, named in errors.

    Returns
    -------
    position in ``channels`` → (T,) values in the channel's units (``channels.py``), for every
    channel of a kind in :data:`WEATHER_CHANNEL_KINDS`.

    Raises
    ------
    DataError
        if a ``sky_longwave`` channel needs the sky's infrared where the file has none.
    """
    channels = tuple(channels)
    planes = [
        (float(ch.azimuth_deg or 0.0), float(ch.tilt_deg if ch.tilt_deg is not None else 90.0))
        for ch in channels
        if ch.kind == "solar"
    ]
    solar = surface_irradiance_w_per_m2(weather, site, planes).to_numpy()
    out: dict[int, np.ndarray] = {}
    solar_i = 0
    for i, ch in enumerate(channels):
        if ch.kind in ("outdoor_temp", "ground_temp"):
            out[i] = weather[f"{ch.kind}_degc"].to_numpy(dtype=float)
        elif ch.kind == "solar":
            out[i] = solar[:, solar_i]
            solar_i += 1
        elif ch.kind == "sky_longwave":
            out[i] = sky_longwave_w_per_m2(
                weather["outdoor_temp_degc"].to_numpy(dtype=float),
                _sky_infrared(weather, source),
            )
        elif ch.kind == "window_solar_gain":
            window = ch.window
            if window is None:
                raise DataError(
                    "a window_solar_gain channel must carry its window",
                    source=source,
                    field=ch.name,
                    hint="build the channels with building.rc.build_network",
                )
            parts = surface_irradiance_components(
                weather, site, window.azimuth_deg, window.tilt_deg
            )
            out[i] = window.solar_gain_w_per_m2(
                parts.beam_w_per_m2, parts.diffuse_w_per_m2, parts.incidence_deg
            )
    return out


def _sky_infrared(weather: pd.DataFrame, source: str | Path) -> np.ndarray:
    values = weather["sky_infrared_w_per_m2"].to_numpy(dtype=float)
    missing = ~np.isfinite(values)
    if missing.any():
        first = weather.index[int(np.flatnonzero(missing)[0])]
        raise DataError(
            f"the weather file has no sky infrared for {int(missing.sum())} period(s), first "
            f"{first} (missing, non-numeric or outside 0…1500 Wh/m² in the file)",
            source=source,
            field="Horizontal Infrared Radiation Intensity (field 13)",
            hint="the building's exterior surfaces set a thermal_emissivity, so hvacflex needs "
            "the sky's long-wave radiation: use a weather file that has it, or drop "
            "thermal_emissivity from the building",
        )
    return values
