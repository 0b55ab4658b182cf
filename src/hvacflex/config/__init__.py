"""Scenario configuration: one TOML file ties a closed-loop run together.

A scenario names the building, the period, the controller (nominal or robust MPC, or the
thermostat baseline), the interruptible-load contract (``[reserve]``), the uncertainty box of
the forecast errors, how the realised errors are drawn, when interruptible load (IL) is
activated, the data files and the comfort band. Every field has a default, so a scenario
file states only what differs; unknown keys are errors. The file format is the pydantic
schema of :mod:`hvacflex.config.schema`; the domain objects are the frozen dataclasses of
:mod:`hvacflex.config.model`; the named presets (:mod:`hvacflex.config.presets`) reproduce
the paper's scenarios, with the product's event model or the paper's whole-horizon one.

Example ``scenario.toml``::

    preset = "rmpc-ppp"          # start from a preset, then override
    building = "office5"
    start = "2014-03-01"
    days = 7

    [controller]
    peak_price_sgd_per_kw = 2.0

    [reserve]                    # IL events of up to 2 h, +1 K during and 1 h after
    event_max_steps = 4
    event_allowance_k = 1.0
    event_recovery_steps = 2

    [uncertainty]
    relative = { solar = 0.3, internal_gain = 0.3 }
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields, is_dataclass, replace
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails

from hvacflex.config import schema
from hvacflex.config.model import (
    NEMS_MAX_INTERRUPTION_STEPS,
    ActivationConfig,
    ActivationMode,
    BillingMode,
    ComfortConfig,
    ControllerConfig,
    ControllerKind,
    DataConfig,
    EstimationConfig,
    EstimationMode,
    FeedbackConfig,
    Linearisation,
    PlantConfig,
    PriceGapFill,
    RealisationConfig,
    RealisationMode,
    ReserveConfig,
    ScenarioConfig,
    UncertaintyConfig,
)
from hvacflex.config.presets import (
    BASELINE_PRESETS,
    DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW,
    PAPER_FEEDBACK_SCENARIOS,
    PAPER_MODEL_SCENARIOS,
    PAPER_SCENARIOS,
    PRESETS,
)
from hvacflex.config.schema import RENAMED_KEYS, RULE_ERROR, ScenarioSpec, to_domain
from hvacflex.constants import MAX_HORIZON_STEPS, PRESET_NAMES
from hvacflex.errors import ConfigError, did_you_mean
from hvacflex.opt.options import (
    DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR,
    DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR,
    FeedbackStructure,
    RobustMode,
)
from hvacflex.tomlio import read_toml

__all__ = [
    "BASELINE_PRESETS",
    "DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR",
    "DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR",
    "DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW",
    "LINEARISATION_MARGIN_K",
    "NEMS_MAX_INTERRUPTION_STEPS",
    "PAPER_FEEDBACK_SCENARIOS",
    "PAPER_MODEL_SCENARIOS",
    "PAPER_SCENARIOS",
    "PRESET_NAMES",
    "ActivationConfig",
    "ActivationMode",
    "BillingMode",
    "ComfortConfig",
    "ControllerConfig",
    "ControllerKind",
    "DataConfig",
    "EstimationConfig",
    "EstimationMode",
    "FeedbackConfig",
    "FeedbackStructure",
    "Linearisation",
    "PlantConfig",
    "PriceGapFill",
    "RealisationConfig",
    "RealisationMode",
    "ReserveConfig",
    "RobustMode",
    "ScenarioConfig",
    "UncertaintyConfig",
    "config_from_dict",
    "differing_settings",
    "load_config",
    "paths_from_folder",
    "preset",
    "resolve_key",
    "resolve_scenario",
    "scaled_uncertainty",
    "scenario_error",
    "scenario_error_of",
    "with_overrides",
]

LINEARISATION_MARGIN_K = 1.0
"""Default T₀ sits this far below the occupied upper bound [K].

