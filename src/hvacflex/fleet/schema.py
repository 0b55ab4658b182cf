"""Fleet files: the TOML description of an aggregator's buildings and its feeder.

A fleet file holds fleet-level settings at its top level (always written by
``hvacflex fleet generate``) and one ``[[buildings]]`` table per building whose
``[buildings.building]`` table is a complete building description, validated exactly as a
building file is (:func:`hvacflex.building.io.building_from_dict`)::

    name = "example"
    seed = 7
    feeder_limit_kw = 60.0          # or inf (no limit), or feeder_limit_csv = "limit.csv"
    min_bid_mw = 0.1
    feeder_margin = 0.02            # plan against (1 − margin) × limit
    robust = "tightening"
    horizon_steps = 48
    comfort_penalty_sgd_per_kelvin_hour = 100.0  # ρ of every building's MPC
    window_lookahead_h = inf        # plan for a window from this long before it [h]
    linearisation_margin_k = 1.0    # T₀ = each building's occupied upper bound − this [K]
    linearisation = "fixed"         # the model at T₀ | "plan": each step at the plan's temps
    lower_plan_margin_k = 0.0       # the plans stay this far above each lower bound [K]
    envelope = true                 # the flexibility envelope, envelope.csv (false: skipped)

    [[feeder_limits]]               # limit windows on top of it (the tighter holds)
    start = "10:00"                 # local "HH:MM", or ISO date-times for a single window
    end = "17:00"
    limit_kw = 50.0
    days = "weekdays"               # weekdays (default) | all; daily windows only

    [reserve]
    enabled = true
    event_max_steps = 4             # D (0 = the whole-horizon model); default: the product's
    event_allowance_k = 1.0         # α [K]
    event_recovery_steps = 2        # R [periods]

    [ppp]
    peak_price_sgd_per_kw = 0.0

    [coordination]
    max_iterations = 30             # bundle rounds (prices: price iterations)
    gap_tolerance = 0.01
    feasibility_tolerance = 0.005
    step_sgd_per_mwh = 0.0          # 0 = automatic (mean energy price)
    cap_rounds = 4                  # prices scheme: cap reallocation rounds
    scheme = "bundle"               # bundle | envelope | prices (docs/guide/fleet.md)
    plan_tolerance_kw = 0.01        # bundle: stop when plans move less than this

    [activation]                    # when the grid operator activates IL (default never)
    mode = "stress"                 # never | random | stress | file | always

    [data]                          # the market and weather every building shares: the
    reserve_price_scale = 200.0     # scenario file's [data] table (hvacflex.config DataSpec)
    weather_file = "site.epw"       # relative paths: from the fleet file's folder

    [[buildings]]
    name = "b000"
    template = "office5"
    occupied_hours = [8, 18]
    comfort_occupied_degc = [23.0, 26.0]
    comfort_unoccupied_degc = [20.0, 30.0]
    [buildings.building]
    ...                             # a building description (docs/explanation/buildings.md)

Unknown keys are errors; every error names the file, the field, the value and a hint.
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, Literal, Self

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError, model_validator

from hvacflex.building.io import building_from_dict
from hvacflex.building.model import Building
from hvacflex.config import (
    DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR,
    DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR,
    LINEARISATION_MARGIN_K,
    ActivationConfig,
    ControllerConfig,
    DataConfig,
    ReserveConfig,
    paths_from_folder,
    scenario_error_of,
)
from hvacflex.config.presets import PRODUCT_RESERVE
from hvacflex.config.schema import (
    INDOOR_TEMP_MAX_DEGC,
    INDOOR_TEMP_MIN_DEGC,
    INITIAL_TEMP_MAX_DEGC,
    INITIAL_TEMP_MIN_DEGC,
    DataSpec,
    to_domain,
)
from hvacflex.constants import HORIZON_STEPS, MAX_HORIZON_STEPS, PERIODS_PER_DAY, TIMEZONE
from hvacflex.errors import ConfigError, DataError
from hvacflex.tomlio import read_toml

Number = Annotated[float, Strict()]
Finite = Annotated[float, Strict(), Field(allow_inf_nan=False)]
IndoorTemp = Annotated[Finite, Field(ge=INDOOR_TEMP_MIN_DEGC, le=INDOOR_TEMP_MAX_DEGC)]
"""A comfort bound [°C], in the scenario file's physical range."""
Text = Annotated[str, Strict(), Field(min_length=1)]
NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_\-]*$"


