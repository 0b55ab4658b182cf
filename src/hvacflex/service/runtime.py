"""One controller per registered building, driven by measurements and operator signals.

The controller is the one ``hvacflex simulate`` uses (:func:`hvacflex.sim.setup.prepare`
and :func:`~hvacflex.sim.setup.make_controller`), kept in memory per building inside a
:class:`hvacflex.sim.step.ControlStep` and warm-started between periods. After every plan
the step's state (LP basis, previous plan, IL events; data only, :mod:`hvacflex.state`) is
stored in the database in the same transaction as the plan, so a restarted service
continues where the last acknowledged plan left off. A state stored by an older hvacflex
(a pickle) is refused, never loaded.

Signals enter the forecast the controller sees (:class:`hvacflex.data.signals.
OperatorSignals`): operator prices replace the shipped prices for the periods they cover,
the operator's peak-power price replaces the scenario's φ (no controller is rebuilt), and
the month's peak so far is the largest ``previous_power_kw`` the building reported in the
month. IL activation follows the event semantics of the closed loop
(:class:`~hvacflex.sim.step.ControlStep`): an activation start or end re-plans the current period at
once; a start locks the plan, whose curtailed flows the building runs while the event lasts.
"""

from __future__ import annotations

import bisect
import gc
import hashlib
import json
import math
import threading
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

import numpy as np
import pandas as pd
from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker

from hvacflex import state
from hvacflex.building.io import building_from_dict
from hvacflex.building.model import Building
from hvacflex.config import ScenarioConfig, preset, with_overrides
from hvacflex.constants import MAX_HORIZON_STEPS, PERIOD, TIMEZONE
from hvacflex.control.base import Controller
from hvacflex.data.signals import OperatorSignals, effective_peak_price
from hvacflex.errors import InputError
from hvacflex.paths import resolve_building
from hvacflex.service.db import (
    Activation,
    BuildingRow,
    ControllerState,
    Measurement,
    PlanRow,
    Signal,
)
from hvacflex.service.payload import event_columns, finite, finite_list, horizon_columns
from hvacflex.service.schemas import (
    TEMP_MAX_DEGC,
    TEMP_MIN_DEGC,
    BuildingSource,
    MeasurementIn,
    ScenarioSettings,
)
from hvacflex.sim.history import PeriodHistory, period_inputs
from hvacflex.sim.setup import Setup, make_controller, prepare
from hvacflex.sim.step import ConflictError, ControlStep, Decision

ACCEPTED_TABLES = ("controller", "reserve", "estimation", "realisation", "forecast", "comfort")
"""Tables of the scenario whose every setting a registration may give: they shape the
controller and the contract and name no file (a key added to them later is accepted too)."""
ACCEPTED_SETTINGS = frozenset(
    {
        "seed",
        "initial_temp_degc",
        "uncertainty.relative",
        "uncertainty.absolute",
        "activation.mode",
        "activation.events_per_year",
        "activation.duration_steps",
        "data.reserve_price_scale",
        "data.reserve_price_correlation",
        "data.price_gap_fill",
        "data.calendar",
    }
)
"""The settings of the other tables a registration may give. Everything else is refused:
``building`` (sent as content), the data and activation files, ``plant`` (the plant is the
building itself; ``plant.idf`` names a file), ``uncertainty.calibrate`` (its
``prediction_errors`` names a results file) and any key added to those tables later, until
it is listed here."""


_ACCEPTED_HINT = (
    "send the building as content; shipped data is the default; accepted: every key of "
    + ", ".join(f"[{table}]" for table in ACCEPTED_TABLES)
    + " and "
    + ", ".join(sorted(ACCEPTED_SETTINGS))
)


def accepted_setting(path: str) -> bool:
    """Whether a registration may give the setting of dotted ``path`` (an allow-list:
    :data:`ACCEPTED_TABLES`, :data:`ACCEPTED_SETTINGS`)."""
    return path in ACCEPTED_SETTINGS or path.split(".", 1)[0] in ACCEPTED_TABLES


