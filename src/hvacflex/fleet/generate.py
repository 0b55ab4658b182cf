"""Heterogeneous fleets from the shipped building templates, written as TOML.

:func:`generate_fleet` draws, per building and from one seed: a floor-area scale (zone,
wall and window areas, the air flows and a chiller's capacity and pump scale with it), an
orientation (every azimuth rotated), a window-to-wall share of the façades, a light or heavy
construction (exterior wall concrete and internal mass), the plant COP, the occupancy start
hour (the office schedule shifts with it) and one of three comfort-band variants. Each
description is validated by the building schema before it is written.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np

from hvacflex.building.hvac import hvac_power_kw
from hvacflex.building.io import building_from_dict
from hvacflex.building.model import Building
from hvacflex.config.presets import PRODUCT_RESERVE
from hvacflex.constants import HORIZON_STEPS, MAX_FLEET_BUILDINGS
from hvacflex.errors import ConfigError
from hvacflex.fleet.schema import fleet_from_dict
from hvacflex.paths import resolve_building
from hvacflex.tomlio import read_toml
from hvacflex.version import atomic_write_text

TEMPLATES = ("office5",)
COMFORT_VARIANTS: tuple[tuple[float, float], ...] = ((23.0, 26.0), (22.5, 25.5), (23.5, 26.5))
DESIGN_OUTDOOR_DEGC = 32.0
DESIGN_HUMIDITY_KG_PER_KG = 0.020
DESIGN_ZONE_DEGC = 24.0
DEFAULT_LIMIT_FRACTION = 0.33
"""Default feeder limit as a share of the fleet's design power (all AHUs at full flow)."""
DESIGN_MIN_ZONE_DEGC = 28.0
"""Zone temperature of the design minimum power (a zone held warm by a tight feeder)."""
MIN_POWER_MARGIN = 1.2
"""The default limit is at least this multiple of the fleet's design minimum power: the
minimum powers the controllers plan with (affine model, occupants' latent gain, the day's
weather) reached 1.14 × the design minimum on a hot afternoon (20 buildings, seed 17,
2014-03-05 14:30: 641.6 kW against 564.5 kW)."""


def design_power_kw(raw: dict[str, Any]) -> float:
    """Electric power at full flow in design conditions (32 °C, 0.020 kg/kg, zones 24 °C) [kW]."""
    return _design_power(building_from_dict(raw))


def _design_power(building: Building) -> float:
    flows = np.asarray(building.hvac.flow_max_kg_s, dtype=float)
    zone = np.full(flows.shape, DESIGN_ZONE_DEGC)
    return float(
        hvac_power_kw(building.hvac, flows, zone, DESIGN_OUTDOOR_DEGC, DESIGN_HUMIDITY_KG_PER_KG)
    )


def design_min_power_kw(building: Building) -> float:
    """Electric power with every zone at its occupied minimum flow (ventilation) in design
    conditions (32 °C, 0.020 kg/kg outdoors, zones at ``DESIGN_MIN_ZONE_DEGC``) [kW]: what a
    feeder must at least carry in office hours on the design day."""
    low = building.hvac.flow_min_at(np.array([True]))[0]
    zone = np.full(low.shape, DESIGN_MIN_ZONE_DEGC)
    return float(
        hvac_power_kw(building.hvac, low, zone, DESIGN_OUTDOOR_DEGC, DESIGN_HUMIDITY_KG_PER_KG)
    )


def default_limit_kw(buildings: list[Building], limit_fraction: float) -> float:
    """The default feeder limit [kW]: ``limit_fraction`` × the design power, but at least
    ``MIN_POWER_MARGIN`` × the design minimum power (so it is feasible on the design day)."""
    design = sum(_design_power(b) for b in buildings)
    minimum = sum(design_min_power_kw(b) for b in buildings)
    return round(max(limit_fraction * design, MIN_POWER_MARGIN * minimum), 1)


def _variant(template: dict[str, Any], rng: np.random.Generator, name: str) -> dict[str, Any]:
    raw = copy.deepcopy(template)
    scale = float(rng.uniform(0.6, 1.6))
    rotation_deg = float(rng.choice(np.arange(0.0, 360.0, 15.0)))
    window_share = float(rng.uniform(0.3, 0.7))
    heavy = bool(rng.random() < 0.5)
    cop = float(np.round(rng.uniform(3.2, 5.2), 2))
    raw["name"] = name
    # the template's power models were fitted to the template's meter, not this variant's:
    # a generated building plans with its own design curves
    raw.pop("power_models", None)
    raw["description"] = (
        f"{template.get('name', 'template')} variant: area ×{scale:.2f}, rotated "
        f"{rotation_deg:.0f}°, window share {window_share:.2f}, "
        f"{'heavy' if heavy else 'light'} construction, COP {cop:.2f}"
    )
    for zone in raw["zones"]:
        zone["floor_area_m2"] = round(zone["floor_area_m2"] * scale, 3)
        zone["capacitance_multiplier"] = 8.0 if heavy else 3.0
    facade_m2: dict[str, float] = {}
    windows_by_zone = {w["zone"]: w for w in raw.get("windows", [])}
    for wall in raw.get("walls", []):
        wall["area_m2"] = round(wall["area_m2"] * scale, 3)
        if "azimuth_deg" in wall:
            wall["azimuth_deg"] = (wall["azimuth_deg"] + rotation_deg) % 360.0
        if wall.get("adjacent") == "outside" and wall["zone"] in windows_by_zone:
            window = windows_by_zone[wall["zone"]]
            total = wall["area_m2"] + window["area_m2"] * scale
            facade_m2[wall["zone"]] = total
            wall["area_m2"] = round(total * (1.0 - window_share), 3)
    for window in raw.get("windows", []):
        total = facade_m2.get(window["zone"], window["area_m2"] * scale)
        window["area_m2"] = round(total * window_share, 3)
        if "azimuth_deg" in window:
            window["azimuth_deg"] = (window["azimuth_deg"] + rotation_deg) % 360.0
    wall_layers = raw.get("constructions", {}).get("exterior_wall", {}).get("layers")
    if wall_layers and len(wall_layers) > 1:
        wall_layers[1]["thickness_m"] = 0.20 if heavy else 0.10
    hvac = raw["hvac"]
    for key in ("flow_max_kg_s", "flow_min_kg_s", "ventilation_flow_kg_s"):
        if isinstance(hvac.get(key), dict):
            hvac[key] = {z: round(v * scale, 4) for z, v in hvac[key].items()}
    hvac["cop"] = cop
    chiller = hvac.get("chiller")
    if isinstance(chiller, dict):  # the plant is sized to the floor, like the air flows
        for key in ("capacity_kw", "pump_design_kw"):
            if key in chiller:
                chiller[key] = round(chiller[key] * scale, 3)
    building_from_dict(raw, source=f"generated building {name}")
    return raw


