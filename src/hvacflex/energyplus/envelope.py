"""The envelope of a hvacflex building as EnergyPlus objects: constructions, zones, surfaces.

The IDF formatter :func:`idf_object` and the part of :func:`hvacflex.energyplus.export.export_idf`
that writes materials, constructions, zones, walls (with their mirrors across partitions) and
windows. The mapping and its approximations are stated in :mod:`hvacflex.energyplus.export`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from hvacflex.building.model import (
    ADIABATIC,
    DEFAULT_INSIDE_FILM_W_PER_M2K,
    GROUND,
    OUTSIDE,
    Building,
    Construction,
    Layer,
    Wall,
    Window,
)
from hvacflex.errors import InputError
from hvacflex.units import STEFAN_BOLTZMANN_W_PER_M2K4

DEFAULT_THERMAL_ABSORPTANCE = 0.9
"""Long-wave emissivity of a surface whose wall gives none [-] (EnergyPlus's default)."""

VERTICAL_TILT_RANGE_DEG = (60.0, 120.0)
"""Tilts [°] of surfaces written as ``Wall``; below: roof or ceiling, above: floor."""

SURFACE_GAP_M = 1.0
"""Gap between placeholder surfaces placed side by side [m]."""

MIN_SPECIFIC_HEAT_J_PER_KGK = 100.0
"""EnergyPlus's lowest accepted specific heat of a ``Material`` [J/(kg K)]."""

REFERENCE_SPECIFIC_HEAT_J_PER_KGK = 1000.0
"""Specific heat written for a layer given as a heat capacity only [J/(kg K)]."""

NO_LONGWAVE_ABSORPTANCE = 1e-4
"""Thermal absorptance written where hvacflex's films stand in for EnergyPlus's long-wave
exchange (``films=True``): EnergyPlus needs one above 0, and at 1e-4 a face exchanges
< 0.1 % of what it does at 0.9."""

SIMPLE_GLAZING_EMISSIVITY = 0.84
"""Long-wave emissivity of both faces of EnergyPlus's ``WindowMaterial:SimpleGlazingSystem``
[-] (fixed by EnergyPlus; no input changes it)."""

FILM_REFERENCE_TEMP_K = 298.15
"""Temperature at which a combined film is split into its convective and linearised
long-wave parts, 4 ε σ T³ [K] (25 °C)."""

Vertex = tuple[float, float, float]


# ---- formatting ---------------------------------------------------------------------------


def _field(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.10g}"
    return str(value)


def idf_object(kind: str, *fields: object) -> str:
    """One IDF object: ``kind,`` then one field per line, the last ending in ``;``.

    ``None`` is an empty field (EnergyPlus's default); floats keep 10 significant digits.
    """
    values = [_field(v) for v in fields]
    body = ",\n".join(f"  {v}" for v in values)
    return f"{kind},\n{body};"


# ---- constructions ------------------------------------------------------------------------


@dataclass(frozen=True)
class ConstructionVariant:
    """A hvacflex construction as EnergyPlus sees it on one kind of surface.

    Attributes
    ----------
    construction : the hvacflex construction.
    solar_absorptance, thermal_absorptance : of the outer layer's outside face [-]
        (``None``: EnergyPlus's defaults, for surfaces not facing the outdoors).
    reversed : the layers inside → outside (the mirror face of a partition).
    mirrored : the layers mirrored about the far face, inside → outside → inside (a wall on
        an adiabatic plane of symmetry; see :func:`wall_variant`).
    """

    construction: Construction
    solar_absorptance: float | None = None
    thermal_absorptance: float | None = None
    reversed: bool = False
    mirrored: bool = False

    @property
    def name(self) -> str:
        if self.mirrored:
            return f"{self.construction.name} mirrored"
        if self.reversed:
            return f"{self.construction.name} reversed"
        if self.solar_absorptance is None:
            return self.construction.name
        return f"{self.construction.name} a{self.solar_absorptance:g} e{self.thermal_absorptance:g}"

    def material_names(self) -> list[str]:
        names = [
            f"{self.construction.name} layer {i + 1}" for i in range(len(self.construction.layers))
        ]
        if self.solar_absorptance is not None:
            names[0] = f"{names[0]} a{self.solar_absorptance:g} e{self.thermal_absorptance:g}"
        if self.mirrored:
            return names[::-1] + names
        return names[::-1] if self.reversed else names


def wall_variant(wall: Wall, *, films: bool = False) -> ConstructionVariant:
    """The construction of ``wall`` with its outside face's absorptances where it faces out.

    A wall on an adiabatic plane (hvacflex: no heat crosses the far face) is written mirrored
    about that plane. EnergyPlus's ``Adiabatic`` boundary does not make the far face's heat
    flux zero: it sets the far face's temperature to the inside face's and leaves out of the
    zone's balance the heat that crosses the far face (measured on office5's half slabs: on
    a free-floating weekend the far face released 19 kW the zone never saw, 6 times what
    the inside face gave it). With the symmetric construction both faces see the same
    temperature and carry the same flux, so the mid-plane is adiabatic and the zone sees
    exactly the half construction hvacflex describes.

    With ``films`` (hvacflex's surface coefficients, :func:`check_films`) an outside face
    exchanges long-wave only where the building says it does (``thermal_emissivity``).
    """
    if wall.adjacent == ADIABATIC:
        return ConstructionVariant(wall.construction, mirrored=True)
    if not wall.is_exterior:
        return ConstructionVariant(wall.construction)
    emissivity = wall.thermal_emissivity
    if emissivity is None:
        emissivity = NO_LONGWAVE_ABSORPTANCE if films else DEFAULT_THERMAL_ABSORPTANCE
    return ConstructionVariant(wall.construction, wall.solar_absorptance, emissivity)


def _material(name: str, layer: Layer, solar: float | None, thermal: float | None) -> str:
    heat_capacity_j_per_m3k = layer.density_kg_per_m3 * layer.specific_heat_j_per_kgk
    if heat_capacity_j_per_m3k <= 0.0:
        return idf_object(
            "Material:NoMass", name, "MediumRough", layer.r_value_m2k_per_w, thermal, solar
        )
    density, specific_heat = layer.density_kg_per_m3, layer.specific_heat_j_per_kgk
    if specific_heat < MIN_SPECIFIC_HEAT_J_PER_KGK:
        specific_heat = REFERENCE_SPECIFIC_HEAT_J_PER_KGK
        density = heat_capacity_j_per_m3k / specific_heat
    return idf_object(
        "Material", name, "MediumRough", layer.thickness_m, layer.conductivity_w_per_mk,
        density, specific_heat, thermal, solar,
    )  # fmt: skip


def _variants(b: Building, films: bool) -> list[ConstructionVariant]:
    found: dict[str, ConstructionVariant] = {}
    for wall in b.walls:
        variant = wall_variant(wall, films=films)
        found.setdefault(variant.name, variant)
        if wall.adjacent not in (OUTSIDE, GROUND, ADIABATIC):
            mirror = ConstructionVariant(wall.construction, reversed=True)
            found.setdefault(mirror.name, mirror)
    return list(found.values())


def glazing_name(window: Window) -> str:
    """Name of the window construction (one per distinct U-value and SHGC)."""
    return f"glazing U{window.u_value_w_per_m2k:g} SHGC{_window_shgc(window):g}"


def _window_shgc(window: Window) -> float:
    return window.shgc_normal if window.shgc_normal is not None else window.shgc


def construction_objects(b: Building, *, films: bool = False) -> list[str]:
    """Materials, constructions and window glazings of ``b``; with ``films`` every face not
    facing the outdoors exchanges no long-wave (:data:`NO_LONGWAVE_ABSORPTANCE`)."""
    inner = NO_LONGWAVE_ABSORPTANCE if films else None
    objects: list[str] = []
    materials: dict[str, str] = {}
    for variant in _variants(b, films):
        names = variant.material_names()
        layers = variant.construction.layers
        for i, layer in enumerate(layers):
            name = f"{variant.construction.name} layer {i + 1}"
            outer = i == 0 and variant.solar_absorptance is not None
            if outer:
                name = names[0]
            if name not in materials:
                materials[name] = _material(
                    name, layer,
                    variant.solar_absorptance if outer else None,
                    variant.thermal_absorptance if outer else inner,
                )  # fmt: skip
        objects.append(idf_object("Construction", variant.name, *names))
    glazing: dict[str, Window] = {}
    for window in b.windows:
        glazing.setdefault(glazing_name(window), window)
    for name, window in glazing.items():
        objects.append(
            idf_object("WindowMaterial:SimpleGlazingSystem", f"{name} glass",
                       window.u_value_w_per_m2k, _window_shgc(window))
        )  # fmt: skip
        objects.append(idf_object("Construction", name, f"{name} glass"))
    return list(materials.values()) + objects


# ---- zones and surfaces -------------------------------------------------------------------


def zone_objects(b: Building) -> list[str]:
    objects = []
    for zone in b.zones:
        objects.append(
            idf_object("Zone", zone.name, 0.0, 0.0, 0.0, 0.0, 1, 1, zone.height_m,
                       zone.volume_m3, zone.floor_area_m2)
        )  # fmt: skip
        if zone.capacitance_multiplier != 1.0:
            objects.append(
                idf_object("ZoneCapacitanceMultiplier:ResearchSpecial",
                           f"{zone.name} capacitance", zone.name, zone.capacitance_multiplier,
                           1.0, 1.0, 1.0)
            )  # fmt: skip
    return objects


def surface_type(tilt_deg: float, exterior: bool) -> str:
    """EnergyPlus surface type of a surface tilted ``tilt_deg`` from horizontal."""
    low, high = VERTICAL_TILT_RANGE_DEG
    if tilt_deg < low:
        return "Roof" if exterior else "Ceiling"
    if tilt_deg > high:
        return "Floor"
    return "Wall"


def rectangle(
    area_m2: float, azimuth_deg: float, tilt_deg: float, height_m: float, origin: Vertex
) -> tuple[Vertex, Vertex, Vertex, Vertex]:
    """Corners of a rectangle of ``area_m2`` whose outward normal has the given orientation.

    Parameters
    ----------
    area_m2 : [m²]
    azimuth_deg : clockwise from north (y axis; x is east) [°].
    tilt_deg : from horizontal, 0 facing up [°].
    height_m : side length up the slope for walls (tilts within
        :data:`VERTICAL_TILT_RANGE_DEG`); other surfaces are squares.
    origin : lower-left corner [m].

    Returns
    -------
    (4,) vertices [m]: upper-left, lower-left, lower-right, upper-right as seen from outside
    (counter-clockwise, so the right-hand normal points out).
    """
    azimuth, tilt = math.radians(azimuth_deg), math.radians(tilt_deg)
    normal = np.array(
        [math.sin(tilt) * math.sin(azimuth), math.sin(tilt) * math.cos(azimuth), math.cos(tilt)]
    )
    right = np.array([-normal[1], normal[0], 0.0])
    norm = float(np.linalg.norm(right))
    right = right / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])
    up = np.cross(normal, right)
    low, high = VERTICAL_TILT_RANGE_DEG
    side_up = height_m if low <= tilt_deg <= high else math.sqrt(area_m2)
    side_right = area_m2 / side_up
    o = np.asarray(origin, dtype=float)
    corners = (o + side_up * up, o, o + side_right * right, o + side_right * right + side_up * up)
    return tuple(tuple(float(v) for v in c) for c in corners)  # type: ignore[return-value]