docs/explanation/model.md §1 recommends T₀ = the occupied lower bound (23 °C), which never
over-predicts the cooling of the supply air while T_r ≥ T₀. But the MPC spends its occupied hours
near the upper bound, where that choice under-predicts the cooling by (26 − 23)/(26 − 13) ≈ 23 %:
the plant then runs colder than planned, the nominal MPC buys that margin on every step, and the
margin hides the forecast errors the robust MPC is there to handle (measured: nominal MPC
cost +5 % and no comfort violation at any box size up to 10 %). One kelvin below the upper
bound keeps the linearisation conservative where it matters (T_r ≥ 25 °C, near the upper
bound) and its non-conservative side self-limiting (below 25 °C the zone is at least 1 K
from the upper bound and the error is ≤ about 0.4 K per kelvin at full flow). See the note
in ``docs/explanation/reproduction.md``."""

_MESSAGES: dict[str, str] = {
    "extra_forbidden": "unknown key",
    "float_type": "must be a number",
    "float_parsing": "must be a number",
    "finite_number": "must be a finite number",
    "int_type": "must be an integer",
    "string_type": "must be a string",
    "bool_type": "must be true or false",
    "literal_error": "invalid choice",
    "tuple_type": "must be a pair [lower, upper]",
    "too_short": "must be a pair [lower, upper]",
    "too_long": "must be a pair [lower, upper]",
    "dict_type": "must be a table",
    "model_type": "must be a table",
    "model_attributes_type": "must be a table",
    "greater_than": "must be > {gt:g}",
    "greater_than_equal": "must be ≥ {ge:g}",
    "less_than": "must be < {lt:g}",
    "less_than_equal": "must be ≤ {le:g}",
}
"""Our wording of pydantic's error types (``ctx`` fills the braces)."""


_RANGES = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")
"""pydantic's error types of a value outside its range."""

_INDOOR_RANGE = (
    f"indoor temperatures are in °C, between {schema.INDOOR_TEMP_MIN_DEGC:g} and "
    f"{schema.INDOOR_TEMP_MAX_DEGC:g}"
)
_RANGE_HINTS: dict[str, str] = {
    "initial_temp_degc": f"a building starts between {schema.INITIAL_TEMP_MIN_DEGC:g} and "
    f"{schema.INITIAL_TEMP_MAX_DEGC:g} °C (default {ScenarioConfig.initial_temp_degc:g})",
    "horizon_steps": f"give 1 … {MAX_HORIZON_STEPS} periods of 30 min (one week, the "
    f"service's cap; default {ControllerConfig.horizon_steps})",
    "occupied_degc": f"{_INDOOR_RANGE}; default {list(ComfortConfig.occupied_degc)}",
    "unoccupied_degc": f"{_INDOOR_RANGE}; default {list(ComfortConfig.unoccupied_degc)}",
    "thermostat_setpoint_degc": _INDOOR_RANGE,
    "linearisation_temp_degc": _INDOOR_RANGE,
}
"""Hints of the range errors of the fields whose range is physical (the allowed range)."""


def preset(name: str, **overrides: Any) -> ScenarioConfig:
    """A named preset, with optional overrides (dotted keys, e.g. ``controller.robust``).

    >>> preset("rmpc-ppp", days=2).controller.peak_price_sgd_per_kw
    1.5
    """
    if name not in PRESETS:
        raise ConfigError(
            "unknown scenario preset",
            field="scenario",
            value=name,
            hint=did_you_mean(name, PRESET_NAMES, f"use one of {list(PRESET_NAMES)}"),
        )
    cfg = _validate({"name": name, **PRESETS[name]}, source="preset")
    return with_overrides(cfg, overrides) if overrides else cfg


def load_config(path: str | Path) -> ScenarioConfig:
    """Load a scenario TOML file (optionally starting from ``preset = "..."``).

    Relative paths in the file (``building``, ``data.weather_file``, ``data.usep_source``,
    ``data.reserve_source``, ``activation.file``, ``plant.idf``,
    ``uncertainty.calibrate.prediction_errors``) are relative to the file's folder
    (:func:`paths_from_folder`).

    Raises
    ------
    ConfigError : naming the file, the field path, the value and a hint.
    """
    path = Path(path)
    raw = read_toml(path, what="scenario")
    base_name = raw.pop("preset", None)
    base: dict[str, Any] = {}
    if base_name is not None:
        if base_name not in PRESETS:
            raise ConfigError(
                "unknown preset",
                source=path,
                field="preset",
                value=base_name,
                hint=did_you_mean(base_name, PRESET_NAMES, f"use one of {list(PRESET_NAMES)}"),
            )
        base = {"name": base_name, **PRESETS[base_name]}
    merged = _deep_merge(base, paths_from_folder(raw, path.parent))
    merged.setdefault("name", path.stem)
    return _validate(merged, source=path)


