"""The disturbance vector ``d`` and the meaning of each of its channels.

The building model (``rc.py``) decides which channels a building has and in which order;
the data layer (``data/forecast.py``) fills them from weather, solar geometry and schedules.
This module is the contract between the two.

Order (fixed): ``[outdoor temperature, solar per surface orientation (in the order the
building lists them), internal gains per zone (zone order), ground temperature (only if a
construction touches ground), sky long-wave (only if an exterior surface sets a
thermal emissivity), solar gain per angle-dependent window (window order), constant (only in
a building identified from data: its fitted constant gains)]``. The last two
were added for the BESTEST validation; buildings without them (office5, room1) keep exactly
the original vector.

Units per kind:

* ``outdoor_temp``  — dry-bulb outdoor air temperature [°C]
* ``solar``         — total irradiance incident on a plane of the given azimuth and tilt [W/m²]
  (beam + sky diffuse + ground-reflected; azimuth clockwise from north, 180° = south-facing;
  tilt from horizontal, 90° = vertical wall, 0° = roof)
* ``internal_gain`` — sensible internal heat gain of one zone (people + lighting + plugs) [W]
* ``ground_temp``   — ground temperature below the slab [°C]
* ``sky_longwave``  — net long-wave loss of a horizontal black surface at outdoor air
  temperature to the sky, ``σ (T_out + 273.15)⁴ − L↓`` with ``L↓`` the downwelling
  (horizontal infrared) sky radiation, EPW field 13 [W/m², ≥ 0 in practice]. A surface
  of emissivity ε and tilt β loses ``ε (1 + cos β)/2`` times it (the part of its view that
  is ground is taken at air temperature).
* ``window_solar_gain`` — solar heat gain per m² of one window whose SHGC depends on the
  incidence angle (``Window.shgc_normal`` set), ``Window.solar_gain_w_per_m2`` of the beam
  and diffuse irradiance on its plane [W/m²]. Such a window uses this channel instead of
  the plane's ``solar`` channel; the channel carries the window (its plane and optics), so
  the data layer fills it from the weather alone. An uncertainty box treats it as ``solar``
  (:attr:`DisturbanceChannel.box_kind`).
* ``constant``      — 1 at every period [-]: carries the fitted constant heat gains of an
  identified building (:mod:`hvacflex.building.identified`); never uncertain.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from hvacflex.building.model import Window

ChannelKind = Literal[
    "outdoor_temp",
    "solar",
    "internal_gain",
    "ground_temp",
    "sky_longwave",
    "window_solar_gain",
    "constant",
]

CHANNEL_UNITS: dict[str, str] = {
    "outdoor_temp": "degC",
    "solar": "W/m2",
    "internal_gain": "W",
    "ground_temp": "degC",
    "sky_longwave": "W/m2",
    "window_solar_gain": "W/m2",
    "constant": "1",
}


@dataclass(frozen=True)
class DisturbanceChannel:
    """One entry of the disturbance vector ``d``.

    Attributes
    ----------
    name : unique, e.g. ``"outdoor_temp_degc"``, ``"solar_az180_tilt90_w_per_m2"``,
        ``"internal_gain_core_w"``, ``"ground_temp_degc"``.
    kind : what it is (see the module docstring for units).
    azimuth_deg, tilt_deg : orientation of the irradiated plane (``solar`` only).
    zone : zone name (``internal_gain``) or window name (``window_solar_gain``).
    window : the window (``window_solar_gain`` only): its plane and angle-dependent SHGC.
    """

    name: str
    kind: ChannelKind
    azimuth_deg: float | None = None
    tilt_deg: float | None = None
    zone: str | None = None
    window: Window | None = None

    @property
    def unit(self) -> str:
        return CHANNEL_UNITS[self.kind]

    @property
    def box_kind(self) -> str:
        """The kind an uncertainty box sizes this channel by: a window's solar gain is
        ``solar``, every other channel its own kind."""
        return "solar" if self.kind == "window_solar_gain" else self.kind


def outdoor_temp_channel() -> DisturbanceChannel:
    return DisturbanceChannel("outdoor_temp_degc", "outdoor_temp")


def solar_channel(azimuth_deg: float, tilt_deg: float) -> DisturbanceChannel:
    name = f"solar_az{azimuth_deg:g}_tilt{tilt_deg:g}_w_per_m2"
    return DisturbanceChannel(name, "solar", azimuth_deg=azimuth_deg, tilt_deg=tilt_deg)


def internal_gain_channel(zone: str) -> DisturbanceChannel:
    return DisturbanceChannel(f"internal_gain_{zone}_w", "internal_gain", zone=zone)


def ground_temp_channel() -> DisturbanceChannel:
    return DisturbanceChannel("ground_temp_degc", "ground_temp")


def sky_longwave_channel() -> DisturbanceChannel:
    return DisturbanceChannel("sky_longwave_w_per_m2", "sky_longwave")


def window_solar_gain_channel(window: Window) -> DisturbanceChannel:
    return DisturbanceChannel(
        f"window_solar_gain_{window.name}_w_per_m2",
        "window_solar_gain",
        zone=window.name,
        window=window,
    )


def constant_channel() -> DisturbanceChannel:
    return DisturbanceChannel("constant", "constant")
