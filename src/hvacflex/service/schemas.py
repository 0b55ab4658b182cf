"""Request and response bodies of the service API (pydantic), with units and physical ranges.

Every response is an :class:`Envelope` ``{status, message, payload}`` (as BOPTEST's).
Times are ISO 8601 strings; a time without an offset is local Singapore time, like the
scenario's ``start``. Request bodies are strict: nothing is coerced (``false`` is not a
number, ``0`` is not a time, ``"1"`` is not a number).
"""

from __future__ import annotations

from datetime import datetime
from typing import TYPE_CHECKING, Annotated, Any, Generic, Literal, TypeVar

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field

from hvacflex.constants import PRESET_NAMES
from hvacflex.fleet.schema import FeederLimitWindowSpec

T = TypeVar("T")

BUILDING_ID_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"
MAX_PRICE_PERIODS = 17_568
"""Longest price series one request may carry: a leap year of 30-min periods."""

TEMP_MIN_DEGC, TEMP_MAX_DEGC = -50.0, 100.0
"""Physical range of a measured node temperature [°C]."""
POWER_MAX_KW = 100_000.0
"""Largest building electric power accepted [kW] (100 MW)."""
ENERGY_PRICE_LIMIT_SGD_PER_MWH = 4_500.0
"""|energy price| ≤ the NEMS offer price cap [SGD/MWh]."""
PEAK_PRICE_MAX_SGD_PER_KW = 1_000.0
"""Largest peak-power price accepted [SGD/kW]."""
MAX_DAYS = 366.0
"""Longest scenario a building may register [days]."""

if TYPE_CHECKING:
    PresetName = str
else:
    PresetName = Literal[PRESET_NAMES]
"""A preset's name (:data:`hvacflex.constants.PRESET_NAMES`, an enum in the OpenAPI
document)."""

_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)


def _iso_string(value: Any) -> Any:
    """Times arrive as ISO 8601 strings only (a number is not read as seconds since 1970)."""
    if not isinstance(value, str):
        raise ValueError("must be an ISO 8601 time string, e.g. 2014-03-03T08:00+08:00")
    return value


TIME_YEARS = (1900, 2199)
"""Years a request time may have at all (the service then checks its own planning range);
beyond them a time cannot even be converted between time zones."""


def _sane_year(value: datetime) -> datetime:
    if not TIME_YEARS[0] <= value.year <= TIME_YEARS[1]:
        raise ValueError(f"must be a time in the years {TIME_YEARS[0]}–{TIME_YEARS[1]}")
    return value


IsoTime = Annotated[
    datetime, Field(strict=False), BeforeValidator(_iso_string), AfterValidator(_sane_year)
]
"""A time in a request: an ISO 8601 string (parsed by pydantic), nothing else."""
EnergyPrice = Annotated[
    float, Field(ge=-ENERGY_PRICE_LIMIT_SGD_PER_MWH, le=ENERGY_PRICE_LIMIT_SGD_PER_MWH)
]
"""An energy price within the NEMS offer price cap [SGD/MWh]."""
ReservePrice = Annotated[float, Field(ge=0.0, le=ENERGY_PRICE_LIMIT_SGD_PER_MWH)]
"""A reserve price within [0, the NEMS offer price cap] [SGD/MWh]."""
OUTDOOR_TEMP_MIN_DEGC, OUTDOOR_TEMP_MAX_DEGC = -50.0, 60.0
"""Range of a posted outdoor-temperature forecast [°C]."""
OutdoorTemp = Annotated[float, Field(ge=OUTDOOR_TEMP_MIN_DEGC, le=OUTDOOR_TEMP_MAX_DEGC)]
HUMIDITY_RATIO_MAX_KG_PER_KG = 0.05
"""The largest outdoor humidity ratio a forecast may post [kg/kg] (a 40 °C dew point)."""
HumidityRatio = Annotated[float, Field(ge=0.0, le=HUMIDITY_RATIO_MAX_KG_PER_KG)]
FLOW_LIMIT_KG_S = 10_000.0
"""|delivered air flow| a measurement may report per zone [kg/s]."""
DeliveredFlow = Annotated[float, Field(ge=-FLOW_LIMIT_KG_S, le=FLOW_LIMIT_KG_S)]