SCENARIO_PATH_KEYS: tuple[tuple[str, str], ...] = (
    ("data", "weather_file"),
    ("data", "usep_source"),
    ("data", "reserve_source"),
    ("activation", "file"),
)
"""(table, key) of the scenario file's keys that name a file or folder."""


def paths_from_folder(raw: Mapping[str, Any], folder: Path) -> dict[str, Any]:
    """The parsed scenario with the relative paths it writes taken from ``folder`` (the
    scenario file's), not from the working directory. A fleet file, which carries the
    scenario's ``[data]`` and ``[activation]`` tables, is resolved by the same function
    (:func:`hvacflex.fleet.schema.load_fleet`).

    ``building`` is a path when it has a folder or ends in ``.toml`` (else a shipped name such
    as ``office5``), ``plant.idf`` when it has a folder or ends in ``.idf`` (else
    ``generated`` or a shipped model such as ``5ZoneAirCooled``); the keys of
    :data:`SCENARIO_PATH_KEYS` and ``uncertainty.calibrate.prediction_errors`` are always
    paths. Values that are not strings are left for the schema to refuse.
    """

    def from_folder(value: str) -> str:
        candidate = Path(value).expanduser()
        return str(candidate if candidate.is_absolute() else folder / candidate)

    out = dict(raw)
    plant = raw.get("plant")
    if isinstance(plant, Mapping) and isinstance(plant.get("idf"), str):
        idf = plant["idf"]
        if idf.lower().endswith(".idf") or "/" in idf:  # else "generated" or a shipped name
            out["plant"] = {**plant, "idf": from_folder(idf)}
    uncertainty = raw.get("uncertainty")
    calibrate = uncertainty.get("calibrate") if isinstance(uncertainty, Mapping) else None
    if (
        isinstance(uncertainty, Mapping)
        and isinstance(calibrate, Mapping)
        and isinstance(calibrate.get("prediction_errors"), str)
    ):
        errors = from_folder(calibrate["prediction_errors"])
        out["uncertainty"] = {
            **uncertainty,
            "calibrate": {**calibrate, "prediction_errors": errors},
        }
    building = raw.get("building")
    if isinstance(building, str) and (Path(building).suffix == ".toml" or "/" in building):
        out["building"] = from_folder(building)
    for table, key in SCENARIO_PATH_KEYS:
        section = out.get(table)
        if isinstance(section, Mapping) and isinstance(section.get(key), str):
            out[table] = {**section, key: from_folder(section[key])}
    return out


def with_overrides(cfg: ScenarioConfig, overrides: Mapping[str, Any]) -> ScenarioConfig:
    """A copy with fields replaced; keys are dotted paths, unique leaf names or tables.

    ``{"peak_price_sgd_per_kw": 2.0}`` and ``{"controller.peak_price_sgd_per_kw": 2.0}`` are
    the same override, and so is ``{"controller": {"peak_price_sgd_per_kw": 2.0}}``: a table
    given as a dict replaces the settings it names and keeps the others; a setting whose value
    is a table of its own (``uncertainty.relative``) is replaced whole, as in a scenario file.
    Values are validated like file input (an unknown key inside a table is an error naming it,
    e.g. ``controller.peak_price``).
    """
    data = cfg.to_dict()
    tables = _table_paths(cfg)
    for key, value in overrides.items():
        path = _override_path(key, value, tables)
        node = data
        for part in path[:-1]:
            node = node[part]
        _assign(node, path, value, tables)
    return _validate(data, source="override")