def _scaled(corners: Sequence[Vertex], area_ratio: float) -> list[Vertex]:
    """``corners`` shrunk about their centre to ``area_ratio`` of the area."""
    points = np.asarray(corners, dtype=float)
    centre = points.mean(axis=0)
    scaled = centre + math.sqrt(area_ratio) * (points - centre)
    return [tuple(float(v) for v in p) for p in scaled]  # type: ignore[misc]


def _flat(corners: Iterable[Vertex]) -> list[float]:
    return [value for corner in corners for value in corner]


def hosted_windows(b: Building) -> dict[str, list[Window]]:
    """Windows by the name of the exterior wall that holds them (same zone, azimuth, tilt).

    Raises
    ------
    InputError
        a window whose zone has no exterior wall facing the same way.
    """
    hosts: dict[str, list[Window]] = {w.name: [] for w in b.walls}
    for window in b.windows:
        host = next(
            (
                w for w in b.walls
                if w.is_exterior and w.zone == window.zone
                and math.isclose(w.azimuth_deg, window.azimuth_deg)
                and math.isclose(w.tilt_deg, window.tilt_deg)
            ),
            None,
        )  # fmt: skip
        if host is None:
            raise InputError(
                "a window needs an exterior wall of its zone facing the same way to sit in",
                source=b.source_path,
                field=f"windows.{window.name}",
                value=(window.zone, window.azimuth_deg, window.tilt_deg),
                hint="add an exterior wall with the window's zone, azimuth_deg and tilt_deg",
            )
        hosts[host.name].append(window)
    return hosts


