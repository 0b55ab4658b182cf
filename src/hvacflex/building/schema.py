"""The building TOML file format: one declarative pydantic schema.

Each ``*Spec`` model mirrors one table of the file; fields carry their unit in the name and
their range in ``Field``; unknown keys are refused (``extra="forbid"``). Checks that need
more than one field (references to zones and constructions, connectivity, per-zone flows)
are model validators that raise :func:`rule_error`, whose context names the field path.
:mod:`hvacflex.building.io` turns a validated :class:`BuildingSpec` into the domain objects
of :mod:`hvacflex.building.model` and a ``ValidationError`` into a ``BuildingConfigError``.

File layout (see ``buildings/office5.toml`` for a commented example)::

    name, description, latitude_deg?, longitude_deg?, height_above_ground_m? (the floor's
    height above ground [m], default 0: a floor on the ground; the IDF export places its
    surfaces there)
    [[zones]]            name, floor_area_m2, height_m, capacitance_multiplier?,
                         infiltration_ach?, internal_gain_radiative_fraction?,
                         solar_lost_fraction?, interior_radiation_w_per_m2k?,
                         energyplus_zone? (the zone's name in an EnergyPlus plant's IDF)
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
    [gains]              occupancy_m2_per_person, sensible_w_per_person, latent_w_per_person,
                         lighting_w_per_m2, equipment_w_per_m2
    [hvac]               supply_temp_degc, flow_min_kg_s = {zone = …} or [one per zone],
                         flow_max_kg_s, ventilation_flow_kg_s?, outdoor_air_fraction, cop,
                         fan_coeff_kw, fan_exponent, reserve_zones?, heating_efficiency?,
                         supply_humidity_ratio_kg_per_kg?, outdoor_air_l_s_per_person?,
                         outdoor_air_l_s_per_m2?, fan_part_load_coefficients?,
                         outdoor_air_purge_h?
    [hvac.chiller]       capacity_kw, min_part_load_ratio?, condenser_fan_kw_per_kw?,
                         pump_design_kw?  (absent: constant cop)
    [power_models.P]     optional, P = "rc" or "energyplus": a power model fitted to that
                         plant's meter (the keys of [identified.power_model]); a scenario
                         whose [plant] kind is P plans with it instead of the design curves

A building identified from trend data (``hvacflex identify fit``) has ``[[zones]]`` with
``name``, ``energyplus_zone`` and ``floor_area_m2`` (every zone's, or none: then the areas are
unknown and ``Building.floor_area_m2`` is NaN) only, no walls, windows, ``[gains]`` or
``[hvac]``, and instead::

    [identified]         supply_temp_degc, provenance? = {data, train, test}
    [identified.zones.Z] c_air_kj_per_k, c_mass_kj_per_k, ua_out_kw_per_k,
                         ua_air_mass_kw_per_k, ua_mass_out_kw_per_k, solar_air_m2,
                         solar_mass_m2, occupied_gain_kw, base_gain_kw, flow_min_kg_s,
                         flow_max_kg_s, ventilation_flow_kg_s, mass_temp_degc,
                         solar_wall_{north,east,south,west}_m2? (one table per zone Z)
    [[identified.couplings]]  zones = [Z1, Z2], ua_kw_per_k
    [[identified.boundaries]] name, c_kj_per_k, ua_out_kw_per_k, solar_m2,
                              occupied_gain_kw, ua_zone_kw_per_k = {Z = …}, temp_degc
    [identified.power_model]  base_kw, kw_per_kw_cooling, kw_per_k_outdoor[, occupied_kw,
                              kw_per_kg_s_k_outdoor_occupied, running_kw, fan_kw_per_kg_s,
                              fan_kw_per_kg2_s2, kw_per_kw_cooling_k_outdoor,
                              kw_per_kw2_cooling, kw_per_kg_s_occupied,
                              kw_per_humidity_ratio_occupied, running_periods]
    [identified.validity]     zone_temp_min_degc = {Z = …}, zone_temp_max_degc = {Z = …},
                              outdoor_temp_min_degc, outdoor_temp_max_degc (optional: the
                              training data's range)
    [identified.idle_air]     fan_only_hours = {monday = ["00:00-06:00", …], …},
                              fan_only_difference_k = {Z = …},
                              fan_only_flow_kg_s = {Z = …} (optional: an idle zone's
                              fan-only air while the coil is scheduled off or, with
                              fan_only_flow_kg_s, while a zone's own cycling unit idles)

The optional keys added for the BESTEST validation (infiltration, radiative split of gains,
interior solar distribution, sky long-wave exchange) all default to the original model.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Annotated, Any, Literal, Self, get_type_hints

from pydantic import (
    AfterValidator,
    AllowInfNan,
    BaseModel,
    ConfigDict,
    Field,
    Strict,
    create_model,
    model_validator,
)
from pydantic_core import PydanticCustomError

from hvacflex.building.identified import (
    MIN_RUNNING_PERIODS,
    WEEKDAYS,
    IdentifiedPower,
    parse_hours,
)
from hvacflex.building.model import (
    ADIABATIC,
    BOUNDARIES,
    DEFAULT_INSIDE_FILM_W_PER_M2K,
    DEFAULT_OUTSIDE_FILM_W_PER_M2K,
    DEFAULT_SOLAR_ABSORPTANCE,
    GROUND,
    MAX_SUPPLY_TEMP_DEGC,
    OUTSIDE,
)

Number = Annotated[float, Strict(), AllowInfNan(False)]
"""A finite TOML number (integer or float; booleans and strings refused)."""
Fraction = Annotated[Number, Field(ge=0.0, le=1.0)]
NonNegative = Annotated[Number, Field(ge=0.0)]
Positive = Annotated[Number, Field(gt=0.0)]
Text = Annotated[str, Strict(), Field(min_length=1)]
"""A non-empty string."""

ZONE_NAME_PATTERN = r"^[a-z][a-z0-9_]*$"
"""Zone names: lower-case identifiers (used in channel and column names), not a boundary."""

SOLAR_FRACTION_TOLERANCE = 1e-6
"""Rounding allowance when checking that a zone's transmitted-solar shares sum to ≤ 1."""