class FleetConfigError(ConfigError):
    """A fleet file is invalid."""


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class ReserveSpec(_Spec):
    """The IL contract every building plans for (defaults: the product's, PRODUCT_RESERVE).

    ``event_max_steps`` = D ≥ 1 is the event model (docs/explanation/il_events.md); 0 selects the
    paper's whole-horizon model (then α and R must be 0).
    """

    enabled: bool = True
    event_max_steps: Annotated[int, Strict(), Field(ge=0, le=PERIODS_PER_DAY)] = PRODUCT_RESERVE[
        "event_max_steps"
    ]
    event_allowance_k: Annotated[Finite, Field(ge=0.0, le=5.0)] = PRODUCT_RESERVE[
        "event_allowance_k"
    ]
    event_recovery_steps: Annotated[int, Strict(), Field(ge=0, le=PERIODS_PER_DAY)] = (
        PRODUCT_RESERVE["event_recovery_steps"]
    )

    @model_validator(mode="after")
    def _whole_horizon(self) -> Self:
        if self.event_max_steps == 0 and (self.event_allowance_k or self.event_recovery_steps):
            raise ValueError(
                "event_allowance_k and event_recovery_steps need the event model "
                "(event_max_steps ≥ 1); the whole-horizon model (0) has no allowance"
            )
        return self

    def config(self) -> ReserveConfig:
        """The single-building :class:`ReserveConfig` of these settings. Offers stay on each
        building's power model (``meter_calibrated_offers`` and ``plan_visible_offers`` off):
        the coordinator cuts each building's offer to what its own meter would show
        (:func:`hvacflex.fleet.aggregation.visible_offers_kw`) before the fleet bids them."""
        events = self.event_max_steps > 0
        return ReserveConfig(
            event_max_steps=self.event_max_steps if events else None,
            event_allowance_k=self.event_allowance_k if events else 0.0,
            event_recovery_steps=self.event_recovery_steps if events else 0,
            meter_calibrated_offers=False,
            plan_visible_offers=False,
        )


class ActivationSpec(_Spec):
    """When the grid operator activates the fleet's IL (:mod:`hvacflex.sim.activation`,
    the scenario file's ``[activation]``); one schedule for the whole fleet, seeded by the
    fleet's ``seed``. An activation reaches the buildings only when the fleet's bid of its
    first period is accepted."""

    mode: Literal["never", "random", "stress", "file", "always"] = "never"
    events_per_year: Annotated[Finite, Field(ge=0.0)] = ActivationConfig.events_per_year
    duration_steps: Annotated[int, Strict(), Field(ge=1, le=PERIODS_PER_DAY)] | None = None
    file: Text | None = None

    @model_validator(mode="after")
    def _file_mode_needs_a_file(self) -> Self:
        if self.mode == "file" and not self.file:
            raise ValueError("mode 'file' needs a file (a CSV with columns time, activated)")
        return self

    def config(self, base: Path | None = None) -> ActivationConfig:
        """The :class:`ActivationConfig` of these settings; a relative ``file`` is read
        relative to ``base`` (the fleet file's folder)."""
        file = self.file
        if file is not None and base is not None and not Path(file).is_absolute():
            file = str(base / file)
        return ActivationConfig(
            mode=self.mode,
            events_per_year=self.events_per_year,
            duration_steps=self.duration_steps,
            file=file,
        )


class PPPSpec(_Spec):
    peak_price_sgd_per_kw: Annotated[Finite, Field(ge=0.0)] = 0.0
    billing_mode: Literal["horizon", "billing-period"] = "horizon"


