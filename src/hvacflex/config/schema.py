"""The scenario TOML file format: one declarative pydantic schema.

Each ``*Spec`` model mirrors one table of the file and one frozen dataclass of
:mod:`hvacflex.config.model`, from which it takes its defaults; fields carry their unit in
the name and their range in ``Field``; unknown keys are refused (``extra="forbid"``).
Checks that span fields are model validators raising :func:`rule_error`, whose context
names the field path; :func:`hvacflex.config.scenario_error` turns a ``ValidationError`` into
a ``ConfigError`` naming the file, the field path, the value and a hint.

File layout (every key optional)::

    preset?, name, building, start, days, dt_s, seed, initial_temp_degc
    [controller]   kind, robust, reserve, peak_price_sgd_per_kw, billing_mode,
                   comfort_penalty_sgd_per_kelvin_hour, comfort_knee_k,
                   comfort_penalty_beyond_knee_sgd_per_kelvin_hour, horizon_steps,
                   linearisation_temp_degc, time_limit_s, thermostat_setpoint_degc,
                   linearisation, optimal_start, demand_limit_fraction, reserve_share,
                   unoccupied_margin_k, unoccupied_plan_margin_k, lower_plan_margin_k,
                   peak_guard, peak_guard_substeps, power_model, power_level, fan_only_air
    [controller.feedback]  structure, memory_steps
    [reserve]      event_max_steps, event_allowance_k, event_recovery_steps,
                   non_delivery_penalty_sgd_per_mwh,
                   non_delivery_forfeits_reserve_payment, il_baseline,
                   commit_ahead_periods, meter_calibrated_offers,
                   plan_visible_offers
    [estimation]   mode, measurement_noise_k
    [uncertainty]  relative = {kind = fraction}, absolute = {kind = value},
                   calibrate = {train = "YYYY-MM-DD..YYYY-MM-DD", quantile, prediction_errors}
    [realisation]  mode, ar1_coefficient, occupancy, occupancy_seed, box_relative, box_absolute
    [forecast]     weather, train_days
    [activation]   mode, events_per_year, duration_steps, file
    [data]         weather_file, usep_source, reserve_source, reserve_price_scale,
                   reserve_price_correlation, price_gap_fill, calendar
    [comfort]      occupied_degc = [lower, upper], unoccupied_degc = [lower, upper]
    [plant]        kind, idf, actuation, timesteps_per_hour, curtailed_setpoint
"""

from __future__ import annotations

import math
from dataclasses import MISSING, fields
from typing import Annotated, Any, Self

import pandas as pd
from pydantic import (
    AfterValidator,
    AllowInfNan,
    BaseModel,
    ConfigDict,
    Field,
    Strict,
    model_validator,
)
from pydantic_core import PydanticCustomError

from hvacflex.config.model import (
    ActivationConfig,
    ActivationMode,
    BillingMode,
    CalibrationConfig,
    ComfortConfig,
    ControllerConfig,
    ControllerKind,
    CurtailedSetpoint,
    DataConfig,
    DisturbanceKind,
    EstimationConfig,
    EstimationMode,
    FeedbackConfig,
    ForecastConfig,
    ILBaseline,
    Linearisation,
    OccupancyMode,
    PeakGuardMode,
    PlantActuation,
    PlantConfig,
    PlantKind,
    PowerLevel,
    PowerModelSource,
    PriceCalendar,
    PriceGapFill,
    RealisationConfig,
    RealisationMode,
    ReserveConfig,
    ScenarioConfig,
    UncertaintyConfig,
    WeatherForecastMode,
)
from hvacflex.constants import (
    MAX_HORIZON_STEPS,
    PERIOD_S,
    PERIODS_PER_DAY,
    VALID_TIMESTEPS_PER_HOUR,
)
from hvacflex.dates import START_EXAMPLE, StartDateError, normalise_start
from hvacflex.opt.options import FeedbackStructure, RobustMode