PER_ZONE_HVAC_KEYS = ("flow_min_kg_s", "flow_max_kg_s", "ventilation_flow_kg_s")
"""``[hvac]`` keys given per zone: a table keyed by zone name or an array in zone order."""

RULE_ERROR = "building_rule"
"""Error type of :func:`rule_error` (a cross-field check of the building file)."""


def rule_error(
    message: str, field: str, value: object = None, hint: str | None = None
) -> PydanticCustomError:
    """A validation error for a check that spans fields.

    ``field`` is the path from the model that raises it (``walls[1].adjacent``); the
    converter in :mod:`hvacflex.building.io` reads ``field``, ``value`` and ``hint`` back.
    """
    return PydanticCustomError(
        RULE_ERROR, "{message}", {"message": message, "field": field, "value": value, "hint": hint}
    )


def _not_a_boundary(name: str) -> str:
    if name in BOUNDARIES:
        raise rule_error(
            "invalid zone name", "", name, hint=f"{list(BOUNDARIES)} name the far side of a wall"
        )
    return name


class Spec(BaseModel):
    """Base of every table: frozen, unknown keys refused."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class ZoneSpec(Spec):
    """``floor_area_m2`` and ``height_m`` are required unless the building is identified."""

    name: Annotated[Text, Field(pattern=ZONE_NAME_PATTERN), AfterValidator(_not_a_boundary)]
    floor_area_m2: Positive | None = None
    height_m: Positive | None = None
    capacitance_multiplier: Annotated[Number, Field(ge=1.0)] = 1.0
    infiltration_ach: NonNegative = 0.0
    internal_gain_radiative_fraction: Fraction = 0.0
    solar_lost_fraction: Fraction = 0.0
    interior_radiation_w_per_m2k: Positive | None = None
    energyplus_zone: Annotated[Text, Field(min_length=1)] | None = None


class LayerSpec(Spec):
    """Density and specific heat may be 0: a massless (no-node) layer such as BESTEST's
    floor insulation."""

    thickness_m: Positive
    conductivity_w_per_mk: Positive
    density_kg_per_m3: NonNegative
    specific_heat_j_per_kgk: NonNegative


class ConstructionSpec(Spec):
    """Either ``layers`` or both ``r_value_m2k_per_w`` and ``capacitance_j_per_m2k``."""

    r_value_m2k_per_w: Positive | None = None
    capacitance_j_per_m2k: Positive | None = None
    layers: Annotated[list[LayerSpec], Field(min_length=1)] | None = None
    inside_film_w_per_m2k: Positive = DEFAULT_INSIDE_FILM_W_PER_M2K
    outside_film_w_per_m2k: Positive | None = None
    nodes_per_layer: Annotated[int, Strict(), Field(ge=1)] | None = None

    @model_validator(mode="after")
    def _one_form(self) -> Self:
        homogeneous = self.r_value_m2k_per_w is not None or self.capacitance_j_per_m2k is not None
        if (self.layers is not None) == homogeneous:
            raise rule_error(
                "give either 'layers' or both 'r_value_m2k_per_w' and 'capacitance_j_per_m2k'",
                "",
                sorted(self.model_fields_set),
            )
        for key in ("r_value_m2k_per_w", "capacitance_j_per_m2k"):
            if homogeneous and getattr(self, key) is None:
                raise rule_error("missing required field", key, hint="add it to the file")
        if self.layers is not None and all(
            layer.density_kg_per_m3 * layer.specific_heat_j_per_kgk <= 0.0 for layer in self.layers
        ):
            raise rule_error(
                "every layer is massless",
                "layers",
                hint="at least one layer needs density and specific heat > 0 (a massless "
                "construction is a window-like conductance)",
            )
        return self


class SurfaceSpec(Spec):
    """Orientation shared by walls and windows; the azimuth of a tilted exterior surface is
    required (checked by :class:`BuildingSpec`), a horizontal one has none."""

    name: Text
    zone: Text
    area_m2: Positive
    azimuth_deg: Number | None = None
    tilt_deg: Annotated[Number, Field(ge=0.0, le=180.0)] = 90.0
    thermal_emissivity: Fraction | None = None

    @property
    def is_horizontal(self) -> bool:
        return self.tilt_deg in (0.0, 180.0)


class WallSpec(SurfaceSpec):
    adjacent: Text
    construction: Text
    solar_absorptance: Fraction = DEFAULT_SOLAR_ABSORPTANCE
    interior_solar_fraction: Fraction | None = None


class WindowSpec(SurfaceSpec):
    u_value_w_per_m2k: Positive
    shgc: Fraction
    outside_film_w_per_m2k: Positive = DEFAULT_OUTSIDE_FILM_W_PER_M2K
    shgc_normal: Fraction | None = None
    incidence_angle_modifier: (
        Annotated[
            list[tuple[Number, Annotated[Number, Field(ge=0.0, le=1.5)]]], Field(min_length=2)
        ]
        | None
    ) = None

    @model_validator(mode="after")
    def _angles_increase(self) -> Self:
        pairs = self.incidence_angle_modifier
        if pairs is not None:
            angles = [angle for angle, _ in pairs]
            if angles != sorted(angles) or angles[0] < 0.0 or angles[-1] > 90.0:
                raise rule_error(
                    "angles must increase within [0, 90]", "incidence_angle_modifier", pairs
                )
        return self


class GainsSpec(Spec):
    occupancy_m2_per_person: Positive
    sensible_w_per_person: NonNegative
    latent_w_per_person: NonNegative
    lighting_w_per_m2: NonNegative
    equipment_w_per_m2: NonNegative


class HvacSpec(Spec):
    """Per-zone flows arrive here as tables keyed by zone name (arrays are keyed by
    :class:`BuildingSpec` before validation)."""

    supply_temp_degc: Annotated[Number, Field(lt=MAX_SUPPLY_TEMP_DEGC)]
    flow_min_kg_s: dict[str, NonNegative]
    flow_max_kg_s: dict[str, Positive]
    ventilation_flow_kg_s: dict[str, NonNegative] | None = None
    outdoor_air_fraction: Fraction
    cop: Positive
    fan_coeff_kw: NonNegative
    fan_exponent: Annotated[Number, Field(ge=1.0)]
    reserve_zones: list[Annotated[str, Strict()]] | None = None
    heating_efficiency: Positive = 1.0
    supply_humidity_ratio_kg_per_kg: Annotated[Number, Field(gt=0.0, le=0.05)] | None = None
    outdoor_air_l_s_per_person: NonNegative | None = None
    outdoor_air_l_s_per_m2: NonNegative | None = None
    fan_part_load_coefficients: (
        Annotated[list[Number], Field(min_length=4, max_length=4)] | None
    ) = None
    chiller: ChillerSpec | None = None
    outdoor_air_purge_h: Annotated[Number, Field(ge=0.0, le=12.0, multiple_of=0.5)] = 0.0
    """Pre-occupancy purge [h] (whole half hours): the outdoor-air damper opens this long
    before each occupied spell; otherwise it opens only while occupied."""


FanCurve = Annotated[list[Number], Field(min_length=4, max_length=4)]
"""(c1, c2, c3, c4) of the fan's part-load curve (``hvacflex.building.air_handler``)."""


