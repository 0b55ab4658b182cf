"""Building domain objects: frozen dataclasses that the rest of the package trusts.

A building is a set of zones (air nodes), opaque constructions placed as walls between a zone
and something else (outside air, the ground, another zone, or an adiabatic plane of
symmetry), windows (pure conductances zone–outside that transmit solar gain to the zone air),
internal-gain densities and an air-handling (VAV) system. The file format and its validation
live in :mod:`hvacflex.building.schema` (the declarative schema) and
:mod:`hvacflex.building.io` (``load_building``); these classes hold the validated values.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import numpy.typing as npt

from hvacflex.building.chiller import ChillerPerformance
from hvacflex.building.identified import NOMINAL_FLOOR_AREA_M2, IdentifiedPower, IdentifiedRC
from hvacflex.constants import PERIOD_S
from hvacflex.units import CP_AIR_J_PER_KG_K, RHO_AIR_KG_PER_M3, SECONDS_PER_HOUR

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
    energyplus_zone : the name of this zone in an EnergyPlus model driven as the plant
        (matched case-insensitively); ``None``: the zone's own ``name``.
    """

    name: str
    floor_area_m2: float
    height_m: float
    capacitance_multiplier: float = 1.0
    infiltration_ach: float = 0.0
    internal_gain_radiative_fraction: float = 0.0
    solar_lost_fraction: float = 0.0
    interior_radiation_w_per_m2k: float | None = None
    energyplus_zone: str | None = None

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
    outdoor_air_kg_s : outdoor air by ventilation need [kg/s]: the air handler takes
        min(this, Σṁ) of outdoor air whenever it runs; ``None``: the fixed share
        ``outdoor_air_fraction`` of the supply.
    chiller : part-load and outdoor-temperature model of the cooling plant
        (:mod:`hvacflex.building.chiller`); ``None``: the constant ``cop``.
    fan_part_load_coefficients : (c1, c2, c3, c4) of the fan's part-load curve,
        P_fan = κ_f (Σṁ_max)^n · (c1 + c2 f + c3 f² + c4 f³), f = Σṁ / Σṁ_max, 0 when the fan
        is off (Σṁ = 0); ``None``: the power law κ_f (Σṁ)^n.
    outdoor_air_purge_h : pre-occupancy purge [h]: the outdoor-air damper opens this long
        before each occupied spell (0: only while occupied). Outside the occupied periods and
        the purge the damper is closed: a running fan recirculates return air only
        (:meth:`outdoor_air_open_at`).
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
    outdoor_air_kg_s: float | None = None
    chiller: ChillerPerformance | None = None
    fan_part_load_coefficients: tuple[float, float, float, float] | None = None
    outdoor_air_purge_h: float = 0.0

    def __post_init__(self) -> None:
        if not self.ventilation_flow_kg_s:
            object.__setattr__(self, "ventilation_flow_kg_s", self.flow_min_kg_s)

    def outdoor_air_open_at(
        self, occupied: npt.ArrayLike, dt_s: float = PERIOD_S
    ) -> npt.NDArray[np.bool_]:
        """(N,) bool: the outdoor-air damper is open in step k — the building is occupied
        in k, or an occupied step follows within the purge (``outdoor_air_purge_h``).

        Parameters
        ----------
        occupied : (N,) bool, the schedule's occupied steps (the occupied comfort band).
        dt_s : step length [s]. An occupied spell beyond the series' end opens no purge.
        """
        occ = np.asarray(occupied, dtype=bool).reshape(-1)
        purge_steps = math.ceil(self.outdoor_air_purge_h * SECONDS_PER_HOUR / dt_s - 1e-9)
        open_ = occ.copy()
        for shift in range(1, purge_steps + 1):
            open_[:-shift] |= occ[shift:]
        return open_

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
    identified : the fitted grey-box network of a building identified from trend data
        (:mod:`hvacflex.building.identified`; it then has no walls or windows), else None.
    height_above_ground_m : the floor's height above ground [m] (default 0: on the ground);
        the IDF export places the surfaces there, so EnergyPlus's wind speed and outside
        films are those of that height (hvacflex's own films are the constructions').
    power_models : plant kind (``"rc"``, ``"energyplus"``) → a power model fitted to that
        plant's meter (the file's ``[power_models.<kind>]``; empty: none).
    metered_power : the one the controller plans with (:meth:`with_power_model_for`), or
        None: the design curves (:func:`hvacflex.building.hvac.affine_power_model`).
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
    identified: IdentifiedRC | None = None
    height_above_ground_m: float = 0.0
    power_models: Mapping[str, IdentifiedPower] = field(default_factory=dict)
    metered_power: IdentifiedPower | None = None

    def with_power_model_for(self, plant_kind: str) -> Building:
        """This building planning with its power model fitted to ``plant_kind``'s meter
        (``power_models[plant_kind]``), or with none (the design curves) when it has none."""
        return replace(self, metered_power=self.power_models.get(plant_kind))

    @property
    def zone_names(self) -> tuple[str, ...]:
        return tuple(zone.name for zone in self.zones)

    @property
    def floor_area_m2(self) -> float:
        """The zones' floor area [m²]; NaN when a zone's is unknown (an identified model
        whose file gives no ``floor_area_m2``): per-m² figures are then not available."""
        return float(sum(zone.floor_area_m2 for zone in self.zones))

    @property
    def gain_floor_areas_m2(self) -> tuple[float, ...]:
        """(m,) the floor area [m²] that scales each zone's ``internal_gain`` channel (the
        gains' densities × this area): the zone's floor area, or for an identified building
        its gain channel's nominal area (``identified.NOMINAL_FLOOR_AREA_M2``), whatever its
        real floor area."""
        if self.identified is not None:
            return tuple(NOMINAL_FLOOR_AREA_M2 for _ in self.zones)
        return tuple(zone.floor_area_m2 for zone in self.zones)

    def zone_index(self, name: str) -> int:
        return self.zone_names.index(name)

    @property
    def reserve_mask(self) -> tuple[bool, ...]:
        """(m,) True where the zone may carry reserve."""
        return tuple(name in self.hvac.reserve_zones for name in self.zone_names)