class CoordinationSpec(_Spec):
    max_iterations: Annotated[int, Strict(), Field(ge=1, le=1000)] = 30
    gap_tolerance: Annotated[Finite, Field(gt=0.0)] = 0.01
    feasibility_tolerance: Annotated[Finite, Field(ge=0.0)] = 0.005
    step_sgd_per_mwh: Annotated[Finite, Field(ge=0.0)] = 0.0
    cap_rounds: Annotated[int, Strict(), Field(ge=0, le=100)] = 4
    scheme: Literal["bundle", "envelope", "prices"] = "bundle"
    plan_tolerance_kw: Annotated[Finite, Field(ge=0.0)] = 0.01


HHMM_PATTERN = r"^([01][0-9]|2[0-3]):[0-5][0-9]$|^24:00$"
"""A local time of day, "HH:MM" ("24:00" = the end of the day)."""


def _minutes_of_day(text: str) -> int | None:
    """Minutes after midnight of a "HH:MM" time, or None when ``text`` is no such time."""
    if not re.match(HHMM_PATTERN, text):
        return None
    hours, minutes = text.split(":")
    return 60 * int(hours) + int(minutes)


def _local_time(text: str) -> pd.Timestamp:
    """An ISO date-time as a Singapore-local timestamp (a zone given is converted)."""
    stamp = pd.Timestamp(text)
    return stamp.tz_localize(TIMEZONE) if stamp.tzinfo is None else stamp.tz_convert(TIMEZONE)


class FeederLimitWindowSpec(_Spec):
    """One ``[[feeder_limits]]`` table: a capacity limit in force over a window.

    ``start`` and ``end`` are both local times of day "HH:MM" (a daily window, on the
    ``days`` it names: ``weekdays``, the default, or ``all``) or both ISO date-times (one
    window; ``days`` does not apply). A 30-min period is in the window when its start is at or
    after ``start`` and before ``end``.
    """

    start: Text
    end: Text
    limit_kw: Annotated[Finite, Field(gt=0.0)]
    days: Literal["weekdays", "all"] | None = None

    @model_validator(mode="after")
    def _times(self) -> Self:
        start, end = _minutes_of_day(self.start), _minutes_of_day(self.end)
        if (start is None) != (end is None):
            raise ValueError(
                f"start {self.start!r} and end {self.end!r} must both be local times "
                '"HH:MM" or both ISO date-times'
            )
        if start is not None and end is not None:
            if start >= end:
                raise ValueError(
                    f"a daily window must end after it starts (start {self.start!r}, end "
                    f"{self.end!r}); split a window over midnight into two"
                )
            return self
        for name in ("start", "end"):
            try:
                _local_time(getattr(self, name))
            except ValueError:
                raise ValueError(
                    f'{name} {getattr(self, name)!r} is neither a local time "HH:MM" nor '
                    "an ISO date-time"
                ) from None
        if _local_time(self.end) <= _local_time(self.start):
            raise ValueError(f"the window must end after it starts ({self.start} → {self.end})")
        if self.days is not None:
            raise ValueError(
                'days applies to daily windows (start and end as "HH:MM"), not to a window '
                "of ISO date-times"
            )
        return self

    @property
    def daily(self) -> bool:
        """A daily window ("HH:MM" times), not one of ISO date-times."""
        return _minutes_of_day(self.start) is not None

    def describe(self) -> str:
        """The window in words, e.g. "10:00–17:00 on weekdays, 318.7 kW"."""
        when = f"{self.start}–{self.end}"
        if self.daily:
            when += " on weekdays" if (self.days or "weekdays") == "weekdays" else " every day"
        return f"{when}, {self.limit_kw:g} kW"

    def seen_mask(
        self, index: pd.DatetimeIndex, seen_at: pd.Timestamp, lookahead_h: float
    ) -> np.ndarray:
        """(T,) :meth:`mask`, less the periods of the window's days (occurrences) that start
        more than ``lookahead_h`` [h] after ``seen_at`` (tz-aware): the periods a plan made at
        ``seen_at`` holds to the window's limit. inf: the whole mask."""
        inside = self.mask(index)
        if math.isinf(lookahead_h):
            return inside
        latest = seen_at + pd.Timedelta(hours=lookahead_h)
        if not self.daily:
            return inside & bool(_local_time(self.start) <= latest)
        local = index.tz_convert(TIMEZONE) if index.tz is not None else index
        local = local if local.tz is not None else local.tz_localize(TIMEZONE)
        start_min = _minutes_of_day(self.start)
        assert start_min is not None
        starts = local.normalize() + pd.Timedelta(minutes=start_min)
        return inside & np.asarray(starts <= latest)

    def mask(self, index: pd.DatetimeIndex) -> np.ndarray:
        """(T,) whether each period start of ``index`` is in the window (in local time)."""
        local = index.tz_convert(TIMEZONE) if index.tz is not None else index
        if not self.daily:
            start, end = _local_time(self.start), _local_time(self.end)
            local = local if local.tz is not None else local.tz_localize(TIMEZONE)
            inside: np.ndarray = np.asarray((local >= start) & (local < end))
            return inside
        start_min, end_min = _minutes_of_day(self.start), _minutes_of_day(self.end)
        assert start_min is not None and end_min is not None
        minutes = np.asarray(local.hour * 60 + local.minute)
        inside = (minutes >= start_min) & (minutes < end_min)
        if (self.days or "weekdays") == "weekdays":
            inside &= np.asarray(local.day_of_week) < WEEKEND_FIRST_DAY
        return np.asarray(inside)