class ChillerSpec(Spec):
    """``[hvac.chiller]``: EnergyPlus's EIR chiller with its DOE-2.1E reciprocating curves
    (:mod:`hvacflex.building.chiller`); the reference COP is ``[hvac] cop``."""

    capacity_kw: Positive
    min_part_load_ratio: Annotated[Number, Field(gt=0.0, le=1.0)] = 0.25
    condenser_fan_kw_per_kw: NonNegative = 0.035
    pump_design_kw: NonNegative = 0.0


class IdentifiedZoneSpec(Spec):
    c_air_kj_per_k: Positive
    c_mass_kj_per_k: Positive
    ua_out_kw_per_k: NonNegative
    ua_air_mass_kw_per_k: Positive
    ua_mass_out_kw_per_k: NonNegative
    solar_air_m2: NonNegative
    solar_mass_m2: NonNegative
    occupied_gain_kw: NonNegative
    base_gain_kw: Number
    flow_min_kg_s: NonNegative
    flow_max_kg_s: Positive
    ventilation_flow_kg_s: NonNegative
    mass_temp_degc: Annotated[Number, Field(ge=-50.0, le=70.0)]
    solar_wall_north_m2: NonNegative = 0.0
    solar_wall_east_m2: NonNegative = 0.0
    solar_wall_south_m2: NonNegative = 0.0
    solar_wall_west_m2: NonNegative = 0.0

    @model_validator(mode="after")
    def _flows_ordered(self) -> Self:
        if not self.flow_min_kg_s <= self.ventilation_flow_kg_s <= self.flow_max_kg_s:
            raise rule_error(
                "flows must satisfy flow_min_kg_s ≤ ventilation_flow_kg_s ≤ flow_max_kg_s",
                "ventilation_flow_kg_s",
                self.ventilation_flow_kg_s,
                hint=f"the range is {self.flow_min_kg_s:g} … {self.flow_max_kg_s:g} kg/s",
            )
        return self