class Envelope(BaseModel, Generic[T]):
    """Every response: the HTTP status, a human-readable message and the payload."""

    status: int
    message: str
    payload: T | None = None


class ErrorEnvelope(BaseModel):
    """An error response: ``payload`` lists the offending fields where known."""

    status: int
    message: str
    payload: list[dict[str, Any]] | None = None


class Health(BaseModel):
    service: str
    version: str
    database: str


class BuildingSource(BaseModel):
    """The building description, as content: exactly one of ``name`` (a shipped building),
    ``toml`` (the text of a building TOML file) or ``description`` (the same as JSON)."""

    model_config = _STRICT
    name: Literal["office5", "room1", "bestest600", "bestest900"] | None = None
    toml: str | None = Field(default=None, max_length=200_000)
    description: dict[str, Any] | None = None


class ScenarioSettings(BaseModel):
    """The scenario: a preset, the period and settings (dotted keys as in ``with_overrides``,
    e.g. ``controller.peak_price_sgd_per_kw``). Settings that name server files (weather,
    price or activation paths) and ``building`` are refused; shipped data is the default."""

    model_config = _STRICT
    preset: PresetName = "rmpc"
    start: str = Field(pattern=r"^\d{4}-\d{2}-\d{2}(T\d{2}:\d{2}(:\d{2})?)?$")
    days: float = Field(gt=0, le=MAX_DAYS)
    settings: dict[str, Any] = Field(default_factory=dict)


class RegisterBuilding(BaseModel):
    model_config = _STRICT
    building_id: str = Field(pattern=BUILDING_ID_PATTERN)
    building: BuildingSource
    scenario: ScenarioSettings


class Registered(BaseModel):
    building_id: str
    key: str = Field(description="The building's API key, shown this once.")
    start: str
    steps: int
    zones: list[str]
    nodes: list[str]


class BuildingInfo(BaseModel):
    building_id: str
    start: str
    steps: int
    zones: list[str]
    nodes: list[str]
    scenario: dict[str, Any]


class MeasurementIn(BaseModel):
    """The building's state at the start of a period."""

    model_config = _STRICT
    time: IsoTime = Field(description="Start of the period measured (a 30-min boundary).")
    node_temperatures_degc: list[float] = Field(
        min_length=1, max_length=10_000, description="(n,) node temperatures [°C]."
    )
    previous_power_kw: float | None = Field(
        default=None, ge=0.0, le=POWER_MAX_KW, description="Mean power of the previous period [kW]."
    )
    previous_delivered_flow_kg_s: list[DeliveredFlow] | None = Field(
        default=None,
        min_length=1,
        max_length=10_000,
        description=(
            "(m,) what the supply air delivered to each zone in the previous period, as the"
            " model's input [kg/s]: the sensible cooling ṁ c_p (T_zone − T_supply,measured)"
            " divided by c_p (T_zone − T_supply,model). A controller with a zone-air filter"
            " (estimator = kalman, fixed linearisation) predicts with it instead of the flow it"
            " decided; ignored otherwise."
        ),
    )


class PricesIn(BaseModel):
    """Energy (and optionally reserve) prices for consecutive periods from ``start``."""

    model_config = _STRICT
    start: IsoTime
    energy_price_sgd_per_mwh: list[EnergyPrice] = Field(min_length=1, max_length=MAX_PRICE_PERIODS)
    reserve_price_sgd_per_mwh: list[ReservePrice] | None = Field(
        default=None, min_length=1, max_length=MAX_PRICE_PERIODS
    )