def _surface(
    name: str, kind: str, construction: str, zone: str, boundary: tuple[str, str | None],
    exposed: bool, corners: Sequence[Vertex],
) -> str:  # fmt: skip
    sun, wind = ("SunExposed", "WindExposed") if exposed else ("NoSun", "NoWind")
    return idf_object(
        "BuildingSurface:Detailed", name, kind, construction, zone, None, boundary[0],
        boundary[1], sun, wind, "autocalculate", len(corners), *_flat(corners),
    )  # fmt: skip


def _boundary(wall: Wall) -> tuple[str, str | None]:
    if wall.adjacent == OUTSIDE:
        return ("Outdoors", None)
    if wall.adjacent == GROUND:
        return ("Ground", None)
    if wall.adjacent == ADIABATIC:
        return ("Adiabatic", None)
    return ("Surface", mirror_name(wall))


def mirror_name(wall: Wall) -> str:
    """Name of the face of a partition ``wall`` seen from its adjacent zone."""
    return f"{wall.name} reverse"


def placed_orientations(b: Building) -> dict[str, tuple[float, float]]:
    """(azimuth_deg, tilt_deg) of each wall in the export, by wall name.

    Exterior walls keep the file's. A wall that does not face the outdoors has no orientation
    in hvacflex's equations, but EnergyPlus needs one for its interior radiation exchange and
    for where beam solar lands: a vertical one faces away from its zone's largest exterior
    wall (its azimuth + 180°; as given when the zone has none), and in a zone without a floor
    its largest adiabatic or ground surface becomes the floor (tilt 180°).
    """
    placed = {w.name: (w.azimuth_deg, w.tilt_deg) for w in b.walls}
    low, high = VERTICAL_TILT_RANGE_DEG
    for zone in b.zones:
        walls = [w for w in b.walls if w.zone == zone.name]
        exterior = [w for w in walls if w.is_exterior and low <= w.tilt_deg <= high]
        facade = max(exterior, key=lambda w: w.area_m2, default=None)
        for w in walls:
            if not w.is_exterior and facade is not None and low <= w.tilt_deg <= high:
                placed[w.name] = ((facade.azimuth_deg + 180.0) % 360.0, w.tilt_deg)
        if any(w.tilt_deg > high for w in walls):
            continue
        boundary = [w for w in walls if w.adjacent in (ADIABATIC, GROUND)]
        floor = max(boundary, key=lambda w: w.area_m2, default=None)
        if floor is not None:
            placed[floor.name] = (0.0, 180.0)
    return placed