WEEKEND_FIRST_DAY = 5
"""``DatetimeIndex.day_of_week`` of Saturday (Monday = 0)."""


class BuildingEntrySpec(_Spec):
    name: Annotated[Text, Field(pattern=NAME_PATTERN)]
    template: str = ""
    occupied_hours: tuple[Annotated[int, Strict()], Annotated[int, Strict()]] = (8, 18)
    comfort_occupied_degc: tuple[IndoorTemp, IndoorTemp] = (23.0, 26.0)
    comfort_unoccupied_degc: tuple[IndoorTemp, IndoorTemp] = (20.0, 30.0)
    initial_temp_degc: Annotated[
        Finite, Field(ge=INITIAL_TEMP_MIN_DEGC, le=INITIAL_TEMP_MAX_DEGC)
    ] = 25.0
    building: dict[str, Any]

    @model_validator(mode="after")
    def _check(self) -> Self:
        start, end = self.occupied_hours
        if not 0 <= start < end <= 24:
            raise ValueError("occupied_hours must satisfy 0 ≤ start < end ≤ 24")
        for band in (self.comfort_occupied_degc, self.comfort_unoccupied_degc):
            if band[0] >= band[1]:
                raise ValueError("a comfort band is [lower, upper] with lower < upper")
        return self


class FleetSpec(_Spec):
    name: Text = "fleet"
    seed: Annotated[int, Strict()] = 2014
    feeder_limit_kw: Annotated[Number, Field(gt=0.0)] | None = None
    feeder_limit_csv: str | None = None
    feeder_limits: list[FeederLimitWindowSpec] = []
    """Limit windows (``[[feeder_limits]]``), applied on top of the constant or CSV limit:
    the tighter holds."""
    feeder_margin: Annotated[Finite, Field(ge=0.0, lt=0.5)] = 0.0
    """The plans hold to (1 − margin) × the limit in force, the fleet's guard to the limit
    itself: headroom for the power model's error."""
    min_bid_mw: Annotated[Finite, Field(ge=0.0)] = 0.1
    robust: Literal["tightening", "none"] = "tightening"
    horizon_steps: Annotated[int, Strict(), Field(ge=2, le=MAX_HORIZON_STEPS)] = HORIZON_STEPS
    window_lookahead_h: Annotated[Number, Field(ge=0.0)] = math.inf
    """How long before a limit window's start [h] the buildings plan for it (for a daily
    window: from that long before its start on each of its days); inf (the default): as soon
    as their horizon reaches it. 10 for a 10:00 window: from the midnight before it, so no
    evening cools the building for the next day's window (docs/guide/fleet.md)."""
    comfort_penalty_sgd_per_kelvin_hour: Annotated[Finite, Field(gt=0.0)] = (
        DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR
    )
    """ρ: every building's price of a planned comfort violation [SGD per K·h], the scenario
    file's ``[controller]`` key (default the product's 100). Under limit windows a low ρ
    (1 … 10) with a comfort knee stores much less cold for a little more discomfort
    (docs/guide/fleet.md, "Five weekdays")."""
    linearisation_margin_k: Annotated[Finite, Field(ge=0.0)] = LINEARISATION_MARGIN_K
    """Every building's model is linearised at T₀ = its occupied upper comfort bound less this
    [K] (the scenario's default T₀, 1 K). Under limit windows the buildings pre-cool and run
    their zones near the lower bound at high flows, where a T₀ near the upper bound
    over-states both the coil's cooling per kg/s and its power: 2 (the lower bound + 1 K for
    a 3-K band) plans those hours more truly (docs/guide/fleet.md, "Five weekdays"). At most
    the band's width (T₀ inside the occupied band)."""
    lower_plan_margin_k: Annotated[Finite, Field(ge=0.0, le=10.0)] = (
        ControllerConfig.lower_plan_margin_k
    )
    """Every building's plan keeps its zones this far above their lower comfort bound [K]
    (the scenario file's ``[controller]`` key; default 0). Under limit windows the plans store
    cold down to the lower bound, where the errors a nominal plan (``robust = "none"``) does
    not see push the zones across it: a margin keeps the stored cold inside the band
    (docs/guide/fleet.md, "Feeder limits: windows"). ``fleet bound`` counts the band itself."""
    linearisation: Literal["fixed", "plan"] = "fixed"
    """Every building's model (the scenario file's ``[controller]`` key): linearised once at
    T₀ (``fixed``, the default) or each step of the horizon at the previous plan's zone
    temperatures over it (``plan``): the supply air's cooling per kg/s and the coil's power
    right where the zones run far from T₀ — pre-cooled at night, warm late in a window."""
    comfort_knee_k: Annotated[Finite, Field(ge=0.0)] | None = None
    """Every building's slack priced at ρ up to this excursion [K] and at
    ``comfort_penalty_beyond_knee_sgd_per_kelvin_hour`` beyond (the scenario file's
    ``[controller]`` key): a window's violation spread over buildings and zones instead of put
    where a kW buys least. None (the default): ρ on all of it."""
    comfort_penalty_beyond_knee_sgd_per_kelvin_hour: Annotated[Finite, Field(gt=0.0)] = (
        DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR
    )
    """ρ₂ ≥ ρ [SGD per K·h], the price of the slack beyond ``comfort_knee_k``."""
    envelope: Annotated[bool, Strict()] = True
    """Compute the flexibility envelope every step and write ``envelope.csv``
    (:mod:`hvacflex.fleet.envelope`); false saves its LPs (a run without the file)."""
    reserve: ReserveSpec = ReserveSpec()
    ppp: PPPSpec = PPPSpec()
    coordination: CoordinationSpec = CoordinationSpec()
    activation: ActivationSpec = ActivationSpec()
    data: DataSpec = DataSpec()
    """The weather and market data every building sees (one market, one weather): the
    scenario file's ``[data]`` table, validated by its schema."""
    buildings: Annotated[list[BuildingEntrySpec], Field(min_length=1)]

    @model_validator(mode="after")
    def _one_limit(self) -> Self:
        if (self.feeder_limit_kw is None) == (self.feeder_limit_csv is None):
            raise ValueError("give exactly one of feeder_limit_kw and feeder_limit_csv")
        if self.feeder_limit_kw is not None and math.isnan(self.feeder_limit_kw):
            raise ValueError("feeder_limit_kw must be a number > 0 or inf")
        rho, beyond = (
            self.comfort_penalty_sgd_per_kelvin_hour,
            self.comfort_penalty_beyond_knee_sgd_per_kelvin_hour,
        )
        if self.comfort_knee_k is not None and beyond < rho:
            raise ValueError(
                "comfort_penalty_beyond_knee_sgd_per_kelvin_hour must be at least "
                f"comfort_penalty_sgd_per_kelvin_hour ({rho:g})"
            )
        names = [b.name for b in self.buildings]
        if len(set(names)) != len(names):
            dup = next(n for n in names if names.count(n) > 1)
            raise ValueError(f"building names must be unique ({dup!r} repeats)")
        return self