Number = Annotated[float, Strict(), AllowInfNan(False)]
"""A finite TOML number (integer or float; booleans and strings refused)."""
NonNegative = Annotated[Number, Field(ge=0.0)]
Positive = Annotated[Number, Field(gt=0.0)]
Integer = Annotated[int, Strict()]
PositiveInt = Annotated[Integer, Field(ge=1)]
NonNegativeInt = Annotated[Integer, Field(ge=0)]
Text = Annotated[str, Strict()]
Flag = Annotated[bool, Strict()]
INDOOR_TEMP_MIN_DEGC = 0.0
INDOOR_TEMP_MAX_DEGC = 50.0
"""Range of an indoor temperature the controller aims at (comfort bounds, thermostat set
point, linearisation temperature) [°C]: wider than any comfort standard, narrow enough to
refuse a typo (260 for 26) or Fahrenheit."""
IndoorTemp = Annotated[Number, Field(ge=INDOOR_TEMP_MIN_DEGC, le=INDOOR_TEMP_MAX_DEGC)]
INITIAL_TEMP_MIN_DEGC = -40.0
INITIAL_TEMP_MAX_DEGC = 60.0
"""Range of the temperature a building can start a run at [°C] (an unheated building in a
cold winter to a closed one in the sun); outside it the state is physically impossible."""
MAX_DAYS = 3660.0
"""Longest run [days] (ten years)."""
Band = tuple[IndoorTemp, IndoorTemp]
"""A comfort band ``[lower, upper]`` [°C]."""

RULE_ERROR = "scenario_rule"
"""Error type of :func:`rule_error` (a check of the scenario file that spans fields)."""

RENAMED_KEYS: dict[tuple[str, str], str] = {
    ("activation", "rate"): "events_per_year (activations per year; the old per-period "
    "probability 0.02 is about 350 per year)",
}
"""Keys of older scenario files and what replaced them (named in the 'unknown key' hint)."""


def rule_error(
    message: str, field: str, value: object = None, hint: str | None = None
) -> PydanticCustomError:
    """A validation error for a check that spans fields; ``field`` is the path from the model
    that raises it (``""`` for a field validator: pydantic's location already names it)."""
    return PydanticCustomError(
        RULE_ERROR, "{message}", {"message": message, "field": field, "value": value, "hint": hint}
    )


def default(cls: type, name: str) -> Any:
    """The default of dataclass ``cls``'s field ``name`` (the one home of the defaults)."""
    spec = next(f for f in fields(cls) if f.name == name)
    if spec.default is not MISSING:
        return spec.default
    assert spec.default_factory is not MISSING
    return spec.default_factory()