def surface_objects(b: Building, *, films: bool = False) -> list[str]:
    """Walls (with their mirrors across partitions) and windows of ``b`` as placeholder
    rectangles, their lower edges at the building's ``height_above_ground_m`` (EnergyPlus
    takes the wind speed, hence the outside films, and the air temperature at each surface's
    centroid height); with ``films`` each surface is followed by its convection coefficients
    (hvacflex's films, :func:`check_films`)."""
    hosts = hosted_windows(b)
    orientation = placed_orientations(b)
    heights = {z.name: z.height_m for z in b.zones}
    objects: list[str] = []
    x_m = 0.0
    for wall in b.walls:
        windows = hosts[wall.name]
        glazed = sum(w.area_m2 for w in windows)
        pieces: list[tuple[str, float, Window | None]] = [(wall.name, wall.area_m2, None)]
        if windows:
            pieces = [
                (wall.name if len(windows) == 1 else f"{wall.name} {i + 1}",
                 w.area_m2 + wall.area_m2 * w.area_m2 / glazed, w)
                for i, w in enumerate(windows)
            ]  # fmt: skip
        azimuth_deg, tilt_deg = orientation[wall.name]
        for name, gross_m2, window in pieces:
            corners = rectangle(gross_m2, azimuth_deg, tilt_deg, heights[wall.zone],
                                (x_m, 0.0, b.height_above_ground_m))  # fmt: skip
            x_m += max(abs(c[0] - x_m) for c in corners) + SURFACE_GAP_M
            variant = wall_variant(wall, films=films)
            objects.append(
                _surface(name, surface_type(tilt_deg, wall.is_exterior), variant.name,
                         wall.zone, _boundary(wall), wall.is_exterior, corners)
            )  # fmt: skip
            if films:
                objects.append(_wall_films(name, wall))
            if window is not None:
                objects.append(_window(window, name, _scaled(corners, window.area_m2 / gross_m2)))
                if films:
                    objects.append(_window_films(window))
            if _boundary(wall)[0] == "Surface":
                objects.append(_mirror(wall, tilt_deg, corners))
                if films:
                    far = wall.construction.outside_film_for(wall.adjacent)
                    assert far is not None  # a partition's far face has a film
                    objects.append(_films(mirror_name(wall), inside=far))
    return objects


# ---- hvacflex's surface coefficients ------------------------------------------------------


MIN_CONVECTION_W_PER_M2K = 0.1
"""EnergyPlus's lowest accepted convection coefficient (``HeatBalanceAlgorithm`` default)."""


