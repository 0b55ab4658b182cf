"""What physics says a fitted zone's parameters can be: bounds, priors and typical ranges.

A zone's grey-box parameters (:data:`hvacflex.identify.greybox.ZONE_PARAMETERS`) scale with
its size, and its sun comes through the façades it has. So where the fit knows a zone's
floor area ``A`` [m²] (``--idf``, ``--floor-area``, ``--template``) each parameter is bounded
by a per-m² range (:data:`BOUNDS_PER_M2`) and pulled by a weak prior toward a typical
office value (:data:`PRIOR_PER_M2`); where it knows the zone's exterior windows and walls
(``--idf``) each wall solar aperture ``solar_wall_<o>_m2`` is bounded by what faces ``o``:

    S_o ≤ Σ_windows A_w max(cos(az_w − o), 0)
          + OPAQUE_SOLAR_SHARE · Σ_walls A_s max(cos(az_s − o), 0)

(a window's SHGC ≤ 1; an opaque wall passes on a few % of the sun it absorbs), so a façade the
zone does not face is fixed at 0, and a zone with no exterior surface at all (a core under a
plenum) gets no sun (its horizontal apertures are fixed at 0 too). Without the floor area the
generic bounds of :data:`hvacflex.identify.fit.BOUNDS` apply; without the façades the wall
apertures are free on every façade. The typical ranges (:data:`TYPICAL_PER_M2`) are the
checks' (:mod:`hvacflex.identify.checks`), narrower than the bounds. Where the IDF says which
zones share surfaces, only those couple, each coupling (and each zone's to a boundary)
bounded by the shared area × :data:`PARTITION_U_W_PER_M2K` (:func:`coupling_bounds`).

Sources of the per-m² figures: air 1.2 kJ/(m³K) × 2.4–4 m of height, with furniture and
light surfaces up to ×10 (``c_air``); a concrete slab 0.1–0.3 m at 2,000 kg/m³ × 0.9 kJ/(kg K)
≈ 180–540 kJ/(K m²) (``c_mass``); inside films 3–8 W/(m²K) over 2–4 m² of surface per m² of
floor (``ua_air_mass``); people, lights and equipment 10–60 W/m² in offices, ≤ 100 W/m²
(``occupied_gain``); windows 3–6 W/(m²K) plus infiltration (``ua_out``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hvacflex.building.identified import WALL_ORIENTATIONS
from hvacflex.building.model import OUTSIDE, Building
from hvacflex.identify.idf_geometry import Aperture, ZoneGeometry

OPAQUE_SOLAR_SHARE = 0.05
"""Share of an opaque exterior wall's area that counts as a solar aperture (its absorbed sun
reaching the air: α U / h_o ≈ 0.6 · 0.5 / 10 ≈ 0.03) [–]."""

BOUNDS_PER_M2: dict[str, tuple[float, float]] = {
    "c_air_kj_per_k": (1.0, 100.0),
    "c_mass_kj_per_k": (5.0, 2000.0),
    "ua_out_kw_per_k": (1.0e-6, 0.05),
    "ua_air_mass_kw_per_k": (1.0e-3, 0.2),
    "ua_mass_out_kw_per_k": (1.0e-7, 0.01),
    "occupied_gain_kw": (0.0, 0.1),
    "base_gain_kw": (0.0, 0.08),
}
"""Physical bounds per m² of the zone's floor [the parameter's unit per m²]: a constant heat
gain is not negative (equipment left on), an occupied gain not above 100 W/m²."""
PRIOR_PER_M2: dict[str, float] = {
    "c_air_kj_per_k": 10.0,
    "c_mass_kj_per_k": 150.0,
    "ua_out_kw_per_k": 1.0e-3,
    "ua_air_mass_kw_per_k": 0.01,
    "ua_mass_out_kw_per_k": 2.0e-4,
    "occupied_gain_kw": 0.02,
    "base_gain_kw": 0.005,
}
"""Typical office values per m² of floor: the priors' centres (and the fit's start)."""
TYPICAL_PER_M2: dict[str, tuple[float, float]] = {
    "c_air_kj_per_k": (2.0, 60.0),
    "c_mass_kj_per_k": (20.0, 1000.0),
    "ua_out_kw_per_k": (0.0, 0.02),
    "ua_air_mass_kw_per_k": (2.0e-3, 0.1),
    "ua_mass_out_kw_per_k": (0.0, 5.0e-3),
    "occupied_gain_kw": (2.0e-3, 0.06),
    "base_gain_kw": (0.0, 0.03),
}
"""The range the magnitude check calls plausible, per m² of floor."""
PARTITION_U_W_PER_M2K = (0.2, 6.0)
"""Bounds of a coupling's conductance per m² of the surfaces two zones share [W/(m²K)]: an
insulated partition with its films … a light one with doors and leaks (a return-air ceiling
of acoustic tiles is ≈ 2–5)."""
PARTITION_U_PRIOR_W_PER_M2K = 1.5
"""A coupling's prior per m² of shared surface: a stud partition or a tiled ceiling with
films [W/(m²K)]."""
SOLAR_PRIOR_SHARE = 0.3
"""A solar aperture's prior: this share of its bound (a window's SHGC × frame share) [–]."""


@dataclass(frozen=True)
class ZonePhysics:
    """What is known of a fitted zone besides its data.

    Attributes
    ----------
    floor_area_m2 : [m²], NaN when unknown.
    wall_solar_max_m2 : (4,) the largest solar aperture per wall orientation of
        :data:`WALL_ORIENTATIONS` [m²] (0: the zone does not face it), or None when the
        façades are unknown.
    horizontal_solar_max_m2 : the largest horizontal aperture [m²] (all its windows and a
        share of its opaque exterior), or None when unknown.
    """

    floor_area_m2: float = math.nan
    wall_solar_max_m2: tuple[float, ...] | None = None
    horizontal_solar_max_m2: float | None = None

    @property
    def area_known(self) -> bool:
        return math.isfinite(self.floor_area_m2) and self.floor_area_m2 > 0


def _facing_m2(apertures: tuple[Aperture, ...], azimuth_deg: float, share: float) -> float:
    return share * sum(
        a.area_m2 * max(math.cos(math.radians(a.azimuth_deg - azimuth_deg)), 0.0) for a in apertures
    )


def zone_physics(geometry: ZoneGeometry | None, floor_area_m2: float | None) -> ZonePhysics:
    """A zone's physics from its IDF geometry (None: façades unknown) and its floor area
    (None: unknown)."""
    area = math.nan if floor_area_m2 is None else float(floor_area_m2)
    if geometry is None:
        return ZonePhysics(floor_area_m2=area)
    walls = tuple(
        _facing_m2(geometry.windows, azimuth, 1.0)
        + _facing_m2(geometry.walls, azimuth, OPAQUE_SOLAR_SHARE)
        for _, azimuth in WALL_ORIENTATIONS
    )
    horizontal = sum(w.area_m2 for w in geometry.windows) + OPAQUE_SOLAR_SHARE * sum(
        w.area_m2 for w in geometry.walls
    )
    return ZonePhysics(area, tuple(round(w, 6) for w in walls), round(horizontal, 6))


def zone_bounds(
    physics: ZonePhysics, generic: dict[str, tuple[float, float]]
) -> dict[str, tuple[float, float]]:
    """Each zone parameter's (low, high) for a zone: the per-m² bounds × its area where known,
    else ``generic``; the solar apertures by its façades (module docstring), a façade it does
    not face as (0, 0): fixed."""
    bounds = dict(generic)
    if physics.area_known:
        for name, (low, high) in BOUNDS_PER_M2.items():
            bounds[name] = (low * physics.floor_area_m2, high * physics.floor_area_m2)
    if physics.wall_solar_max_m2 is not None:
        for (orientation, _), top in zip(WALL_ORIENTATIONS, physics.wall_solar_max_m2, strict=True):
            bounds[f"solar_wall_{orientation}_m2"] = (0.0, top)
    if physics.horizontal_solar_max_m2 is not None:
        for name in ("solar_air_m2", "solar_mass_m2"):
            bounds[name] = (0.0, physics.horizontal_solar_max_m2)
    return bounds


def zone_priors(
    physics: ZonePhysics, generic: dict[str, float], bounds: dict[str, tuple[float, float]]
) -> dict[str, float]:
    """Each zone parameter's prior centre: the per-m² typical value × the area where known,
    else ``generic``; a solar aperture :data:`SOLAR_PRIOR_SHARE` of its bound where the
    façades are known; always inside ``bounds``."""
    priors = dict(generic)
    if physics.area_known:
        for name, value in PRIOR_PER_M2.items():
            priors[name] = value * physics.floor_area_m2
    if physics.wall_solar_max_m2 is not None:
        for name in ("solar_air_m2", "solar_mass_m2"):
            priors[name] = 0.0
        for orientation, _ in WALL_ORIENTATIONS:
            name = f"solar_wall_{orientation}_m2"
            priors[name] = SOLAR_PRIOR_SHARE * bounds[name][1]
    return {
        name: min(max(value, bounds[name][0]), bounds[name][1]) for name, value in priors.items()
    }


def coupling_bounds(shared_m2: float) -> tuple[float, float, float]:
    """(low, high, prior) of a coupling's conductance [kW/K] between two zones (or a zone and
    a boundary) sharing ``shared_m2`` [m²] of surface (:data:`PARTITION_U_W_PER_M2K`)."""
    low, high = PARTITION_U_W_PER_M2K
    kw = shared_m2 / 1000.0
    return low * kw, high * kw, PARTITION_U_PRIOR_W_PER_M2K * kw


def building_zone_geometry(building: Building) -> dict[str, ZoneGeometry]:
    """A designed building's zones (``--template``: the user's description) as the fit sees
    an IDF's, by the data's lower-case name (``energyplus_zone``, else the zone's name): floor
    area, exterior windows and walls (area, azimuth, tilt) and the partitions' areas."""
    data_name = {z.name: (z.energyplus_zone or z.name).lower() for z in building.zones}
    zones = {}
    for zone in building.zones:
        shared: dict[str, float] = {}
        for wall in building.walls:
            if wall.zone == zone.name and wall.adjacent in data_name:
                far = data_name[wall.adjacent]
                shared[far] = shared.get(far, 0.0) + wall.area_m2
            elif wall.adjacent == zone.name and wall.zone in data_name:
                far = data_name[wall.zone]
                shared[far] = shared.get(far, 0.0) + wall.area_m2
        zones[data_name[zone.name]] = ZoneGeometry(
            name=zone.energyplus_zone or zone.name,
            floor_area_m2=zone.floor_area_m2,
            windows=tuple(
                Aperture(w.area_m2, w.azimuth_deg, w.tilt_deg)
                for w in building.windows
                if w.zone == zone.name
            ),
            walls=tuple(
                Aperture(w.area_m2, w.azimuth_deg, w.tilt_deg)
                for w in building.walls
                if w.zone == zone.name and w.adjacent == OUTSIDE and w.tilt_deg >= 60.0
            ),
            shared_m2=tuple(sorted(shared.items())),
        )
    return zones