CALENDAR_SETTING = "data.calendar"
"""The scenario setting of the live calendar (:mod:`hvacflex.data.calendar`)."""

MAX_TIME_LIMIT_S = 60.0
"""Largest solver time limit per plan [s] (a plan answers an HTTP request)."""


class NotFoundError(InputError):
    """The building or plan does not exist."""


def building_from_source(
    source: BuildingSource, building_id: str
) -> tuple[Building, dict[str, Any]]:
    """The building of a registration and the description to store (always the parsed
    document, so a restart rebuilds it without files)."""
    given = [n for n in ("name", "toml", "description") if getattr(source, n) is not None]
    if len(given) != 1:
        raise InputError(
            "give exactly one of name, toml, description",
            field="building",
            value=given,
            hint='e.g. {"name": "office5"} or {"toml": "<building TOML text>"}',
        )
    if source.name is not None:
        from hvacflex.tomlio import read_toml

        document = read_toml(resolve_building(source.name), what="building")
    elif source.toml is not None:
        try:
            document = tomllib.loads(source.toml)
        except tomllib.TOMLDecodeError as exc:
            raise InputError(f"not valid TOML ({exc})", field="building.toml") from None
    else:
        document = dict(source.description or {})
    building = building_from_dict(document, source=f"building {building_id}")
    return building, document


def scenario_config(settings: ScenarioSettings, building_id: str) -> ScenarioConfig:
    """The scenario of a registration; settings naming server files are refused."""
    from hvacflex.config import resolve_key

    overrides: dict[str, Any] = {}
    for key, value in settings.settings.items():
        try:
            path = ".".join(resolve_key(key))
        except InputError as exc:
            raise InputError(
                "unknown setting", field=f"scenario.settings.{key}", hint=exc.hint
            ) from None
        if not accepted_setting(path):
            raise InputError(
                "the service does not take this setting: settings may not name files on the "
                "server or replace the building or the plant",
                field=f"scenario.settings.{key}",
                value=value,
                hint=_ACCEPTED_HINT,
            )
        if path == "activation.mode" and value == "file":
            raise InputError(
                "activation files are not accepted; the operator posts activations",
                field=f"scenario.settings.{key}",
                value=value,
            )
        overrides[path] = value
    overrides.update(start=settings.start, days=settings.days, building=building_id)
    overrides["name"] = building_id
    horizon = overrides.get("controller.horizon_steps")
    if isinstance(horizon, int) and horizon > MAX_HORIZON_STEPS:  # before the scenario's cap
        raise InputError(
            f"must be ≤ {MAX_HORIZON_STEPS} periods (one week) in the service",
            field="scenario.settings.controller.horizon_steps",
            value=horizon,
        )
    config = with_overrides(preset(settings.preset), overrides)
    controller = config.controller
    if controller.time_limit_s > MAX_TIME_LIMIT_S:
        raise InputError(
            f"must be ≤ {MAX_TIME_LIMIT_S:g} s in the service",
            field="scenario.settings.controller.time_limit_s",
            value=controller.time_limit_s,
        )
    return config


def to_local(time: datetime) -> pd.Timestamp:
    """A request time as a Singapore timestamp (naive times are Singapore time)."""
    stamp = pd.Timestamp(time)
    return stamp.tz_localize(TIMEZONE) if stamp.tzinfo is None else stamp.tz_convert(TIMEZONE)


@dataclass(frozen=True)
class StoredMeasurement:
    """A stored measurement: its period and start time, whether it was new, and its plan
    if the period's measurement was planned already (a repeated body)."""

    period: int
    time: str
    new: bool
    plan: dict[str, Any] | None