def check_films(b: Building) -> None:
    """Refuse a building whose films EnergyPlus cannot be given as convection coefficients.

    ``surfaces="hvacflex"`` writes every face's combined film as its convection coefficient
    and switches long-wave off where hvacflex has none. That is hvacflex's model only for
    zones with combined films and all-convective gains: a zone with an interior radiant star
    (``interior_radiation_w_per_m2k``) or radiative gains would need long-wave inside (with
    it off, EnergyPlus puts the radiant gains on the windows alone), and an outside film
    below its long-wave part cannot be split.

    Raises
    ------
    InputError
        naming the zone or surface.
    """
    for zone in b.zones:
        if zone.interior_radiation_w_per_m2k is not None or zone.internal_gain_radiative_fraction:
            raise InputError(
                "surfaces='hvacflex' needs combined films and convective gains",
                field=f"zones.{zone.name}",
                value=(zone.interior_radiation_w_per_m2k, zone.internal_gain_radiative_fraction),
                hint="compare this building with surfaces='energyplus' (EnergyPlus models "
                "interior long-wave itself)",
            )
    outdoor = [(f"walls.{w.name}", _outside_film(w)) for w in b.walls if w.adjacent == OUTSIDE]
    outdoor += [(f"windows.{w.name}", _window_outside_film(w)) for w in b.windows]
    for field, coefficient in outdoor:
        if coefficient < MIN_CONVECTION_W_PER_M2K:
            raise InputError(
                "outside film below its long-wave part: no convection coefficient is left",
                field=field,
                value=round(coefficient, 3),
                hint="raise outside_film_w_per_m2k, or compare with surfaces='energyplus'",
            )


def longwave_coefficient_w_per_m2k(emissivity: float) -> float:
    """Linearised long-wave coefficient 4 ε σ T³ at :data:`FILM_REFERENCE_TEMP_K` [W/(m²K)]."""
    return 4.0 * emissivity * STEFAN_BOLTZMANN_W_PER_M2K4 * FILM_REFERENCE_TEMP_K**3


def _films(name: str, *, inside: float, outside: float | None = None) -> str:
    fields: list[object] = [name, "Inside", "Value", inside, None, None]
    if outside is not None:
        fields += ["Outside", "Value", outside, None, None]
    return idf_object("SurfaceProperty:ConvectionCoefficients", *fields)


def _inside_film(wall: Wall) -> float:
    return wall.construction.inside_film_w_per_m2k


def _wall_films(name: str, wall: Wall) -> str:
    """hvacflex's combined films as EnergyPlus convection coefficients. Inside, the combined
    film is all convection (no face inside exchanges long-wave). Outside, where the face
    still exchanges long-wave with sky and ground (the building gives ``thermal_emissivity``,
    which hvacflex's sky term models), the film less its linearised long-wave part."""
    outside = _outside_film(wall) if wall.adjacent == OUTSIDE else None
    return _films(name, inside=_inside_film(wall), outside=outside)


def _outside_film(wall: Wall) -> float:
    film = wall.construction.outside_film_for(OUTSIDE)
    assert film is not None  # an outdoor face always has a film
    if wall.thermal_emissivity is None:
        return film
    return film - longwave_coefficient_w_per_m2k(wall.thermal_emissivity)


def _window_films(window: Window) -> str:
    """A window's films: inside hvacflex's default inside film (its U-value's), outside its
    outside film less the long-wave EnergyPlus's glazing keeps (ε 0.84, to sky and ground)."""
    return _films(
        window.name, inside=DEFAULT_INSIDE_FILM_W_PER_M2K, outside=_window_outside_film(window)
    )


def _window_outside_film(window: Window) -> float:
    return window.outside_film_w_per_m2k - longwave_coefficient_w_per_m2k(SIMPLE_GLAZING_EMISSIVITY)


def _window(window: Window, host: str, corners: Sequence[Vertex]) -> str:
    return idf_object(
        "FenestrationSurface:Detailed", window.name, "Window", glazing_name(window), host,
        None, "autocalculate", None, 1, len(corners), *_flat(corners),
    )  # fmt: skip


def _mirror(wall: Wall, tilt_deg: float, corners: Sequence[Vertex]) -> str:
    """The partition's face in the adjacent zone: reversed vertices and layers."""
    kind = surface_type(180.0 - tilt_deg, exterior=False)
    return _surface(
        mirror_name(wall), kind, ConstructionVariant(wall.construction, reversed=True).name,
        wall.adjacent, ("Surface", wall.name), False, list(corners)[::-1],
    )  # fmt: skip
