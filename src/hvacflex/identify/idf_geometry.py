"""What an EnergyPlus model says about its zones' geometry: floor areas and façades.

``identify fit --idf`` reads the IDF the trend came from for two things the trend lacks:

* each zone's **floor area** [m²] — the Zone object's ``Floor Area`` field where it is a
  number, else the summed area of the zone's floor surfaces (``Surface Type`` Floor of
  ``BuildingSurface:Detailed``, ``Floor:Detailed``, ``Floor:Adiabatic``,
  ``Floor:GroundContact``, ``Floor:Interzone``), as EnergyPlus's zone summary reports it (one
  zone, its ``Multiplier`` not applied);
* which zones share surfaces, and their areas [m²] (``Outside Boundary Condition`` Surface or
  Zone of ``BuildingSurface:Detailed``): the couplings of the fit and their bounds;
* each zone's **exterior windows and walls**: area [m²], azimuth of the outward normal
  clockwise from true north [°] and tilt from horizontal [°]
  (``FenestrationSurface:Detailed`` and ``Window`` on a base surface with ``Outdoors`` as its
  outside boundary; the base surfaces ``BuildingSurface:Detailed`` of type Wall,
  ``Wall:Detailed`` and ``Wall:Exterior``). The fit bounds each zone's wall solar apertures
  by them (:mod:`hvacflex.identify.physics`);
* when its **cooling coils** and its **supply fans** are scheduled available
  (:func:`idf_cooling_available`, :func:`idf_fan_available`): where an idle zone's air is
  fan-only (``hvacflex.identify.fit.idle_air``).

The outward normal of a polygon is Newell's normal of its vertices in the
``GlobalGeometryRules`` entry direction (counter-clockwise seen from outside by default);
with ``Relative`` coordinates the azimuth adds the ``Building`` object's North Axis and the
zone's Direction of Relative North.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.data.weather_forecast import period_of_day
from hvacflex.energyplus.idf import IdfObject, objects_of, parse_idf, read_idf
from hvacflex.energyplus.schedules import cooling_coil_available, fan_available
from hvacflex.errors import InputError

HORIZONTAL_TILT_DEG = 60.0
"""A surface tilted less than this from horizontal is no façade (a skylight, a roof) [°]."""

SIMPLE_FLOORS = {"floor:adiabatic": 2, "floor:groundcontact": 2, "floor:interzone": 2}
"""Rectangular floor objects: class → index of their zone field (length × width at the end)."""
DETAILED_FLOORS = ("floor:detailed",)
DETAILED_WALLS = ("wall:detailed",)
"""Polygon objects whose class says their type: zone field 2, boundary 4, vertex count 9."""


@dataclass(frozen=True)
class Aperture:
    """A surface of a zone's envelope: ``area_m2`` [m²], ``azimuth_deg`` of its outward
    normal clockwise from true north [°], ``tilt_deg`` from horizontal [°]."""

    area_m2: float
    azimuth_deg: float
    tilt_deg: float


@dataclass(frozen=True)
class ZoneGeometry:
    """One zone of an IDF.

    Attributes
    ----------
    name : the IDF's spelling; floor_area_m2 : its floor area [m²] (0 without floors);
    windows : its exterior windows; walls : its exterior walls (gross, windows included);
    shared_m2 : (other zone's lower-case name, area [m²]) of the surfaces it shares with
    another zone (walls, floors, ceilings whose outside is a surface of that zone), summed
    per zone.
    """

    name: str
    floor_area_m2: float
    windows: tuple[Aperture, ...] = ()
    walls: tuple[Aperture, ...] = ()
    shared_m2: tuple[tuple[str, float], ...] = ()


def _number(text: str, default: float | None = None) -> float | None:
    try:
        return float(text)
    except ValueError:
        return default


def newell_normal(vertices: np.ndarray) -> np.ndarray:
    """(3,) Newell's normal of a polygon's (n, 3) vertices, its length twice the area [m²]:
    right-handed (counter-clockwise vertices give the normal towards the viewer)."""
    following = np.roll(vertices, -1, axis=0)
    return np.array(
        [
            ((vertices[:, 1] - following[:, 1]) * (vertices[:, 2] + following[:, 2])).sum(),
            ((vertices[:, 2] - following[:, 2]) * (vertices[:, 0] + following[:, 0])).sum(),
            ((vertices[:, 0] - following[:, 0]) * (vertices[:, 1] + following[:, 1])).sum(),
        ]
    )


def aperture_of(vertices: np.ndarray, rotation_deg: float, clockwise: bool = False) -> Aperture:
    """The area, azimuth and tilt of a polygon (n, 3) [m] whose vertices run counter-clockwise
    seen from outside (``clockwise``: the other way), its coordinates turned by
    ``rotation_deg`` [°] (clockwise, to true north)."""
    normal = newell_normal(vertices) * (-1.0 if clockwise else 1.0)
    length = float(np.linalg.norm(normal))
    if length == 0.0:
        return Aperture(0.0, 0.0, 0.0)
    n = normal / length
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(n[2])))))
    azimuth = math.degrees(math.atan2(float(n[0]), float(n[1])))
    return Aperture(length / 2.0, (azimuth + rotation_deg) % 360.0, tilt)


def _vertices(obj: IdfObject, count_index: int, source: str | Path) -> np.ndarray:
    values = [_number(v) for v in obj.fields[count_index + 1 :] if v != ""]
    if any(v is None for v in values) or len(values) < 9 or len(values) % 3:
        raise InputError(
            "the surface's vertices are not numbers in threes",
            source=source,
            line=obj.line,
            field=obj.field(0),
            hint="give X,Y,Z per vertex, at least three vertices",
        )
    return np.array(values, dtype=np.float64).reshape(-1, 3)


@dataclass(frozen=True)
class _Rules:
    clockwise: bool
    relative: bool
    north_axis_deg: float
    zone_north_deg: dict[str, float]


def _rules(objects: tuple[IdfObject, ...]) -> _Rules:
    rules = objects_of(objects, "GlobalGeometryRules")
    clockwise = bool(rules) and rules[0].field(1).lower() == "clockwise"
    relative = not rules or rules[0].field(2).lower() != "world"
    building = objects_of(objects, "Building")
    north = _number(building[0].field(1), 0.0) if building else 0.0
    zones = {
        z.field(0).lower(): _number(z.field(1), 0.0) or 0.0 for z in objects_of(objects, "Zone")
    }
    return _Rules(clockwise, relative, north or 0.0, zones)


def _rotation(rules: _Rules, zone: str) -> float:
    return (
        rules.north_axis_deg + rules.zone_north_deg.get(zone.lower(), 0.0)
        if rules.relative
        else 0.0
    )


def _simple_rectangle_area(obj: IdfObject) -> float:
    length, width = _number(obj.fields[-2], 0.0), _number(obj.fields[-1], 0.0)
    return float((length or 0.0) * (width or 0.0))


def _floor_areas(objects: tuple[IdfObject, ...], source: str | Path) -> dict[str, float]:
    floors: dict[str, float] = {}
    for obj in objects:
        kind = obj.class_name.lower()
        if kind == "buildingsurface:detailed" and obj.field(1).lower() == "floor":
            zone, area = obj.field(3), aperture_of(_vertices(obj, 10, source), 0.0).area_m2
        elif kind in DETAILED_FLOORS:
            zone, area = obj.field(2), aperture_of(_vertices(obj, 9, source), 0.0).area_m2
        elif kind in SIMPLE_FLOORS:
            zone, area = obj.field(SIMPLE_FLOORS[kind]), _simple_rectangle_area(obj)
        else:
            continue
        floors[zone.lower()] = floors.get(zone.lower(), 0.0) + area
    return floors


def _exterior_walls(
    objects: tuple[IdfObject, ...], rules: _Rules, source: str | Path
) -> dict[str, tuple[str, Aperture]]:
    """Exterior base surfaces by lower-case name → (zone, aperture): every exterior
    polygon (walls and roofs: a window's base) and the rectangular ``Wall:Exterior``."""
    found: dict[str, tuple[str, Aperture]] = {}
    for obj in objects:
        kind = obj.class_name.lower()
        if kind == "buildingsurface:detailed" and obj.field(5).lower() == "outdoors":
            zone, vertices = obj.field(3), _vertices(obj, 10, source)
        elif (
            kind in (*DETAILED_WALLS, "roofceiling:detailed") and obj.field(4).lower() == "outdoors"
        ):
            zone, vertices = obj.field(2), _vertices(obj, 9, source)
        elif kind == "wall:exterior":
            zone = obj.field(2)
            azimuth, tilt = _number(obj.field(4), 0.0) or 0.0, _number(obj.field(5), 90.0)
            aperture = Aperture(
                _simple_rectangle_area(obj),
                (azimuth + _rotation(rules, zone)) % 360.0,
                90.0 if tilt is None else tilt,
            )
            found[obj.field(0).lower()] = (zone, aperture)
            continue
        else:
            continue
        aperture = aperture_of(vertices, _rotation(rules, zone), rules.clockwise)
        found[obj.field(0).lower()] = (zone, aperture)
    return found


def _shared_areas(
    objects: tuple[IdfObject, ...], source: str | Path
) -> dict[str, dict[str, float]]:
    """zone → other zone → area [m²] of the ``BuildingSurface:Detailed`` surfaces whose
    outside boundary is a surface of (or the) other zone, seen from the zone (lower case)."""
    polygons = [o for o in objects if o.is_a("BuildingSurface:Detailed")]
    zone_of = {o.field(0).lower(): o.field(3).lower() for o in polygons}
    shared: dict[str, dict[str, float]] = {}
    for obj in polygons:
        boundary, other = obj.field(5).lower(), obj.field(6).lower()
        far = zone_of.get(other) if boundary == "surface" else other if boundary == "zone" else None
        zone = obj.field(3).lower()
        if far is None or far == zone:
            continue
        area = aperture_of(_vertices(obj, 10, source), 0.0).area_m2
        shared.setdefault(zone, {})
        shared[zone][far] = shared[zone].get(far, 0.0) + area
    return shared


def _windows(
    objects: tuple[IdfObject, ...],
    bases: dict[str, tuple[str, Aperture]],
    rules: _Rules,
    source: str | Path,
) -> list[tuple[str, Aperture]]:
    """(zone, aperture) of every window (``Window`` / ``GlassDoor`` type) on an exterior
    base surface, its multiplier applied to the area."""
    found = []
    for obj in objects:
        kind = obj.class_name.lower()
        if kind == "fenestrationsurface:detailed":
            if obj.field(1).lower() not in ("window", "glassdoor"):
                continue
            base = bases.get(obj.field(3).lower())
            if base is None:
                continue
            multiplier = _number(obj.field(7), 1.0) or 1.0
            aperture = aperture_of(
                _vertices(obj, 8, source), _rotation(rules, base[0]), rules.clockwise
            )
        elif kind == "window":
            base = bases.get(obj.field(2).lower())
            if base is None:
                continue
            multiplier = _number(obj.field(4), 1.0) or 1.0
            area = _simple_rectangle_area(obj)
            aperture = Aperture(area, base[1].azimuth_deg, base[1].tilt_deg)
        else:
            continue
        found.append(
            (
                base[0],
                Aperture(aperture.area_m2 * multiplier, aperture.azimuth_deg, aperture.tilt_deg),
            )
        )
    return found


def idf_zone_geometry(path: str | Path) -> dict[str, ZoneGeometry]:
    """Every ``Zone`` of the IDF at ``path`` by its lower-case name (module docstring).

    Raises
    ------
    InputError
        for an unreadable IDF or a surface whose vertices are not numbers.
    """
    objects = parse_idf(read_idf(path), path)
    rules = _rules(objects)
    floors = _floor_areas(objects, path)
    bases = _exterior_walls(objects, rules, path)
    windows = _windows(objects, bases, rules, path)
    shared = _shared_areas(objects, path)
    zones = {}
    for zone in objects_of(objects, "Zone"):
        name = zone.field(0)
        key = name.lower()
        given = _number(zone.field(9))
        zones[key] = ZoneGeometry(
            name=name,
            floor_area_m2=float(given) if given else floors.get(key, 0.0),
            windows=tuple(a for z, a in windows if z.lower() == key),
            walls=tuple(
                a
                for z, a in bases.values()
                if z.lower() == key and a.tilt_deg >= HORIZONTAL_TILT_DEG
            ),
            shared_m2=tuple(sorted(shared.get(key, {}).items())),
        )
    return zones


def idf_floor_areas_m2(path: str | Path, zones: tuple[str, ...]) -> tuple[float, ...]:
    """(m,) the floor areas [m²] of ``zones`` (the data's names, any case) in the IDF.

    Raises
    ------
    InputError
        naming a zone the IDF lacks, or one without floor area (no floor surface and no
        ``Floor Area`` field), with the fix.
    """
    geometry = idf_zone_geometry(path)
    areas = []
    for zone in zones:
        found = geometry.get(zone.lower())
        if found is None:
            raise InputError(
                "the IDF has no such zone",
                source=path,
                field="--zones",
                value=zone,
                hint=f"the trend's zones must be the IDF's; its zones are "
                f"{[g.name for g in geometry.values()]}",
            )
        if not found.floor_area_m2 > 0:
            raise InputError(
                "the IDF gives the zone no floor area (no floor surface, no Floor Area field)",
                source=path,
                field=f"Zone {found.name}",
                hint="give the zone's floor area with --floor-area ZONE=M2",
            )
        areas.append(found.floor_area_m2)
    return tuple(areas)


def idf_cooling_available(path: str | Path, starts: pd.DatetimeIndex) -> np.ndarray | None:
    """(T,) bool: whether the IDF at ``path`` schedules some cooling coil available in each
    30-min period starting at ``starts`` (local times), or None where its coils' schedules
    cannot be read (:func:`hvacflex.energyplus.schedules.cooling_coil_available`)."""
    return _scheduled(path, starts, cooling_coil_available)


def idf_fan_available(path: str | Path, starts: pd.DatetimeIndex) -> np.ndarray | None:
    """(T,) bool: whether the IDF at ``path`` schedules some supply fan available in each
    30-min period starting at ``starts`` (local times), or None where its fans' schedules
    cannot be read (:func:`hvacflex.energyplus.schedules.fan_available`)."""
    return _scheduled(path, starts, fan_available)


def _scheduled(
    path: str | Path,
    starts: pd.DatetimeIndex,
    table_of: Callable[[tuple[IdfObject, ...], list[datetime.date]], np.ndarray | None],
) -> np.ndarray | None:
    objects = parse_idf(read_idf(path), path)
    days = sorted({stamp.date() for stamp in starts})
    table = table_of(objects, days)
    if table is None:
        return None
    row = {day: i for i, day in enumerate(days)}
    out: np.ndarray = table[[row[stamp.date()] for stamp in starts], period_of_day(starts)]
    return out