@dataclass
class MeteredHistory:
    """A building's metered power by period, kept up to date from its measurement rows.

    Period j's power is what the measurement of period j + 1 posted as
    ``previous_power_kw``. Measurements are write-once and a building's are stored one at a
    time (:attr:`BuildingRuntime.store_lock`), so its rows are committed in the order of
    their ids: reading the rows with an id above the largest read so far finds every row
    stored since (O(new rows) a plan, where rebuilding the history was O(k)).
    """

    history: PeriodHistory
    last_id: int = 0
    """The largest measurement id read so far (0: none)."""

    def read(self, session: Session, building_id: str) -> PeriodHistory:
        """The history with every measurement stored until now (its power only)."""
        rows = session.execute(
            select(Measurement.id, Measurement.period, Measurement.previous_power_kw)
            .where(Measurement.building_id == building_id, Measurement.id > self.last_id)
            .order_by(Measurement.id)
        )
        steps = self.history.steps
        for row_id, period, power in rows:
            self.last_id = max(self.last_id, int(row_id))
            if power is not None and 1 <= period <= steps:
                self.history.power_kw[period - 1] = float(power)
        return self.history


@dataclass
class BuildingRuntime:
    """A building's setup (model, shipped data) and its controller, in memory."""

    building_id: str
    setup: Setup
    control: ControlStep
    lock: threading.Lock
    """Held while the controller plans (seconds)."""
    store_lock: threading.Lock = field(default_factory=threading.Lock)
    """Held while a measurement is stored (milliseconds): one write per period at a time."""
    metered: MeteredHistory = field(init=False)
    """The metered power posted so far, read incrementally (:meth:`Runtime.history`)."""

    def __post_init__(self) -> None:
        self.metered = MeteredHistory(PeriodHistory.empty(self.setup.exogenous.index, self.steps))

    @property
    def controller(self) -> Controller:
        return self.control.controller

    @property
    def steps(self) -> int:
        return self.setup.config.steps

    def period_of(self, time: datetime, field: str) -> int:
        """The period that starts at ``time``.

        Raises
        ------
        InputError : not a 30-min boundary, or outside the building's scenario.
        """
        stamp = to_local(time)
        start = self.setup.exogenous.index[0]
        offset = (stamp - start) / PERIOD
        if offset != math.floor(offset):
            raise InputError("must be a 30-min period start", field=field, value=str(stamp))
        k = int(offset)
        if not 0 <= k < self.steps:
            raise InputError(
                "outside the building's scenario",
                field=field,
                value=str(stamp),
                hint=f"periods run from {start.isoformat()} for {self.steps} periods",
            )
        return k

    def period_containing(self, time: datetime) -> int:
        """The period holding ``time``, clipped to the scenario."""
        stamp = to_local(time)
        k = math.floor((stamp - self.setup.exogenous.index[0]) / PERIOD)
        return min(max(k, 0), self.steps - 1)

    def time_of(self, k: int) -> str:
        return str(self.setup.exogenous.index[k].isoformat())


def freeze_heap() -> None:
    """Move every object alive now into the garbage collector's permanent generation
    (:func:`gc.freeze`): later full collections skip them. A building's model, data and
    controller are many long-lived objects; in a process that answers requests each full
    collection over them held the GIL, and so every request, for 0.1–0.5 s on a loaded
    machine. The garbage of that moment (if any) is kept too: call it after loading, not
    in a loop."""
    gc.freeze()