class IdentifiedCouplingSpec(Spec):
    zones: Annotated[list[Text], Field(min_length=2, max_length=2)]
    ua_kw_per_k: NonNegative


class IdentifiedBoundarySpec(Spec):
    name: Text
    c_kj_per_k: Positive
    ua_out_kw_per_k: NonNegative
    solar_m2: NonNegative
    occupied_gain_kw: NonNegative
    ua_zone_kw_per_k: dict[str, NonNegative]
    temp_degc: Annotated[Number, Field(ge=-50.0, le=70.0)]


POWER_FIELD_RANGES: dict[str, Any] = {"running_periods": Field(ge=MIN_RUNNING_PERIODS)}
"""The ranges of :class:`IdentifiedPower`'s fields that have one (the others: any finite
number)."""


def identified_power_fields() -> dict[str, Any]:
    """:class:`~hvacflex.building.identified.IdentifiedPower`'s fields as the schema's, the
    dataclass being their one home: each a finite :data:`Number` in its
    :data:`POWER_FIELD_RANGES` range, optional (absent: None) where the dataclass allows None,
    defaulted as the dataclass defaults it, required where it has no default.

    Raises
    ------
    TypeError
        When the dataclass has a field that is not a float or an optional float (a new field
        the file format would need a rule for).
    """
    hints = get_type_hints(IdentifiedPower)
    fields: dict[str, Any] = {}
    for field in dataclasses.fields(IdentifiedPower):
        number: Any = Annotated[Number, POWER_FIELD_RANGES.get(field.name, Field())]
        if hints[field.name] == float | None:
            number = number | None
        elif hints[field.name] is not float:
            raise TypeError(f"IdentifiedPower.{field.name}: a float or float | None expected")
        default = ... if field.default is dataclasses.MISSING else field.default
        fields[field.name] = (number, default)
    return fields


