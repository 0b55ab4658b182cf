"""Scenario configuration: one TOML file ties a closed-loop run together.

A scenario names the building, the period, the controller (nominal or robust MPC, or the
thermostat baseline), the uncertainty box of the forecast errors, how the realised errors
are drawn, when interruptible load (IL) is activated, the data files and the comfort band.
Every field has a default, so a scenario file states only what differs; unknown keys are
errors. Named presets reproduce the paper's scenarios::

    nmpc             (a) nominal MPC: σ = 0 in the controller, reserve offered, φ = 0
    rmpc             (b) robust MPC: σ from the box, φ = 0
    rmpc-ppp         (c) robust MPC with a peak-power price φ = 1.5 SGD/kW
    nmpc-no-reserve  nominal MPC that offers no reserve
    thermostat       rule-based flow control to a set-point, no reserve
    rmpc-feedback    robust MPC with affine disturbance feedback (closed-loop robustness)
    rmpc-feedback-ppp  the same with φ = 1.5 SGD/kW
    rmpc-output-feedback  robust MPC from zone-air measurements (Kalman filter, estimation
                     margin) with trajectory linearisation (docs/estimation.md)

Example ``scenario.toml``::

    preset = "rmpc-ppp"          # start from a preset, then override
    building = "office5"
    start = "2014-03-01"
    days = 7

    [controller]
    peak_price_sgd_per_kw = 2.0

    [uncertainty]
    relative = { solar = 0.3, internal_gain = 0.3 }
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, is_dataclass, replace
from pathlib import Path
from typing import Any, Literal, get_args

import pandas as pd

from hvacflex.data.uncertainty import AR1_COEFFICIENT
from hvacflex.errors import ConfigError
from hvacflex.tomlio import read_toml
from hvacflex.units import STEP_30MIN_S

ControllerKind = Literal["mpc", "thermostat"]
RobustMode = Literal["none", "tightening", "dual", "feedback"]
BillingMode = Literal["horizon", "billing-period"]
RealisationMode = Literal["zero", "uniform", "worst-upper", "worst-lower", "ar1"]
ActivationMode = Literal["never", "always", "random", "file"]
FeedbackStructure = Literal["full", "memory", "zone-local", "time-invariant"]
PriceGapFill = Literal["none", "previous-day"]
Linearisation = Literal["fixed", "trajectory"]
EstimationMode = Literal["full-state", "kalman"]

DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW = 1.5
"""The paper's scenario (c) peak-power price [SGD/kW]."""

LINEARISATION_MARGIN_K = 1.0
"""Default T₀ sits this far below the occupied upper bound [K].

DESIGN §1 recommends T₀ = the occupied lower bound (23 °C), which never over-predicts the
cooling of the supply air while T_r ≥ T₀. But the MPC spends its occupied hours near the
upper bound, where that choice under-predicts the cooling by (26 − 23)/(26 − 13) ≈ 23 %: the
plant then runs colder than planned, the nominal MPC buys that margin on every step, and the
margin hides the forecast errors the robust MPC is there to handle (measured: nominal MPC
cost +5 % and no comfort violation at any box size up to 10 %). One kelvin below the upper
bound keeps the linearisation conservative where it matters (T_r ≥ 25 °C, near the upper
bound) and its non-conservative side self-limiting (below 25 °C the zone is at least 1 K
from the upper bound and the error is ≤ about 0.4 K per kelvin at full flow). See the note
in ``docs/reproduction.md``."""

DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR = 100.0
"""ρ: an exact penalty at this scale (DESIGN §3)."""


@dataclass(frozen=True)
class FeedbackConfig:
    """Structure of the affine disturbance-feedback policy (``robust = "feedback"``)."""

    structure: FeedbackStructure = "zone-local"
    memory_steps: int = 4
    """Innovations older than this many steps get no gain (every structure but ``"full"``:
    the memory, and the lags of the time-invariant and zone-local gains)."""


