"""Building TOML files in, :class:`~hvacflex.building.model.Building` out.

``load_building`` reads the file (:func:`hvacflex.tomlio.read_toml`), validates it against
the schema of :mod:`hvacflex.building.schema` and converts it into the frozen domain objects;
the rest of the package trusts them. A schema violation becomes a ``BuildingConfigError``
that names the file, the field path (``walls[3].area_m2``), the value and a hint.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, get_args, get_origin

from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails

from hvacflex.building.chiller import ChillerPerformance
from hvacflex.building.identified import (
    GAIN_CHANNEL_PEAK_W,
    NOMINAL_FLOOR_AREA_M2,
    NOMINAL_HEIGHT_M,
    WEEKDAYS,
    IdentifiedBoundary,
    IdentifiedCoupling,
    IdentifiedIdleAir,
    IdentifiedPower,
    IdentifiedRC,
    IdentifiedValidity,
    IdentifiedZone,
    parse_hours,
)
from hvacflex.building.model import (
    OUTSIDE,
    Building,
    Construction,
    HvacSystem,
    InternalGains,
    Layer,
    Wall,
    Window,
    Zone,
)
from hvacflex.building.schema import (
    RULE_ERROR,
    BuildingSpec,
    ConstructionSpec,
    HvacSpec,
    IdentifiedSpec,
    SurfaceSpec,
    WallSpec,
    WindowSpec,
)
from hvacflex.errors import BuildingConfigError
from hvacflex.tomlio import read_toml
from hvacflex.units import RHO_AIR_KG_PER_M3

FIELD_HINTS: dict[str, str] = {
    "zones": "add [[zones]]",
    "zones.name": "use lower-case letters, digits and '_', starting with a letter, and not "
    "one of ['outside', 'ground', 'adiabatic']",
    "capacitance_multiplier": "1 is the air alone; furniture and internal mass add to it",
    "layers": "an array of layer tables {thickness_m, conductivity_w_per_mk, "
    "density_kg_per_m3, specific_heat_j_per_kgk}, outside → inside",
    "incidence_angle_modifier": "an array of [angle_deg, factor] pairs, angles increasing "
    "from 0 to 90",
    "supply_temp_degc": "the model is cooling-only with a fixed supply temperature below the "
    "comfort band, typically 12–14 °C",
    "fan_exponent": "a convex fan curve needs n ≥ 1; fan affinity laws give 2–3",
    "flow_min_kg_s": "a table keyed by zone name, or an array with one value per zone",
    "flow_max_kg_s": "a table keyed by zone name, or an array with one value per zone",
    "ventilation_flow_kg_s": "a table keyed by zone name, or an array with one value per zone",
    "reserve_zones": "an array of zone names",
    "running_periods": "a power model fitted on so few periods with the air loop running is "
    "not trusted: refit it on a trend with more HVAC operation (hvacflex identify power / "
    "identify fit, docs/guide/identify.md)",
}
"""Hints added to schema errors, by field name or ``table.field`` (indices dropped)."""

_MESSAGES: dict[str, str] = {
    "missing": "missing required field",
    "extra_forbidden": "unknown key",
    "float_type": "expected a finite number",
    "float_parsing": "expected a finite number",
    "finite_number": "expected a finite number",
    "int_type": "expected an integer",
    "string_type": "expected a string",
    "bool_type": "expected true or false",
    "string_too_short": "expected a non-empty string",
    "string_pattern_mismatch": "invalid zone name",
    "list_type": "expected an array",
    "tuple_type": "expected an array",
    "too_short": "too few entries (at least {min_length})",
    "dict_type": "expected a table",
    "model_type": "expected a table",
    "greater_than": "must be > {gt:g}",
    "greater_than_equal": "must be ≥ {ge:g}",
    "less_than": "must be < {lt:g}",
    "less_than_equal": "must be ≤ {le:g}",
}
"""Our wording of pydantic's error types (``ctx`` fills the braces)."""


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
    BuildingConfigError : naming the file, the field (``walls[3].area_m2``) and the value;
        also for a file that is missing, not UTF-8 text, empty or not TOML.
    """
    source = Path(path)
    data = read_toml(source, what="building", error=BuildingConfigError)
    return building_from_dict(data, source=source)


def building_from_dict(data: Mapping[str, Any], *, source: Path | str = "<dict>") -> Building:
    """Validate a parsed TOML document (``dict``) into a :class:`Building`.

    ``source`` names the origin in error messages; it becomes ``source_path`` when a path.
    """
    try:
        spec = BuildingSpec.model_validate(dict(data))
    except ValidationError as exc:
        raise config_error(exc, source) from None
    return to_building(spec, source_path=Path(source) if isinstance(source, Path) else None)


def config_error(exc: ValidationError, source: Path | str) -> BuildingConfigError:
    """The first problem of a schema ``ValidationError`` as a ``BuildingConfigError``.

    An unknown key is reported first (a misspelt key also makes the intended one missing).

    The field path joins pydantic's location (``zones[2].floor_area_m2``), extended by the
    ``field`` a cross-field rule names; the message is ours (``_MESSAGES``); the hint comes
    from the rule or from ``FIELD_HINTS``.
    """
    errors = exc.errors(include_url=False)
    error: ErrorDetails = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
    ctx: dict[str, Any] = dict(error.get("ctx") or {})
    loc: tuple[int | str, ...] = tuple(error["loc"])
    value: object = error["input"]
    hint: str | None = None
    if error["type"] == RULE_ERROR:
        loc += _parse_path(ctx["field"])
        message, value, hint = str(ctx["message"]), ctx["value"], ctx["hint"]
    elif error["type"] == "extra_forbidden":
        message, value = "unknown key", loc[-1]
        allowed = _model_at(loc[:-1])
        hint = f"allowed keys here: {sorted(allowed.model_fields)}" if allowed else None
    else:
        template = _MESSAGES.get(error["type"])
        message = template.format(**ctx) if template else error["msg"]
        if error["type"] == "missing":
            value, hint = None, "add it to the file"
    field = _join(loc)
    named = [part for part in loc if isinstance(part, str)]
    hint = (
        hint or FIELD_HINTS.get(".".join(named[-2:])) or FIELD_HINTS.get(named[-1] if named else "")
    )
    return BuildingConfigError(message, source=source, field=field, value=value, hint=hint)


def _join(loc: tuple[int | str, ...]) -> str:
    """``("walls", 0, "area_m2")`` → ``walls[0].area_m2``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else f".{part}" if text else str(part)
    return text


