"""The scenario's domain objects: frozen dataclasses, one per table of the scenario TOML.

These are what the rest of the package reads (``ScenarioConfig`` & co.); the file format and
its validation live in :mod:`hvacflex.config.schema`, which takes its defaults from here.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import pandas as pd

from hvacflex.constants import (
    AR1_COEFFICIENT,
    DEFAULT_DAYS,
    DEFAULT_START,
    HORIZON_STEPS,
    PERIOD_S,
    TIMEZONE,
)
from hvacflex.data.market import RESERVE_PRICE_CORRELATION
from hvacflex.data.weather_forecast import WEATHER_TRAIN_DAYS
from hvacflex.opt.options import (
    DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR,
    DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR,
    FeedbackStructure,
    RobustMode,
)

ControllerKind = Literal["mpc", "thermostat", "trim-respond", "demand-limit", "gta-dr", "plant"]
BillingMode = Literal["horizon", "billing-period"]
RealisationMode = Literal["zero", "uniform", "worst-upper", "worst-lower", "ar1"]
ActivationMode = Literal["never", "always", "random", "stress", "file"]
PriceGapFill = Literal["none", "previous-day"]
PriceCalendar = Literal["data", "live"]
DisturbanceKind = Literal["outdoor_temp", "solar", "internal_gain", "ground_temp", "sky_longwave"]
Linearisation = Literal["fixed", "trajectory", "plan"]
PeakGuardMode = Literal["auto", "on", "off"]
PowerModelSource = Literal["metered", "design"]
PowerLevel = Literal["auto", "model", "meter"]
EstimationMode = Literal["full-state", "kalman"]
PlantKind = Literal["rc", "energyplus"]
PlantActuation = Literal["setpoint", "flow"]
CurtailedSetpoint = Literal["plan", "limit"]
WeatherForecastMode = Literal["perfect", "statistical"]
OccupancyMode = Literal["schedule", "stochastic"]
ILBaseline = Literal["pre-event", "similar-days"]

NEMS_MAX_INTERRUPTION_STEPS = 4
"""The NEMS 120-minute rule (since 2019): after four 30-min periods of interruption the
provider may resume consumption. The product presets plan for events of up to this length."""

DEFAULT_EVENTS_PER_YEAR = 4.0
"""Rate of random IL activations [events per year]. NEMS activates interruptible load only
after a contingency (the loss of a large generating unit drives the frequency down), which
happens a few times a year; 4 a year is our assumption within that "rare"
(docs/explanation/il_events.md), not a published statistic — a setting (``[activation]
events_per_year``)."""

DEFAULT_COMMIT_AHEAD_PERIODS = 2
"""g: reserve for period k is committed at the start of period k − g [30-min periods]. NEMS
offers can be revised until about 65 min before their period (gate closure), so an offer
decided at the start of a period is firm for the period after next."""

DEFAULT_NON_DELIVERY_PENALTY_SGD_PER_MWH = 4500.0
"""Penalty on reserve not delivered during an activation [SGD/MWh]: the NEMS energy price
cap, i.e. the shortfall is charged as if bought at the cap."""


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
    comfort_knee_k: float | None = None
    """The MPC: each zone's slack is priced at ρ up to this excursion [K] and at
    ``comfort_penalty_beyond_knee_sgd_per_kelvin_hour`` beyond it (None: ρ on all of it)."""
    comfort_penalty_beyond_knee_sgd_per_kelvin_hour: float = (
        DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR
    )
    horizon_steps: int = HORIZON_STEPS
    linearisation_temp_degc: float | None = None
    """T₀ of the VAV linearisation [°C]; ``None`` = the occupied upper comfort bound less
    ``LINEARISATION_MARGIN_K`` (25 °C for the default band), where the controller operates."""
    time_limit_s: float = 20.0
    thermostat_setpoint_degc: float = 24.0
    """Occupied set-point of the rule-based controllers (and the MPC's fallback) [°C]."""
    optimal_start: bool = False
    """Rule-based controllers: pre-cool before occupancy with the learned lead
    (:class:`hvacflex.control.baselines.OptimalStart`)."""
    unoccupied_margin_k: float = 1.0
    """Rule-based controllers: the night float's set-point below the unoccupied upper comfort
    bound [K] (never below the lower bound)."""
    peak_guard: PeakGuardMode = "auto"
    """The in-period peak guard while φ > 0 (docs/explanation/model.md, the committed peak):
    ``"auto"`` on a plant that reads its meter within a period (the RC plant), ``"on"``
    required (a plant that cannot: refused before the run), ``"off"`` never."""
    peak_guard_substeps: int = 6
    """The guard's meter readings per period (6: every 5 min of a 30-min period)."""
    unoccupied_plan_margin_k: float = 0.5
    """The MPC: its plan keeps the end-of-period zone temperatures this far below the upper
    comfort bound of unoccupied periods [K] (not written into ``comfort_upper_*``)."""
    lower_plan_margin_k: float = 0.0
    """The MPC: its plan keeps the end-of-period zone temperatures this far above the lower
    comfort bound [K], occupied or not (never above the plan's upper bound; not written into
    ``comfort_lower_*``)."""
    fan_only_air: bool = True
    """The MPC on an identified building with ``[identified.idle_air]``: plan an idle zone's
    input in the coil's off hours (a unit per zone: its fan's hours) as its fan-only air, and
    count the coil's air (a unit per zone: the fan-only air) for the idle zones when another
    zone's call starts the coil (the fans) (:mod:`hvacflex.control.idle_air`); ``False``: the
    minimum flow is the coil's air at every hour."""
    power_model: PowerModelSource = "metered"
    """The LP's power rows: ``"metered"`` the building file's power model fitted to the meter
    of the scenario's plant (``[power_models.<kind>]``) where it has one, else the design
    curves; ``"design"`` the design curves (an identified building has only its fitted one)."""
    power_level: PowerLevel = "auto"
    """The MPC: the level of the LP's power rows. ``"model"``: the power model's own;
    ``"meter"``: levelled to the meter, each period's power the model's plus the mean of the
    metered minus the model's power over the building's recent served periods of the same
    class (occupied, the morning pull-down's unoccupied steps, the other unoccupied ones) at
    the same time of day (:meth:`hvacflex.control.meter_response.MeterHistory.offsets_kw`);
    ``"auto"``: ``"meter"`` on an EnergyPlus plant, ``"model"`` on hvacflex's RC plant (whose
    meter is the power model's own curves, or what the model was fitted to)."""
    demand_limit_fraction: float = 0.9
    """``demand-limit``: the peak target's share of yesterday's unmanaged peak."""
    reserve_share: float = 0.2
    """``gta-dr``: the share of the predicted HVAC load offered as IL reserve."""
    feedback: FeedbackConfig = field(default_factory=FeedbackConfig)
    linearisation: Linearisation = "fixed"
    """``"fixed"``: the model linearised once at (ṁ_min, T₀); ``"trajectory"``: re-linearised
    each step about the previous plan shifted by one step (docs/explanation/estimation.md §3);
    ``"plan"``: every step of the horizon at the previous plan's zone temperatures over that
    step, one step on — the supply air's cooling per kg/s (B diag(s_k), A kept) and the
    design curves' coil power (docs/explanation/estimation.md §3)."""


@dataclass(frozen=True)
class EstimationConfig:
    """What the controller measures (``[estimation]``, docs/explanation/estimation.md).

    ``"full-state"``: every node temperature of the plant; ``"kalman"``: only the zone air
    temperatures, with uniform sensor error in ±``measurement_noise_k`` [K], and a Kalman
    filter with per-zone offset states estimates the rest (tuned covariances).
    """

    mode: EstimationMode = "full-state"
    measurement_noise_k: float = 0.1
    """Half-width of the uniform zone-air sensor error [K]."""


@dataclass(frozen=True)
class ReserveConfig:
    """The interruptible-load (IL) contract the controller plans for (``[reserve]``).

    ``event_max_steps = None`` is the paper's whole-horizon model: the curtailed trajectory
    u − r must keep the strict comfort band for the whole horizon. An integer D is the event
    model: at most one activation of up to D consecutive 30-min periods in the horizon, during
    which and ``event_recovery_steps`` periods after which the upper comfort bound widens by
    ``event_allowance_k``. See ``docs/explanation/il_events.md``.
    """

    event_max_steps: int | None = None
    event_allowance_k: float = 0.0
    event_recovery_steps: int = 0
    non_delivery_penalty_sgd_per_mwh: float = DEFAULT_NON_DELIVERY_PENALTY_SGD_PER_MWH
    """Price of reserve not delivered during an activation [SGD/MWh of shortfall]."""
    non_delivery_forfeits_reserve_payment: bool = True
    """Whether the reserve payment of the capacity not delivered is paid back as well."""
    il_baseline: ILBaseline = "pre-event"
    """How delivery is measured (:mod:`hvacflex.settlement`): against the metered power of
    the period before the activation (``"pre-event"``) or the mean of the same period on the
    last 5 similar days (``"similar-days"``)."""
    commit_ahead_periods: int = DEFAULT_COMMIT_AHEAD_PERIODS
    """g [periods]: the reserve of period k is committed g periods ahead and is then firm
    (the controller plans with it fixed); 0 = decided at the period's start. Applies to the
    event model with a controller that plans ahead (an MPC); the whole-horizon model (the
    paper's) and the rule-based controllers decide each period's offer at its start."""
    meter_calibrated_offers: bool = True
    """Whether the event model's offers are scaled by how the meter answers the plan's power
    changes (:mod:`hvacflex.control.meter_response`: ρ ∈ [0, 1] from the building's recent
    occupied periods), so that the capacity offered is what the metered settlement will see;
    False: offers on the power model's own scale. The whole-horizon model (the paper's)
    never scales."""
    plan_visible_offers: bool = True
    """Whether the event model's plan is paid only for the part of each offer that the
    settlement baselines will see (:func:`hvacflex.opt.lp.add_visible_offers`), so that it
    shapes its load to be seen where that pays; False: the plan is paid q·r and the offers
    are cut to what is seen afterwards. The offers are sized to the baselines either way."""

    @property
    def ahead_offer_steps(self) -> int:
        """J: the steps 0 … J − 1 of a plan for which an offer is sized — the committed one
        g and, under the event model, the event plan's D + R periods."""
        event = 0 if self.event_max_steps is None else self.event_max_steps
        return max(self.commit_ahead_periods, event + self.event_recovery_steps - 1) + 1


@dataclass(frozen=True)
class CalibrationConfig:
    """Size the box from a training period's errors (``[uncertainty] calibrate``,
    docs/explanation/forecast.md, :func:`hvacflex.data.calibration.calibrate_box`).

    ``train`` is ``"YYYY-MM-DD..YYYY-MM-DD"`` (both days included; it must not overlap the
    run); the box's half-widths per channel are the ``quantile`` of the errors of the
    forecasts the scenario's forecaster would have made on those days (every lead of the
    horizon), against the data the plant would have seen. ``prediction_errors``: a results
    file (``results.parquet``) whose ``prediction_error_<zone>_k`` on the training days size
    the per-zone model-error term; ``None``: no model-error term.
    """

    train: str
    quantile: float = 0.95
    prediction_errors: str | None = None

    @property
    def train_days(self) -> tuple[pd.Timestamp, pd.Timestamp]:
        """(first day, last day) of the training period, local midnight."""
        first, last = self.train.split("..")
        return pd.Timestamp(first, tz=TIMEZONE), pd.Timestamp(last, tz=TIMEZONE)


@dataclass(frozen=True)
class UncertaintyConfig:
    """Half-widths σ of the forecast-error box, per disturbance kind.

    ``relative`` is a fraction of the forecast value (solar, internal gains); ``absolute`` is
    in the channel's unit (K for temperatures, W/m² for solar, W for gains). Both add up.
    The default (±5 % of heat gains, ±0.5 K outdoor) is the largest level the default
    building satisfies with margin; see ``docs/reference/data.md`` and docs/explanation/model.md §3.
    """

    relative: Mapping[str, float] = field(
        default_factory=lambda: {"solar": 0.05, "internal_gain": 0.05}
    )
    absolute: Mapping[str, float] = field(default_factory=lambda: {"outdoor_temp": 0.5})
    calibrate: CalibrationConfig | None = None
    """Replace ``relative``/``absolute`` by a box calibrated on a training period."""


@dataclass(frozen=True)
class RealisationConfig:
    """What the plant sees (``[realisation]``): the data, the internal gains' occupancy and
    an extra error w drawn in a box.

    ``occupancy = "schedule"``: the gains of the office schedule; ``"stochastic"``: a seeded
    stochastic occupancy model per zone (:mod:`hvacflex.data.occupancy`), while the
    controller still forecasts the schedule. w is drawn by ``mode`` in the scenario's
    uncertainty box, or — when ``box_relative`` or ``box_absolute`` is given — in a box of its
    own (``box_relative``, ``box_absolute``: kind → fraction / value, as in
    ``[uncertainty]``; a stress test outside the box the controller plans for).
    """

    mode: RealisationMode = "uniform"
    ar1_coefficient: float = AR1_COEFFICIENT
    occupancy: OccupancyMode = "schedule"
    occupancy_seed: int | None = None
    """Seed of the stochastic occupancy draws; ``None`` = the scenario's ``seed``."""
    box_relative: Mapping[str, float] | None = None
    box_absolute: Mapping[str, float] | None = None


@dataclass(frozen=True)
class ForecastConfig:
    """What the controller is told about the future (``[forecast]``, docs/explanation/forecast.md).

    ``weather = "perfect"``: the weather file itself; ``"statistical"``: diurnal climatology
    plus a decaying AR(1) anomaly fitted on the ``train_days`` days before the run
    (:mod:`hvacflex.data.weather_forecast`). Internal gains are always the schedule's.
    """

    weather: WeatherForecastMode = "perfect"
    train_days: int = WEATHER_TRAIN_DAYS


@dataclass(frozen=True)
class ActivationConfig:
    """When the grid operator activates the IL reserve (:mod:`hvacflex.sim.activation`).

    ``never``; ``random``: events at ``events_per_year`` (seeded), each lasting 1 …
    ``duration_steps`` periods (uniform), never overlapping; ``stress``: one activation every
    weekday, starting between 08:00 and 18:00, 1 … ``duration_steps`` periods (seeded);
    ``file``: periods read from a CSV; ``always``: every period (the paper's
    literal case; under the event model the periods past the event length are counted as
    beyond the model).
    """

    mode: ActivationMode = "never"
    events_per_year: float = DEFAULT_EVENTS_PER_YEAR
    """Mean number of activations per year (``mode = "random"``)."""
    duration_steps: int | None = None
    """Longest activation [30-min periods] of ``random`` and ``stress``; ``None`` = the
    reserve's ``event_max_steps`` (:data:`NEMS_MAX_INTERRUPTION_STEPS` when that is unset)."""
    file: str | None = None
    """CSV with columns ``time`` (period start, ISO 8601) and ``activated`` (0/1)."""


@dataclass(frozen=True)
class DataConfig:
    """Data files; ``None`` means the shipped default."""

    weather_file: str | None = None
    usep_source: str | None = None
    reserve_source: str | None = None
    reserve_price_scale: float | None = None
    """Scale of the synthetic reserve price [SGD/MWh] (its level where USEP is the 2014 mean,
    before noise); ``None`` = the calibrated default, 48.5 SGD/MWh
    (:data:`hvacflex.data.market.RESERVE_PRICE_SCALE`, docs/reference/data.md)."""
    reserve_price_correlation: float = RESERVE_PRICE_CORRELATION
    """Weight ρ of the USEP-driven part of the synthetic reserve price (1 = the calibrated
    series, 0 = independent of USEP; :func:`hvacflex.data.market.synthetic_reserve_prices`)."""
    price_gap_fill: PriceGapFill = "none"
    """Gaps in the price files: ``"none"`` (an error) or ``"previous-day"`` (copy the period)."""
    calendar: PriceCalendar = "data"
    """``"data"``: every period inside the price data; ``"live"``: real dates, the prices of
    a day outside the data from the data's day of the same weekday nearest its date
    (:mod:`hvacflex.data.calendar`; the service's live mode)."""


@dataclass(frozen=True)
class ComfortConfig:
    """Comfort band [°C] in occupied and unoccupied periods."""

    occupied_degc: tuple[float, float] = (23.0, 26.0)
    unoccupied_degc: tuple[float, float] = (20.0, 30.0)


@dataclass(frozen=True)
class PlantConfig:
    """What the closed loop drives (``[plant]``, docs/guide/energyplus.md).

    ``kind = "rc"`` is hvacflex's own RC network (flow-actuated); ``"energyplus"`` an
    EnergyPlus 25.2 model: ``idf`` is ``"generated"`` (the building's own export, ``--hvac
    vav``) or the path of an IDF file; ``actuation`` is ``"setpoint"`` (zone cooling
    setpoints, the EnergyPlus default) or ``"flow"`` (zone supply flows; the RC plant's only
    one); ``None`` = the plant's default. ``timesteps_per_hour`` is EnergyPlus's zone time step.
    ``curtailed_setpoint`` is what a setpoint-actuated plant is told in a curtailed period
    (IL activated, reserve offered): ``"plan"``, each zone's planned curtailed temperature,
    or ``"limit"``, the upper comfort bound plus the event allowance α in force — the deepest
    shed the contract allows (docs/explanation/il_events.md, "Shedding to the limit").
    """

    kind: PlantKind = "rc"
    idf: str = "generated"
    actuation: PlantActuation | None = None
    timesteps_per_hour: int = 6
    curtailed_setpoint: CurtailedSetpoint = "plan"

    @property
    def resolved_actuation(self) -> PlantActuation:
        """The actuation used: the given one, else ``"flow"`` (rc) / ``"setpoint"``."""
        if self.actuation is not None:
            return self.actuation
        return "flow" if self.kind == "rc" else "setpoint"


@dataclass(frozen=True)
class ScenarioConfig:
    """Everything one closed-loop run needs. Build with ``load_config`` or ``preset``."""

    name: str = "rmpc"
    building: str = "office5"
    start: str = DEFAULT_START
    """First period [local time, ISO 8601: YYYY-MM-DD or YYYY-MM-DDTHH:MM, normalised]."""
    days: float = DEFAULT_DAYS
    dt_s: float = PERIOD_S
    seed: int = 2014
    initial_temp_degc: float = 25.0
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    reserve: ReserveConfig = field(default_factory=ReserveConfig)
    estimation: EstimationConfig = field(default_factory=EstimationConfig)
    uncertainty: UncertaintyConfig = field(default_factory=UncertaintyConfig)
    realisation: RealisationConfig = field(default_factory=RealisationConfig)
    activation: ActivationConfig = field(default_factory=ActivationConfig)
    data: DataConfig = field(default_factory=DataConfig)
    comfort: ComfortConfig = field(default_factory=ComfortConfig)
    plant: PlantConfig = field(default_factory=PlantConfig)
    forecast: ForecastConfig = field(default_factory=ForecastConfig)

    @property
    def steps(self) -> int:
        """Number of control steps in the run."""
        return round(self.days * 86400.0 / self.dt_s)

    @property
    def start_timestamp(self) -> pd.Timestamp:
        return pd.Timestamp(self.start, tz=TIMEZONE)

    @property
    def activation_max_steps(self) -> int:
        """Longest random activation [periods]: ``activation.duration_steps``, else D, else
        the NEMS 120-min rule."""
        if self.activation.duration_steps is not None:
            return self.activation.duration_steps
        if self.reserve.event_max_steps is not None:
            return self.reserve.event_max_steps
        return NEMS_MAX_INTERRUPTION_STEPS

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-serialisable dict (tuples become lists)."""
        data: dict[str, Any] = json.loads(json.dumps(asdict(self)))
        return data

    def config_hash(self) -> str:
        """Stable 12-hex-digit hash of every field except ``name`` (used to cache runs)."""
        payload = self.to_dict()
        payload.pop("name")
        if self.plant == PlantConfig():
            payload.pop("plant")  # the default plant keeps the run keys of earlier versions
        if self.forecast == ForecastConfig():
            payload.pop("forecast")  # so do the default forecast, occupancy and box
        for table, key, empty in (
            ("realisation", "occupancy", "schedule"),
            ("realisation", "occupancy_seed", None),
            ("data", "reserve_price_correlation", RESERVE_PRICE_CORRELATION),
            ("realisation", "box_relative", None),
            ("realisation", "box_absolute", None),
            ("uncertainty", "calibrate", None),
            ("plant", "curtailed_setpoint", "plan"),
            ("controller", "comfort_knee_k", None),
            ("controller", "lower_plan_margin_k", 0.0),
        ):
            if table in payload and payload[table][key] == empty:
                payload[table].pop(key)
        if self.controller.comfort_knee_k is None:  # ρ₂ acts only beyond a knee
            payload["controller"].pop("comfort_penalty_beyond_knee_sgd_per_kelvin_hour")
        text = json.dumps(payload, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:12]