@dataclass(frozen=True)
class ControllerConfig:
    """How the building is controlled.

    ``robust = "none"`` is the nominal MPC (σ = 0 in the controller); the realised errors are
    drawn from the scenario's uncertainty box all the same, so nominal and robust runs face
    the same disturbances.
    """

    kind: ControllerKind = "mpc"
    robust: RobustMode = "tightening"
    reserve: bool = True
    peak_price_sgd_per_kw: float = 0.0
    billing_mode: BillingMode = "horizon"
    comfort_penalty_sgd_per_kelvin_hour: float = DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR
    horizon_steps: int = 48
    linearisation_temp_degc: float | None = None
    """T₀ of the VAV linearisation [°C]; ``None`` = the occupied upper comfort bound less
    ``LINEARISATION_MARGIN_K`` (25 °C for the default band), where the controller operates."""
    time_limit_s: float = 20.0
    thermostat_setpoint_degc: float = 24.0
    feedback: FeedbackConfig = field(default_factory=FeedbackConfig)
    linearisation: Linearisation = "fixed"
    """``"fixed"``: the model linearised once at (ṁ_min, T₀); ``"trajectory"``: re-linearised
    each step about the previous plan shifted by one step (docs/estimation.md §3)."""


@dataclass(frozen=True)
class EstimationConfig:
    """What the controller measures (docs/estimation.md).

    ``"full-state"``: every node temperature of the plant; ``"kalman"``: only the zone air
    temperatures, with uniform sensor error in ±``measurement_noise_k`` [K], and a Kalman
    filter with per-zone offset states estimates the rest (tuned covariances).
    """

    mode: EstimationMode = "full-state"
    measurement_noise_k: float = 0.1


@dataclass(frozen=True)
class UncertaintyConfig:
    """Half-widths σ of the forecast-error box, per disturbance kind.

    ``relative`` is a fraction of the forecast value (solar, internal gains); ``absolute`` is
    in the channel's unit (K for temperatures, W/m² for solar, W for gains). Both add up.
    The default (±5 % of heat gains, ±0.5 K outdoor) is the largest level the default
    building satisfies with margin; see ``docs/data.md`` and DESIGN §3.
    """

    relative: Mapping[str, float] = field(
        default_factory=lambda: {"solar": 0.05, "internal_gain": 0.05}
    )
    absolute: Mapping[str, float] = field(default_factory=lambda: {"outdoor_temp": 0.5})


@dataclass(frozen=True)
class RealisationConfig:
    """How the simulator draws the realised forecast error w inside the box."""

    mode: RealisationMode = "uniform"
    ar1_coefficient: float = AR1_COEFFICIENT


@dataclass(frozen=True)
class ActivationConfig:
    """When the IL reserve is activated (the plant then runs u − r)."""

    mode: ActivationMode = "never"
    rate: float = 0.02
    """Probability that an activation starts in a period (``mode = "random"``)."""
    duration_steps: int = 2
    file: str | None = None
    """CSV with columns ``time`` (period start, ISO 8601) and ``activated`` (0/1)."""


@dataclass(frozen=True)
class DataConfig:
    """Data files; ``None`` means the shipped default."""

    weather_file: str | None = None
    usep_source: str | None = None
    reserve_source: str | None = None
    reserve_price_scale: float | None = None
    """Scale of the synthetic reserve price; ``None`` = the calibrated default."""
    price_gap_fill: PriceGapFill = "none"
    """Gaps in the price files: ``"none"`` (an error) or ``"previous-day"`` (copy the period)."""


@dataclass(frozen=True)
class ComfortConfig:
    """Comfort band [°C] in occupied and unoccupied periods."""

    occupied_degc: tuple[float, float] = (23.0, 26.0)
    unoccupied_degc: tuple[float, float] = (20.0, 30.0)