if TYPE_CHECKING:
    IdentifiedPowerSpec = Spec
else:
    IdentifiedPowerSpec = create_model(
        "IdentifiedPowerSpec",
        __base__=Spec,
        __module__=__name__,
        __doc__="A power model fitted to the meter (:class:`hvacflex.building.identified."
        "IdentifiedPower`; its fields: :func:`identified_power_fields`).",
        **identified_power_fields(),
    )


class IdentifiedValiditySpec(Spec):
    """The training data's range: per zone its air temperatures, and the outdoor air."""

    zone_temp_min_degc: dict[str, Annotated[Number, Field(ge=-50.0, le=70.0)]]
    zone_temp_max_degc: dict[str, Annotated[Number, Field(ge=-50.0, le=70.0)]]
    outdoor_temp_min_degc: Annotated[Number, Field(ge=-50.0, le=70.0)]
    outdoor_temp_max_degc: Annotated[Number, Field(ge=-50.0, le=70.0)]


class IdentifiedIdleAirSpec(Spec):
    """An idle zone's fan-only air: the hours per weekday, each zone's temperature drop."""

    fan_only_hours: dict[str, list[Annotated[str, Strict()]]]
    fan_only_difference_k: dict[str, Annotated[Number, Field(ge=-20.0, le=50.0)]]
    fan_only_flow_kg_s: dict[str, Annotated[Number, Field(ge=0.0, le=1e3)]] | None = None


class IdentifiedSpec(Spec):
    supply_temp_degc: Annotated[Number, Field(lt=MAX_SUPPLY_TEMP_DEGC)]
    provenance: dict[str, Annotated[str, Strict()]] = {}
    zones: dict[str, IdentifiedZoneSpec]
    couplings: list[IdentifiedCouplingSpec] = []
    boundaries: list[IdentifiedBoundarySpec] = []
    power_model: IdentifiedPowerSpec | None = None
    validity: IdentifiedValiditySpec | None = None
    idle_air: IdentifiedIdleAirSpec | None = None


class BuildingSpec(Spec):
    """The whole file."""

    name: Text
    description: Annotated[str, Strict()] = ""
    latitude_deg: Annotated[Number, Field(ge=-90.0, le=90.0)] | None = None
    longitude_deg: Annotated[Number, Field(ge=-180.0, le=180.0)] | None = None
    height_above_ground_m: Annotated[Number, Field(ge=0.0, le=1000.0)] = 0.0
    zones: Annotated[list[ZoneSpec], Field(min_length=1)]
    constructions: dict[str, ConstructionSpec] = {}
    walls: list[WallSpec] = []
    windows: list[WindowSpec] = []
    gains: GainsSpec | None = None
    hvac: HvacSpec | None = None
    identified: IdentifiedSpec | None = None
    power_models: dict[Literal["rc", "energyplus"], IdentifiedPowerSpec] = {}

    @model_validator(mode="before")
    @classmethod
    def _key_per_zone_arrays(cls, data: Any) -> Any:
        """``flow_max_kg_s = [0.3, 0.3]`` → ``{a = 0.3, b = 0.3}`` in zone order."""
        names = _raw_zone_names(data)
        hvac = data.get("hvac") if isinstance(data, dict) else None
        if names is None or not isinstance(hvac, dict):
            return data
        keyed = dict(hvac)
        for key in PER_ZONE_HVAC_KEYS:
            raw = hvac.get(key)
            if isinstance(raw, list):
                if len(raw) != len(names):
                    raise rule_error(
                        f"expected {len(names)} values (one per zone)",
                        f"hvac.{key}",
                        raw,
                        hint=f"or a table keyed by zone name {names}",
                    )
                keyed[key] = dict(zip(names, raw, strict=True))
        return {**data, "hvac": keyed}

    @property
    def zone_names(self) -> tuple[str, ...]:
        return tuple(zone.name for zone in self.zones)

    @model_validator(mode="after")
    def _cross_checks(self) -> Self:
        if self.identified is not None:
            _check_identified(self, self.identified)
            return self
        _check_designed(self)
        _check_walls(self)
        _check_windows(self)
        _check_unique_names(self)
        _check_connected(self)
        _check_solar_distribution(self)
        _check_hvac(self)
        return self


