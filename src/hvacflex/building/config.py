"""Building descriptions: TOML files loaded into validated, frozen dataclasses.

A building is a set of zones (air nodes), opaque constructions placed as walls between a zone
and something else (outside air, the ground, another zone, or an adiabatic plane of
symmetry), windows (pure conductances zone–outside that transmit solar gain to the zone air),
internal-gain densities and an air-handling (VAV) system. ``load_building`` reads the file,
checks every value once (errors name the file, the field and the value, and say what would be
valid) and returns a :class:`Building`; the rest of the package trusts it.

File layout (see ``buildings/office5.toml`` for a commented example)::

    name, description, latitude_deg?, longitude_deg?
    [[zones]]            name, floor_area_m2, height_m, capacitance_multiplier?,
                         infiltration_ach?, internal_gain_radiative_fraction?,
                         solar_lost_fraction?, interior_radiation_w_per_m2k?
    [constructions.X]    r_value_m2k_per_w + capacitance_j_per_m2k   (homogeneous)
                         or layers = [{thickness_m, conductivity_w_per_mk,
                                       density_kg_per_m3, specific_heat_j_per_kgk}, ...]
                         (outside → inside), inside_film_w_per_m2k?, outside_film_w_per_m2k?,
                         nodes_per_layer?
    [[walls]]            name, zone, adjacent ("outside" | "ground" | "adiabatic" | zone),
                         construction, area_m2, azimuth_deg?, tilt_deg?, solar_absorptance?,
                         thermal_emissivity?, interior_solar_fraction?
    [[windows]]          name, zone, area_m2, u_value_w_per_m2k, shgc, azimuth_deg, tilt_deg?,
                         thermal_emissivity?, outside_film_w_per_m2k?, shgc_normal?,
                         incidence_angle_modifier?

The optional keys added for the BESTEST validation (infiltration, radiative split of gains,
interior solar distribution, sky long-wave exchange) all default to the original model.
    [gains]              occupancy_m2_per_person, sensible_w_per_person, latent_w_per_person,
                         lighting_w_per_m2, equipment_w_per_m2
    [hvac]               supply_temp_degc, flow_min_kg_s = {zone = …}, flow_max_kg_s = {…},
                         outdoor_air_fraction, cop, fan_coeff_kw, fan_exponent,
                         reserve_zones?, heating_efficiency?, supply_humidity_ratio_kg_per_kg?
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from hvacflex.errors import BuildingConfigError
from hvacflex.units import CP_AIR_J_PER_KG_K, RHO_AIR_KG_PER_M3

OUTSIDE = "outside"
GROUND = "ground"
ADIABATIC = "adiabatic"
BOUNDARIES = (OUTSIDE, GROUND, ADIABATIC)
"""Reserved names for the far side of a wall that is not a zone."""

DEFAULT_INSIDE_FILM_W_PER_M2K = 1.0 / 0.13
"""Combined inside surface coefficient, ISO 6946 R_si = 0.13 m²K/W (horizontal flow)."""

DEFAULT_OUTSIDE_FILM_W_PER_M2K = 1.0 / 0.04
"""Combined outside surface coefficient, ISO 6946 R_se = 0.04 m²K/W."""

DEFAULT_SOLAR_ABSORPTANCE = 0.6
"""Solar absorptance of an exterior opaque surface when the file gives none (mid-tone)."""

MAX_SUPPLY_TEMP_DEGC = 20.0
"""Upper limit of the supply-air temperature: below the lowest comfort bound (the
unoccupied band starts at 20 °C), so that supply air always cools (B ≤ 0)."""

DOUBLE_CLEAR_ANGLE_MODIFIER: tuple[tuple[float, float], ...] = (
    (0.0, 1.0),
    (40.0, 0.74 / 0.76),
    (50.0, 0.71 / 0.76),
    (60.0, 0.64 / 0.76),
    (70.0, 0.50 / 0.76),
    (80.0, 0.26 / 0.76),
    (90.0, 0.0),
)
"""SHGC(θ)/SHGC(0) of uncoated double clear glazing (3 mm panes, air gap): ASHRAE Handbook
of Fundamentals, ch. 15, fenestration table of glazing ID 5a (SHGC 0.76 at normal
incidence, 0.74 / 0.71 / 0.64 / 0.50 / 0.26 at 40–80°, hemispherical 0.66)."""

SOLAR_FRACTION_TOLERANCE = 1e-6
"""Rounding allowance when checking that a zone's transmitted-solar shares sum to ≤ 1."""

_NAME_PATTERN = re.compile(r"^[a-z][a-z0-9_]*$")


@dataclass(frozen=True)
class Layer:
    """One homogeneous layer of a construction.

    Attributes
    ----------
    thickness_m : [m]
    conductivity_w_per_mk : thermal conductivity [W/(m·K)]
    density_kg_per_m3 : [kg/m³]
    specific_heat_j_per_kgk : [J/(kg·K)]
    """

    thickness_m: float
    conductivity_w_per_mk: float
    density_kg_per_m3: float
    specific_heat_j_per_kgk: float

    @property
    def r_value_m2k_per_w(self) -> float:
        """Conduction resistance per unit area d/k [m²K/W]."""
        return self.thickness_m / self.conductivity_w_per_mk

    @property
    def capacitance_j_per_m2k(self) -> float:
        """Heat capacity per unit area ρ·c·d [J/(m²K)]."""
        return self.density_kg_per_m3 * self.specific_heat_j_per_kgk * self.thickness_m