@dataclass(frozen=True)
class ScenarioConfig:
    """Everything one closed-loop run needs. Build with :func:`load_config` or :func:`preset`."""

    name: str = "rmpc"
    building: str = "office5"
    start: str = "2014-01-01"
    days: float = 7.0
    dt_s: float = 1800.0
    seed: int = 2014
    initial_temp_degc: float = 25.0
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    estimation: EstimationConfig = field(default_factory=EstimationConfig)
    uncertainty: UncertaintyConfig = field(default_factory=UncertaintyConfig)
    realisation: RealisationConfig = field(default_factory=RealisationConfig)
    activation: ActivationConfig = field(default_factory=ActivationConfig)
    data: DataConfig = field(default_factory=DataConfig)
    comfort: ComfortConfig = field(default_factory=ComfortConfig)

    @property
    def steps(self) -> int:
        """Number of control steps in the run."""
        return round(self.days * 86400.0 / self.dt_s)

    @property
    def start_timestamp(self) -> pd.Timestamp:
        return pd.Timestamp(self.start, tz="Asia/Singapore")

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-serialisable dict (tuples become lists)."""
        data: dict[str, Any] = json.loads(json.dumps(asdict(self)))
        return data

    def config_hash(self) -> str:
        """Stable 12-hex-digit hash of every field except ``name`` (used to cache runs)."""
        payload = self.to_dict()
        payload.pop("name")
        text = json.dumps(payload, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:12]


_PRESETS: dict[str, dict[str, Any]] = {
    "nmpc": {"controller": {"robust": "none"}},
    "rmpc": {"controller": {"robust": "tightening"}},
    "rmpc-ppp": {
        "controller": {
            "robust": "tightening",
            "peak_price_sgd_per_kw": DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW,
        }
    },
    "nmpc-no-reserve": {"controller": {"robust": "none", "reserve": False}},
    "thermostat": {"controller": {"kind": "thermostat", "robust": "none", "reserve": False}},
    "rmpc-feedback": {"controller": {"robust": "feedback"}},
    "rmpc-output-feedback": {
        "controller": {"robust": "tightening", "linearisation": "trajectory"},
        "estimation": {"mode": "kalman"},
    },
    "rmpc-feedback-ppp": {
        "controller": {
            "robust": "feedback",
            "peak_price_sgd_per_kw": DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW,
        }
    },
}

PRESET_NAMES: tuple[str, ...] = tuple(_PRESETS)

PAPER_SCENARIOS: dict[str, str] = {"a": "nmpc", "b": "rmpc", "c": "rmpc-ppp"}
"""The paper's scenario letters and the presets that implement them."""


def preset(name: str, **overrides: Any) -> ScenarioConfig:
    """A named preset, with optional overrides (dotted keys, e.g. ``controller.robust``).

    >>> preset("rmpc-ppp", days=2).controller.peak_price_sgd_per_kw
    1.5
    """
    if name not in _PRESETS:
        raise ConfigError(
            "unknown scenario preset",
            field="scenario",
            value=name,
            hint=f"use one of {list(PRESET_NAMES)}",
        )
    cfg = _build(ScenarioConfig, {"name": name, **_PRESETS[name]}, source="preset", prefix="")
    return with_overrides(cfg, overrides) if overrides else cfg


def load_config(path: str | Path) -> ScenarioConfig:
    """Load a scenario TOML file (optionally starting from ``preset = "..."``)."""
    path = Path(path)
    raw = read_toml(path, what="scenario")
    base_name = raw.pop("preset", None)
    base: dict[str, Any] = {}
    if base_name is not None:
        if base_name not in _PRESETS:
            raise ConfigError(
                "unknown preset",
                source=path,
                field="preset",
                value=base_name,
                hint=f"use one of {list(PRESET_NAMES)}",
            )
        base = {"name": base_name, **_PRESETS[base_name]}
    merged = _deep_merge(base, raw)
    merged.setdefault("name", path.stem)
    cfg: ScenarioConfig = _build(ScenarioConfig, merged, source=path, prefix="")
    return cfg


def with_overrides(cfg: ScenarioConfig, overrides: Mapping[str, Any]) -> ScenarioConfig:
    """A copy with fields replaced; keys are dotted paths or unique leaf names.

    ``{"peak_price_sgd_per_kw": 2.0}`` and ``{"controller.peak_price_sgd_per_kw": 2.0}`` are
    the same override. Values are validated like file input.
    """
    data = cfg.to_dict()
    for key, value in overrides.items():
        path = _resolve_key(key)
        node = data
        for part in path[:-1]:
            node = node[part]
        node[path[-1]] = value
    out: ScenarioConfig = _build(ScenarioConfig, data, source="override", prefix="")
    return out


def _leaf_paths(cls: type, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    out: list[tuple[str, ...]] = []
    for f in fields(cls):
        sub = _DATACLASS_FIELDS.get((cls.__name__, f.name))
        if sub is not None:
            out += _leaf_paths(sub, (*prefix, f.name))
        else:
            out.append((*prefix, f.name))
    return out


def _resolve_key(key: str) -> tuple[str, ...]:
    leaves = _leaf_paths(ScenarioConfig)
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
        hint=f"valid settings: {', '.join(valid)}",
    )


_DATACLASS_FIELDS: dict[tuple[str, str], type] = {
    ("ScenarioConfig", "controller"): ControllerConfig,
    ("ScenarioConfig", "estimation"): EstimationConfig,
    ("ScenarioConfig", "uncertainty"): UncertaintyConfig,
    ("ScenarioConfig", "realisation"): RealisationConfig,
    ("ScenarioConfig", "activation"): ActivationConfig,
    ("ScenarioConfig", "data"): DataConfig,
    ("ScenarioConfig", "comfort"): ComfortConfig,
    ("ControllerConfig", "feedback"): FeedbackConfig,
}