class Runtime:
    """The service's controllers and the loop logic, over the database."""

    def __init__(
        self, sessions: sessionmaker[Session], *, live: bool = False, freeze_heap: bool = False
    ) -> None:
        self.sessions = sessions
        self.live = live
        """Live mode (``hvacflex serve --live``): buildings plan on real dates (scenario
        setting ``data.calendar = "live"``, :mod:`hvacflex.data.calendar`)."""
        self.freeze_heap = freeze_heap
        """Each building built is taken out of the garbage collector's full passes
        (:func:`freeze_heap`): the server process's way, where a full pass over ten
        buildings' objects stalled every request for 0.1–0.5 s."""
        self._buildings: dict[str, BuildingRuntime] = {}
        self._lock = threading.Lock()

    def _with_calendar(self, settings: ScenarioSettings) -> ScenarioSettings:
        """In live mode, the settings with ``data.calendar = "live"`` unless they set it."""
        from hvacflex.config import resolve_key

        if not self.live:
            return settings
        for key in settings.settings:
            try:
                if ".".join(resolve_key(key)) == CALENDAR_SETTING:
                    return settings
            except InputError:
                continue  # scenario_config names the unknown key
        return settings.model_copy(
            update={"settings": {**settings.settings, CALENDAR_SETTING: "live"}}
        )

    # -- buildings ----------------------------------------------------------------------
    def register(
        self,
        session: Session,
        building_id: str,
        source: BuildingSource,
        settings: ScenarioSettings,
        by: str,
    ) -> BuildingRuntime:
        """Validate and store a building; its data are loaded once to check they exist."""
        if session.get(BuildingRow, building_id) is not None:
            raise ConflictError("already registered", field="building_id", value=building_id)
        building, document = building_from_source(source, building_id)
        settings = self._with_calendar(settings)
        config = scenario_config(settings, building_id)
        if config.data.calendar == "live" and not self.live:
            raise InputError(
                "real dates need the service's live mode",
                field=f"scenario.settings.{CALENDAR_SETTING}",
                value="live",
                hint="start the service with `hvacflex serve --live`, or leave the setting out",
            )
        setup = prepare(config, building)
        runtime = _building_runtime(building_id, setup)
        session.add(
            BuildingRow(
                building_id=building_id,
                description_json=json.dumps(document),
                scenario_json=settings.model_dump_json(),
                created_by=by,
            )
        )
        with self._lock:
            self._buildings[building_id] = runtime
        if self.freeze_heap:
            freeze_heap()
        return runtime

    def get(self, session: Session, building_id: str) -> BuildingRuntime:
        """The building's runtime, rebuilt from the database after a restart.

        Raises
        ------
        NotFoundError : no such building.
        """
        with self._lock:
            runtime = self._buildings.get(building_id)
        if runtime is not None:
            return runtime
        row = session.get(BuildingRow, building_id)
        if row is None:
            raise NotFoundError("no such building", field="building_id", value=building_id)
        building = building_from_dict(json.loads(row.description_json), source=building_id)
        settings = ScenarioSettings.model_validate_json(row.scenario_json)
        config = scenario_config(settings, building_id)
        setup = prepare(config, building)
        runtime = _building_runtime(building_id, setup)
        stored = session.get(ControllerState, building_id)
        if stored is not None:
            runtime.control.set_state(
                state.decode(stored.state, source=f"the stored state of building {building_id}")
            )
        with self._lock:
            runtime = self._buildings.setdefault(building_id, runtime)
        if self.freeze_heap:
            freeze_heap()
        return runtime

    def evict(self, building_id: str) -> None:
        """Forget the in-memory controller (rebuilt from the database on next use)."""
        with self._lock:
            self._buildings.pop(building_id, None)

    def building_ids(self, session: Session) -> list[str]:
        return list(
            session.scalars(select(BuildingRow.building_id).order_by(BuildingRow.building_id))
        )

    # -- signals ------------------------------------------------------------------------
    def signals(self, session: Session) -> OperatorSignals:
        """The operator's signals in force: posted prices, outdoor temperatures and
        humidities by period (the latest posted for a period wins), the latest φ."""
        energy, reserve = self._price_overrides(session)
        peak = self.latest_signal(session, "peak_price")
        phi = None if peak is None else float(peak["peak_price_sgd_per_kw"])
        weather, humidity = _posted_series(
            session, "weather", ("outdoor_temp_degc", "outdoor_humidity_ratio_kg_per_kg")
        )
        return OperatorSignals(
            energy,
            reserve,
            outdoor_temp_degc=weather,
            outdoor_humidity_ratio_kg_per_kg=humidity,
            peak_price_sgd_per_kw=phi,
        )

    def _price_overrides(
        self, session: Session
    ) -> tuple[dict[pd.Timestamp, float], dict[pd.Timestamp, float]]:
        energy, reserve = _posted_series(
            session, "prices", ("energy_price_sgd_per_mwh", "reserve_price_sgd_per_mwh")
        )
        return energy, reserve

    def latest_signal(self, session: Session, kind: str) -> dict[str, Any] | None:
        row = session.scalars(
            select(Signal).where(Signal.kind == kind).order_by(Signal.id.desc()).limit(1)
        ).first()
        return None if row is None else dict(json.loads(row.body_json))

    def activity(self, session: Session, runtime: BuildingRuntime) -> Callable[[int], bool]:
        """Whether IL is active in a period k: the latest start/end event (for this building
        or all) whose period is ≤ k is a start (the later posted wins within a period)."""
        rows = session.scalars(
            select(Activation)
            .where(
                (Activation.building_id == runtime.building_id) | (Activation.building_id.is_(None))
            )
            .order_by(Activation.id)
        )
        events = sorted(
            (runtime.period_containing(datetime.fromisoformat(row.time_utc)), i, row.event)
            for i, row in enumerate(rows)
        )
        periods = [j for j, _, _ in events]

        def activated(k: int) -> bool:
            last = bisect.bisect_right(periods, k) - 1
            return last >= 0 and events[last][2] == "start"

        return activated

    def activated(self, session: Session, runtime: BuildingRuntime, k: int) -> bool:
        """IL active in period k (:meth:`activity`)."""
        return self.activity(session, runtime)(k)

    def history(
        self,
        session: Session,
        runtime: BuildingRuntime,
        k: int,
        delivered_flow_kg_s: np.ndarray | None = None,
    ) -> PeriodHistory:
        """The building's metered periods before ``k`` (:class:`~hvacflex.sim.history.
        PeriodHistory`): period j's power is what the measurement of j + 1 posted as
        ``previous_power_kw`` (NaN where none did), its activation the activation signal's
        (:meth:`activity`); ``delivered_flow_kg_s``: period k − 1's delivered input (m,)
        [kg/s] posted with k's measurement, if any.

        Incremental: the building's history is kept in memory (:class:`MeteredHistory`)
        and only the measurements stored since the last plan are read (a plan costs O(new
        rows), not O(k)); a plan reads only the periods before ``k``."""
        history = runtime.metered.read(session, runtime.building_id)
        activated = self.activity(session, runtime)
        history.activated[:] = False
        history.activated[:k] = [activated(j) for j in range(k)]
        history.delivered_flow_kg_s, history.delivered_period = None, -1
        if delivered_flow_kg_s is not None and k >= 1:
            history.delivered_flow_kg_s = np.asarray(delivered_flow_kg_s, dtype=float)
            history.delivered_period = k - 1
        return history

    # -- plans --------------------------------------------------------------------------
    def plan(
        self,
        session: Session,
        runtime: BuildingRuntime,
        k: int,
        x_degc: np.ndarray,
        trigger: str,
        revision: int | None = None,
        delivered_flow_kg_s: np.ndarray | None = None,
    ) -> dict[str, Any]:
        """Plan period k from the node temperatures ``x_degc`` (n,) [°C] under the IL event
        model (:class:`~hvacflex.sim.step.ControlStep`) and store the plan (the
        caller commits) as ``revision`` (default: the period's next); the controller's and
        the event state are stored with it. ``delivered_flow_kg_s``: the measurement's
        report of period k − 1's delivered input (m,) [kg/s], if any.

        Raises
        ------
        ConflictError : k is before the building's latest planned period.
        """
        setup = runtime.setup
        activated = self.activity(session, runtime)
        control = runtime.control
        measured = setup.model.c @ x_degc if control.takes_measurements else None
        inputs = period_inputs(
            k,
            self.history(session, runtime, k, delivered_flow_kg_s),
            setup.forecaster,
            self.signals(session),
            setup.config,
            x_degc=x_degc,
            measured_zone_temp_degc=measured,
        )
        forecast = inputs.forecast
        decision = control.decide(k, inputs, activated=activated)
        payload = self._payload(runtime, k, decision, decision.plan, forecast.index)
        payload["peak_price_sgd_per_kw"] = effective_peak_price(
            forecast, setup.config.controller.peak_price_sgd_per_kw
        )
        payload["horizon_energy_price_sgd_per_mwh"] = finite_list(
            forecast.energy_price_sgd_per_mwh[: len(payload["horizon_time"])]
        )
        payload.update(event_columns(decision, activated(k)))
        self._store_plan(session, runtime.building_id, k, trigger, payload, revision)
        stored = session.get(ControllerState, runtime.building_id)
        blob = state.encode(control.get_state())
        if stored is None:
            session.add(ControllerState(building_id=runtime.building_id, period=k, state=blob))
        else:
            stored.period, stored.state = k, blob
        return payload

    def _payload(
        self,
        runtime: BuildingRuntime,
        k: int,
        decision: Decision,
        solution: Any,
        index: pd.DatetimeIndex,
    ) -> dict[str, Any]:
        action = decision.action
        horizon = runtime.setup.config.controller.horizon_steps
        columns = horizon_columns(decision, solution, runtime.setup.model.c, index, horizon)
        return {
            "building_id": runtime.building_id,
            "period": k,
            "time": runtime.time_of(k),
            "zones": list(runtime.setup.zone_names),
            "status": action.status,
            "fallback": bool(action.fallback),
            "objective_sgd": columns.pop("objective_sgd"),
            "flow_kg_s": [float(v) for v in action.flow_kg_s],
            "reserve_flow_kg_s": [float(v) for v in action.reserve_flow_kg_s],
            "reserve_kw": float(action.reserve_kw),
            "offer_meter_ratio": finite(action.offer_meter_ratio),
            "planned_power_kw": finite(action.planned_power_kw),
            "solve_time_s": float(action.solve_time_s),
            "planned_slack_max_k": finite(action.planned_slack_max_k),
            "delta_max_k": finite(action.delta_max_k),
            "predicted_served_degc": finite_list(action.predicted_served_degc),
            "predicted_curtailed_degc": finite_list(action.predicted_curtailed_degc),
            "predicted_event_worst_degc": None
            if action.predicted_event_worst_degc is None
            else finite_list(action.predicted_event_worst_degc),
            **columns,
        }

    def _store_plan(
        self,
        session: Session,
        building_id: str,
        k: int,
        trigger: str,
        payload: dict[str, Any],
        revision: int | None,
    ) -> None:
        if revision is None:
            latest = session.scalar(
                select(func.max(PlanRow.revision)).where(
                    PlanRow.building_id == building_id, PlanRow.period == k
                )
            )
            revision = (latest or 0) + 1
        payload["revision"] = revision
        payload["trigger"] = trigger
        session.add(
            PlanRow(
                building_id=building_id,
                period=k,
                revision=payload["revision"],
                trigger=trigger,
                status=payload["status"],
                fallback=payload["fallback"],
                objective_sgd=payload["objective_sgd"],
                payload_json=json.dumps(payload),
            )
        )
        session.flush()

    def latest_plan(
        self, session: Session, building_id: str, period: int | None = None
    ) -> dict[str, Any] | None:
        query = select(PlanRow).where(PlanRow.building_id == building_id)
        if period is not None:
            query = query.where(PlanRow.period == period)
        row = session.scalars(
            query.order_by(PlanRow.period.desc(), PlanRow.revision.desc()).limit(1)
        ).first()
        return None if row is None else dict(json.loads(row.payload_json))

    # -- the loop's triggers (run by :class:`~hvacflex.service.planner.Planner`) --------
    def store_measurement(
        self, building_id: str, body: MeasurementIn, not_before: int = -1
    ) -> StoredMeasurement:
        """Validate and store a measurement (committed when this returns); the same body
        twice is one record. It is planned later (:meth:`plan_measurement`).

        ``not_before`` is the latest period with a measurement waiting to be planned.

        Raises
        ------
        InputError : the time is not a period of the scenario, or temperatures are out of
            range or of the wrong count.
        ConflictError : another measurement is stored for the period, or the period is
            before the latest planned (or waiting) one.
        """
        with self.sessions() as session:
            runtime = self.get(session, building_id)
        n = len(runtime.setup.model.node_names)
        x = np.asarray(body.node_temperatures_degc, dtype=float)
        if x.shape != (n,):
            raise InputError(
                f"expected {n} node temperatures (nodes {list(runtime.setup.model.node_names)})",
                field="node_temperatures_degc",
                value=len(x),
            )
        bad = np.flatnonzero(~((x >= TEMP_MIN_DEGC) & (x <= TEMP_MAX_DEGC)))
        if bad.size:
            raise InputError(
                f"must be in [{TEMP_MIN_DEGC:g}, {TEMP_MAX_DEGC:g}] °C",
                field=f"node_temperatures_degc[{bad[0]}]",
                value=float(x[bad[0]]),
            )
        record: dict[str, Any] = {
            "period": runtime.period_of(body.time, "time"),
            "x": x.tolist(),
            "previous_power_kw": body.previous_power_kw,
        }
        if body.previous_delivered_flow_kg_s is not None:
            m = len(runtime.setup.zone_names)
            if len(body.previous_delivered_flow_kg_s) != m:
                raise InputError(
                    f"expected {m} delivered flows (zones {list(runtime.setup.zone_names)})",
                    field="previous_delivered_flow_kg_s",
                    value=len(body.previous_delivered_flow_kg_s),
                )
            record["delivered_flow_kg_s"] = list(body.previous_delivered_flow_kg_s)
        k = int(record["period"])
        canonical = json.dumps(record)  # a key only when reported: older digests stand
        digest = hashlib.sha256(canonical.encode()).hexdigest()
        with runtime.store_lock, self.sessions() as session, session.begin():
            existing = session.scalars(
                select(Measurement).where(
                    Measurement.building_id == building_id, Measurement.period == k
                )
            ).first()
            if existing is not None:
                if existing.body_sha256 != digest:
                    raise ConflictError(
                        "a different measurement is already stored for this period",
                        field="time",
                        value=runtime.time_of(k),
                        hint="measurements are write-once per building and period",
                    )
                plan = self.own_plan(session, building_id, k)
                return StoredMeasurement(k, runtime.time_of(k), False, plan)
            latest = session.scalar(
                select(func.max(PlanRow.period)).where(PlanRow.building_id == building_id)
            )
            last = max(-1 if latest is None else int(latest), not_before)
            if k < last:
                raise ConflictError(
                    f"period {k} is before the building's latest planned period {last}",
                    field="time",
                    value=k,
                    hint="plans go forward: post the measurement of the current period",
                )
            session.add(
                Measurement(
                    building_id=building_id,
                    period=k,
                    body_json=canonical,
                    body_sha256=digest,
                    previous_power_kw=body.previous_power_kw,
                )
            )
        return StoredMeasurement(k, runtime.time_of(k), True, None)

    def own_plan(self, session: Session, building_id: str, k: int) -> dict[str, Any] | None:
        """The latest plan of period k if the period's measurement was planned (None while
        it waits for its plan)."""
        planned = session.scalar(
            select(func.count(PlanRow.id)).where(
                PlanRow.building_id == building_id,
                PlanRow.period == k,
                PlanRow.trigger == "measurement",
            )
        )
        return self.latest_plan(session, building_id, k) if planned else None

    def plan_measurement(self, building_id: str, k: int, revision: int) -> dict[str, Any]:
        """Plan period k on its stored measurement, as plan ``revision``, and commit."""
        with self.sessions() as session:
            runtime = self.get(session, building_id)
        with runtime.lock, self.sessions() as session, session.begin():
            row = session.scalars(
                select(Measurement).where(
                    Measurement.building_id == building_id, Measurement.period == k
                )
            ).one()
            record = json.loads(row.body_json)
            x = np.asarray(record["x"], dtype=float)
            flow = record.get("delivered_flow_kg_s")
            delivered = None if flow is None else np.asarray(flow, dtype=float)
            try:
                return self.plan(
                    session, runtime, k, x, "measurement", revision, delivered_flow_kg_s=delivered
                )
            except BaseException:
                self.evict(building_id)
                raise

    def boundary_building(self, building_id: str, time: datetime) -> dict[str, Any] | None:
        """At a 30-min boundary: plan the building's current period if it has no plan for
        it yet, on its latest measurement (None when nothing is planned)."""
        with self.sessions() as session:
            runtime = self.get(session, building_id)
        stamp = to_local(time)
        k = math.floor((stamp - runtime.setup.exogenous.index[0]) / PERIOD)
        if not 0 <= k < runtime.steps:
            return None
        with runtime.lock, self.sessions() as session, session.begin():
            if runtime.control.period >= k:  # planned already (or a later period)
                return None
            x = self._latest_state(session, building_id, k)
            if x is None:
                return None
            try:
                return self.plan(session, runtime, k, x, "boundary")
            except BaseException:
                self.evict(building_id)
                raise

    def activation_building(self, building_id: str) -> dict[str, Any] | None:
        """Re-plan the building's latest period if the stored activation events (committed
        by the caller) change its activation state: an activation start or end takes effect
        at once, by the IL event semantics of the closed loop (None when nothing changes)."""
        with self.sessions() as session:
            runtime = self.get(session, building_id)
        with runtime.lock, self.sessions() as session, session.begin():
            plan = self.latest_plan(session, building_id)
            if plan is None:
                return None
            k = int(plan["period"])
            if self.activated(session, runtime, k) == plan["il_activated"]:
                return None
            x = self._latest_state(session, building_id, k)
            if x is None:
                return None
            try:
                return self.plan(session, runtime, k, x, "activation")
            except BaseException:
                self.evict(building_id)
                raise

    @staticmethod
    def _latest_state(session: Session, building_id: str, k: int) -> np.ndarray | None:
        """The node temperatures (n,) [°C] of the building's latest measurement ≤ period k."""
        last = session.scalars(
            select(Measurement)
            .where(Measurement.building_id == building_id, Measurement.period <= k)
            .order_by(Measurement.period.desc())
            .limit(1)
        ).first()
        return None if last is None else np.asarray(json.loads(last.body_json)["x"], dtype=float)


def _building_runtime(building_id: str, setup: Setup) -> BuildingRuntime:
    control = ControlStep(
        setup.config, make_controller(setup), len(setup.zone_names), replannable=True
    )
    return BuildingRuntime(building_id, setup, control, threading.Lock())


def _posted_series(
    session: Session, kind: str, columns: tuple[str, ...]
) -> tuple[dict[pd.Timestamp, float], ...]:
    """The stored signals of ``kind`` as one series per body key of ``columns`` (lists of
    consecutive periods from the body's ``start_utc``): period start (UTC) → value, the
    latest posted winning; a key a body lacks adds nothing."""
    series: tuple[dict[pd.Timestamp, float], ...] = tuple({} for _ in columns)
    rows = session.scalars(select(Signal).where(Signal.kind == kind).order_by(Signal.id))
    for row in rows:
        body = json.loads(row.body_json)
        start = pd.Timestamp(body["start_utc"])
        for values, column in zip(series, columns, strict=True):
            for i, value in enumerate(body.get(column) or []):
                values[start + i * PERIOD] = float(value)
    return series