_HINTS = {
    "feeder_limit_kw": "a number of kW > 0, or inf for no limit",
    "feeder_limit_csv": "a CSV with columns time, feeder_limit_kw (half-hourly)",
    "feeder_limits": '[[feeder_limits]] start = "10:00", end = "17:00", limit_kw = 300.0, '
    'days = "weekdays" (or "all"); or start and end as ISO date-times',
    "limit_kw": "the window's limit, a number of kW > 0",
    "days": '"weekdays" (the default) or "all"; only for "HH:MM" windows',
    "start": 'a local time "HH:MM" or an ISO date-time such as "2014-03-03T14:00"',
    "end": 'a local time "HH:MM" ("24:00" for midnight) or an ISO date-time',
    "window_lookahead_h": "hours ≥ 0 before a window's start the plans see it, or inf",
    "comfort_penalty_sgd_per_kelvin_hour": "ρ [SGD per K·h] > 0, e.g. 100 (the product's)",
    "linearisation": '"fixed" (the default) or "plan"',
    "lower_plan_margin_k": "kelvin in [0, 10] above each lower comfort bound, e.g. 0.5; 0 for none",
    "linearisation_margin_k": "kelvin ≥ 0 below each occupied upper bound, e.g. 1 (the "
    "default) or 2 under limit windows",
    "comfort_knee_k": "the excursion [K] ≥ 0 priced at ρ, e.g. 0.5; leave out for none",
    "comfort_penalty_beyond_knee_sgd_per_kelvin_hour": "ρ₂ [SGD per K·h] ≥ ρ, e.g. 1000",
    "min_bid_mw": "the market's minimum bid, 0.1 MW for NEMS interruptible load",
    "buildings": "add [[buildings]] tables (hvacflex fleet generate writes them)",
    "building": "a complete building description, as in a building TOML file",
    "occupied_hours": "[start, end] local hours, e.g. [8, 18]",
    "event_max_steps": "D in 30-min periods (4 = the NEMS 120-min rule), 0 = whole horizon",
    "scheme": "bundle (default), envelope or prices",
    "event_allowance_k": "α [K] above the upper comfort bound during an event, e.g. 1.0",
}