_LITERALS: dict[tuple[str, str], tuple[str, ...]] = {
    ("ControllerConfig", "kind"): get_args(ControllerKind),
    ("ControllerConfig", "robust"): get_args(RobustMode),
    ("ControllerConfig", "billing_mode"): get_args(BillingMode),
    ("RealisationConfig", "mode"): get_args(RealisationMode),
    ("ActivationConfig", "mode"): get_args(ActivationMode),
    ("FeedbackConfig", "structure"): get_args(FeedbackStructure),
    ("DataConfig", "price_gap_fill"): get_args(PriceGapFill),
    ("ControllerConfig", "linearisation"): get_args(Linearisation),
    ("EstimationConfig", "mode"): get_args(EstimationMode),
}

_DISTURBANCE_KINDS = ("outdoor_temp", "solar", "internal_gain", "ground_temp")


def _deep_merge(base: dict[str, Any], top: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in top.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _deep_merge(dict(out[key]), value)
        else:
            out[key] = value
    return out


def _build(cls: type, raw: Mapping[str, Any], *, source: str | Path, prefix: str) -> Any:
    """Construct dataclass ``cls`` from a TOML table, checking keys, types and values."""
    known = {f.name: f for f in fields(cls)}
    for key in raw:
        if key not in known:
            raise ConfigError(
                "unknown key",
                source=source,
                field=f"{prefix}{key}",
                hint=f"valid keys here: {sorted(known)}",
            )
    kwargs: dict[str, Any] = {}
    for name, value in raw.items():
        where = f"{prefix}{name}"
        sub = _DATACLASS_FIELDS.get((cls.__name__, name))
        if sub is not None:
            if is_dataclass(value):
                value = asdict(value)  # type: ignore[arg-type]
            if not isinstance(value, Mapping):
                raise ConfigError("must be a table", source=source, field=where, value=value)
            kwargs[name] = _build(sub, value, source=source, prefix=f"{where}.")
        else:
            kwargs[name] = _check_value(cls, name, value, source=source, where=where)
    obj = cls(**kwargs)
    _check_object(obj, source=source, prefix=prefix)
    return obj


def _check_value(cls: type, name: str, value: Any, *, source: str | Path, where: str) -> Any:
    choices = _LITERALS.get((cls.__name__, name))
    if choices is not None and value not in choices:
        raise ConfigError(
            "invalid choice", source=source, field=where, value=value, hint=f"use one of {choices}"
        )
    default = next(f for f in fields(cls) if f.name == name)
    annotation = str(default.type)
    if annotation.startswith("tuple[float, float]"):
        if not (isinstance(value, list | tuple) and len(value) == 2):
            raise ConfigError(
                "must be a pair [lower, upper]", source=source, field=where, value=value
            )
        return (float(value[0]), float(value[1]))
    if annotation.startswith("Mapping[str, float]"):
        if not isinstance(value, Mapping):
            raise ConfigError("must be a table", source=source, field=where, value=value)
        for kind, v in value.items():
            if kind not in _DISTURBANCE_KINDS:
                raise ConfigError(
                    "unknown disturbance kind",
                    source=source,
                    field=f"{where}.{kind}",
                    hint=f"use one of {_DISTURBANCE_KINDS}",
                )
            if not isinstance(v, int | float) or v < 0:
                raise ConfigError(
                    "must be a number ≥ 0", source=source, field=f"{where}.{kind}", value=v
                )
        return {str(k): float(v) for k, v in value.items()}
    if annotation in ("float", "float | None") and isinstance(value, int | float):
        if isinstance(value, bool):
            raise ConfigError("must be a number", source=source, field=where, value=value)
        return float(value)
    if annotation == "int" and not (isinstance(value, int) and not isinstance(value, bool)):
        raise ConfigError("must be an integer", source=source, field=where, value=value)
    if annotation == "bool" and not isinstance(value, bool):
        raise ConfigError("must be true or false", source=source, field=where, value=value)
    if annotation in ("str", "str | None") and value is not None and not isinstance(value, str):
        raise ConfigError("must be a string", source=source, field=where, value=value)
    if annotation == "float" and not isinstance(value, int | float):
        raise ConfigError("must be a number", source=source, field=where, value=value)
    return value


def _positive(obj: Any, name: str, *, source: str | Path, prefix: str) -> None:
    value = getattr(obj, name)
    if not value > 0:
        raise ConfigError("must be > 0", source=source, field=f"{prefix}{name}", value=value)


def _check_object(obj: Any, *, source: str | Path, prefix: str) -> None:
    """Cross-field checks, once per dataclass."""
    if isinstance(obj, ScenarioConfig):
        for name in ("days", "dt_s"):
            _positive(obj, name, source=source, prefix=prefix)
        if obj.dt_s != STEP_30MIN_S:
            raise ConfigError(
                "the control step must be the 30-min period of the data",
                source=source,
                field=f"{prefix}dt_s",
                value=obj.dt_s,
                hint=f"use dt_s = {STEP_30MIN_S:g} (prices, weather, forecasts and KPIs are "
                "half-hourly)",
            )
        try:
            start = pd.Timestamp(obj.start)
        except ValueError:
            raise ConfigError(
                "not a date", source=source, field="start", value=obj.start, hint="e.g. 2014-03-01"
            ) from None
        if start.tzinfo is not None:
            raise ConfigError(
                "give local Singapore time without a time-zone offset",
                source=source,
                field="start",
                value=obj.start,
                hint="e.g. 2014-03-01 or 2014-03-01T08:00",
            )
        if start != start.floor("30min"):
            raise ConfigError(
                "must start a 30-min period",
                source=source,
                field="start",
                value=obj.start,
                hint="e.g. 2014-03-01T08:00 or 2014-03-01T08:30",
            )
    elif isinstance(obj, EstimationConfig):
        if not obj.measurement_noise_k >= 0:
            raise ConfigError(
                "must be ≥ 0",
                source=source,
                field=f"{prefix}measurement_noise_k",
                value=obj.measurement_noise_k,
                hint="half-width of the uniform zone-air sensor error, e.g. 0.1",
            )
    elif isinstance(obj, ControllerConfig):
        _positive(obj, "horizon_steps", source=source, prefix=prefix)
        _positive(obj, "time_limit_s", source=source, prefix=prefix)
        _positive(obj, "comfort_penalty_sgd_per_kelvin_hour", source=source, prefix=prefix)
        if obj.peak_price_sgd_per_kw < 0:
            raise ConfigError(
                "must be ≥ 0",
                source=source,
                field=f"{prefix}peak_price_sgd_per_kw",
                value=obj.peak_price_sgd_per_kw,
            )
        if obj.kind == "thermostat" and obj.reserve:
            raise ConfigError(
                "the thermostat baseline cannot offer reserve",
                source=source,
                field=f"{prefix}reserve",
                value=True,
                hint="set reserve = false or kind = 'mpc'",
            )
    elif isinstance(obj, ComfortConfig):
        for name in ("occupied_degc", "unoccupied_degc"):
            lower, upper = getattr(obj, name)
            if not lower < upper:
                raise ConfigError(
                    "lower bound must be below the upper bound",
                    source=source,
                    field=f"{prefix}{name}",
                    value=[lower, upper],
                )
    elif isinstance(obj, ActivationConfig):
        if not 0.0 <= obj.rate <= 1.0:
            raise ConfigError(
                "must be in [0, 1]", source=source, field=f"{prefix}rate", value=obj.rate
            )
        _positive(obj, "duration_steps", source=source, prefix=prefix)
        if obj.mode == "file" and not obj.file:
            raise ConfigError(
                "mode 'file' needs a file",
                source=source,
                field=f"{prefix}file",
                hint="give a CSV with columns time, activated",
            )
    elif isinstance(obj, RealisationConfig):
        if not 0.0 <= obj.ar1_coefficient < 1.0:
            raise ConfigError(
                "must be in [0, 1)",
                source=source,
                field=f"{prefix}ar1_coefficient",
                value=obj.ar1_coefficient,
            )
    elif isinstance(obj, FeedbackConfig):
        _positive(obj, "memory_steps", source=source, prefix=prefix)


def scaled_uncertainty(cfg: ScenarioConfig, level: float) -> ScenarioConfig:
    """The scenario with σ = ``level`` × the heat gains (solar, internal), keeping T_out's σ."""
    unc = replace(cfg.uncertainty, relative={"solar": level, "internal_gain": level})
    return replace(cfg, uncertainty=unc)