class WeatherIn(BaseModel):
    """An outdoor-temperature forecast [°C] (and optionally the outdoor humidity ratio
    [kg/kg]) for consecutive periods from ``start``."""

    model_config = _STRICT
    start: IsoTime
    outdoor_temp_degc: list[OutdoorTemp] = Field(min_length=1, max_length=MAX_PRICE_PERIODS)
    outdoor_humidity_ratio_kg_per_kg: list[HumidityRatio] | None = Field(
        default=None, min_length=1, max_length=MAX_PRICE_PERIODS
    )


class PeakPriceIn(BaseModel):
    model_config = _STRICT
    peak_price_sgd_per_kw: float = Field(ge=0.0, le=PEAK_PRICE_MAX_SGD_PER_KW)


class FeederLimitIn(BaseModel):
    model_config = _STRICT
    limit_kw: float = Field(gt=0.0, le=1e7)


MAX_LIMIT_WINDOWS = 1_000
"""Most feeder limit windows one request may carry."""


class FeederLimitWindowsIn(BaseModel):
    """Feeder limit windows, each as a fleet file's ``[[feeder_limits]]`` table
    (:class:`~hvacflex.fleet.schema.FeederLimitWindowSpec`): ``start`` and ``end`` both
    "HH:MM" (a daily window; ``days`` ``weekdays`` or ``all``) or both ISO date-times (one
    window), and ``limit_kw`` > 0. ``event_id`` (e.g. an OpenADR event's): the windows
    replace those posted before under the same id (none: cancel them)."""

    model_config = _STRICT
    windows: list[FeederLimitWindowSpec] = Field(max_length=MAX_LIMIT_WINDOWS)
    event_id: str | None = Field(default=None, min_length=1, max_length=128)


class FeederLimitSchedule(BaseModel):
    """The feeder limit in force per period start: the latest constant limit
    (``POST /v1/signals/feeder-limit``) lowered by every window in force, the tighter
    holding (as a fleet's ``[[feeder_limits]]``)."""

    time: list[str]
    limit_kw: list[float | None] = Field(description="None: no limit in the period")
    windows: list[FeederLimitWindowSpec]


class ActivationIn(BaseModel):
    """An IL activation start or end; ``building_ids`` omitted = every building."""

    model_config = _STRICT
    event: Literal["start", "end"]
    time: IsoTime
    building_ids: list[str] | None = Field(default=None, max_length=10_000)


class ActivationRefusedIn(BaseModel):
    """A dispatch the site refused (e.g. the OpenADR VEN's opt-out): the buildings it was
    for, when it would have started and why; kept on the record and in the audit."""

    model_config = _STRICT
    time: IsoTime
    building_ids: list[str] = Field(min_length=1, max_length=10_000)
    reason: str = Field(min_length=1, max_length=1000)
    event_id: str | None = Field(default=None, max_length=128)


class ClockIn(BaseModel):
    """The service clock (an accelerated or replayed clock): periods that start at or before
    it are planned on the latest measurement of buildings that sent none for them."""

    model_config = _STRICT
    time: IsoTime