MOVED_KEYS: dict[str, str] = {
    "reserve_price_scale": "data.reserve_price_scale",
}
"""Top-level keys of older fleet files and the key of the ``[data]`` table that replaced
them (refused with the fix)."""


def _fleet_error(exc: ValidationError, source: Path | str) -> FleetConfigError:
    errors = exc.errors(include_url=False)
    error = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
    loc = tuple(error["loc"])
    if loc and loc[0] == "data":  # the scenario file's table: its messages and hints
        problem = scenario_error_of(error, source, kind=FleetConfigError)
        assert isinstance(problem, FleetConfigError)
        return problem
    if error["type"] == "extra_forbidden" and len(loc) == 1 and loc[0] in MOVED_KEYS:
        table, key = MOVED_KEYS[str(loc[0])].split(".")
        return FleetConfigError(
            f"this key moved to [{table}] {key}",
            source=source,
            field=str(loc[0]),
            value=error["input"],
            hint=f"write it in the fleet file's [{table}] table: [{table}] {key} = "
            f"{error['input']!r} (docs/guide/fleet.md)",
        )
    field = ""
    for part in loc:
        field += f"[{part}]" if isinstance(part, int) else (f".{part}" if field else str(part))
    named = [p for p in loc if isinstance(p, str)]
    hint = _HINTS.get(named[-1]) if named else None
    if error["type"] == "extra_forbidden":
        message, value = "unknown key", loc[-1] if loc else None
        hint = hint or "see the keys `hvacflex fleet generate` writes (docs/guide/fleet.md)"
    elif error["type"] == "missing":
        message, value, hint = "missing required field", None, hint or "add it to the file"
    else:
        message, value = str(error["msg"]).removeprefix("Value error, "), error["input"]
        if isinstance(value, dict | list):
            value = None
    return FleetConfigError(message, source=source, field=field or None, value=value, hint=hint)


