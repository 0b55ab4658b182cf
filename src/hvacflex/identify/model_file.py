"""The identified model (``model.toml``) that ``hvacflex identify fit`` writes: a building file.

The file is a building file of :func:`hvacflex.building.io.load_building`
(docs/explanation/buildings.md, ``[identified]`` in :mod:`hvacflex.building.schema`): ``[[zones]]``
with lower-case identifier names made from the data's names (:func:`identifier`), each with its
data/IDF name in ``energyplus_zone`` (matched case-insensitively by the EnergyPlus plant) and, when
known, its ``floor_area_m2`` (conditioned zones only: a boundary carries none), and the fitted
network in ``[identified]``: per zone its parameters (:data:`hvacflex.identify.greybox.
ZONE_PARAMETERS`, units in the names) and its supply-flow range, the couplings, the
boundaries (unconditioned zones, as nodes), the supply temperature, the power model and the
training data's range (``[identified.validity]``: zone and outdoor temperatures). So a
scenario's ``building = "model.toml"`` controls the building it came from.
:func:`load_identified_model` reads it back into the fit's arrays.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hvacflex.building.identified import (
    WEEKDAYS,
    IdentifiedBoundary,
    IdentifiedIdleAir,
    IdentifiedPower,
    IdentifiedValidity,
    hours_text,
)
from hvacflex.building.io import load_building
from hvacflex.errors import ConfigError
from hvacflex.identify.greybox import ZONE_PARAMETERS, GreyBoxParameters


def identifier(name: str) -> str:
    """A zone name as a lower-case identifier: ``"SPACE1-1"`` → ``"space1_1"``."""
    text = re.sub(r"[^a-z0-9_]+", "_", name.lower()).strip("_")
    return text if text[:1].isalpha() else f"zone_{text}"


PowerModel = IdentifiedPower
"""HVAC electricity ≈ ``base_kw + kw_per_kw_cooling · ΣQ + kw_per_k_outdoor · To`` [kW]."""


@dataclass(frozen=True)
class BoundaryNode:
    """An unconditioned zone's node as fitted after the zones (its couplings to the zones are
    the fit's boundary conductances): ``c_kj_per_k`` [kJ/K], ``ua_out_kw_per_k`` [kW/K],
    ``solar_m2`` [m²], ``occupied_gain_kw`` [kW], ``temp_degc`` its mean measured temperature
    on the test days [°C]."""

    c_kj_per_k: float
    ua_out_kw_per_k: float
    solar_m2: float
    occupied_gain_kw: float
    temp_degc: float


@dataclass(frozen=True)
class AirSystem:
    """What the data say about the zones' supply air.

    Attributes
    ----------
    supply_temp_degc : the supply temperature of the HVAC input [°C];
    flow_min_kg_s, flow_max_kg_s, ventilation_flow_kg_s : (m,) the flow range per zone and
    the least flow while occupied [kg/s]; mass_temp_degc : (m,) each mass node's mean
    estimated temperature on the test days (where a controlled run starts it) [°C].
    """

    supply_temp_degc: float
    flow_min_kg_s: tuple[float, ...]
    flow_max_kg_s: tuple[float, ...]
    ventilation_flow_kg_s: tuple[float, ...]
    mass_temp_degc: tuple[float, ...]


@dataclass(frozen=True)
class IdentifiedModel:
    """A fitted model as the file holds it.

    Attributes
    ----------
    name : a title; zones : (m,) lower-case identifiers; energyplus_zones : (m,) the data's
    names; parameters : the grey-box parameters; power : the power model or None (no meter in
    the data); provenance : where it came from (data file, train and test days); boundaries :
    (nb,) the data's unconditioned zones (inputs of the fit, nodes of the building);
    air : supply temperature and flow ranges; boundary_nodes : (nb,) the boundaries' nodes;
    floor_areas_m2 : (m,) each zone's floor area [m²], or None when unknown (the file then
    gives none: per-m² figures are not available); validity : the training data's range
    (``[identified.validity]``), or None; idle_air : the idle zones' fan-only air while the
    coil is scheduled off (``[identified.idle_air]``), or None (not learned).
    """

    name: str
    zones: tuple[str, ...]
    energyplus_zones: tuple[str, ...]
    parameters: GreyBoxParameters
    power: PowerModel | None
    provenance: dict[str, str]
    air: AirSystem
    boundaries: tuple[str, ...] = ()
    boundary_nodes: tuple[BoundaryNode, ...] = ()
    floor_areas_m2: tuple[float, ...] | None = None
    validity: IdentifiedValidity | None = None
    idle_air: IdentifiedIdleAir | None = None


def _toml_value(value: object) -> str:
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        pairs = (f"{json.dumps(k)} = {_toml_value(v)}" for k, v in value.items())
        return "{" + ", ".join(pairs) + "}"
    return repr(float(value))  # type: ignore[arg-type]


def _table(lines: list[str], header: str, items: dict[str, object]) -> None:
    lines += ["", header] + [f"{key} = {_toml_value(value)}" for key, value in items.items()]


def write_identified_model(model: IdentifiedModel, path: str | Path) -> Path:
    """Write ``model`` as a building file (module docstring); returns the path."""
    path = Path(path)
    lines = [f"name = {_toml_value(model.name)}"]
    lines.append(f"description = {_toml_value('grey-box RC model identified from trend data')}")
    for i, (zone, energyplus) in enumerate(zip(model.zones, model.energyplus_zones, strict=True)):
        entry: dict[str, object] = {"name": zone, "energyplus_zone": energyplus}
        if model.floor_areas_m2 is not None:
            entry["floor_area_m2"] = model.floor_areas_m2[i]
        _table(lines, "[[zones]]", entry)
    _table(lines, "[identified]", {"supply_temp_degc": model.air.supply_temp_degc})
    _table(lines, "[identified.provenance]", dict(model.provenance))
    names = [n for n, _ in ZONE_PARAMETERS]
    air = model.air
    for i, zone in enumerate(model.zones):
        values: dict[str, object] = dict(zip(names, model.parameters.zone[i].tolist(), strict=True))
        values["flow_min_kg_s"] = air.flow_min_kg_s[i]
        values["flow_max_kg_s"] = air.flow_max_kg_s[i]
        values["ventilation_flow_kg_s"] = air.ventilation_flow_kg_s[i]
        values["mass_temp_degc"] = air.mass_temp_degc[i]
        _table(lines, f"[identified.zones.{zone}]", values)
    for (i, j), ua in zip(
        model.parameters.couplings, model.parameters.coupling_ua_kw_per_k, strict=True
    ):
        _table(
            lines,
            "[[identified.couplings]]",
            {"zones": [model.zones[i], model.zones[j]], "ua_kw_per_k": float(ua)},
        )
    for b, (name, node) in enumerate(zip(model.boundaries, model.boundary_nodes, strict=True)):
        ua = {
            model.zones[int(i)]: float(value)
            for (i, k), value in zip(
                model.parameters.boundary_couplings,
                model.parameters.boundary_ua_kw_per_k,
                strict=True,
            )
            if k == b
        }
        _table(
            lines,
            "[[identified.boundaries]]",
            {"name": name, **vars(node), "ua_zone_kw_per_k": ua},
        )
    if model.power is not None:
        power = {k: v for k, v in vars(model.power).items() if v is not None}
        _table(lines, "[identified.power_model]", power)
    if model.validity is not None:
        v = model.validity
        _table(
            lines,
            "[identified.validity]",
            {
                "zone_temp_min_degc": dict(zip(model.zones, v.zone_temp_min_degc, strict=True)),
                "zone_temp_max_degc": dict(zip(model.zones, v.zone_temp_max_degc, strict=True)),
                "outdoor_temp_min_degc": v.outdoor_temp_min_degc,
                "outdoor_temp_max_degc": v.outdoor_temp_max_degc,
            },
        )
    if model.idle_air is not None:
        idle = model.idle_air
        hours = {day: hours_text(idle.fan_only[i]) for i, day in enumerate(WEEKDAYS)}
        differences = dict(zip(model.zones, idle.fan_only_difference_k, strict=True))
        table: dict[str, object] = {"fan_only_hours": hours, "fan_only_difference_k": differences}
        if idle.fan_only_flow_kg_s is not None:
            flows = dict(zip(model.zones, idle.fan_only_flow_kg_s, strict=True))
            table["fan_only_flow_kg_s"] = flows
        _table(lines, "[identified.idle_air]", table)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def load_identified_model(path: str | Path) -> IdentifiedModel:
    """Read an identified model (a building file with ``[identified]``) into the fit's
    arrays.

    Raises
    ------
    BuildingConfigError
        naming the file, the field and the value for anything invalid.
    ConfigError
        for a building file without an ``[identified]`` table.
    """
    building = load_building(path)
    rc = building.identified
    if rc is None:
        raise ConfigError(
            "not an identified model",
            source=path,
            field="identified",
            hint="write the file with hvacflex identify fit",
        )
    zones = building.zone_names
    names = [n for n, _ in ZONE_PARAMETERS]
    edges, edge_ua = [], []
    for b, node in enumerate(rc.boundaries):
        for zone, ua in node.ua_zone_kw_per_k:
            edges.append((zones.index(zone), b))
            edge_ua.append(ua)
    parameters = GreyBoxParameters(
        zone=np.array([[getattr(z, n) for n in names] for z in rc.zones], dtype=np.float64),
        couplings=np.array(
            [(zones.index(c.zone_a), zones.index(c.zone_b)) for c in rc.couplings], dtype=np.int64
        ).reshape(-1, 2),
        coupling_ua_kw_per_k=np.array([c.ua_kw_per_k for c in rc.couplings], dtype=np.float64),
        boundaries=len(rc.boundaries),
        boundary_couplings=np.array(edges, dtype=np.int64).reshape(-1, 2),
        boundary_ua_kw_per_k=np.array(edge_ua, dtype=np.float64),
    )
    return IdentifiedModel(
        name=building.name,
        zones=zones,
        energyplus_zones=tuple(z.energyplus_zone or z.name for z in building.zones),
        parameters=parameters,
        power=rc.power,
        provenance=dict(rc.provenance),
        air=AirSystem(
            supply_temp_degc=rc.supply_temp_degc,
            flow_min_kg_s=tuple(z.flow_min_kg_s for z in rc.zones),
            flow_max_kg_s=tuple(z.flow_max_kg_s for z in rc.zones),
            ventilation_flow_kg_s=tuple(z.ventilation_flow_kg_s for z in rc.zones),
            mass_temp_degc=tuple(z.mass_temp_degc for z in rc.zones),
        ),
        boundaries=tuple(node.name for node in rc.boundaries),
        boundary_nodes=tuple(_node(node) for node in rc.boundaries),
        floor_areas_m2=(
            tuple(z.floor_area_m2 for z in building.zones)
            if np.isfinite(building.floor_area_m2)
            else None
        ),
        validity=rc.validity,
        idle_air=rc.idle_air,
    )


def _node(node: IdentifiedBoundary) -> BoundaryNode:
    return BoundaryNode(
        c_kj_per_k=node.c_kj_per_k,
        ua_out_kw_per_k=node.ua_out_kw_per_k,
        solar_m2=node.solar_m2,
        occupied_gain_kw=node.occupied_gain_kw,
        temp_degc=node.temp_degc,
    )