@dataclass(frozen=True)
class Construction:
    """An opaque construction (wall, roof, slab, partition), per unit area.

    Either homogeneous (``r_value_m2k_per_w`` and ``capacitance_j_per_m2k`` given, one layer)
    or layered (``layers`` from the outside / far side to the inside / zone side).

    Attributes
    ----------
    name : key in ``[constructions]``.
    layers : (L,) layers, outside → inside; a homogeneous construction has one layer whose
        ``thickness_m`` is 1 and whose conductivity and volumetric heat give R and C.
    inside_film_w_per_m2k : combined (convective + radiative) surface coefficient on the
        zone side [W/(m²K)].
    outside_film_w_per_m2k : coefficient on the far side [W/(m²K)]; ``None`` picks it from the
        wall's adjacency (outside air: ISO 6946 25 W/m²K; another zone: the inside value;
        ground: direct contact, no film).
    nodes_per_layer : ``None`` lumps the whole construction into one capacitance node (the
        default); ``k`` splits every layer into ``k`` equal finite-volume slices.
    """

    name: str
    layers: tuple[Layer, ...]
    inside_film_w_per_m2k: float = DEFAULT_INSIDE_FILM_W_PER_M2K
    outside_film_w_per_m2k: float | None = None
    nodes_per_layer: int | None = None

    @property
    def r_material_m2k_per_w(self) -> float:
        """Σ layer resistances, surface to surface [m²K/W]."""
        return sum(layer.r_value_m2k_per_w for layer in self.layers)

    @property
    def capacitance_j_per_m2k(self) -> float:
        """Σ ρ c d over the layers [J/(m²K)]."""
        return sum(layer.capacitance_j_per_m2k for layer in self.layers)

    def outside_film_for(self, adjacent: str) -> float | None:
        """Far-side film coefficient [W/(m²K)] for a wall with this adjacency; ``None``: no
        film (ground contact, or an adiabatic face that carries no heat)."""
        if self.outside_film_w_per_m2k is not None:
            return self.outside_film_w_per_m2k
        if adjacent == OUTSIDE:
            return DEFAULT_OUTSIDE_FILM_W_PER_M2K
        if adjacent in (GROUND, ADIABATIC):
            return None
        return self.inside_film_w_per_m2k

    def u_value_w_per_m2k(self, adjacent: str = OUTSIDE) -> float:
        """Steady-state transmittance film to film, 1/(R_si + Σ R + R_se) [W/(m²K)]."""
        outside = self.outside_film_for(adjacent)
        r_total = 1.0 / self.inside_film_w_per_m2k + self.r_material_m2k_per_w
        if outside is not None:
            r_total += 1.0 / outside
        return 1.0 / r_total

    def slices(self) -> tuple[tuple[float, float], ...]:
        """Finite-volume slices ``(r_m2k_per_w, c_j_per_m2k)``, outside → inside.

        One slice (all layers lumped) when ``nodes_per_layer`` is ``None``; otherwise each
        layer split into ``nodes_per_layer`` equal slices. Σ r and Σ c equal the layer sums.
        """
        if self.nodes_per_layer is None:
            return ((self.r_material_m2k_per_w, self.capacitance_j_per_m2k),)
        k = self.nodes_per_layer
        return tuple(
            (layer.r_value_m2k_per_w / k, layer.capacitance_j_per_m2k / k)
            for layer in self.layers
            for _ in range(k)
        )

    def chain(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The capacitance nodes and the resistances between them, per unit area.

        Massless slices (a layer with zero density or specific heat, e.g. a no-mass
        insulation board) carry no node: their resistance joins the link they sit in.

        Returns
        -------
        capacitance_j_per_m2k : (k,) node capacitances, outside → inside.
        resistance_m2k_per_w : (k + 1,) outer surface → node 0, node 0 → node 1, …,
            node k−1 → inner surface (films excluded); Σ equals ``r_material_m2k_per_w``.
        """
        capacitance: list[float] = []
        resistance: list[float] = [0.0]
        pending = 0.0  # massless resistance since the last node
        for r, c in self.slices():
            if c <= 0.0:
                pending += r
                continue
            if capacitance:
                resistance.append(resistance.pop() + pending + r / 2)
            else:
                resistance[0] = r / 2 + pending
            capacitance.append(c)
            resistance.append(r / 2)
            pending = 0.0
        resistance[-1] += pending
        return tuple(capacitance), tuple(resistance)


@dataclass(frozen=True)
class Wall:
    """An opaque surface of a zone.

    Attributes
    ----------
    name : unique node name stem.
    zone : the zone on the inside.
    adjacent : ``"outside"``, ``"ground"``, ``"adiabatic"`` or another zone's name.
    construction : the construction (resolved).
    area_m2 : [m²]
    azimuth_deg : clockwise from north, 180 = south-facing (exterior surfaces only).
    tilt_deg : from horizontal, 90 = vertical, 0 = roof, 180 = facing down (raised floor).
    solar_absorptance : α of the outside surface (exterior surfaces only) [-]; an exterior
        wall with α = 0 (e.g. the shaded underside of a raised floor) gets no solar channel.
    thermal_emissivity : long-wave emissivity ε of the outside surface [-]; ``None`` (default):
        no explicit sky exchange (the outside film is taken to exchange with air-temperature
        surroundings). When set on an exterior wall, the outer surface loses
        ``ε · (1 + cos tilt)/2 · L_sky`` [W/m²] (``sky_longwave`` channel, ``channels.py``).
    interior_solar_fraction : share of the zone's transmitted solar absorbed on this wall's
        inside surface [-]; ``None``: the wall receives none (see :class:`Zone`).
    """

    name: str
    zone: str
    adjacent: str
    construction: Construction
    area_m2: float
    azimuth_deg: float = 0.0
    tilt_deg: float = 90.0
    solar_absorptance: float = DEFAULT_SOLAR_ABSORPTANCE
    thermal_emissivity: float | None = None
    interior_solar_fraction: float | None = None

    @property
    def sky_view_factor(self) -> float:
        """View factor of the outside surface to the sky, (1 + cos tilt)/2 [-]."""
        return (1.0 + math.cos(math.radians(self.tilt_deg))) / 2.0

    @property
    def is_exterior(self) -> bool:
        return self.adjacent == OUTSIDE

    @property
    def ua_w_per_k(self) -> float:
        """Steady-state conductance film to film, U·A [W/K] (0 for an adiabatic wall)."""
        if self.adjacent == ADIABATIC:
            return 0.0
        return self.construction.u_value_w_per_m2k(self.adjacent) * self.area_m2


@dataclass(frozen=True)
class Window:
    """A window: conductance zone–outside and solar transmission to the zone air.

    Attributes
    ----------
    name, zone : identity and the zone it belongs to.
    area_m2 : glazed area incl. frame [m²].
    u_value_w_per_m2k : whole-window U incl. films [W/(m²K)].
    shgc : solar heat gain coefficient (the τ of the paper, incl. the inward-flowing part of
        the absorbed solar) [-]: a constant, so for validation use the hemispherical
        (diffuse-averaged) value rather than the normal-incidence one.
    azimuth_deg, tilt_deg : orientation as for :class:`Wall`.
    thermal_emissivity : long-wave emissivity of the outer pane [-]; ``None``: no explicit
        sky exchange (as for :class:`Wall`).
    outside_film_w_per_m2k : combined outside surface coefficient included in the U-value
        [W/(m²K)]; only used to split the sky long-wave loss of the outer pane between the
        outdoor air and the zone (share ``U / h_out`` reaches the zone).
    shgc_normal : SHGC at normal incidence [-]; ``None`` (default): the constant ``shgc``
        applies to all irradiance. When set, the window's gain is angle dependent: beam
        × ``shgc_normal`` × modifier(incidence angle) + diffuse × ``shgc`` (then the
        hemispherical value), through its own ``window_solar_gain`` channel.
    incidence_angle_modifier : ((angle_deg, SHGC(θ)/SHGC(0)), …) interpolated linearly;
        default :data:`DOUBLE_CLEAR_ANGLE_MODIFIER`.
    """

    name: str
    zone: str
    area_m2: float
    u_value_w_per_m2k: float
    shgc: float
    azimuth_deg: float
    tilt_deg: float = 90.0
    thermal_emissivity: float | None = None
    outside_film_w_per_m2k: float = DEFAULT_OUTSIDE_FILM_W_PER_M2K
    shgc_normal: float | None = None
    incidence_angle_modifier: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        if not self.incidence_angle_modifier:
            object.__setattr__(self, "incidence_angle_modifier", DOUBLE_CLEAR_ANGLE_MODIFIER)

    def solar_gain_w_per_m2(
        self,
        beam_w_per_m2: npt.ArrayLike,
        diffuse_w_per_m2: npt.ArrayLike,
        incidence_deg: npt.ArrayLike,
    ) -> npt.NDArray[np.float64]:
        """Solar heat gain per m² of window (the ``window_solar_gain`` channel) [W/m²].

        Parameters
        ----------
        beam_w_per_m2 : (T,) beam irradiance on the window plane [W/m²].
        diffuse_w_per_m2 : (T,) sky + ground diffuse irradiance on the plane [W/m²].
        incidence_deg : (T,) angle of incidence of the beam [°] (≥ 90: behind the plane).

        Returns
        -------
        (T,) ``shgc_normal · IAM(θ) · beam + shgc · diffuse`` (``shgc`` × total when
        ``shgc_normal`` is None).
        """
        beam = np.asarray(beam_w_per_m2, dtype=np.float64)
        diffuse = np.asarray(diffuse_w_per_m2, dtype=np.float64)
        if self.shgc_normal is None:
            constant: npt.NDArray[np.float64] = self.shgc * (beam + diffuse)
            return constant
        angles, factors = zip(*self.incidence_angle_modifier, strict=True)
        modifier = np.interp(np.asarray(incidence_deg, dtype=np.float64), angles, factors)
        gain: npt.NDArray[np.float64] = self.shgc_normal * modifier * beam + self.shgc * diffuse
        return gain

    @property
    def ua_w_per_k(self) -> float:
        return self.u_value_w_per_m2k * self.area_m2

    @property
    def sky_view_factor(self) -> float:
        """View factor of the outer pane to the sky, (1 + cos tilt)/2 [-]."""
        return (1.0 + math.cos(math.radians(self.tilt_deg))) / 2.0


@dataclass(frozen=True)
class Zone:
    """A thermal zone (one air node).

    Attributes
    ----------
    name : lower-case identifier (used in channel and column names).
    floor_area_m2 : [m²]
    height_m : floor-to-ceiling height (air volume = area × height) [m].
    capacitance_multiplier : zone-node capacitance over the air's ρ c_p V (furniture and
        light internal mass) [-], ≥ 1.
    infiltration_ach : outdoor-air infiltration [air changes per hour]; a conductance
        ρ c_p V · ACH / 3600 between the zone air and the outdoor air (with the package's
        sea-level ρ: scale the ACH by ρ_site/ρ_sea-level for a high-altitude site).
    internal_gain_radiative_fraction : share of the internal sensible gain emitted as
        long-wave radiation, spread over the inside surfaces of the zone's walls in proportion
        to their areas [-]; the rest (default: all) is convective, to the air node.
    solar_lost_fraction : share of the zone's transmitted solar reflected back out through
        its windows [-]. Transmitted solar goes to the walls' inside surfaces with their
        ``interior_solar_fraction``; whatever is neither assigned to a wall nor lost goes to
        the air node (the default: all of it, as in the paper).
    interior_radiation_w_per_m2k : linearised long-wave coefficient h_r between the zone's
        opaque inside surfaces [W/(m²K)]; ``None`` (default): no explicit exchange, the inside
        films are combined (convective + radiative) coefficients to the air node. When set,
        every wall of the zone gets a (massless) inside-surface node joined to the air by its
        inside film, then read as convective only, and to a radiant star node by h_r·A
        (the mean-radiant-temperature star of Walton / ISO 13790); radiative gains land on
        the surface nodes. Massless nodes are eliminated exactly (Kron reduction).
    """

    name: str
    floor_area_m2: float
    height_m: float
    capacitance_multiplier: float = 1.0
    infiltration_ach: float = 0.0
    internal_gain_radiative_fraction: float = 0.0
    solar_lost_fraction: float = 0.0
    interior_radiation_w_per_m2k: float | None = None

    @property
    def volume_m3(self) -> float:
        return self.floor_area_m2 * self.height_m

    @property
    def infiltration_w_per_k(self) -> float:
        """Infiltration conductance ρ c_p V · ACH / 3600 [W/K]."""
        return RHO_AIR_KG_PER_M3 * CP_AIR_J_PER_KG_K * self.volume_m3 * self.infiltration_ach / 3600

    @property
    def capacitance_j_per_k(self) -> float:
        """Zone-node capacitance, multiplier × ρ_air c_p V [J/K]."""
        return self.capacitance_multiplier * RHO_AIR_KG_PER_M3 * CP_AIR_J_PER_KG_K * self.volume_m3


@dataclass(frozen=True)
class InternalGains:
    """Peak internal-gain densities (the data layer applies the office schedule).

    Attributes
    ----------
    occupancy_m2_per_person : floor area per occupant [m²/person].
    sensible_w_per_person, latent_w_per_person : heat per occupant [W].
    lighting_w_per_m2, equipment_w_per_m2 : lighting and plug loads [W/m²].
    """

    occupancy_m2_per_person: float
    sensible_w_per_person: float
    latent_w_per_person: float
    lighting_w_per_m2: float
    equipment_w_per_m2: float

    @property
    def peak_sensible_w_per_m2(self) -> float:
        """People (sensible) + lighting + equipment at full schedule [W/m²]."""
        people = self.sensible_w_per_person / self.occupancy_m2_per_person
        return people + self.lighting_w_per_m2 + self.equipment_w_per_m2

    @property
    def peak_latent_w_per_m2(self) -> float:
        return self.latent_w_per_person / self.occupancy_m2_per_person


@dataclass(frozen=True)
class HvacSystem:
    """One VAV air-handling unit serving every zone at a fixed supply-air temperature.

    Attributes
    ----------
    supply_temp_degc : supply-air temperature T_s [°C].
    flow_min_kg_s, flow_max_kg_s : (m,) supply-air mass-flow bounds per zone, zone order
        [kg/s]. ``flow_min_kg_s`` is the lowest flow ever allowed (0 = the air handler may
        stop when the building is unoccupied); the linear model is exact there.
    ventilation_flow_kg_s : (m,) minimum flow while the building is occupied, so that the
        outdoor-air share covers the ventilation requirement [kg/s]
        (flow_min ≤ ventilation ≤ flow_max; default: ``flow_min_kg_s``).
    outdoor_air_fraction : f_oa, share of outdoor air in the supply air [-].
    cop : cooling plant coefficient of performance (coil heat / electric power) [-].
    fan_coeff_kw : κ_f in P_fan = κ_f (Σṁ)^n [kW/(kg/s)^n].
    fan_exponent : n [-], ≥ 1 (the fan curve is convex).
    reserve_zones : zones allowed to offer interruptible-load reserve (default: all).
    heating_efficiency : electric heating coil efficiency (coil heat / power) [-].
    supply_humidity_ratio_kg_per_kg : humidity ratio leaving the cooling coil [kg/kg];
        ``None``: saturated air at ``supply_temp_degc`` (see ``hvac.py``).
    """

    supply_temp_degc: float
    flow_min_kg_s: tuple[float, ...]
    flow_max_kg_s: tuple[float, ...]
    outdoor_air_fraction: float
    cop: float
    fan_coeff_kw: float
    fan_exponent: float
    reserve_zones: tuple[str, ...]
    heating_efficiency: float = 1.0
    supply_humidity_ratio_kg_per_kg: float | None = None
    ventilation_flow_kg_s: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if not self.ventilation_flow_kg_s:
            object.__setattr__(self, "ventilation_flow_kg_s", self.flow_min_kg_s)

    def flow_min_at(self, occupied: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """(N, m) lower flow bound per step: ventilation when occupied, else the minimum.

        Parameters
        ----------
        occupied : (N,) bool, building occupied in each step.
        """
        occ = np.asarray(occupied, dtype=bool)[:, None]
        low: npt.NDArray[np.float64] = np.where(
            occ,
            np.asarray(self.ventilation_flow_kg_s, dtype=np.float64)[None, :],
            np.asarray(self.flow_min_kg_s, dtype=np.float64)[None, :],
        )
        return low


@dataclass(frozen=True)
class Building:
    """A validated building description.

    Attributes
    ----------
    name, description : identity.
    zones : (m,) zones in file order (the order of every per-zone vector).
    walls, windows : envelope and internal surfaces.
    constructions : by name.
    gains : internal-gain densities.
    hvac : the air-handling system.
    latitude_deg, longitude_deg : site, if the file gives it (the weather file has it too).
    source_path : the file it came from (``None`` if built in code).
    """

    name: str
    zones: tuple[Zone, ...]
    walls: tuple[Wall, ...]
    windows: tuple[Window, ...]
    constructions: Mapping[str, Construction]
    gains: InternalGains
    hvac: HvacSystem
    description: str = ""
    latitude_deg: float | None = None
    longitude_deg: float | None = None
    source_path: Path | None = field(default=None, compare=False)

    @property
    def zone_names(self) -> tuple[str, ...]:
        return tuple(zone.name for zone in self.zones)

    @property
    def floor_area_m2(self) -> float:
        return sum(zone.floor_area_m2 for zone in self.zones)

    def zone_index(self, name: str) -> int:
        return self.zone_names.index(name)

    @property
    def reserve_mask(self) -> tuple[bool, ...]:
        """(m,) True where the zone may carry reserve."""
        return tuple(name in self.hvac.reserve_zones for name in self.zone_names)


# --------------------------------------------------------------------------------------
# Loading and validation
# --------------------------------------------------------------------------------------

_TOP_KEYS = {
    "name",
    "description",
    "latitude_deg",
    "longitude_deg",
    "zones",
    "constructions",
    "walls",
    "windows",
    "gains",
    "hvac",
}
_ZONE_KEYS = {
    "name",
    "floor_area_m2",
    "height_m",
    "capacitance_multiplier",
    "infiltration_ach",
    "internal_gain_radiative_fraction",
    "solar_lost_fraction",
    "interior_radiation_w_per_m2k",
}
_CONSTRUCTION_KEYS = {
    "r_value_m2k_per_w",
    "capacitance_j_per_m2k",
    "layers",
    "inside_film_w_per_m2k",
    "outside_film_w_per_m2k",
    "nodes_per_layer",
}
_LAYER_KEYS = {
    "thickness_m",
    "conductivity_w_per_mk",
    "density_kg_per_m3",
    "specific_heat_j_per_kgk",
}
_WALL_KEYS = {
    "name",
    "zone",
    "adjacent",
    "construction",
    "area_m2",
    "azimuth_deg",
    "tilt_deg",
    "solar_absorptance",
    "thermal_emissivity",
    "interior_solar_fraction",
}
_WINDOW_KEYS = {
    "name",
    "zone",
    "area_m2",
    "u_value_w_per_m2k",
    "shgc",
    "azimuth_deg",
    "tilt_deg",
    "thermal_emissivity",
    "outside_film_w_per_m2k",
    "shgc_normal",
    "incidence_angle_modifier",
}
_GAINS_KEYS = {
    "occupancy_m2_per_person",
    "sensible_w_per_person",
    "latent_w_per_person",
    "lighting_w_per_m2",
    "equipment_w_per_m2",
}
_HVAC_KEYS = {
    "supply_temp_degc",
    "flow_min_kg_s",
    "flow_max_kg_s",
    "outdoor_air_fraction",
    "cop",
    "fan_coeff_kw",
    "fan_exponent",
    "reserve_zones",
    "heating_efficiency",
    "supply_humidity_ratio_kg_per_kg",
    "ventilation_flow_kg_s",
}


class _Reader:
    """Typed field access on a TOML table, raising errors that name file and field."""

    def __init__(self, source: Path | str) -> None:
        self.source = source

    def error(
        self, message: str, field_name: str, value: object = None, hint: str | None = None
    ) -> BuildingConfigError:
        return BuildingConfigError(
            message, source=self.source, field=field_name, value=value, hint=hint
        )

    def table(self, data: Any, path: str) -> dict[str, Any]:
        if not isinstance(data, dict):
            raise self.error("expected a table", path, data)
        return data

    def check_keys(self, table: Mapping[str, Any], allowed: set[str], path: str) -> None:
        for key in table:
            if key not in allowed:
                where = f"{path}.{key}" if path else key
                raise self.error(
                    "unknown key", where, key, hint=f"allowed keys here: {sorted(allowed)}"
                )

    def require(self, table: Mapping[str, Any], key: str, path: str) -> Any:
        if key not in table:
            where = f"{path}.{key}" if path else key
            raise self.error("missing required field", where, hint="add it to the file")
        return table[key]

    def number(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        default: float | None = None,
        positive: bool = False,
        nonnegative: bool = False,
        upper: float | None = None,
    ) -> float:
        where = f"{path}.{key}" if path else key
        if key not in table:
            if default is None:
                raise self.error("missing required field", where, hint="add it to the file")
            return default
        value = table[key]
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise self.error("expected a finite number", where, value)
        number = float(value)
        if positive and number <= 0:
            raise self.error("must be > 0", where, value)
        if nonnegative and number < 0:
            raise self.error("must be ≥ 0", where, value)
        if upper is not None and number > upper:
            raise self.error(f"must be ≤ {upper:g}", where, value)
        return number

    def string(self, table: Mapping[str, Any], key: str, path: str) -> str:
        value = self.require(table, key, path)
        if not isinstance(value, str) or not value:
            raise self.error("expected a non-empty string", f"{path}.{key}" if path else key, value)
        return value

    def items(self, data: Mapping[str, Any], key: str) -> list[dict[str, Any]]:
        value = data.get(key, [])
        if not isinstance(value, list):
            raise self.error(f"expected an array of tables [[{key}]]", key, value)
        return [self.table(item, f"{key}[{i}]") for i, item in enumerate(value)]


def load_building(path: str | Path) -> Building:
    """Read and validate a building TOML file.

    Parameters
    ----------
    path : the ``.toml`` file.

    Returns
    -------
    The validated :class:`Building`.

    Raises
    ------
    BuildingConfigError : naming the file, the field (``walls[3].area_m2``) and the value.
    """
    source = Path(path)
    reader = _Reader(source)
    try:
        text = source.read_text(encoding="utf-8")
    except OSError as exc:
        raise reader.error(f"cannot read the file ({exc.strerror})", "file", str(source)) from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise BuildingConfigError(f"invalid TOML: {exc}", source=source) from exc
    return building_from_dict(data, source=source)


def building_from_dict(data: Mapping[str, Any], *, source: Path | str = "<dict>") -> Building:
    """Validate a parsed TOML document (``dict``) into a :class:`Building`.

    ``source`` names the origin in error messages; it becomes ``source_path`` when a path.
    """
    rd = _Reader(source)
    rd.check_keys(data, _TOP_KEYS, "")
    name = rd.string(data, "name", "")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise rd.error("expected a string", "description", description)
    latitude = _optional_number(rd, data, "latitude_deg", -90.0, 90.0)
    longitude = _optional_number(rd, data, "longitude_deg", -180.0, 180.0)

    zones = _read_zones(rd, data)
    zone_names = tuple(z.name for z in zones)
    constructions = _read_constructions(rd, data)
    walls = _read_walls(rd, data, zone_names, constructions)
    windows = _read_windows(rd, data, zone_names)
    _check_unique_names(rd, zones, walls, windows)
    _check_connected(rd, zone_names, walls, windows)
    _check_solar_distribution(rd, zones, walls)
    gains = _read_gains(rd, data)
    hvac = _read_hvac(rd, data, zone_names)
    return Building(
        name=name,
        zones=zones,
        walls=walls,
        windows=windows,
        constructions=constructions,
        gains=gains,
        hvac=hvac,
        description=description,
        latitude_deg=latitude,
        longitude_deg=longitude,
        source_path=Path(source) if isinstance(source, Path) else None,
    )


def _optional_number(
    rd: _Reader, data: Mapping[str, Any], key: str, lower: float, upper: float
) -> float | None:
    if key not in data:
        return None
    value = rd.number(data, key, "", upper=upper)
    if value < lower:
        raise rd.error(f"must be ≥ {lower:g}", key, data[key])
    return value


def _read_zones(rd: _Reader, data: Mapping[str, Any]) -> tuple[Zone, ...]:
    rd.require(data, "zones", "")
    items = rd.items(data, "zones")
    if not items:
        raise rd.error("a building needs at least one zone", "zones", [], hint="add [[zones]]")
    zones = []
    for i, item in enumerate(items):
        path = f"zones[{i}]"
        rd.check_keys(item, _ZONE_KEYS, path)
        name = rd.string(item, "name", path)
        if not _NAME_PATTERN.match(name) or name in BOUNDARIES:
            raise rd.error(
                "invalid zone name",
                f"{path}.name",
                name,
                hint="use lower-case letters, digits and '_', starting with a letter, and not "
                f"one of {list(BOUNDARIES)}",
            )
        zones.append(
            Zone(
                name=name,
                floor_area_m2=rd.number(item, "floor_area_m2", path, positive=True),
                height_m=rd.number(item, "height_m", path, positive=True),
                capacitance_multiplier=_at_least_one(rd, item, "capacitance_multiplier", path),
                infiltration_ach=rd.number(
                    item, "infiltration_ach", path, default=0.0, nonnegative=True
                ),
                internal_gain_radiative_fraction=_fraction(
                    rd, item, "internal_gain_radiative_fraction", path
                ),
                solar_lost_fraction=_fraction(rd, item, "solar_lost_fraction", path),
                interior_radiation_w_per_m2k=rd.number(
                    item, "interior_radiation_w_per_m2k", path, positive=True
                )
                if "interior_radiation_w_per_m2k" in item
                else None,
            )
        )
    return tuple(zones)


def _fraction(rd: _Reader, item: Mapping[str, Any], key: str, path: str) -> float:
    return rd.number(item, key, path, default=0.0, nonnegative=True, upper=1.0)


def _optional_fraction(rd: _Reader, item: Mapping[str, Any], key: str, path: str) -> float | None:
    if key not in item:
        return None
    return rd.number(item, key, path, nonnegative=True, upper=1.0)


def _at_least_one(rd: _Reader, item: Mapping[str, Any], key: str, path: str) -> float:
    value = rd.number(item, key, path, default=1.0)
    if value < 1.0:
        raise rd.error("must be ≥ 1 (the air alone)", f"{path}.{key}", item[key])
    return value


def _read_constructions(rd: _Reader, data: Mapping[str, Any]) -> dict[str, Construction]:
    table = rd.table(data.get("constructions", {}), "constructions")
    constructions: dict[str, Construction] = {}
    for name, raw in table.items():
        path = f"constructions.{name}"
        item = rd.table(raw, path)
        rd.check_keys(item, _CONSTRUCTION_KEYS, path)
        has_layers = "layers" in item
        has_rc = "r_value_m2k_per_w" in item or "capacitance_j_per_m2k" in item
        if has_layers == has_rc:
            raise rd.error(
                "give either 'layers' or both 'r_value_m2k_per_w' and 'capacitance_j_per_m2k'",
                path,
                sorted(item),
            )
        layers: tuple[Layer, ...]
        if has_layers:
            raw_layers = item["layers"]
            if not isinstance(raw_layers, list) or not raw_layers:
                raise rd.error(
                    "expected a non-empty array of layer tables", f"{path}.layers", raw_layers
                )
            parsed = []
            for j, raw_layer in enumerate(raw_layers):
                lpath = f"{path}.layers[{j}]"
                layer = rd.table(raw_layer, lpath)
                rd.check_keys(layer, _LAYER_KEYS, lpath)
                parsed.append(
                    Layer(
                        *(
                            rd.number(
                                layer,
                                key,
                                lpath,
                                positive=key in _POSITIVE_LAYER_FIELDS,
                                nonnegative=True,
                            )
                            for key in _LAYER_FIELDS
                        )
                    )
                )
            if all(layer.capacitance_j_per_m2k <= 0.0 for layer in parsed):
                raise rd.error(
                    "every layer is massless",
                    f"{path}.layers",
                    hint="at least one layer needs density and specific heat > 0 (a "
                    "massless construction is a window-like conductance)",
                )
            layers = tuple(parsed)
        else:
            r_value = rd.number(item, "r_value_m2k_per_w", path, positive=True)
            capacitance = rd.number(item, "capacitance_j_per_m2k", path, positive=True)
            # a unit-thickness layer with k = 1/R and ρc = C carries R and C exactly
            layers = (Layer(1.0, 1.0 / r_value, capacitance, 1.0),)
        nodes = item.get("nodes_per_layer")
        if nodes is not None and (
            isinstance(nodes, bool) or not isinstance(nodes, int) or nodes < 1
        ):
            raise rd.error("must be an integer ≥ 1", f"{path}.nodes_per_layer", nodes)
        outside_film = (
            rd.number(item, "outside_film_w_per_m2k", path, positive=True)
            if "outside_film_w_per_m2k" in item
            else None
        )
        constructions[name] = Construction(
            name=name,
            layers=layers,
            inside_film_w_per_m2k=rd.number(
                item,
                "inside_film_w_per_m2k",
                path,
                default=DEFAULT_INSIDE_FILM_W_PER_M2K,
                positive=True,
            ),
            outside_film_w_per_m2k=outside_film,
            nodes_per_layer=nodes,
        )
    return constructions


_LAYER_FIELDS = (
    "thickness_m",
    "conductivity_w_per_mk",
    "density_kg_per_m3",
    "specific_heat_j_per_kgk",
)
_POSITIVE_LAYER_FIELDS = {"thickness_m", "conductivity_w_per_mk"}
"""Density and specific heat may be 0: a massless (no-node) layer such as BESTEST's floor
insulation."""


def _read_orientation(
    rd: _Reader, item: Mapping[str, Any], path: str, *, required: bool
) -> tuple[float, float]:
    tilt = rd.number(item, "tilt_deg", path, default=90.0)
    if not 0.0 <= tilt <= 180.0:
        raise rd.error("must be in [0, 180]", f"{path}.tilt_deg", item["tilt_deg"])
    horizontal = tilt in (0.0, 180.0)
    if required and "azimuth_deg" not in item and not horizontal:
        raise rd.error(
            "missing required field",
            f"{path}.azimuth_deg",
            hint="exterior surfaces need an azimuth",
        )
    azimuth = rd.number(item, "azimuth_deg", path, default=0.0) % 360.0
    if horizontal:
        azimuth = 0.0  # a horizontal surface (roof, underside of a floor) has no azimuth
    return azimuth, tilt


def _read_walls(
    rd: _Reader,
    data: Mapping[str, Any],
    zone_names: tuple[str, ...],
    constructions: Mapping[str, Construction],
) -> tuple[Wall, ...]:
    walls = []
    for i, item in enumerate(rd.items(data, "walls")):
        path = f"walls[{i}]"
        rd.check_keys(item, _WALL_KEYS, path)
        name = rd.string(item, "name", path)
        zone = _zone_ref(rd, item, "zone", path, zone_names)
        adjacent = rd.string(item, "adjacent", path)
        if adjacent not in BOUNDARIES and adjacent not in zone_names:
            raise rd.error(
                "unknown zone or boundary",
                f"{path}.adjacent",
                adjacent,
                hint=f"use one of {list(BOUNDARIES)} or a zone name {list(zone_names)}",
            )
        if adjacent == zone:
            raise rd.error("a wall cannot connect a zone to itself", f"{path}.adjacent", adjacent)
        construction_name = rd.string(item, "construction", path)
        if construction_name not in constructions:
            raise rd.error(
                "unknown construction",
                f"{path}.construction",
                construction_name,
                hint=f"define [constructions.{construction_name}] or use one of "
                f"{sorted(constructions)}",
            )
        exterior = adjacent == OUTSIDE
        azimuth, tilt = _read_orientation(rd, item, path, required=exterior)
        absorptance = rd.number(
            item,
            "solar_absorptance",
            path,
            default=DEFAULT_SOLAR_ABSORPTANCE,
            nonnegative=True,
            upper=1.0,
        )
        walls.append(
            Wall(
                name=name,
                zone=zone,
                adjacent=adjacent,
                construction=constructions[construction_name],
                area_m2=rd.number(item, "area_m2", path, positive=True),
                azimuth_deg=azimuth,
                tilt_deg=tilt,
                solar_absorptance=absorptance if exterior else 0.0,
                thermal_emissivity=_optional_fraction(rd, item, "thermal_emissivity", path)
                if exterior
                else None,
                interior_solar_fraction=_optional_fraction(
                    rd, item, "interior_solar_fraction", path
                ),
            )
        )
    return tuple(walls)


def _zone_ref(
    rd: _Reader, item: Mapping[str, Any], key: str, path: str, zone_names: tuple[str, ...]
) -> str:
    zone = rd.string(item, key, path)
    if zone not in zone_names:
        raise rd.error("unknown zone", f"{path}.{key}", zone, hint=f"zones are {list(zone_names)}")
    return zone


def _read_windows(
    rd: _Reader, data: Mapping[str, Any], zone_names: tuple[str, ...]
) -> tuple[Window, ...]:
    windows = []
    for i, item in enumerate(rd.items(data, "windows")):
        path = f"windows[{i}]"
        rd.check_keys(item, _WINDOW_KEYS, path)
        azimuth, tilt = _read_orientation(rd, item, path, required=True)
        windows.append(
            Window(
                name=rd.string(item, "name", path),
                zone=_zone_ref(rd, item, "zone", path, zone_names),
                area_m2=rd.number(item, "area_m2", path, positive=True),
                u_value_w_per_m2k=rd.number(item, "u_value_w_per_m2k", path, positive=True),
                shgc=rd.number(item, "shgc", path, nonnegative=True, upper=1.0),
                azimuth_deg=azimuth,
                tilt_deg=tilt,
                thermal_emissivity=_optional_fraction(rd, item, "thermal_emissivity", path),
                outside_film_w_per_m2k=rd.number(
                    item,
                    "outside_film_w_per_m2k",
                    path,
                    default=DEFAULT_OUTSIDE_FILM_W_PER_M2K,
                    positive=True,
                ),
                shgc_normal=_optional_fraction(rd, item, "shgc_normal", path),
                incidence_angle_modifier=_read_angle_modifier(rd, item, path),
            )
        )
    return tuple(windows)


def _read_angle_modifier(
    rd: _Reader, item: Mapping[str, Any], path: str
) -> tuple[tuple[float, float], ...]:
    if "incidence_angle_modifier" not in item:
        return ()
    raw = item["incidence_angle_modifier"]
    where = f"{path}.incidence_angle_modifier"
    hint = "an array of [angle_deg, factor] pairs, angles increasing from 0 to 90"
    if not isinstance(raw, list) or len(raw) < 2:
        raise rd.error("expected at least two [angle_deg, factor] pairs", where, raw, hint=hint)
    pairs = []
    for pair in raw:
        if (
            not isinstance(pair, list)
            or len(pair) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in pair)
        ):
            raise rd.error("expected a [angle_deg, factor] pair", where, pair, hint=hint)
        pairs.append((float(pair[0]), float(pair[1])))
    angles = [a for a, _ in pairs]
    if angles != sorted(angles) or angles[0] < 0 or angles[-1] > 90:
        raise rd.error("angles must increase within [0, 90]", where, raw, hint=hint)
    if any(not 0.0 <= factor <= 1.5 for _, factor in pairs):
        raise rd.error("factors must lie in [0, 1.5]", where, raw, hint=hint)
    return tuple(pairs)


def _check_unique_names(
    rd: _Reader, zones: tuple[Zone, ...], walls: tuple[Wall, ...], windows: tuple[Window, ...]
) -> None:
    seen: dict[str, str] = {}
    entries = [(f"zones[{i}].name", z.name) for i, z in enumerate(zones)]
    entries += [(f"walls[{i}].name", w.name) for i, w in enumerate(walls)]
    entries += [(f"windows[{i}].name", w.name) for i, w in enumerate(windows)]
    for where, name in entries:
        if name in seen:
            raise rd.error(
                f"duplicate name (already used by {seen[name]})",
                where,
                name,
                hint="zone, wall and window names must be unique",
            )
        seen[name] = where


def _check_connected(
    rd: _Reader, zone_names: tuple[str, ...], walls: tuple[Wall, ...], windows: tuple[Window, ...]
) -> None:
    """Every zone must reach the outside air or the ground through walls and windows."""
    neighbours: dict[str, set[str]] = {name: set() for name in zone_names}
    for wall in walls:
        if wall.adjacent == ADIABATIC:
            continue
        neighbours[wall.zone].add(wall.adjacent)
        if wall.adjacent in neighbours:
            neighbours[wall.adjacent].add(wall.zone)
    for window in windows:
        neighbours[window.zone].add(OUTSIDE)
    reached: set[str] = set()
    frontier = [name for name in zone_names if neighbours[name] & {OUTSIDE, GROUND}]
    while frontier:
        name = frontier.pop()
        if name in reached:
            continue
        reached.add(name)
        frontier.extend(n for n in neighbours[name] if n in neighbours and n not in reached)
    for i, name in enumerate(zone_names):
        if name not in reached:
            raise rd.error(
                "zone is not connected to the outside or the ground through any wall or window",
                f"zones[{i}]",
                name,
                hint="add a wall with adjacent = 'outside' or 'ground', a window, or a wall to a "
                "connected zone (adiabatic walls do not count)",
            )


def _check_solar_distribution(
    rd: _Reader, zones: tuple[Zone, ...], walls: tuple[Wall, ...]
) -> None:
    """The transmitted-solar shares of a zone (walls + lost) may not exceed 1."""
    for i, zone in enumerate(zones):
        assigned = sum(w.interior_solar_fraction or 0.0 for w in walls if w.zone == zone.name)
        total = assigned + zone.solar_lost_fraction
        if total > 1.0 + SOLAR_FRACTION_TOLERANCE:
            raise rd.error(
                f"transmitted-solar shares add up to {total:.4f} > 1 (walls' "
                f"interior_solar_fraction {assigned:.4f} + solar_lost_fraction)",
                f"zones[{i}]",
                zone.name,
                hint="the shares of the zone's transmitted solar must sum to at most 1 (the "
                "rest goes to the air node)",
            )


def _read_gains(rd: _Reader, data: Mapping[str, Any]) -> InternalGains:
    item = rd.table(rd.require(data, "gains", ""), "gains")
    rd.check_keys(item, _GAINS_KEYS, "gains")
    return InternalGains(
        occupancy_m2_per_person=rd.number(item, "occupancy_m2_per_person", "gains", positive=True),
        sensible_w_per_person=rd.number(item, "sensible_w_per_person", "gains", nonnegative=True),
        latent_w_per_person=rd.number(item, "latent_w_per_person", "gains", nonnegative=True),
        lighting_w_per_m2=rd.number(item, "lighting_w_per_m2", "gains", nonnegative=True),
        equipment_w_per_m2=rd.number(item, "equipment_w_per_m2", "gains", nonnegative=True),
    )


def _per_zone(
    rd: _Reader, item: Mapping[str, Any], key: str, zone_names: tuple[str, ...]
) -> tuple[float, ...]:
    path = f"hvac.{key}"
    raw = rd.require(item, key, "hvac")
    if isinstance(raw, list):
        if len(raw) != len(zone_names):
            raise rd.error(
                f"expected {len(zone_names)} values (one per zone)",
                path,
                raw,
                hint=f"or a table keyed by zone name {list(zone_names)}",
            )
        raw = dict(zip(zone_names, raw, strict=True))
    table = rd.table(raw, path)
    for name in table:
        if name not in zone_names:
            raise rd.error(
                "unknown zone", f"{path}.{name}", name, hint=f"zones are {list(zone_names)}"
            )
    return tuple(rd.number(table, name, path, nonnegative=True) for name in zone_names)


def _read_hvac(rd: _Reader, data: Mapping[str, Any], zone_names: tuple[str, ...]) -> HvacSystem:
    item = rd.table(rd.require(data, "hvac", ""), "hvac")
    rd.check_keys(item, _HVAC_KEYS, "hvac")
    supply = rd.number(item, "supply_temp_degc", "hvac")
    if supply >= MAX_SUPPLY_TEMP_DEGC:
        raise rd.error(
            f"supply air must be below the comfort band (< {MAX_SUPPLY_TEMP_DEGC:g} °C)",
            "hvac.supply_temp_degc",
            item["supply_temp_degc"],
            hint="the model is cooling-only with a fixed supply temperature, typically 12–14 °C",
        )
    flow_min = _per_zone(rd, item, "flow_min_kg_s", zone_names)
    flow_max = _per_zone(rd, item, "flow_max_kg_s", zone_names)
    for name, low, high in zip(zone_names, flow_min, flow_max, strict=True):
        if high <= 0:
            raise rd.error("must be > 0", f"hvac.flow_max_kg_s.{name}", high)
        if low > high:
            raise rd.error(
                f"minimum flow exceeds the maximum flow {high:g} kg/s",
                f"hvac.flow_min_kg_s.{name}",
                low,
                hint="flow_min_kg_s must be ≤ flow_max_kg_s",
            )
    ventilation = flow_min
    if "ventilation_flow_kg_s" in item:
        ventilation = _per_zone(rd, item, "ventilation_flow_kg_s", zone_names)
        for name, low, vent, high in zip(zone_names, flow_min, ventilation, flow_max, strict=True):
            if not low <= vent <= high:
                raise rd.error(
                    f"must lie between the minimum {low:g} and maximum {high:g} kg/s",
                    f"hvac.ventilation_flow_kg_s.{name}",
                    vent,
                    hint="flow_min_kg_s ≤ ventilation_flow_kg_s ≤ flow_max_kg_s",
                )
    reserve_raw = item.get("reserve_zones", list(zone_names))
    if not isinstance(reserve_raw, list) or not all(isinstance(z, str) for z in reserve_raw):
        raise rd.error("expected an array of zone names", "hvac.reserve_zones", reserve_raw)
    for z in reserve_raw:
        if z not in zone_names:
            raise rd.error(
                "unknown zone", "hvac.reserve_zones", z, hint=f"zones are {list(zone_names)}"
            )
    supply_w = (
        rd.number(item, "supply_humidity_ratio_kg_per_kg", "hvac", positive=True, upper=0.05)
        if "supply_humidity_ratio_kg_per_kg" in item
        else None
    )
    exponent = rd.number(item, "fan_exponent", "hvac")
    if exponent < 1.0:
        raise rd.error(
            "must be ≥ 1 (a convex fan curve)",
            "hvac.fan_exponent",
            item["fan_exponent"],
            hint="fan affinity laws give 2–3",
        )
    return HvacSystem(
        supply_temp_degc=supply,
        flow_min_kg_s=flow_min,
        flow_max_kg_s=flow_max,
        outdoor_air_fraction=rd.number(
            item, "outdoor_air_fraction", "hvac", nonnegative=True, upper=1.0
        ),
        cop=rd.number(item, "cop", "hvac", positive=True),
        fan_coeff_kw=rd.number(item, "fan_coeff_kw", "hvac", nonnegative=True),
        fan_exponent=exponent,
        reserve_zones=tuple(z for z in zone_names if z in reserve_raw),
        heating_efficiency=rd.number(
            item, "heating_efficiency", "hvac", default=1.0, positive=True
        ),
        supply_humidity_ratio_kg_per_kg=supply_w,
        ventilation_flow_kg_s=ventilation,
    )