def _override_path(key: str, value: Any, tables: set[tuple[str, ...]]) -> tuple[str, ...]:
    """The path an override sets: a table for a dict, else the setting :func:`resolve_key`
    finds (``reserve=False`` is ``controller.reserve``, ``reserve={...}`` the table)."""
    dotted = tuple(key.split("."))
    if dotted in tables and isinstance(value, Mapping):
        return dotted
    try:
        return resolve_key(key)
    except ConfigError:
        if dotted in tables:
            return dotted  # a table given a non-table value: the schema names the field
        raise


def _assign(
    node: dict[str, Any], path: tuple[str, ...], value: Any, tables: set[tuple[str, ...]]
) -> None:
    """``node[path[-1]] = value``, merging a dict given for a table key by key."""
    if path in tables and isinstance(value, Mapping):
        for key, item in value.items():
            _assign(node[path[-1]], (*path, str(key)), item, tables)
    else:
        node[path[-1]] = value  # a non-table value for a table: the schema names the field


def resolve_scenario(
    source: str | Path | ScenarioConfig, overrides: Mapping[str, Any] | None = None
) -> ScenarioConfig:
    """The scenario of a run: a preset name, a scenario TOML file or a config, overridden.

    Parameters
    ----------
    source : a :class:`ScenarioConfig` as is; a preset name (:func:`preset`); a ``Path``, or
        another string that ends in ``.toml`` or names an existing file, is read with
        :func:`load_config`; any other string is an unknown preset.
    overrides : settings as :func:`with_overrides` takes them (``start``, ``days``, ``seed``,
        ``building``, ``price_gap_fill``, ``controller={...}``, …); empty or None: none.

    Raises
    ------
    ConfigError : an unknown preset (field ``scenario``), an invalid file or override.
    """
    if isinstance(source, ScenarioConfig):
        cfg = source
    elif isinstance(source, str) and source in PRESETS:
        cfg = preset(source)
    elif isinstance(source, Path) or source.endswith(".toml") or Path(source).is_file():
        cfg = load_config(source)
    else:
        cfg = preset(source)  # an unknown preset: the error lists the presets
    return with_overrides(cfg, overrides) if overrides else cfg


def config_from_dict(document: Mapping[str, Any], *, source: str | Path) -> ScenarioConfig:
    """A :class:`ScenarioConfig` from its :meth:`~ScenarioConfig.to_dict` form (e.g. a run's
    ``config.json``), validated like a scenario file.

    Raises
    ------
    ConfigError : naming ``source``, the field path, the value and a hint.
    """
    return _validate(document, source=source)


def differing_settings(a: ScenarioConfig, b: ScenarioConfig) -> list[str]:
    """The dotted settings (all but ``name``) whose values differ between two scenarios."""
    return [
        ".".join(path)
        for path in _leaf_paths(a)
        if path != ("name",) and _get(a, path) != _get(b, path)
    ]


def _get(cfg: Any, path: tuple[str, ...]) -> Any:
    for part in path:
        cfg = getattr(cfg, part)
    return cfg


def scaled_uncertainty(cfg: ScenarioConfig, level: float) -> ScenarioConfig:
    """The scenario with σ = ``level`` × the heat gains (solar, internal), keeping T_out's σ."""
    unc = replace(cfg.uncertainty, relative={"solar": level, "internal_gain": level})
    return replace(cfg, uncertainty=unc)


def _validate(document: Mapping[str, Any], *, source: str | Path) -> ScenarioConfig:
    """A scenario document (parsed TOML, preset, overridden dict) → :class:`ScenarioConfig`."""
    try:
        spec = ScenarioSpec.model_validate(dict(document))
    except ValidationError as exc:
        raise scenario_error(exc, source) from None
    config: ScenarioConfig = to_domain(spec)
    return config


def scenario_error(exc: ValidationError, source: str | Path) -> ConfigError:
    """The first problem of a schema ``ValidationError`` as a ``ConfigError``.

    The field path joins pydantic's location (``uncertainty.relative.wind``), extended by the
    field a cross-field rule names; an unknown key is reported first (a misspelt key is the
    likelier mistake), with the valid keys of its table or the key that replaced it.
    """
    errors = exc.errors(include_url=False)
    error: ErrorDetails = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
    return scenario_error_of(error, source)