def _raw_zone_names(data: Any) -> list[str] | None:
    """The zone names of an unvalidated document, if they are all strings."""
    zones = data.get("zones") if isinstance(data, dict) else None
    if not isinstance(zones, list):
        return None
    names = [zone.get("name") if isinstance(zone, dict) else None for zone in zones]
    return (
        [name for name in names if isinstance(name, str)]
        if all(isinstance(name, str) for name in names)
        else None
    )


def _check_zone_ref(spec: BuildingSpec, zone: str, where: str) -> None:
    if zone not in spec.zone_names:
        raise rule_error("unknown zone", where, zone, hint=f"zones are {list(spec.zone_names)}")


def _check_azimuth(surface: SurfaceSpec, where: str) -> None:
    if surface.azimuth_deg is None and not surface.is_horizontal:
        raise rule_error(
            "missing required field",
            f"{where}.azimuth_deg",
            hint="exterior surfaces need an azimuth",
        )


def _check_walls(spec: BuildingSpec) -> None:
    for i, wall in enumerate(spec.walls):
        where = f"walls[{i}]"
        _check_zone_ref(spec, wall.zone, f"{where}.zone")
        if wall.adjacent not in BOUNDARIES and wall.adjacent not in spec.zone_names:
            raise rule_error(
                "unknown zone or boundary",
                f"{where}.adjacent",
                wall.adjacent,
                hint=f"use one of {list(BOUNDARIES)} or a zone name {list(spec.zone_names)}",
            )
        if wall.adjacent == wall.zone:
            raise rule_error(
                "a wall cannot connect a zone to itself", f"{where}.adjacent", wall.adjacent
            )
        if wall.construction not in spec.constructions:
            raise rule_error(
                "unknown construction",
                f"{where}.construction",
                wall.construction,
                hint=f"define [constructions.{wall.construction}] or use one of "
                f"{sorted(spec.constructions)}",
            )
        if wall.adjacent == OUTSIDE:
            _check_azimuth(wall, where)


def _check_windows(spec: BuildingSpec) -> None:
    for i, window in enumerate(spec.windows):
        _check_azimuth(window, f"windows[{i}]")
        _check_zone_ref(spec, window.zone, f"windows[{i}].zone")


def _check_unique_names(spec: BuildingSpec) -> None:
    seen: dict[str, str] = {}
    entries = [(f"zones[{i}].name", z.name) for i, z in enumerate(spec.zones)]
    entries += [(f"walls[{i}].name", w.name) for i, w in enumerate(spec.walls)]
    entries += [(f"windows[{i}].name", w.name) for i, w in enumerate(spec.windows)]
    for where, name in entries:
        if name in seen:
            raise rule_error(
                f"duplicate name (already used by {seen[name]})",
                where,
                name,
                hint="zone, wall and window names must be unique",
            )
        seen[name] = where


def _check_connected(spec: BuildingSpec) -> None:
    """Every zone must reach the outside air or the ground through walls and windows."""
    neighbours: dict[str, set[str]] = {name: set() for name in spec.zone_names}
    for wall in spec.walls:
        if wall.adjacent == ADIABATIC:
            continue
        neighbours[wall.zone].add(wall.adjacent)
        if wall.adjacent in neighbours:
            neighbours[wall.adjacent].add(wall.zone)
    for window in spec.windows:
        neighbours[window.zone].add(OUTSIDE)
    reached: set[str] = set()
    frontier = [name for name in spec.zone_names if neighbours[name] & {OUTSIDE, GROUND}]
    while frontier:
        name = frontier.pop()
        if name in reached:
            continue
        reached.add(name)
        frontier.extend(n for n in neighbours[name] if n in neighbours and n not in reached)
    for i, name in enumerate(spec.zone_names):
        if name not in reached:
            raise rule_error(
                "zone is not connected to the outside or the ground through any wall or window",
                f"zones[{i}]",
                name,
                hint="add a wall with adjacent = 'outside' or 'ground', a window, or a wall to a "
                "connected zone (adiabatic walls do not count)",
            )