def generate_fleet(
    buildings: int,
    seed: int,
    *,
    template: str = "office5",
    feeder_limit_kw: float | None = None,
    limit_fraction: float = DEFAULT_LIMIT_FRACTION,
    min_bid_mw: float = 0.1,
    name: str | None = None,
) -> dict[str, Any]:
    """A fleet document (the parsed form of a fleet TOML file), validated.

    Parameters
    ----------
    buildings : number of buildings, 1 … ``MAX_FLEET_BUILDINGS``.
    seed : seed of every random choice (same seed → same fleet).
    template : shipped building name or path of the template building TOML.
    feeder_limit_kw : the feeder limit [kW]; None → :func:`default_limit_kw` (``limit_fraction``
        × the fleet's design power, at least 1.2 × its design minimum power); ``inf`` → no
        limit.
    """
    if not 1 <= buildings <= MAX_FLEET_BUILDINGS:
        raise ConfigError(
            f"a fleet holds 1 … {MAX_FLEET_BUILDINGS} buildings",
            field="buildings",
            value=buildings,
            hint=f"give a number of buildings between 1 and {MAX_FLEET_BUILDINGS}",
        )
    base = read_toml(resolve_building(template), what="building")
    rng = np.random.default_rng(seed)
    entries = []
    for i in range(buildings):
        raw = _variant(base, rng, f"b{i:04d}")
        start = int(rng.choice([7, 8, 9]))
        comfort = COMFORT_VARIANTS[int(rng.integers(len(COMFORT_VARIANTS)))]
        entries.append(
            {
                "name": raw["name"],
                "template": str(template),
                "occupied_hours": [start, start + 10],
                "comfort_occupied_degc": list(comfort),
                "comfort_unoccupied_degc": [20.0, 30.0],
                "initial_temp_degc": 25.0,
                "building": raw,
            }
        )
    if feeder_limit_kw is None:
        built = [building_from_dict(e["building"]) for e in entries]
        feeder_limit_kw = default_limit_kw(built, limit_fraction)
    doc: dict[str, Any] = {
        "name": name or f"fleet-{buildings}-seed{seed}",
        "seed": seed,
        "feeder_limit_kw": float(feeder_limit_kw),
        "feeder_margin": 0.0,
        "min_bid_mw": float(min_bid_mw),
        "robust": "tightening",
        "horizon_steps": HORIZON_STEPS,
        "reserve": {"enabled": True, **PRODUCT_RESERVE},
        "ppp": {"peak_price_sgd_per_kw": 0.0, "billing_mode": "horizon"},
        "coordination": {
            "max_iterations": 30,
            "gap_tolerance": 0.01,
            "feasibility_tolerance": 0.005,
            "step_sgd_per_mwh": 0.0,
            "cap_rounds": 4,
            "scheme": "bundle",
            "plan_tolerance_kw": 0.01,
        },
        "buildings": entries,
    }
    fleet_from_dict(doc, source="generated fleet")
    return doc


# ---------------------------------------------------------------------- TOML writing


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _is_table_list(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _table(lines: list[str], prefix: str, table: dict[str, Any]) -> None:
    """Scalars and inline values first, then sub-tables and arrays of tables."""
    nested = []
    for key, value in table.items():
        if isinstance(value, dict) and any(
            isinstance(v, dict) or _is_table_list(v) for v in value.values()
        ):
            nested.append((key, value))
        elif (isinstance(value, dict) and prefix == "") or _is_table_list(value):
            nested.append((key, value))
        elif isinstance(value, dict) and len(value) > 4:
            nested.append((key, value))
        else:
            lines.append(f"{key} = {_value(value)}")
    for key, value in nested:
        path = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict):
            lines += ["", f"[{path}]"]
            _table(lines, path, value)
        else:
            for item in value:
                lines += ["", f"[[{path}]]"]
                _table(lines, path, item)


def to_toml(doc: dict[str, Any]) -> str:
    """TOML text of a document of tables, arrays of tables and plain values."""
    lines = ["# hvacflex fleet file (hvacflex fleet generate); format: docs/guide/fleet.md"]
    _table(lines, "", doc)
    return "\n".join(lines) + "\n"


def write_fleet(doc: dict[str, Any], path: str | Path) -> Path:
    """Write ``doc`` as TOML atomically and check that it reads back as the same fleet."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, to_toml(doc))
    return out