class Plan(BaseModel):
    """A stored plan for one building and period (lists in zone order, horizon order)."""

    building_id: str
    period: int
    time: str
    revision: int
    trigger: str
    zones: list[str]
    status: str
    fallback: bool
    il_activated: bool
    il_role: str = Field(
        description="IL role of the period (hvacflex.sim.events.Role): served, curtail-fresh, "
        "event-start, event-locked or beyond-model."
    )
    il_curtailed: bool = Field(description="The building runs u − r this period.")
    il_beyond_model: bool = Field(description="Activated for more than D periods (counted).")
    il_event_window: bool = Field(description="Part of an IL event or its recovery.")
    il_allowance_k: float = Field(description="Allowance α on the upper comfort bound [K].")
    il_reference_power_kw: float | None = Field(
        description="The locked plan's served power, the settlement reference [kW]."
    )
    objective_sgd: float | None = Field(
        description="Objective of this period's optimisation (None: fallback, rule, or a "
        "period that runs a locked event plan)."
    )
    flow_kg_s: list[float]
    reserve_flow_kg_s: list[float]
    applied_flow_kg_s: list[float]
    reserve_kw: float
    offer_meter_ratio: float | None = Field(
        default=None,
        description="ρ ∈ [0, 1]: the meter's response to the plan's power that this period's "
        "reserve_kw was sized with (under commitments, by the decision that committed it; "
        "None: not scaled; docs/explanation/il_events.md).",
    )
    planned_power_kw: float | None
    solve_time_s: float
    planned_slack_max_k: float | None
    delta_max_k: float | None
    predicted_served_degc: list[float | None]
    predicted_curtailed_degc: list[float | None]
    predicted_event_worst_degc: list[float | None] | None = None
    horizon_time: list[str]
    horizon_power_kw: list[float | None]
    horizon_reserve_kw: list[float | None]
    horizon_temp_degc: list[list[float | None]]
    horizon_energy_price_sgd_per_mwh: list[float | None] | None = Field(
        default=None,
        description="Energy price the plan used per horizon period [SGD/MWh] (posted prices "
        "where the operator sent them, else the shipped USEP).",
    )
    peak_price_sgd_per_kw: float | None = Field(
        default=None, description="The peak-power price φ the plan was made with [SGD/kW]."
    )


class MeasurementRecord(BaseModel):
    """A stored measurement: its period and what the building metered before it."""

    period: int
    time: str = Field(description="Start of the period measured.")
    previous_power_kw: float | None = Field(
        description="Mean electric power the building reported for the previous period [kW]."
    )
    received_at: str = Field(description="When the service received it (UTC).")


class PlanAck(BaseModel):
    """A measurement acknowledged (202): stored, its plan to come as ``revision``."""

    building_id: str
    period: int
    time: str
    revision: int = Field(description="The revision of the period's plan this produces.")


MAX_WAIT_S = 10.0
"""Longest a measurement request may wait for its plan (``?wait_s``) [s]."""


class PlanList(BaseModel):
    plans: list[Plan]


class BidBuilding(BaseModel):
    building_id: str
    period: int
    time: str
    reserve_kw: float
    planned_power_kw: float | None


class Bid(BaseModel):
    """The aggregate over every building's latest plan, per period start."""

    time: list[str]
    reserve_kw: list[float]
    planned_power_kw: list[float]
    buildings: list[BidBuilding]
    feeder_limit_kw: float | None
    feeder_limit_exceeded: bool
    feeder_limit_schedule_kw: list[float | None] = Field(
        default_factory=list,
        description="The feeder limit in force at each period of ``time`` [kW] (the constant "
        "limit lowered by the limit windows; None: no limit); ``feeder_limit_exceeded`` "
        "compares the planned power with it.",
    )
    stale_buildings: list[str] = Field(
        default_factory=list,
        description="Buildings with a plan but no measurement for longer than the service's "
        "stale time (``serve --stale-after-s``); their plans are not counted in the sums.",
    )


class Stored(BaseModel):
    id: int
    kind: str


class ActivationRecord(BaseModel):
    """A stored IL activation start or end (``building_id`` None: every building)."""

    id: int
    building_id: str | None
    event: str
    time: str = Field(description="The activation's time (ISO 8601, Singapore time).")
    received_at: str = Field(description="When the service stored it (ISO 8601, UTC).")


class AuditRecord(BaseModel):
    at: str
    key_id: str | None
    role: str | None
    method: str
    path: str
    status_code: int
    body_sha256: str
    action: str | None = Field(
        default=None,
        description="What the request did (activation, activation_refused, prices, "
        "measurement, …; see docs/guide/service.md), None for a path the service does not know.",
    )
    body_head: str = Field(
        default="", description="The request body's first characters, as stored."
    )