def _parse_path(path: str) -> tuple[int | str, ...]:
    """``walls[1].adjacent`` → ``("walls", 1, "adjacent")``; ``""`` → ``()``."""
    parts: list[int | str] = []
    for piece in filter(None, path.split(".")):
        name, *indices = piece.replace("]", "").split("[")
        parts.append(name)
        parts.extend(int(index) for index in indices)
    return tuple(parts)


def _model_at(loc: tuple[int | str, ...]) -> type[BaseModel] | None:
    """The schema model found at a location of the document (for the allowed keys)."""
    kind: Any = BuildingSpec
    for part in loc:
        if _is_model(kind):
            if not isinstance(part, str) or part not in kind.model_fields:
                return None
            kind = kind.model_fields[part].annotation
        else:  # an index into a list or a key of a table
            kind = _unwrap(kind)
    kind = _unwrap(kind)
    return kind if _is_model(kind) else None


def _is_model(kind: Any) -> bool:
    return isinstance(kind, type) and issubclass(kind, BaseModel)


def _unwrap(kind: Any) -> Any:
    """The model inside ``list[X]``, ``dict[str, X]`` or ``X | None``, else ``kind``."""
    if _is_model(kind):
        return kind
    for arg in get_args(kind) if get_origin(kind) is not None else ():
        inner = _unwrap(arg)
        if _is_model(inner):
            return inner
    return kind


# --------------------------------------------------------------------------------------
# Schema → domain objects
# --------------------------------------------------------------------------------------


def to_building(spec: BuildingSpec, *, source_path: Path | None = None) -> Building:
    """The domain :class:`Building` of a validated file."""
    if spec.identified is not None:
        return _identified_building(spec, spec.identified, source_path)
    assert spec.gains is not None and spec.hvac is not None  # checked by the schema
    constructions = {name: _construction(name, c) for name, c in spec.constructions.items()}
    return Building(
        name=spec.name,
        zones=tuple(Zone(**zone.model_dump()) for zone in spec.zones),
        walls=tuple(_wall(wall, constructions) for wall in spec.walls),
        windows=tuple(_window(window) for window in spec.windows),
        constructions=constructions,
        gains=InternalGains(**spec.gains.model_dump()),
        hvac=_hvac(spec.hvac, spec.zone_names, _design_people(spec), _floor_area_m2(spec)),
        description=spec.description,
        latitude_deg=spec.latitude_deg,
        height_above_ground_m=spec.height_above_ground_m,
        longitude_deg=spec.longitude_deg,
        source_path=source_path,
        power_models={
            plant: IdentifiedPower(**model.model_dump())
            for plant, model in spec.power_models.items()
        },
    )


def _construction(name: str, spec: ConstructionSpec) -> Construction:
    if spec.layers is not None:
        layers = tuple(Layer(**layer.model_dump()) for layer in spec.layers)
    else:
        assert spec.r_value_m2k_per_w is not None and spec.capacitance_j_per_m2k is not None
        # a unit-thickness layer with k = 1/R and ρc = C carries R and C exactly
        layers = (Layer(1.0, 1.0 / spec.r_value_m2k_per_w, spec.capacitance_j_per_m2k, 1.0),)
    return Construction(
        name=name,
        layers=layers,
        inside_film_w_per_m2k=spec.inside_film_w_per_m2k,
        outside_film_w_per_m2k=spec.outside_film_w_per_m2k,
        nodes_per_layer=spec.nodes_per_layer,
    )