def scenario_error_of(
    error: ErrorDetails, source: str | Path, *, kind: type[ConfigError] = ConfigError
) -> ConfigError:
    """One problem of a ``ValidationError`` of the scenario schema as a ``kind`` error.

    ``error["loc"]`` is read as a path from the scenario file's top (``data.calendar``): a
    file that carries one of its tables under the same name (a fleet file's ``[data]``)
    reports that table's problems with the scenario file's messages and hints.
    """
    ctx: dict[str, Any] = dict(error.get("ctx") or {})
    loc = tuple(str(part) for part in error["loc"] if part != "[key]")
    value: object = error["input"]
    hint: str | None = None
    if error["type"] == RULE_ERROR:
        loc += tuple(filter(None, str(ctx["field"]).split(".")))
        message, value, hint = str(ctx["message"]), ctx["value"], ctx["hint"]
    elif error["type"] == "extra_forbidden":
        message, hint = "unknown key", _unknown_key_hint(loc)
    elif error["type"] in ("missing", "too_short", "too_long") and loc[-1].isdigit():
        loc, message = loc[:-1], "must be a pair [lower, upper]"  # a comfort band
    else:
        template = _MESSAGES.get(error["type"])
        message = template.format(**ctx) if template else error["msg"]
        if "expected" in ctx:
            hint = f"use one of {ctx['expected']}"
        if loc and loc[-1] in ("0", "1") and len(loc) >= 2 and loc[-2] in _RANGE_HINTS:
            message = f"{('lower', 'upper')[int(loc[-1])]} bound {message}"
            loc = loc[:-1]
        hint = _RANGE_HINTS.get(loc[-1]) if loc and error["type"] in _RANGES else hint
    return kind(message, source=source, field=".".join(loc), value=value, hint=hint)


def _unknown_key_hint(loc: tuple[str, ...]) -> str | None:
    renamed = RENAMED_KEYS.get((loc[-2], loc[-1])) if len(loc) >= 2 else None
    if renamed is not None:
        return f"this key was replaced by {loc[-2]}.{renamed}"
    model: type[BaseModel] = ScenarioSpec
    for part in loc[:-1]:
        annotation = model.model_fields[part].annotation if part in model.model_fields else None
        if not (isinstance(annotation, type) and issubclass(annotation, BaseModel)):
            return None  # inside a table of disturbance kinds
        model = annotation
    valid = sorted(model.model_fields)
    return did_you_mean(loc[-1], valid, f"valid keys here: {valid}")


def _leaf_paths(obj: Any, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    out: list[tuple[str, ...]] = []
    for f in fields(obj):
        value = getattr(obj, f.name)
        if is_dataclass(value):
            out += _leaf_paths(value, (*prefix, f.name))
        else:
            out.append((*prefix, f.name))
    return out


def _table_paths(obj: Any, prefix: tuple[str, ...] = ()) -> set[tuple[str, ...]]:
    """The dotted paths of the tables (nested dataclasses) of a config."""
    out: set[tuple[str, ...]] = set()
    for f in fields(obj):
        value = getattr(obj, f.name)
        if is_dataclass(value):
            out |= {(*prefix, f.name)} | _table_paths(value, (*prefix, f.name))
    return out


def resolve_key(key: str) -> tuple[str, ...]:
    """The dotted path of a setting given by its path or a unique leaf name
    (``"peak_price_sgd_per_kw"`` → ``("controller", "peak_price_sgd_per_kw")``).

    Raises
    ------
    ConfigError : no such setting, or a leaf name that several sections share.
    """
    leaves = _leaf_paths(ScenarioConfig())
    dotted = tuple(key.split("."))
    if dotted in leaves:
        return dotted
    matches = [p for p in leaves if p[-len(dotted) :] == dotted]
    if len(matches) == 1:
        return matches[0]
    valid = sorted(".".join(p) for p in leaves)
    raise ConfigError(
        "unknown or ambiguous setting" if matches else "unknown setting",
        field=key,
        hint=did_you_mean(
            key, [*valid, *(p[-1] for p in leaves)], f"valid settings: {', '.join(valid)}"
        ),
    )


def _deep_merge(base: dict[str, Any], top: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in top.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _deep_merge(dict(out[key]), value)
        else:
            out[key] = value
    return out