@dataclass(frozen=True)
class FleetBuilding:
    """One building of a fleet: the validated description and its operating settings."""

    name: str
    building: Building
    raw: dict[str, Any]
    occupied_hours: tuple[int, int]
    comfort_occupied_degc: tuple[float, float]
    comfort_unoccupied_degc: tuple[float, float]
    initial_temp_degc: float


@dataclass(frozen=True)
class Fleet:
    """A validated fleet file.

    ``feeder_limit_kw`` is the constant limit [kW] (``inf`` = none) or None when
    ``feeder_limit_csv`` gives a half-hourly series (read by :meth:`limit_series_kw`).
    """

    spec: FleetSpec
    buildings: tuple[FleetBuilding, ...]
    source: Path | None

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def data(self) -> DataConfig:
        """The ``[data]`` table as the scenario's :class:`DataConfig` (the same conversion
        as a scenario file's); relative paths are from the fleet file's folder when it was
        read by :func:`load_fleet`."""
        data: DataConfig = to_domain(self.spec.data)
        return data

    @property
    def feeder_limit_path(self) -> Path | None:
        """The ``feeder_limit_csv`` file (relative to the fleet file's folder), or None."""
        if self.spec.feeder_limit_csv is None:
            return None
        path = Path(self.spec.feeder_limit_csv)
        if not path.is_absolute() and self.source is not None:
            path = self.source.parent / path
        return path

    @property
    def activation(self) -> ActivationConfig:
        """The ``[activation]`` table as the scenario's :class:`ActivationConfig` (a relative
        ``file`` from the fleet file's folder)."""
        return self.spec.activation.config(None if self.source is None else self.source.parent)

    def limit_series_kw(
        self, index: pd.DatetimeIndex, seen_at: pd.Timestamp | None = None
    ) -> np.ndarray:
        """(T,) feeder limit [kW] in force for each period start of ``index`` (inf = no
        limit): the constant or CSV limit, lowered to each ``[[feeder_limits]]`` window's
        ``limit_kw`` in the window's periods (the tighter holds). ``seen_at`` (tz-aware):
        the limit a plan made then holds to — a window's day counts only from
        ``window_lookahead_h`` before its start (:meth:`FeederLimitWindowSpec.seen_mask`);
        None: every window.

        Raises
        ------
        DataError
            When the CSV is unreadable or does not cover every period of ``index``.
        """
        limit = self._base_limit_kw(index)
        lookahead = self.spec.window_lookahead_h
        for window in self.spec.feeder_limits:
            inside = (
                window.mask(index)
                if seen_at is None
                else window.seen_mask(index, seen_at, lookahead)
            )
            limit = np.where(inside, np.minimum(limit, window.limit_kw), limit)
        return limit

    def _base_limit_kw(self, index: pd.DatetimeIndex) -> np.ndarray:
        """(T,) the constant or CSV limit [kW] before the windows."""
        if self.spec.feeder_limit_kw is not None:
            return np.full(len(index), float(self.spec.feeder_limit_kw))
        path = self.feeder_limit_path
        assert path is not None
        series = self._limit_csv_series_kw
        tz = pd.DatetimeIndex(series.index).tz
        values = series.reindex(index.tz_convert(tz)).to_numpy(float)
        if np.isnan(values).any() or (values <= 0).any():
            first = index[int(np.flatnonzero(np.isnan(values) | (values <= 0))[0])]
            raise DataError(
                "the feeder limit is missing or ≤ 0 for a simulated period",
                source=path,
                field="feeder_limit_kw",
                value=str(first),
                hint="give a positive limit for every half hour of the run and horizon",
            )
        return values

    @cached_property
    def _limit_csv_series_kw(self) -> pd.Series:
        """The ``feeder_limit_csv`` series [kW] by period start, read once (a run with a
        window lookahead asks for the limit every step)."""
        path = self.feeder_limit_path
        assert path is not None
        try:
            frame = pd.read_csv(path)
            times = pd.DatetimeIndex(pd.to_datetime(frame["time"]))
            if times.tz is None:
                times = times.tz_localize(TIMEZONE)
            series = pd.Series(frame["feeder_limit_kw"].to_numpy(float), index=times)
        except (OSError, KeyError, ValueError) as exc:
            raise DataError(
                f"cannot read the feeder limit ({type(exc).__name__}: {exc})",
                source=path,
                field="feeder_limit_csv",
                hint="a CSV with columns time, feeder_limit_kw",
            ) from None
        return series