def _orientation(surface: SurfaceSpec) -> tuple[float, float]:
    """(azimuth_deg in [0, 360), tilt_deg); a horizontal surface has azimuth 0."""
    if surface.is_horizontal:
        return 0.0, surface.tilt_deg
    return (surface.azimuth_deg or 0.0) % 360.0, surface.tilt_deg


def _wall(spec: WallSpec, constructions: Mapping[str, Construction]) -> Wall:
    azimuth, tilt = _orientation(spec)
    exterior = spec.adjacent == OUTSIDE
    return Wall(
        name=spec.name,
        zone=spec.zone,
        adjacent=spec.adjacent,
        construction=constructions[spec.construction],
        area_m2=spec.area_m2,
        azimuth_deg=azimuth,
        tilt_deg=tilt,
        solar_absorptance=spec.solar_absorptance if exterior else 0.0,
        thermal_emissivity=spec.thermal_emissivity if exterior else None,
        interior_solar_fraction=spec.interior_solar_fraction,
    )


def _window(spec: WindowSpec) -> Window:
    azimuth, tilt = _orientation(spec)
    return Window(
        name=spec.name,
        zone=spec.zone,
        area_m2=spec.area_m2,
        u_value_w_per_m2k=spec.u_value_w_per_m2k,
        shgc=spec.shgc,
        azimuth_deg=azimuth,
        tilt_deg=tilt,
        thermal_emissivity=spec.thermal_emissivity,
        outside_film_w_per_m2k=spec.outside_film_w_per_m2k,
        shgc_normal=spec.shgc_normal,
        incidence_angle_modifier=tuple(spec.incidence_angle_modifier or ()),
    )


def _floor_area_m2(spec: BuildingSpec) -> float:
    """Floor area of a designed building [m²] (every zone gives it: checked by the schema)."""
    return sum(zone.floor_area_m2 or 0.0 for zone in spec.zones)


def _design_people(spec: BuildingSpec) -> float:
    """Design occupants of a designed building (its gains are given: checked by the schema)."""
    assert spec.gains is not None
    return _floor_area_m2(spec) / spec.gains.occupancy_m2_per_person


def outdoor_air_need_kg_s(
    people: float, floor_area_m2: float, l_s_per_person: float, l_s_per_m2: float
) -> float:
    """Ventilation need of the breathing zone (ASHRAE 62.1 ventilation-rate procedure,
    V = R_p · P + R_a · A) as a mass flow [kg/s] at ρ = RHO_AIR_KG_PER_M3.

    Parameters
    ----------
    people : design occupancy P [-]; floor_area_m2 : A [m²];
    l_s_per_person : R_p [L/s per person]; l_s_per_m2 : R_a [L/s per m²].
    """
    return (l_s_per_person * people + l_s_per_m2 * floor_area_m2) * RHO_AIR_KG_PER_M3 / 1000.0


def _hvac(
    spec: HvacSpec, zone_names: tuple[str, ...], people: float, floor_area_m2: float
) -> HvacSystem:
    def per_zone(table: Mapping[str, float]) -> tuple[float, ...]:
        return tuple(table[name] for name in zone_names)

    reserve = zone_names if spec.reserve_zones is None else spec.reserve_zones
    outdoor_air = None
    if spec.outdoor_air_l_s_per_person is not None or spec.outdoor_air_l_s_per_m2 is not None:
        outdoor_air = outdoor_air_need_kg_s(
            people,
            floor_area_m2,
            spec.outdoor_air_l_s_per_person or 0.0,
            spec.outdoor_air_l_s_per_m2 or 0.0,
        )
    chiller = None
    if spec.chiller is not None:
        chiller = ChillerPerformance(reference_cop=spec.cop, **spec.chiller.model_dump())
    fan_curve = spec.fan_part_load_coefficients
    return HvacSystem(
        supply_temp_degc=spec.supply_temp_degc,
        flow_min_kg_s=per_zone(spec.flow_min_kg_s),
        flow_max_kg_s=per_zone(spec.flow_max_kg_s),
        outdoor_air_fraction=spec.outdoor_air_fraction,
        cop=spec.cop,
        fan_coeff_kw=spec.fan_coeff_kw,
        fan_exponent=spec.fan_exponent,
        reserve_zones=tuple(z for z in zone_names if z in reserve),
        heating_efficiency=spec.heating_efficiency,
        supply_humidity_ratio_kg_per_kg=spec.supply_humidity_ratio_kg_per_kg,
        ventilation_flow_kg_s=per_zone(spec.ventilation_flow_kg_s or spec.flow_min_kg_s),
        outdoor_air_kg_s=outdoor_air,
        chiller=chiller,
        fan_part_load_coefficients=(
            None if fan_curve is None else (fan_curve[0], fan_curve[1], fan_curve[2], fan_curve[3])
        ),
        outdoor_air_purge_h=float(spec.outdoor_air_purge_h),
    )