def _check_solar_distribution(spec: BuildingSpec) -> None:
    """The transmitted-solar shares of a zone (walls + lost) may not exceed 1."""
    for i, zone in enumerate(spec.zones):
        assigned = sum(w.interior_solar_fraction or 0.0 for w in spec.walls if w.zone == zone.name)
        total = assigned + zone.solar_lost_fraction
        if total > 1.0 + SOLAR_FRACTION_TOLERANCE:
            raise rule_error(
                f"transmitted-solar shares add up to {total:.4f} > 1 (walls' "
                f"interior_solar_fraction {assigned:.4f} + solar_lost_fraction)",
                f"zones[{i}]",
                zone.name,
                hint="the shares of the zone's transmitted solar must sum to at most 1 (the "
                "rest goes to the air node)",
            )


def _check_per_zone_keys(spec: BuildingSpec, field: str, table: dict[str, float]) -> None:
    """Every key of ``table`` (at ``field``, e.g. ``hvac.flow_min_kg_s``) names a zone, and
    every zone has one."""
    for name in table:
        _check_zone_ref(spec, name, f"{field}.{name}")
    for name in spec.zone_names:
        if name not in table:
            raise rule_error("missing required field", f"{field}.{name}", hint="add it to the file")


def _check_hvac(spec: BuildingSpec) -> None:
    hvac = spec.hvac
    assert hvac is not None  # _check_designed ran first
    _check_per_zone_keys(spec, "hvac.flow_min_kg_s", hvac.flow_min_kg_s)
    _check_per_zone_keys(spec, "hvac.flow_max_kg_s", hvac.flow_max_kg_s)
    for name in spec.zone_names:
        low, high = hvac.flow_min_kg_s[name], hvac.flow_max_kg_s[name]
        if low > high:
            raise rule_error(
                f"minimum flow exceeds the maximum flow {high:g} kg/s",
                f"hvac.flow_min_kg_s.{name}",
                low,
                hint="flow_min_kg_s must be ≤ flow_max_kg_s",
            )
    if hvac.ventilation_flow_kg_s is not None:
        _check_per_zone_keys(spec, "hvac.ventilation_flow_kg_s", hvac.ventilation_flow_kg_s)
        for name in spec.zone_names:
            low, high = hvac.flow_min_kg_s[name], hvac.flow_max_kg_s[name]
            vent = hvac.ventilation_flow_kg_s[name]
            if not low <= vent <= high:
                raise rule_error(
                    f"must lie between the minimum {low:g} and maximum {high:g} kg/s",
                    f"hvac.ventilation_flow_kg_s.{name}",
                    vent,
                    hint="flow_min_kg_s ≤ ventilation_flow_kg_s ≤ flow_max_kg_s",
                )
    for zone in hvac.reserve_zones or []:
        _check_zone_ref(spec, zone, "hvac.reserve_zones")


def _check_designed(spec: BuildingSpec) -> None:
    """A designed building needs its geometry, ``[gains]`` and ``[hvac]``."""
    for i, zone in enumerate(spec.zones):
        for key in ("floor_area_m2", "height_m"):
            if getattr(zone, key) is None:
                raise rule_error("missing required field", f"zones[{i}].{key}", hint="add it")
    for key in ("gains", "hvac"):
        if getattr(spec, key) is None:
            raise rule_error(
                "missing required field",
                key,
                hint=f"add [{key}] (or an [identified] table: hvacflex identify fit)",
            )