LINEARISATION_TOLERANCE_K = 1e-9
"""A margin equal to a band's width (up to the rounding of the band's ends) is allowed [K]."""


def _check_linearisation(
    margin_k: float, entry: BuildingEntrySpec, building: Building, index: int, source: Path | str
) -> None:
    """Refuse a ``linearisation_margin_k`` that puts a building's T₀ (its occupied upper
    bound less the margin) below its occupied band or at or below its supply-air
    temperature, naming the file, the key, the building and the largest margin."""
    lower, upper = entry.comfort_occupied_degc
    supply = building.hvac.supply_temp_degc
    if margin_k <= upper - lower + LINEARISATION_TOLERANCE_K and upper - margin_k > supply:
        return
    widest = min(upper - lower, upper - supply - LINEARISATION_TOLERANCE_K)
    t0 = upper - margin_k
    why = (
        f"at or below its supply air ({supply:g} °C)" if t0 <= supply else "below its occupied band"
    )
    raise FleetConfigError(
        f"puts T₀ = {t0:g} °C of buildings[{index}] ({entry.name!r}, occupied band "
        f"{lower:g}–{upper:g} °C) {why}",
        source=source,
        field="linearisation_margin_k",
        value=margin_k,
        hint=f"at most {max(widest, 0.0):.3g} K, or widen that building's comfort_occupied_degc",
    )


def fleet_from_dict(data: dict[str, Any], *, source: Path | str = "<dict>") -> Fleet:
    """Validate a parsed fleet document; each building through the building schema.

    Paths are taken as they are (:func:`load_fleet` resolves a file's relative paths)."""
    try:
        spec = FleetSpec.model_validate(data)
    except ValidationError as exc:
        raise _fleet_error(exc, source) from None
    buildings = []
    for i, entry in enumerate(spec.buildings):
        building = building_from_dict(entry.building, source=f"{source}: buildings[{i}].building")
        _check_linearisation(spec.linearisation_margin_k, entry, building, i, source)
        buildings.append(
            FleetBuilding(
                name=entry.name,
                building=building,
                raw=entry.building,
                occupied_hours=entry.occupied_hours,
                comfort_occupied_degc=entry.comfort_occupied_degc,
                comfort_unoccupied_degc=entry.comfort_unoccupied_degc,
                initial_temp_degc=entry.initial_temp_degc,
            )
        )
    return Fleet(spec, tuple(buildings), Path(source) if isinstance(source, Path) else None)


def load_fleet(path: str | Path) -> Fleet:
    """Read and validate a fleet TOML file.

    Raises
    ------
    FleetConfigError, BuildingConfigError
        Naming the file, the field (``buildings[3].building.zones[0].floor_area_m2``), the
        value and a hint.

    Relative paths of the ``[data]`` and ``[activation]`` tables are taken from the file's
    folder, by the function that resolves a scenario file's
    (:func:`hvacflex.config.paths_from_folder`).
    """
    return load_fleet_document(path)[0]


def load_fleet_document(path: str | Path) -> tuple[Fleet, dict[str, Any]]:
    """:func:`load_fleet` and the file's document as read (relative paths as written: what
    a run ships to its workers), from one read of the file."""
    source = Path(path)
    raw = read_toml(source, what="fleet", error=FleetConfigError)
    document = copy.deepcopy(raw)  # the validation must not reach into what is shipped
    return fleet_from_dict(paths_from_folder(raw, source.parent), source=source), document