class Spec(BaseModel):
    """Base of every table: frozen, unknown keys refused."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class FeedbackSpec(Spec):
    structure: FeedbackStructure = default(FeedbackConfig, "structure")
    """Which gains the affine disturbance-feedback policy has: ``full`` (every gain),
    ``memory`` (innovations of the last ``memory_steps`` only), ``time-invariant`` (one gain
    per lag up to ``memory_steps``) or ``zone-local`` (each zone's input reacts to its own
    zone's innovations, time-invariant; docs/explanation/closed_loop.md)."""
    memory_steps: PositiveInt = default(FeedbackConfig, "memory_steps")


class ControllerSpec(Spec):
    kind: ControllerKind = default(ControllerConfig, "kind")
    """The controller: ``mpc`` (the model-predictive controller; ``robust`` says which) or a
    rule-based baseline: ``thermostat``, ``trim-respond``, ``demand-limit``, ``gta-dr``
    (docs/explanation/baselines.md)."""
    robust: RobustMode = default(ControllerConfig, "robust")
    """How the MPC treats forecast errors: ``none`` the nominal MPC (NMPC), ``tightening`` the
    robust MPC (RMPC, comfort bounds tightened by the worst case over the box), ``dual`` the
    same robust LP in explicit dual form, ``feedback`` affine disturbance-feedback policies
    (docs/explanation/closed_loop.md)."""
    reserve: Flag = default(ControllerConfig, "reserve")
    """Whether interruptible-load (IL) reserve is offered and paid the reserve price."""
    peak_price_sgd_per_kw: NonNegative = default(ControllerConfig, "peak_price_sgd_per_kw")
    """The peak-power price φ [SGD/kW]: the cost of the highest power of the billing window (0:
    peak not priced)."""
    billing_mode: BillingMode = default(ControllerConfig, "billing_mode")
    """Which peak φ is charged on: ``horizon`` (the peak of each plan's horizon, the paper's) or
    ``billing-period`` (the calendar month's peak, the peak so far being a floor the plan need
    not pay again)."""
    comfort_penalty_sgd_per_kelvin_hour: Positive = default(
        ControllerConfig, "comfort_penalty_sgd_per_kelvin_hour"
    )
    """ρ: the price of a planned comfort violation [SGD per K·h] (an exact penalty: large enough
    that the plan violates only when the band cannot be kept)."""
    comfort_knee_k: NonNegative | None = default(ControllerConfig, "comfort_knee_k")
    """A comfort penalty that grows with the excursion: each zone's planned slack costs ρ up to
    this many kelvin and ``comfort_penalty_beyond_knee_sgd_per_kelvin_hour`` beyond, so a
    violation the plan cannot avoid is spread over zones and periods instead of put where a kW
    buys least (docs/explanation/model.md §3); leave it out for ρ on all of it. The MPC only."""
    comfort_penalty_beyond_knee_sgd_per_kelvin_hour: Positive = default(
        ControllerConfig, "comfort_penalty_beyond_knee_sgd_per_kelvin_hour"
    )
    """ρ₂ [SGD per K·h] ≥ ρ: the price of the slack beyond ``comfort_knee_k``."""
    horizon_steps: Annotated[PositiveInt, Field(le=MAX_HORIZON_STEPS)] = default(
        ControllerConfig, "horizon_steps"
    )
    """N: the MPC's look-ahead [30-min periods] (48 = one day)."""
    linearisation_temp_degc: IndoorTemp | None = default(
        ControllerConfig, "linearisation_temp_degc"
    )
    time_limit_s: Positive = default(ControllerConfig, "time_limit_s")
    """The solver's time limit per plan [s]; without an optimal plan in time the controller
    falls back to its previous plan (else the thermostat) for that period and offers no
    reserve (counted in ``fallback_count``)."""
    thermostat_setpoint_degc: IndoorTemp = default(ControllerConfig, "thermostat_setpoint_degc")
    feedback: FeedbackSpec = FeedbackSpec()
    linearisation: Linearisation = default(ControllerConfig, "linearisation")
    optimal_start: Flag = default(ControllerConfig, "optimal_start")
    unoccupied_margin_k: Annotated[Number, Field(ge=0.0, le=10.0)] = default(
        ControllerConfig, "unoccupied_margin_k"
    )
    """Rule-based controllers (``thermostat``, ``trim-respond``, ``demand-limit``,
    ``gta-dr``): the night float's set-point below the unoccupied upper comfort bound [K], never
    below its lower bound (``thermostat-25.5``: 1 K; ``thermostat-25.5-float``: 0.25 K)."""
    peak_guard: PeakGuardMode = default(ControllerConfig, "peak_guard")
    """While the peak is priced (φ > 0) the plan's peak is a commitment (``committed_peak_kw``:
    the plan's peak, or the month's billed peak so far if higher); the in-period peak guard
    reads the plant's meter ``peak_guard_substeps`` times a period and, while it exceeds the
    commitment, sheds supply flow towards the period's floor in the zones below their upper
    comfort bound, releasing as soon as the planned flows fit; on EnergyPlus it reads the HVAC
    meters at the engine's zone time step and raises the cooling set-points towards the upper
    bound by integral action on the excess, releasing step by step (docs/explanation/model.md).
    ``auto``: where the plant reads its meter within a period (the RC and the EnergyPlus plant);
    ``on``: required (a plant that cannot is refused before the run); ``off``: never."""
    peak_guard_substeps: Annotated[PositiveInt, Field(le=60)] = default(
        ControllerConfig, "peak_guard_substeps"
    )
    """The RC plant's peak-guard meter readings per period (6: every 5 min of a 30-min period;
    EnergyPlus reads at its zone time step)."""
    unoccupied_plan_margin_k: Annotated[Number, Field(ge=0.0, le=10.0)] = default(
        ControllerConfig, "unoccupied_plan_margin_k"
    )
    """The MPC does not ride the unoccupied bound: the end-of-period zone temperatures it
    plans stay this far below the upper comfort bound of unoccupied periods [K] (never below
    the lower bound; the ``comfort_upper_*`` result columns, which the KPIs grade against,
    keep the band)."""
    lower_plan_margin_k: Annotated[Number, Field(ge=0.0, le=10.0)] = default(
        ControllerConfig, "lower_plan_margin_k"
    )
    """The MPC does not ride the lower bound: the end-of-period zone temperatures it plans
    stay this far above the lower comfort bound [K], occupied or not (never above the plan's
    upper bound; the ``comfort_lower_*`` columns keep the band). 0 (the default): a plan may
    pre-cool to the bound itself, where a nominal plan's realised errors then cross it."""
    fan_only_air: Flag = default(ControllerConfig, "fan_only_air")
    """An identified building that records its coil's hours (``[identified.idle_air]``): the
    MPC plans an idle zone's input in the coil's off hours (a unit per zone: its fan's
    hours) as its fan-only air and counts the coil's air (a unit per zone: the fan-only air)
    for the idle zones when another zone's call starts the coil (the fans); ``false``: the
    minimum flow is the coil's air at every hour (docs/guide/identify.md §3)."""
    power_model: PowerModelSource = default(ControllerConfig, "power_model")
    """The LP's power rows: ``metered`` plans with the building file's power model fitted to
    the meter of the scenario's plant (``[power_models.rc]`` / ``[power_models.energyplus]``,
    ``hvacflex identify power``; docs/explanation/model.md §1.6) where the file has one, else with
    the design curves; ``design`` always with the design curves (an identified building has only
    its fitted model)."""
    power_level: PowerLevel = default(ControllerConfig, "power_level")
    """The MPC's planned power in occupied periods: ``model`` as the power model gives it;
    ``auto`` (default) ``meter`` on an EnergyPlus plant and ``model`` on the RC plant;
    ``meter`` levelled to the meter: plus the mean of the metered minus the model's power over
    the periods a fresh plan served at the same time of day in the last five days (over the
    last 20 occupied ones while fewer than two exist) (an offset-free output,
    like the Kalman filter's offsets for the zones; docs/explanation/model.md §1.6). It moves
    the planned power, the committed peak and the pull-down cap onto the meter's scale where
    the plant's own loops deliver other flows than the plan's (EnergyPlus under setpoint
    actuation); the flows' costs per kW are unchanged."""
    demand_limit_fraction: Annotated[Number, Field(gt=0.0, le=1.0)] = default(
        ControllerConfig, "demand_limit_fraction"
    )
    reserve_share: Annotated[Number, Field(ge=0.0, le=1.0)] = default(
        ControllerConfig, "reserve_share"
    )

    @model_validator(mode="after")
    def _convex_knee(self) -> Self:
        beyond = self.comfort_penalty_beyond_knee_sgd_per_kelvin_hour
        if self.comfort_knee_k is not None and beyond < self.comfort_penalty_sgd_per_kelvin_hour:
            raise rule_error(
                f"the penalty beyond the comfort knee must be at least comfort_penalty_"
                f"sgd_per_kelvin_hour ({self.comfort_penalty_sgd_per_kelvin_hour:g})",
                "comfort_penalty_beyond_knee_sgd_per_kelvin_hour",
                beyond,
                hint="raise it, or lower comfort_penalty_sgd_per_kelvin_hour",
            )
        return self

    @model_validator(mode="after")
    def _plan_linearisation_needs_an_open_loop_policy(self) -> Self:
        if self.linearisation == "plan" and self.robust == "feedback":
            raise rule_error(
                "linearisation = 'plan' (B diag(s_k) at each step) is not available with "
                "robust = 'feedback'",
                "linearisation",
                self.linearisation,
                hint="use linearisation = 'fixed' or 'trajectory' with feedback, or robust = "
                "'tightening' or 'none'",
            )
        return self

    @model_validator(mode="after")
    def _thermostat_offers_no_reserve(self) -> Self:
        if self.kind in ("thermostat", "trim-respond", "demand-limit", "plant") and self.reserve:
            raise rule_error(
                f"the {self.kind} baseline cannot offer reserve",
                "reserve",
                True,
                hint="set reserve = false, or kind = 'gta-dr' or 'mpc'",
            )
        return self


class ReserveSpec(Spec):
    event_max_steps: PositiveInt | None = default(ReserveConfig, "event_max_steps")
    """D: the longest IL activation the plan must survive [30-min periods] (the event model: at
    most one activation of up to D periods in the horizon); leave it out for the paper's
    whole-horizon model."""
    event_allowance_k: NonNegative = default(ReserveConfig, "event_allowance_k")
    """α: how far the upper comfort bound widens during an IL event and its recovery [K] (event
    model only)."""
    event_recovery_steps: NonNegativeInt = default(ReserveConfig, "event_recovery_steps")
    """R: the periods after an event that keep the allowance α, decaying, for the zones to
    recover [30-min periods]."""
    non_delivery_penalty_sgd_per_mwh: NonNegative = default(
        ReserveConfig, "non_delivery_penalty_sgd_per_mwh"
    )
    non_delivery_forfeits_reserve_payment: bool = default(
        ReserveConfig, "non_delivery_forfeits_reserve_payment"
    )
    il_baseline: ILBaseline = default(ReserveConfig, "il_baseline")
    commit_ahead_periods: Annotated[NonNegativeInt, Field(le=MAX_HORIZON_STEPS)] = default(
        ReserveConfig, "commit_ahead_periods"
    )
    meter_calibrated_offers: bool = default(ReserveConfig, "meter_calibrated_offers")
    plan_visible_offers: bool = default(ReserveConfig, "plan_visible_offers")


class EstimationSpec(Spec):
    mode: EstimationMode = default(EstimationConfig, "mode")
    """What the controller measures: ``full-state`` (every node temperature of the plant) or
    ``kalman`` (zone air only, with sensor error, estimated by a Kalman filter)."""
    measurement_noise_k: NonNegative = default(EstimationConfig, "measurement_noise_k")


def _train_period(text: str) -> str:
    """``"YYYY-MM-DD..YYYY-MM-DD"``, first day ≤ last day."""
    parts = text.split("..")
    hint = "e.g. '2014-02-24..2014-03-02' (both days included)"
    if len(parts) != 2:
        raise rule_error("not a period 'first..last'", "", text, hint=hint)
    try:
        first, last = (pd.Timestamp(p) for p in parts)
    except ValueError:
        raise rule_error("not a period of dates", "", text, hint=hint) from None
    if first != first.normalize() or last != last.normalize() or first.tzinfo or last.tzinfo:
        raise rule_error("give whole days without a time or time zone", "", text, hint=hint)
    if last < first:
        raise rule_error("the last day is before the first", "", text, hint=hint)
    return text


class CalibrationSpec(Spec):
    train: Annotated[Text, AfterValidator(_train_period)]
    """The training period ``"YYYY-MM-DD..YYYY-MM-DD"`` (both days included, outside the run)
    whose forecast errors size the box."""
    quantile: Annotated[Number, Field(gt=0.0, lt=1.0)] = default(CalibrationConfig, "quantile")
    """The quantile of the training errors taken as each channel's half-width (0.95: the box
    covers 95 % of them)."""
    prediction_errors: Text | None = default(CalibrationConfig, "prediction_errors")
    """A results file (``results.parquet``) whose ``prediction_error_<zone>_k`` on the training
    days size a per-zone model-error term (a relative path is taken from the scenario file's
    folder); leave it out for none."""


class UncertaintySpec(Spec):
    relative: dict[DisturbanceKind, NonNegative] = default(UncertaintyConfig, "relative")
    """Half-widths of the forecast-error box as a fraction of the forecast, per disturbance kind
    (``solar = 0.05`` is ±5 %; ``solar`` also sizes an angle-dependent window's gain)."""
    absolute: dict[DisturbanceKind, NonNegative] = default(UncertaintyConfig, "absolute")
    """Half-widths of the forecast-error box in the channel's unit, per disturbance kind (K for
    ``outdoor_temp`` and ``ground_temp``, W/m² for ``solar`` and ``sky_longwave`` (the sky's
    long-wave loss, in a building with emissive exterior surfaces), W for ``internal_gain``);
    added to ``relative``."""
    calibrate: CalibrationSpec | None = None


class RealisationSpec(Spec):
    mode: RealisationMode = default(RealisationConfig, "mode")
    """How the error w the plant sees is drawn inside the box: ``zero`` (the forecast is exact),
    ``uniform`` (independent, uniform in ±σ, seeded), ``ar1`` (uniform marginals, correlated in
    time), ``worst-upper`` (+σ: hottest) or ``worst-lower`` (−σ)."""
    ar1_coefficient: Annotated[Number, Field(ge=0.0, lt=1.0)] = default(
        RealisationConfig, "ar1_coefficient"
    )
    """The AR(1) coefficient of ``mode = "ar1"`` (0: independent steps; towards 1: slowly
    varying errors)."""
    occupancy: OccupancyMode = default(RealisationConfig, "occupancy")
    """The internal gains the plant sees: ``schedule`` (the office schedule the controller
    forecasts) or ``stochastic`` (seeded occupants per zone)."""
    occupancy_seed: NonNegativeInt | None = default(RealisationConfig, "occupancy_seed")
    """Seed of the stochastic occupants alone (the other draws keep the scenario's ``seed``);
    leave it out to use the scenario's ``seed``."""
    box_relative: dict[DisturbanceKind, NonNegative] | None = default(
        RealisationConfig, "box_relative"
    )
    """A box of its own for w, relative half-widths per kind as in ``[uncertainty]`` (a stress
    test outside the box the controller plans for); leave it out to draw in the scenario's
    box."""
    box_absolute: dict[DisturbanceKind, NonNegative] | None = default(
        RealisationConfig, "box_absolute"
    )
    """A box of its own for w, absolute half-widths per kind as in ``[uncertainty]``; leave it
    out to draw in the scenario's box."""


class ForecastSpec(Spec):
    weather: WeatherForecastMode = default(ForecastConfig, "weather")
    """The weather forecast the controller is told: ``perfect`` (the weather file itself) or
    ``statistical`` (fitted on the days before the run, docs/explanation/forecast.md)."""
    train_days: PositiveInt = default(ForecastConfig, "train_days")
    """The days before the run the statistical weather forecast is fitted on [days]."""


class ActivationSpec(Spec):
    mode: ActivationMode = default(ActivationConfig, "mode")
    """When the grid activates the IL reserve: ``never``; ``random`` (``events_per_year``,
    seeded); ``stress`` (one activation every weekday, starting 08:00–18:00); ``file`` (periods
    read from ``file``); ``always`` (every period, the paper's literal case)."""
    events_per_year: NonNegative = default(ActivationConfig, "events_per_year")
    duration_steps: PositiveInt | None = default(ActivationConfig, "duration_steps")
    file: Text | None = default(ActivationConfig, "file")

    @model_validator(mode="after")
    def _file_mode_needs_a_file(self) -> Self:
        if self.mode == "file" and not self.file:
            raise rule_error(
                "mode 'file' needs a file", "file", hint="give a CSV with columns time, activated"
            )
        return self


class DataSpec(Spec):
    weather_file: Text | None = default(DataConfig, "weather_file")
    """An EPW weather file (a typical year, mapped onto the run's year); leave it out for the
    shipped Singapore Changi TMYx."""
    usep_source: Text | None = default(DataConfig, "usep_source")
    """USEP energy-price CSV file(s) or a folder of them; leave it out for the shipped NEMS USEP
    2014 (docs/reference/data.md)."""
    reserve_source: Text | None = default(DataConfig, "reserve_source")
    """A reserve-price CSV; leave it out for the seeded synthetic reserve prices
    (docs/reference/data.md)."""
    reserve_price_scale: Positive | None = default(DataConfig, "reserve_price_scale")
    reserve_price_correlation: Annotated[Number, Field(ge=0.0, le=1.0)] = default(
        DataConfig, "reserve_price_correlation"
    )
    """How much of the synthetic reserve price follows USEP, a weight in [0, 1]: 1 (the
    default) is the calibrated series, which follows USEP and its spikes; 0 a price
    independent of USEP at the same level (``reserve_price_scale`` × lognormal noise); in
    between a mix. Only for the synthetic price: refused with ``reserve_source``."""
    price_gap_fill: PriceGapFill = default(DataConfig, "price_gap_fill")
    calendar: PriceCalendar = default(DataConfig, "calendar")

    @model_validator(mode="after")
    def _synthetic_keys_need_the_synthetic_price(self) -> Self:
        if self.reserve_source is None:
            return self
        for name in ("reserve_price_scale", "reserve_price_correlation"):
            if name in self.model_fields_set:
                raise rule_error(
                    f"{name} shapes the synthetic reserve price, but reserve_source gives the "
                    "prices",
                    name,
                    getattr(self, name),
                    hint=f"remove {name}, or remove reserve_source to use the synthetic price",
                )
        return self


def _ordered(band: tuple[float, float]) -> tuple[float, float]:
    """The lower bound below the upper bound."""
    if not band[0] < band[1]:
        raise rule_error("lower bound must be below the upper bound", "", list(band))
    return band


class ComfortSpec(Spec):
    occupied_degc: Annotated[Band, AfterValidator(_ordered)] = default(
        ComfortConfig, "occupied_degc"
    )
    """The comfort band ``[lower, upper]`` while the office is occupied [°C]."""
    unoccupied_degc: Annotated[Band, AfterValidator(_ordered)] = default(
        ComfortConfig, "unoccupied_degc"
    )
    """The comfort band ``[lower, upper]`` while it is not (nights, weekends, public holidays)
    [°C]."""


def _valid_timesteps(value: int) -> int:
    """One of :data:`VALID_TIMESTEPS_PER_HOUR` (the zone time steps that tile the 30-min
    period)."""
    if value not in VALID_TIMESTEPS_PER_HOUR:
        raise rule_error(
            "EnergyPlus zone time steps must tile the 30-min period",
            "",
            value,
            hint=f"use one of {list(VALID_TIMESTEPS_PER_HOUR)}",
        )
    return value


class PlantSpec(Spec):
    kind: PlantKind = default(PlantConfig, "kind")
    """What the controller is graded on: ``rc`` (hvacflex's own nonlinear RC network) or
    ``energyplus`` (an EnergyPlus 25.2 model, needs the ``energyplus`` extra;
    docs/guide/energyplus.md)."""
    idf: Annotated[Text, Field(min_length=1)] = default(PlantConfig, "idf")
    """The EnergyPlus model: ``generated`` (the building's own IDF export), a shipped model's
    name (``5ZoneAirCooled``, ``packaged_shops``) or the path of an EnergyPlus 25.2 IDF file
    (a relative path is taken from the scenario file's folder)."""
    actuation: PlantActuation | None = default(PlantConfig, "actuation")
    """What hvacflex sets on the plant: ``setpoint`` (zone cooling setpoints, EnergyPlus's
    default) or ``flow`` (zone supply flows, the RC plant's only one); leave it out for the
    plant's default."""
    timesteps_per_hour: Annotated[PositiveInt, AfterValidator(_valid_timesteps)] = default(
        PlantConfig, "timesteps_per_hour"
    )
    """EnergyPlus's zone time steps per hour."""
    curtailed_setpoint: CurtailedSetpoint = default(PlantConfig, "curtailed_setpoint")
    """What a setpoint-actuated plant is told while IL curtails it (activated, reserve
    offered): ``plan`` (each zone's planned curtailed temperature) or ``limit`` (the upper
    comfort bound plus the event allowance α: the deepest shed the contract allows, more
    delivered against the meter for warmer zones)."""

    @model_validator(mode="after")
    def _rc_is_flow_actuated(self) -> Self:
        if self.kind == "rc" and self.actuation == "setpoint":
            raise rule_error(
                "the RC plant is flow-actuated",
                "actuation",
                "setpoint",
                hint="use actuation = 'flow' (or leave it out), or kind = 'energyplus'",
            )
        flow = self.kind == "rc" or self.actuation == "flow"
        if self.curtailed_setpoint == "limit" and flow:
            raise rule_error(
                "a curtailed setpoint needs setpoint actuation (the plant is flow-actuated)",
                "curtailed_setpoint",
                "limit",
                hint="use kind = 'energyplus' with actuation = 'setpoint' (or left out), "
                "or leave curtailed_setpoint out",
            )
        return self


def _period_start(text: str) -> str:
    """A local date-time on a 30-min period start in ISO 8601, normalised
    (:func:`hvacflex.dates.normalise_start`)."""
    try:
        return normalise_start(text)
    except StartDateError as exc:
        raise rule_error(
            exc.problem, "", text, hint=f"e.g. {START_EXAMPLE} (Singapore local time)"
        ) from None


def whole_periods_problem(days: float) -> str | None:
    """What is wrong with a run length of ``days`` [days], or None: it must be finite, > 0,
    at most :data:`MAX_DAYS` and a whole number (≥ 1) of 30-min periods."""
    periods = days * PERIODS_PER_DAY
    if not math.isfinite(days):
        return "must be a finite number of days"
    if days <= 0:
        return "must be > 0"
    if days > MAX_DAYS:
        return f"must be at most {MAX_DAYS:g} days (ten years)"
    if periods < 1 - 1e-6:
        return "must be at least one 30-min period (1/48 day ≈ 0.0208)"
    if abs(periods - round(periods)) > 1e-6:
        return "must be a whole number of 30-min periods (a multiple of 1/48 day)"
    return None


DAYS_HINT = "e.g. days = 0.5, 7 or 365"


def _whole_periods(days: float) -> float:
    """A whole number (≥ 1) of 30-min periods, at most :data:`MAX_DAYS` days."""
    problem = whole_periods_problem(days)
    if problem is not None:
        raise rule_error(problem, "", days, hint=DAYS_HINT)
    return days


def _half_hourly(dt_s: float) -> float:
    """Only :data:`PERIOD_S` (the 30-min period of the data)."""
    if dt_s != PERIOD_S:
        raise rule_error(
            "the control step must be the 30-min period of the data",
            "",
            dt_s,
            hint=f"use dt_s = {PERIOD_S:g} (prices, weather, forecasts and KPIs are half-hourly)",
        )
    return dt_s


class ScenarioSpec(Spec):
    name: Text = default(ScenarioConfig, "name")
    """The run's name (in reports and tables); a scenario file's default is its file name."""
    building: Text = default(ScenarioConfig, "building")
    """The building: a shipped name (``office5``, ``room1``, ``bestest600``, ``bestest900``) or
    the path of a building TOML file (docs/explanation/buildings.md)."""
    start: Annotated[Text, AfterValidator(_period_start)] = default(ScenarioConfig, "start")
    days: Annotated[Number, AfterValidator(_whole_periods)] = default(ScenarioConfig, "days")
    """The run's length [days]: a whole number of 30-min periods."""
    dt_s: Annotated[Positive, AfterValidator(_half_hourly)] = default(ScenarioConfig, "dt_s")
    """The control period [s]; prices, weather and KPIs are half-hourly, so only 1800."""
    seed: NonNegativeInt = default(ScenarioConfig, "seed")
    """The seed of every random draw of the run (forecast errors, activations, occupancy,
    synthetic reserve prices)."""
    initial_temp_degc: Annotated[
        Number, Field(ge=INITIAL_TEMP_MIN_DEGC, le=INITIAL_TEMP_MAX_DEGC)
    ] = default(ScenarioConfig, "initial_temp_degc")
    """The temperature of every node of the building at the start [°C]."""
    controller: ControllerSpec = ControllerSpec()
    reserve: ReserveSpec = ReserveSpec()
    estimation: EstimationSpec = EstimationSpec()
    uncertainty: UncertaintySpec = UncertaintySpec()
    realisation: RealisationSpec = RealisationSpec()
    activation: ActivationSpec = ActivationSpec()
    data: DataSpec = DataSpec()
    comfort: ComfortSpec = ComfortSpec()
    plant: PlantSpec = PlantSpec()
    forecast: ForecastSpec = ForecastSpec()

    @model_validator(mode="after")
    def _training_before_or_after_the_run(self) -> Self:
        calibrate = self.uncertainty.calibrate
        if calibrate is None:
            return self
        first, last = (pd.Timestamp(p) for p in calibrate.train.split(".."))
        start = pd.Timestamp(self.start)
        end = start + pd.Timedelta(days=self.days)
        if first < end and last + pd.Timedelta(days=1) > start:
            raise rule_error(
                "the training period overlaps the run",
                "uncertainty.calibrate.train",
                calibrate.train,
                hint=f"the run is {start:%Y-%m-%d %H:%M} … {end:%Y-%m-%d %H:%M}; train on "
                "other days, so the box's coverage on the run is out of sample",
            )
        return self

    @model_validator(mode="after")
    def _plant_control_needs_a_setpoint_plant(self) -> Self:
        plant = self.plant
        if self.controller.kind == "plant" and (
            plant.kind != "energyplus" or plant.actuation == "flow"
        ):
            raise rule_error(
                "the plant's own control (controller kind 'plant') needs a setpoint-actuated "
                "EnergyPlus plant",
                "plant.kind",
                plant.kind,
                hint="set [plant] kind = 'energyplus' with actuation = 'setpoint'",
            )
        return self

    @model_validator(mode="after")
    def _commitments_inside_the_horizon(self) -> Self:
        ahead, horizon = self.reserve.commit_ahead_periods, self.controller.horizon_steps
        if ahead >= horizon:
            raise rule_error(
                f"reserve is committed {ahead} periods ahead, not inside the horizon of "
                f"{horizon} periods",
                "reserve.commit_ahead_periods",
                ahead,
                hint=f"use 0 … {horizon - 1} (NEMS: 2, offers firm ≈ 65 min ahead)",
            )
        return self

    @model_validator(mode="after")
    def _gta_dr_needs_events(self) -> Self:
        if self.controller.kind == "gta-dr" and self.reserve.event_max_steps is None:
            raise rule_error(
                "the gta-dr baseline raises set-points by the event allowance α, which needs "
                "the IL event model",
                "reserve.event_max_steps",
                None,
                hint="set [reserve] event_max_steps (e.g. 4) and event_allowance_k (e.g. 1.0)",
            )
        return self

    @model_validator(mode="after")
    def _events_need_an_open_loop_policy(self) -> Self:
        robust = self.controller.robust
        if self.reserve.event_max_steps is not None and robust in ("feedback", "dual"):
            raise rule_error(
                f"the IL event model is not available with robust = {robust!r}",
                "reserve.event_max_steps",
                self.reserve.event_max_steps,
                hint="use robust = 'tightening' or 'none', or drop event_max_steps (the "
                "whole-horizon model, e.g. preset 'rmpc-feedback')",
            )
        return self


TABLES: dict[type[BaseModel], type] = {
    ScenarioSpec: ScenarioConfig,
    ControllerSpec: ControllerConfig,
    FeedbackSpec: FeedbackConfig,
    ReserveSpec: ReserveConfig,
    EstimationSpec: EstimationConfig,
    UncertaintySpec: UncertaintyConfig,
    RealisationSpec: RealisationConfig,
    ActivationSpec: ActivationConfig,
    DataSpec: DataConfig,
    ComfortSpec: ComfortConfig,
    PlantSpec: PlantConfig,
    CalibrationSpec: CalibrationConfig,
    ForecastSpec: ForecastConfig,
}
"""Each table's schema and the domain dataclass it becomes."""


def to_domain(spec: BaseModel) -> Any:
    """The frozen dataclass of a validated table (nested tables converted recursively)."""
    values: dict[str, Any] = {}
    for name in type(spec).model_fields:
        value = getattr(spec, name)
        if isinstance(value, BaseModel):
            value = to_domain(value)
        elif isinstance(value, dict):
            value = {str(k): float(v) for k, v in value.items()}
        elif isinstance(value, tuple):
            value = tuple(float(v) for v in value)
        values[name] = value
    return TABLES[type(spec)](**values)