def _check_identified_areas(spec: BuildingSpec) -> None:
    """An identified building's zones carry a ``floor_area_m2`` each or none (a model whose
    areas are unknown); never a ``height_m`` (its network has no volume)."""
    given = [zone.floor_area_m2 is not None for zone in spec.zones]
    if any(given) and not all(given):
        i = given.index(False)
        raise rule_error(
            "missing floor area: give every zone's floor_area_m2 or none",
            f"zones[{i}].floor_area_m2",
            hint="add the zone's floor area [m²] (the IDF's zone floor, or the building's "
            "plans), or remove the others' (per-m² figures are then not available)",
        )
    for i, zone in enumerate(spec.zones):
        if zone.height_m is not None:
            raise rule_error(
                "an identified zone has no height",
                f"zones[{i}].height_m",
                zone.height_m,
                hint="remove it: the fitted capacitances hold the zone's air",
            )


def _check_validity(spec: BuildingSpec, validity: IdentifiedValiditySpec) -> None:
    """Every zone has its range, each range's minimum at most its maximum."""
    for key in ("zone_temp_min_degc", "zone_temp_max_degc"):
        table = getattr(validity, key)
        for name in table:
            _check_zone_ref(spec, name, f"identified.validity.{key}.{name}")
        for name in spec.zone_names:
            if name not in table:
                raise rule_error(
                    "missing required field", f"identified.validity.{key}.{name}", hint="add it"
                )
    for name in spec.zone_names:
        low, high = validity.zone_temp_min_degc[name], validity.zone_temp_max_degc[name]
        if low > high:
            raise rule_error(
                f"exceeds the maximum {high:g} °C",
                f"identified.validity.zone_temp_min_degc.{name}",
                low,
                hint="the minimum must be ≤ the maximum",
            )
    if validity.outdoor_temp_min_degc > validity.outdoor_temp_max_degc:
        raise rule_error(
            f"exceeds the maximum {validity.outdoor_temp_max_degc:g} °C",
            "identified.validity.outdoor_temp_min_degc",
            validity.outdoor_temp_min_degc,
            hint="the minimum must be ≤ the maximum",
        )


def _check_idle_air(spec: BuildingSpec, idle: IdentifiedIdleAirSpec) -> None:
    """Weekdays by name, spans ``HH:MM-HH:MM``, every zone's temperature drop."""
    for day, spans in idle.fan_only_hours.items():
        field = f"identified.idle_air.fan_only_hours.{day}"
        if day not in WEEKDAYS:
            raise rule_error("unknown weekday", field, day, hint=f"one of {list(WEEKDAYS)}")
        try:
            parse_hours(spans)
        except ValueError as error:
            raise rule_error(str(error), field, spans, hint='e.g. ["00:00-06:00"]') from None
    for key, table in (
        ("fan_only_difference_k", idle.fan_only_difference_k),
        ("fan_only_flow_kg_s", idle.fan_only_flow_kg_s),
    ):
        if table is not None:
            _check_per_zone_keys(spec, f"identified.idle_air.{key}", table)


def _check_identified(spec: BuildingSpec, identified: IdentifiedSpec) -> None:
    """An identified building: no envelope, gains or HVAC tables; one parameter table per
    zone; couplings and boundaries naming its zones."""
    for key in ("walls", "windows", "constructions", "gains", "hvac"):
        if getattr(spec, key):
            raise rule_error(
                "an identified building has no envelope, gains or HVAC tables",
                key,
                hint="remove it: the [identified] table holds the fitted model",
            )
    names = spec.zone_names
    _check_identified_areas(spec)
    if sorted(identified.zones) != sorted(names):
        raise rule_error(
            "the identified zones differ from [[zones]]",
            "identified.zones",
            sorted(identified.zones),
            hint=f"give one [identified.zones.<name>] table per zone of {list(names)}",
        )
    for i, coupling in enumerate(identified.couplings):
        for zone in coupling.zones:
            _check_zone_ref(spec, zone, f"identified.couplings[{i}].zones")
    for i, boundary in enumerate(identified.boundaries):
        for zone in boundary.ua_zone_kw_per_k:
            _check_zone_ref(spec, zone, f"identified.boundaries[{i}].ua_zone_kw_per_k")
    if identified.validity is not None:
        _check_validity(spec, identified.validity)
    if identified.idle_air is not None:
        _check_idle_air(spec, identified.idle_air)