def _idle_air(identified: IdentifiedSpec, names: tuple[str, ...]) -> IdentifiedIdleAir | None:
    """The ``[identified.idle_air]`` table in zone order (a weekday not named: none fan-only)."""
    idle = identified.idle_air
    if idle is None:
        return None
    return IdentifiedIdleAir(
        fan_only=tuple(parse_hours(idle.fan_only_hours.get(day, [])) for day in WEEKDAYS),
        fan_only_difference_k=tuple(idle.fan_only_difference_k[n] for n in names),
        fan_only_flow_kg_s=(
            None
            if idle.fan_only_flow_kg_s is None
            else tuple(idle.fan_only_flow_kg_s[n] for n in names)
        ),
    )


def _identified_building(
    spec: BuildingSpec, identified: IdentifiedSpec, source_path: Path | None
) -> Building:
    """An identified building (:mod:`hvacflex.building.identified`): zones with the file's
    floor areas (NaN where it gives none: per-m² figures are then not available) and nominal
    height, gains that make each zone's ``internal_gain`` channel the people schedule × 1 kW
    (over :data:`NOMINAL_FLOOR_AREA_M2`, ``Building.gain_floor_areas_m2``), and an
    air system with the fitted supply temperature and flow ranges (its COP and fan terms are
    not used: the power model is the fitted one)."""
    names = spec.zone_names
    zones = tuple(
        IdentifiedZone(name=name, **identified.zones[name].model_dump()) for name in names
    )
    rc = IdentifiedRC(
        zones=zones,
        couplings=tuple(
            IdentifiedCoupling(c.zones[0], c.zones[1], c.ua_kw_per_k) for c in identified.couplings
        ),
        boundaries=tuple(
            IdentifiedBoundary(
                name=b.name,
                c_kj_per_k=b.c_kj_per_k,
                ua_out_kw_per_k=b.ua_out_kw_per_k,
                solar_m2=b.solar_m2,
                occupied_gain_kw=b.occupied_gain_kw,
                ua_zone_kw_per_k=tuple(b.ua_zone_kw_per_k.items()),
                temp_degc=b.temp_degc,
            )
            for b in identified.boundaries
        ),
        supply_temp_degc=identified.supply_temp_degc,
        power=(
            None
            if identified.power_model is None
            else IdentifiedPower(**identified.power_model.model_dump())
        ),
        provenance=tuple(identified.provenance.items()),
        validity=(
            None
            if identified.validity is None
            else IdentifiedValidity(
                zone_temp_min_degc=tuple(identified.validity.zone_temp_min_degc[n] for n in names),
                zone_temp_max_degc=tuple(identified.validity.zone_temp_max_degc[n] for n in names),
                outdoor_temp_min_degc=identified.validity.outdoor_temp_min_degc,
                outdoor_temp_max_degc=identified.validity.outdoor_temp_max_degc,
            )
        ),
        idle_air=_idle_air(identified, names),
    )
    return Building(
        name=spec.name,
        zones=tuple(
            Zone(
                name=z.name,
                floor_area_m2=math.nan if z.floor_area_m2 is None else z.floor_area_m2,
                height_m=NOMINAL_HEIGHT_M,
                energyplus_zone=z.energyplus_zone,
            )
            for z in spec.zones
        ),
        walls=(),
        windows=(),
        constructions={},
        gains=InternalGains(
            occupancy_m2_per_person=NOMINAL_FLOOR_AREA_M2,
            sensible_w_per_person=GAIN_CHANNEL_PEAK_W,
            latent_w_per_person=0.0,
            lighting_w_per_m2=0.0,
            equipment_w_per_m2=0.0,
        ),
        hvac=HvacSystem(
            supply_temp_degc=identified.supply_temp_degc,
            flow_min_kg_s=tuple(z.flow_min_kg_s for z in zones),
            flow_max_kg_s=tuple(z.flow_max_kg_s for z in zones),
            ventilation_flow_kg_s=tuple(z.ventilation_flow_kg_s for z in zones),
            outdoor_air_fraction=0.0,
            cop=1.0,
            fan_coeff_kw=0.0,
            fan_exponent=1.0,
            reserve_zones=names,
        ),
        description=spec.description,
        latitude_deg=spec.latitude_deg,
        height_above_ground_m=spec.height_above_ground_m,
        longitude_deg=spec.longitude_deg,
        source_path=source_path,
        identified=rc,
    )
