"""The FastAPI app: a versioned JSON API under ``/v1`` in one envelope ``{status, message,
payload}``; every route but ``/v1/health`` needs an ``X-API-Key``.

Roles (see :mod:`.keys`): ``operator`` registers buildings, posts prices, the peak-power
price, the feeder limit, IL activations and the clock, and reads every plan and the
aggregate bid; ``building`` posts its own measurements and reads its own plan. A building key
gets 403 on any other building. Every mutating request is written to the ``audit`` table
(who, when, what) before its response is sent. The envelope, that middleware, the error
handlers and the key checks are in :mod:`.http`.
"""

import asyncio
import contextlib
import functools
import gc
import json
import re
import threading
from collections.abc import AsyncIterator, Callable
from datetime import datetime
from typing import Annotated, Any

import numpy as np
import pandas as pd
from fastapi import Depends, FastAPI, HTTPException, Query, Request
from fastapi.responses import JSONResponse, PlainTextResponse, Response
from sqlalchemy import select
from starlette.concurrency import run_in_threadpool

from hvacflex import __version__
from hvacflex.constants import PERIOD, PERIOD_FREQ, PERIODS_PER_DAY, TIMEZONE
from hvacflex.errors import InputError
from hvacflex.service import feeder_limits
from hvacflex.service.dashboard import add_page_routes
from hvacflex.service.db import (
    DEFAULT_DB_URL,
    Activation,
    AuditEntry,
    ServiceClock,
    Signal,
    open_database,
    read_session_factory,
    session_factory,
)
from hvacflex.service.http import (
    API_KEY,
    COMMON_ERRORS,
    ERRORS,
    JSON_ERRORS,
    Auth,
    BodyLimitAndAudit,
    add_error_handlers,
    check_building_reader,
    roles,
)
from hvacflex.service.keys import (
    CLOCK_ROUTE,
    REGISTER_ROUTE,
    KeyBudgets,
    Principal,
    RouteLimit,
    create_key,
)
from hvacflex.service.operations import (
    DEFAULT_STALE_AFTER_S,
    PROMETHEUS_CONTENT_TYPE,
    ObserveRequests,
    RequestMetrics,
    metrics_text,
    stale_buildings,
)
from hvacflex.service.plan_cache import NO_PLAN, CachedPlan, plan_answer
from hvacflex.service.plan_processes import (
    MAX_NICENESS,
    PLAN_NICENESS,
    PlanProcesses,
    shares_processes,
)
from hvacflex.service.planner import DEFAULT_PLAN_WORKERS, Planner
from hvacflex.service.runtime import NotFoundError, Runtime, to_local
from hvacflex.service.runtime import freeze_heap as runtime_freeze_heap
from hvacflex.service.schemas import (
    MAX_WAIT_S,
    ActivationIn,
    ActivationRecord,
    ActivationRefusedIn,
    AuditRecord,
    Bid,
    BidBuilding,
    BuildingInfo,
    ClockIn,
    Envelope,
    FeederLimitIn,
    FeederLimitSchedule,
    FeederLimitWindowsIn,
    Health,
    MeasurementIn,
    MeasurementRecord,
    PeakPriceIn,
    Plan,
    PlanAck,
    PlanList,
    PricesIn,
    RegisterBuilding,
    Registered,
    Stored,
    WeatherIn,
)


def start_wall_clock(planner: Planner, poll_s: float = 10.0) -> threading.Event:
    """A daemon thread that runs the 30-min boundary trigger at each wall-clock boundary
    (Singapore time); set the returned event to stop it."""
    stop = threading.Event()

    def tick() -> None:
        last: pd.Timestamp | None = None
        while not stop.wait(poll_s):
            now = pd.Timestamp.now(tz=TIMEZONE).floor(PERIOD_FREQ)
            if now != last:
                last = now
                planner.boundary(now.to_pydatetime())

    threading.Thread(target=tick, name="hvacflex-wall-clock", daemon=True).start()
    return stop


def create_app(
    db_url: str = DEFAULT_DB_URL,
    *,
    wall_clock: bool = False,
    stale_after_s: float = DEFAULT_STALE_AFTER_S,
    plan_workers: int = DEFAULT_PLAN_WORKERS,
    plan_processes: int = 0,
    plan_niceness: int = PLAN_NICENESS,
    freeze_heap: bool = False,
    live: bool = False,
    route_limits: dict[str, RouteLimit] | None = None,
) -> FastAPI:
    """The service app on the database at ``db_url`` (migrated to the newest schema).

    ``wall_clock`` runs the 30-min boundary trigger on the wall clock as well (buildings
    whose scenario covers today); otherwise the operator drives it with ``POST /v1/clock``.
    A building whose latest measurement is older than ``stale_after_s`` [s] is stale: its
    plan is left out of the aggregate bid. Plans are made off the request path
    (:mod:`.planner`): in ``plan_processes`` worker processes (:mod:`.plan_processes`, each
    building pinned to one; started before this returns), or with 0 (or an SQLite database
    in memory) in ``plan_workers`` threads of this process; measurements acknowledged before
    a restart and not yet planned are queued at once; the processes run ``plan_niceness``
    (0–19) lower in CPU priority than this one. ``freeze_heap`` (the server process's
    choice; it acts on the whole process): the objects loaded at start and each building's
    objects once built leave the garbage collector's full passes
    (:func:`~hvacflex.service.runtime.freeze_heap`), which otherwise stall every request.
    ``live``: the live mode — buildings registered plan on real dates (``data.calendar =
    "live"``) and times of prices, activations and the clock are not held to the price
    data's span. ``route_limits``: each
    key's budget on the costly routes (default
    :data:`~hvacflex.service.keys.DEFAULT_ROUTE_LIMITS`: 10 registrations per hour, 1 clock
    per 10 s); over it, 429 with ``Retry-After``.

    Raises
    ------
    InputError : the database cannot be opened (:func:`~hvacflex.service.db.open_database`),
        ``stale_after_s`` is not positive, or ``plan_niceness`` is not in 0–19.
    """
    if not stale_after_s > 0:
        raise InputError("must be > 0 s", field="stale_after_s", value=stale_after_s)
    if not 0 <= plan_niceness <= MAX_NICENESS:
        raise InputError(
            f"must be in [0, {MAX_NICENESS}]", field="plan_niceness", value=plan_niceness
        )
    engine = open_database(db_url)
    sessions = session_factory(engine)
    runtime = Runtime(sessions, live=live, freeze_heap=freeze_heap)
    planner = _planner(runtime, db_url, plan_workers, plan_processes, plan_niceness)
    app = FastAPI(
        title="hvacflex service",
        version=__version__,
        description=(
            "Prices and activations in, plans and reserve bids out. See docs/guide/service.md."
        ),
        openapi_url="/v1/openapi.json",
        docs_url=None,  # /v1/docs is the self-hosted page of hvacflex.service.dashboard
        redoc_url=None,
        responses=COMMON_ERRORS,
        lifespan=_stop_on_shutdown(planner),
    )
    app.state.sessions = sessions
    app.state.runtime = runtime
    app.state.planner = planner
    app.state.engine = engine
    app.state.stale_after_s = stale_after_s
    app.state.request_metrics = RequestMetrics()
    app.state.budgets = KeyBudgets(route_limits)
    if wall_clock:
        app.state.wall_clock_stop = start_wall_clock(planner)
    add_error_handlers(app)
    read_sessions = read_session_factory(engine)
    app.state.read_sessions = read_sessions
    auth = Auth(sessions, read_sessions)
    app.state.auth = auth
    _service_routes(app, runtime)
    _building_routes(app, planner, auth)
    _plan_routes(app, planner, auth)
    _measurement_routes(app, runtime, auth)
    _forecast_signal_routes(app, planner, auth)
    _signal_routes(app, planner, auth)
    _feeder_limit_routes(app, runtime, auth)
    _operator_routes(app, runtime, auth)
    add_page_routes(app)
    app.add_middleware(BodyLimitAndAudit, sessions=sessions)
    app.add_middleware(ObserveRequests, metrics=app.state.request_metrics)
    planner.recover()
    if freeze_heap:
        gc.collect()  # once, before serving: what is garbage now is not frozen
        runtime_freeze_heap()
    return app


PLAN_WAITERS_PER_PROCESS = 8
"""Planner threads per planning process: they only wait for the processes (a building's
jobs in order, many buildings' at once)."""


def _planner(
    runtime: Runtime, db_url: str, plan_workers: int, plan_processes: int, plan_niceness: int
) -> Planner:
    """The planner: its jobs in ``plan_processes`` processes (``plan_niceness`` lower in
    priority) where the database can be shared (and ``plan_processes`` > 0), else in
    ``plan_workers`` threads."""
    if plan_processes < 0:
        raise InputError("must be ≥ 0", field="plan_processes", value=plan_processes)
    if plan_processes == 0 or not shares_processes(db_url):
        return Planner(runtime, plan_workers)
    processes = PlanProcesses(db_url, plan_processes, live=runtime.live, niceness=plan_niceness)
    try:
        processes.start()
    except BaseException:
        processes.shutdown()
        raise
    waiters = max(plan_workers, PLAN_WAITERS_PER_PROCESS * plan_processes)
    return Planner(runtime, waiters, plans=processes)


def _stop_on_shutdown(planner: Planner) -> Callable[[FastAPI], Any]:
    """The app's lifespan: the planner's workers stop when the server does."""

    @contextlib.asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        yield
        planner.shutdown()

    return lifespan


def _service_routes(app: FastAPI, runtime: Runtime) -> None:
    """Health and metrics: no key needed."""
    sessions, engine = runtime.sessions, app.state.engine

    @app.get("/v1/health", tags=["service"])
    def health() -> Envelope[Health]:
        """Liveness and the database in use (no key needed)."""
        with sessions() as session:
            session.execute(select(1))
        payload = Health(service="hvacflex", version=__version__, database=engine.dialect.name)
        return Envelope(status=200, message="ok", payload=payload)

    @app.get(
        "/v1/metrics",
        tags=["service"],
        response_class=PlainTextResponse,
        responses={
            200: {"content": {"text/plain": {"schema": {"type": "string"}}}},
            **JSON_ERRORS,
        },
    )
    def metrics() -> PlainTextResponse:
        """Prometheus text format (no key needed; no building ids): requests, latencies,
        plans, solver failures, buildings and stale buildings (docs/guide/service.md)."""
        with sessions() as session:
            text = metrics_text(session, app.state.request_metrics, app.state.stale_after_s)
        return PlainTextResponse(text, media_type=PROMETHEUS_CONTENT_TYPE)


def _building_routes(app: FastAPI, planner: Planner, auth: Auth) -> None:
    """Registration, the buildings and every building's latest plan."""
    runtime = planner.runtime
    sessions = runtime.sessions
    operator, building_reader, _building_writer = roles(auth)
    Operator = Annotated[Principal, Depends(operator)]

    @app.post("/v1/buildings", tags=["operator"], responses=ERRORS, status_code=201)
    def register(body: RegisterBuilding, who: Operator) -> Envelope[Registered]:
        """Register a building from its description and scenario settings (content only);
        the response carries the building's key, shown this once."""
        app.state.budgets.spend(REGISTER_ROUTE, who.key_id)  # before the model is built
        with sessions() as session, session.begin():
            built = runtime.register(
                session, body.building_id, body.building, body.scenario, who.key_id
            )
            key = create_key(session, "building", body.building_id)
        info = _info(built, body)
        payload = Registered(key=key, **info.model_dump(exclude={"scenario"}))
        return Envelope(status=201, message="registered", payload=payload)

    def _info(built: Any, body: RegisterBuilding) -> BuildingInfo:
        return BuildingInfo(
            building_id=built.building_id,
            start=built.time_of(0),
            steps=built.steps,
            zones=list(built.setup.zone_names),
            nodes=list(built.setup.model.node_names),
            scenario=body.scenario.model_dump(),
        )

    @app.get("/v1/buildings", tags=["operator"], responses=ERRORS)
    def list_buildings(_who: Operator) -> Envelope[list[str]]:
        """Every registered building."""
        with sessions() as session:
            ids = runtime.building_ids(session)
        return Envelope(status=200, message=f"{len(ids)} buildings", payload=ids)

    @app.get("/v1/buildings/{building_id}", tags=["building"], responses=ERRORS)
    def get_building(
        building_id: str, _who: Annotated[Principal, Depends(building_reader)]
    ) -> Envelope[BuildingInfo]:
        """The building's periods, zones and nodes (operator, or the building itself)."""
        from hvacflex.service.db import BuildingRow

        with sessions() as session:
            built = runtime.get(session, building_id)
            row = session.get(BuildingRow, building_id)
        assert row is not None
        scenario = json.loads(row.scenario_json)
        info = BuildingInfo(
            building_id=building_id,
            start=built.time_of(0),
            steps=built.steps,
            zones=list(built.setup.zone_names),
            nodes=list(built.setup.model.node_names),
            scenario=scenario,
        )
        return Envelope(status=200, message="ok", payload=info)

    @app.get("/v1/plans", tags=["operator"], responses=ERRORS)
    def all_plans(_who: Operator) -> Envelope[PlanList]:
        """Every building's latest plan."""
        with sessions() as session:
            plans = [runtime.latest_plan(session, b) for b in runtime.building_ids(session)]
        out = [Plan(**p) for p in plans if p is not None]
        return Envelope(status=200, message=f"{len(out)} plans", payload=PlanList(plans=out))


def _plan_routes(app: FastAPI, planner: Planner, auth: Auth) -> None:
    """A building's measurements (acknowledged, planned off the request path) and its
    latest plan (read at once)."""
    runtime = planner.runtime
    latest = planner.latest_plans
    building_writer = roles(auth)[2]

    @app.post(
        "/v1/buildings/{building_id}/measurements",
        tags=["building"],
        responses={
            202: {
                "model": Envelope[PlanAck],
                "description": "Stored; its plan (this revision) is being made",
            },
            **ERRORS,
        },
    )
    def post_measurement(
        building_id: str,
        body: MeasurementIn,
        _who: Annotated[Principal, Depends(building_writer)],
        wait_s: Annotated[float, Query(ge=0, le=MAX_WAIT_S)] = 0.0,
    ) -> Envelope[Plan]:
        """The building's state at a period start. Stored, then planned off the request
        path: 202 with the revision its plan will have; with ``wait_s`` the plan itself
        (200) if it is made within that many seconds. The same measurement twice is stored
        once (the stored plan, or the same revision, is returned)."""
        ack = planner.acknowledge(building_id, body)
        plan = ack.wait(wait_s)
        if plan is None:
            payload = PlanAck(
                building_id=building_id, period=ack.period, time=ack.time, revision=ack.revision
            )
            message = "stored; planning" if ack.new else "measurement already stored; planning"
            return JSONResponse(  # type: ignore[return-value]
                {"status": 202, "message": message, "payload": payload.model_dump()}, 202
            )
        message = "planned" if ack.new else "measurement already stored; stored plan"
        return Envelope(status=200, message=message, payload=Plan(**plan))

    @app.get(
        "/v1/buildings/{building_id}/plan",
        tags=["building"],
        responses=ERRORS,
        response_model=Envelope[Plan],
    )
    async def get_plan(
        building_id: str,
        request: Request,
        key: Annotated[str | None, Depends(API_KEY)],
        period: Annotated[int | None, Query(ge=0, le=1_000_000)] = None,
    ) -> Response:
        """The latest finished plan (of ``period`` if given), at once: a plan being made
        is not waited for (operator, or the building itself)."""
        if auth.verified_keys.poll_due():  # the revocations, read off the event loop
            asyncio.get_running_loop().run_in_executor(None, auth.poll_keys)
        answer = plan_from_memory(request, key, building_id, period)
        if answer is not None:
            return answer
        return await run_in_threadpool(read_plan, request, key, building_id, period)

    def plan_from_memory(
        request: Request, key: str | None, building_id: str, period: int | None
    ) -> Response | None:
        """The answer from memory, on the event loop: the key verified recently and the
        building's latest plan as the planner handed it back (:mod:`.plan_cache`); None
        where either is not known here (the database answers)."""
        who = auth.cached(request, key)
        if who is None:
            return None
        check_building_reader(who, building_id)
        entry = latest.get(building_id)
        if entry is NO_PLAN:
            raise HTTPException(404, "no plan yet")
        if not isinstance(entry, CachedPlan) or period not in (None, entry.period):
            return None
        return Response(entry.body, media_type="application/json")

    def read_plan(
        request: Request, key: str | None, building_id: str, period: int | None
    ) -> Response:
        """The key checked and the plan read on one connection, in one trip through the
        threadpool; the latest plan is kept for the next reads (:meth:`LatestPlans.fill`)."""
        from hvacflex.service.db import BuildingRow

        token = latest.token(building_id)  # before the plan is read
        with app.state.read_sessions() as session:  # one statement each when there is a plan
            check_building_reader(auth.check(session, request, key), building_id)
            plan = runtime.latest_plan(session, building_id, period)
            if plan is None and session.get(BuildingRow, building_id) is None:
                raise NotFoundError("no such building", field="building_id", value=building_id)
        answer = NO_PLAN if plan is None else plan_answer(plan)
        if period is None:
            latest.fill(building_id, answer, token)
        if not isinstance(answer, CachedPlan):
            raise HTTPException(404, "no plan yet")
        return Response(answer.body, media_type="application/json")


def _measurement_routes(app: FastAPI, runtime: Runtime, auth: Auth) -> None:
    """The stored measurements (what a building metered), for the operator or the building."""
    sessions = runtime.sessions
    building_reader = roles(auth)[1]

    @app.get("/v1/buildings/{building_id}/measurements", tags=["building"], responses=ERRORS)
    def get_measurements(
        building_id: str,
        _who: Annotated[Principal, Depends(building_reader)],
        limit: Annotated[int, Query(ge=1, le=1000)] = PERIODS_PER_DAY,
    ) -> Envelope[list[MeasurementRecord]]:
        """The building's latest measurements, newest first: period, time and the power it
        metered in the period before (what an OpenADR VEN reports as telemetry)."""
        from hvacflex.service.db import Measurement

        with sessions() as session:
            built = runtime.get(session, building_id)
            rows = session.scalars(
                select(Measurement)
                .where(Measurement.building_id == building_id)
                .order_by(Measurement.period.desc())
                .limit(limit)
            )
            records = [
                MeasurementRecord(
                    period=r.period,
                    time=built.time_of(r.period),
                    previous_power_kw=r.previous_power_kw,
                    received_at=r.received_at.isoformat(),
                )
                for r in rows
            ]
        return Envelope(status=200, message=f"{len(records)} measurements", payload=records)


def _store_signal(sessions: Any, kind: str, body: dict[str, Any]) -> Stored:
    """Store an operator signal (committed when this returns)."""
    with sessions() as session, session.begin():
        row = Signal(kind=kind, body_json=json.dumps(body))
        session.add(row)
        session.flush()
        return Stored(id=row.id, kind=kind)


def _forecast_signal_routes(app: FastAPI, planner: Planner, auth: Auth) -> None:
    """Prices and the outdoor-temperature forecast: laid over the buildings' forecasts."""
    runtime = planner.runtime
    sessions = runtime.sessions
    Operator = Annotated[Principal, Depends(roles(auth)[0])]

    @app.post("/v1/signals/prices", tags=["operator"], responses=ERRORS)
    def post_prices(body: PricesIn, _who: Operator) -> Envelope[Stored]:
        """Energy (and reserve) prices of consecutive periods from ``start``; they replace
        the shipped prices in every building's forecast from the next plan on."""
        start = _signal_start(body.start, runtime.live)
        last = len(body.energy_price_sgd_per_mwh) - 1
        check_plannable(
            start + last * PERIOD,
            f"energy_price_sgd_per_mwh[{last}]",
            runtime.live,
        )
        _check_prices(body)
        stored = _store_signal(
            sessions,
            "prices",
            {
                "start_utc": start.tz_convert("UTC").isoformat(),
                "energy_price_sgd_per_mwh": body.energy_price_sgd_per_mwh,
                "reserve_price_sgd_per_mwh": body.reserve_price_sgd_per_mwh,
            },
        )
        return Envelope(status=200, message="stored", payload=stored)

    @app.post("/v1/signals/weather", tags=["operator"], responses=ERRORS)
    def post_weather(body: WeatherIn, _who: Operator) -> Envelope[Stored]:
        """An outdoor-temperature forecast [°C] (and, optionally, humidity ratio [kg/kg]) of
        consecutive periods from ``start``; it replaces the typical year's in every
        building's forecast there."""
        start = _signal_start(body.start, runtime.live)
        stored = _store_signal(
            sessions,
            "weather",
            {
                "start_utc": start.tz_convert("UTC").isoformat(),
                "outdoor_temp_degc": body.outdoor_temp_degc,
                "outdoor_humidity_ratio_kg_per_kg": body.outdoor_humidity_ratio_kg_per_kg,
            },
        )
        return Envelope(status=200, message="stored", payload=stored)


def _signal_routes(app: FastAPI, planner: Planner, auth: Auth) -> None:
    """The peak-power price, the feeder limit, activations and the clock."""
    runtime = planner.runtime
    sessions = runtime.sessions
    Operator = Annotated[Principal, Depends(roles(auth)[0])]

    @app.post("/v1/signals/peak-price", tags=["operator"], responses=ERRORS)
    def post_peak_price(body: PeakPriceIn, _who: Operator) -> Envelope[Stored]:
        """The peak-power price φ [SGD/kW] every building plans with from now on."""
        stored = _store_signal(sessions, "peak_price", body.model_dump())
        return Envelope(status=200, message="stored", payload=stored)

    @app.post("/v1/activations", tags=["operator"], responses=ERRORS)
    def post_activation(body: ActivationIn, _who: Operator) -> Envelope[PlanList]:
        """IL activation start or end; the affected buildings' current plans change at once
        (the plans re-issued are returned)."""
        time = to_local(body.time)
        check_plannable(time, "time", runtime.live)
        with sessions() as session, session.begin():
            known = set(runtime.building_ids(session))
            targets = sorted(known) if body.building_ids is None else body.building_ids
            for i, building_id in enumerate(targets):
                if building_id not in known:
                    raise NotFoundError(
                        "no such building", field=f"building_ids[{i}]", value=building_id
                    )
            for building_id in body.building_ids or [None]:  # type: ignore[list-item]
                session.add(
                    Activation(
                        building_id=building_id,
                        event=body.event,
                        time_utc=time.tz_convert("UTC").isoformat(),
                    )
                )
        plans = planner.activation(targets)
        payload = PlanList(plans=[Plan(**p) for p in plans])
        return Envelope(
            status=200, message=f"{body.event}: {len(plans)} plans changed", payload=payload
        )

    @app.post("/v1/activations/refused", tags=["operator"], responses=ERRORS)
    def post_activation_refused(body: ActivationRefusedIn, _who: Operator) -> Envelope[Stored]:
        """A dispatch refused (no plan changes): the buildings, the time and the reason go
        on the record (signal ``activation_refused``) and into the audit."""
        with sessions() as session:
            known = set(runtime.building_ids(session))
        for i, building_id in enumerate(body.building_ids):
            if building_id not in known:
                raise NotFoundError(
                    "no such building", field=f"building_ids[{i}]", value=building_id
                )
        stored = _store_signal(sessions, "activation_refused", body.model_dump(mode="json"))
        return Envelope(status=200, message="activation refused: recorded", payload=stored)

    @app.post("/v1/clock", tags=["operator"], responses=ERRORS)
    def post_clock(body: ClockIn, who: Operator) -> Envelope[PlanList]:
        """Advance the service clock; each building without a plan for the period that now
        starts is planned on its latest measurement (the 30-min boundary trigger)."""
        time = to_local(body.time)
        check_plannable(time, "time", runtime.live)
        app.state.budgets.spend(CLOCK_ROUTE, who.key_id)  # before every building re-plans
        with sessions() as session, session.begin():
            row = session.get(ServiceClock, 1)
            if row is None:
                session.add(ServiceClock(id=1, time_utc=time.tz_convert("UTC").isoformat()))
            else:
                row.time_utc = time.tz_convert("UTC").isoformat()
        plans = planner.boundary(body.time)
        payload = PlanList(plans=[Plan(**p) for p in plans])
        return Envelope(status=200, message=f"{len(plans)} plans made", payload=payload)


MAX_SCHEDULE_PERIODS = 17_568
"""Longest feeder limit schedule one request may read: a leap year of periods."""


def _feeder_limit_routes(app: FastAPI, runtime: Runtime, auth: Auth) -> None:
    """The feeder limit: a constant limit, limit windows and the schedule they make."""
    sessions = runtime.sessions
    Operator = Annotated[Principal, Depends(roles(auth)[0])]

    @app.post("/v1/signals/feeder-limit", tags=["operator"], responses=ERRORS)
    def post_feeder_limit(body: FeederLimitIn, _who: Operator) -> Envelope[Stored]:
        """The feeder limit [kW] the aggregate bid is checked against (the limit windows
        lower it where they hold)."""
        stored = _store_signal(sessions, feeder_limits.CONSTANT_KIND, body.model_dump())
        return Envelope(status=200, message="stored", payload=stored)

    @app.post("/v1/signals/feeder-limits", tags=["operator"], responses=ERRORS)
    def post_feeder_limit_windows(body: FeederLimitWindowsIn, _who: Operator) -> Envelope[Stored]:
        """Feeder limit windows, as a fleet file's ``[[feeder_limits]]`` tables: each lowers
        the limit to its ``limit_kw`` in its periods (the tighter holds). Under an
        ``event_id`` they replace the windows posted before with that id (an empty list
        cancels them)."""
        if not body.windows and body.event_id is None:
            raise InputError(
                "give at least one window (an empty list cancels an event's windows: give "
                "its event_id)",
                field="windows",
                value=[],
            )
        stored = _store_signal(sessions, feeder_limits.WINDOWS_KIND, body.model_dump(mode="json"))
        return Envelope(status=200, message=f"{len(body.windows)} windows stored", payload=stored)

    @app.get("/v1/feeder-limits", tags=["operator"], responses=ERRORS)
    def feeder_limit_schedule(
        _who: Operator,
        start: Annotated[str, Query(description="the first period start (ISO 8601)")],
        periods: Annotated[int, Query(ge=1, le=MAX_SCHEDULE_PERIODS)] = PERIODS_PER_DAY,
    ) -> Envelope[FeederLimitSchedule]:
        """The feeder limit in force at each of ``periods`` period starts from ``start``
        (null: no limit), and the windows in force."""
        first = _period_start(start, "start")
        index = pd.date_range(first, periods=periods, freq=PERIOD_FREQ)
        with sessions() as session:
            limit = feeder_limits.schedule_kw(session, index)
            windows = feeder_limits.windows_in_force(session)
        payload = FeederLimitSchedule(
            time=[t.isoformat() for t in index],
            limit_kw=feeder_limits.as_optional(limit),
            windows=windows,
        )
        return Envelope(status=200, message=f"{periods} periods", payload=payload)


def _period_start(text: str, field: str) -> pd.Timestamp:
    """An ISO time that must be a 30-min period start, as a Singapore timestamp.

    Raises
    ------
    InputError : not an ISO time, or not a period start.
    """
    try:
        stamp = to_local(datetime.fromisoformat(text))
    except ValueError:
        raise InputError("not an ISO 8601 time", field=field, value=text) from None
    return _on_period_start(stamp, field)


def _on_period_start(stamp: pd.Timestamp, field: str) -> pd.Timestamp:
    """``stamp`` if it starts a 30-min period.

    Raises
    ------
    InputError : naming ``field``, where it does not.
    """
    if stamp != stamp.floor(PERIOD_FREQ):
        raise InputError("must be a 30-min period start", field=field, value=str(stamp))
    return stamp


def _signal_start(start: datetime, live: bool) -> pd.Timestamp:
    """A signal's first period (its ``start``, a datetime) as a Singapore timestamp: a 30-min
    period start that can still be planned (:func:`check_plannable`).

    Raises
    ------
    InputError : naming the field ``start``, where it is neither.
    """
    stamp = _on_period_start(to_local(start), "start")
    check_plannable(stamp, "start", live)
    return stamp


def _operator_routes(app: FastAPI, runtime: Runtime, auth: Auth) -> None:
    """The aggregate bid and the audit trail."""
    sessions = runtime.sessions
    Operator = Annotated[Principal, Depends(roles(auth)[0])]

    @app.get("/v1/bid", tags=["operator"], responses=ERRORS)
    def aggregate_bid(_who: Operator) -> Envelope[Bid]:
        """The sum over every building's latest plan: reserve offered and planned power per
        period start, and whether the planned power exceeds the feeder limit. A stale
        building (no measurement for ``stale_after_s``) is listed and left out of the sums."""
        with sessions() as session:
            stale = stale_buildings(session, app.state.stale_after_s)
            fresh = [b for b in runtime.building_ids(session) if b not in set(stale)]
            plans = [runtime.latest_plan(session, b) for b in fresh]
            constant_kw = feeder_limits.constant_limit_kw(session)
            windows = feeder_limits.windows_in_force(session)
        reserve: dict[str, float] = {}
        power: dict[str, float] = {}
        members: list[BidBuilding] = []
        for plan in plans:
            if plan is None:
                continue
            members.append(
                BidBuilding(
                    building_id=plan["building_id"],
                    period=plan["period"],
                    time=plan["time"],
                    reserve_kw=plan["reserve_kw"],
                    planned_power_kw=plan["planned_power_kw"],
                )
            )
            for t, r, p in zip(
                plan["horizon_time"],
                plan["horizon_reserve_kw"],
                plan["horizon_power_kw"],
                strict=False,
            ):
                key = to_local_iso(t)
                reserve[key] = reserve.get(key, 0.0) + (r or 0.0)
                power[key] = power.get(key, 0.0) + (p or 0.0)
        times = sorted(reserve)
        schedule = feeder_limits.schedule_at(constant_kw, windows, times)
        bid = Bid(
            time=times,
            reserve_kw=[reserve[t] for t in times],
            planned_power_kw=[power[t] for t in times],
            buildings=members,
            feeder_limit_kw=feeder_limits.as_optional(np.array([constant_kw]))[0],
            feeder_limit_exceeded=bool((np.array([power[t] for t in times]) > schedule).any()),
            feeder_limit_schedule_kw=feeder_limits.as_optional(schedule),
            stale_buildings=stale,
        )
        message = f"{len(members)} buildings" + (f", {len(stale)} stale left out" if stale else "")
        return Envelope(status=200, message=message, payload=bid)

    @app.get("/v1/activations", tags=["operator"], responses=ERRORS)
    def activations(
        _who: Operator, limit: Annotated[int, Query(ge=1, le=1000)] = 100
    ) -> Envelope[list[ActivationRecord]]:
        """The latest IL activation starts and ends, newest first."""
        with sessions() as session:
            rows = session.scalars(select(Activation).order_by(Activation.id.desc()).limit(limit))
            records = [
                ActivationRecord(
                    id=r.id,
                    building_id=r.building_id,
                    event=r.event,
                    time=to_local_iso(r.time_utc),
                    received_at=r.created_at.isoformat(),
                )
                for r in rows
            ]
        return Envelope(status=200, message=f"{len(records)} activations", payload=records)

    @app.get("/v1/audit", tags=["operator"], responses=ERRORS)
    def audit(
        _who: Operator, limit: Annotated[int, Query(ge=1, le=1000)] = 100
    ) -> Envelope[list[AuditRecord]]:
        """The latest mutating requests, newest first."""
        with sessions() as session:
            rows = session.scalars(select(AuditEntry).order_by(AuditEntry.id.desc()).limit(limit))
            records = [
                AuditRecord(
                    at=r.at.isoformat(),
                    key_id=r.key_id,
                    role=r.role,
                    method=r.method,
                    path=r.path,
                    status_code=r.status_code,
                    body_sha256=r.body_sha256,
                    action=audit_action(r.method, r.path),
                    body_head=r.body_head,
                )
                for r in rows
            ]
        return Envelope(status=200, message=f"{len(records)} records", payload=records)


AUDIT_ACTIONS: tuple[tuple[str, re.Pattern[str], str], ...] = tuple(
    (method, re.compile(pattern), action)
    for method, pattern, action in (
        ("POST", r"/v1/buildings", "registration"),
        ("POST", r"/v1/buildings/[^/]+/measurements", "measurement"),
        ("POST", r"/v1/signals/prices", "prices"),
        ("POST", r"/v1/signals/weather", "weather"),
        ("POST", r"/v1/signals/peak-price", "peak_price"),
        ("POST", r"/v1/signals/feeder-limit", "feeder_limit"),
        ("POST", r"/v1/signals/feeder-limits", "feeder_limit_windows"),
        ("POST", r"/v1/activations", "activation"),
        ("POST", r"/v1/activations/refused", "activation_refused"),
        ("POST", r"/v1/clock", "clock"),
    )
)
"""(method, path pattern, action) of the mutating routes, as the audit names them."""


def audit_action(method: str, path: str) -> str | None:
    """The action an audited request was (:data:`AUDIT_ACTIONS`), None if none matches."""
    for known_method, pattern, action in AUDIT_ACTIONS:
        if method == known_method and pattern.fullmatch(path):
            return action
    return None


@functools.cache
def plannable_span() -> tuple[pd.Timestamp, pd.Timestamp]:
    """The first and the last period start the service can plan: those of the price data
    (Singapore time)."""
    from hvacflex.data.forecast import DEFAULT_USEP_FOLDER
    from hvacflex.data.market import load_usep
    from hvacflex.paths import data_dir

    index = load_usep(data_dir() / DEFAULT_USEP_FOLDER).index
    return index[0], index[-1]


def check_plannable(stamp: pd.Timestamp, field: str, live: bool = False) -> None:
    """Refuse a time outside the price data (:func:`plannable_span`), naming the range; in
    live mode (``live``) every time is plannable (a building's own scenario span decides).

    Raises
    ------
    InputError : ``stamp`` is before the first or after the last period start.
    """
    if live:
        return
    first, last = plannable_span()
    if not first <= stamp <= last:
        raise InputError(
            f"outside the times the service can plan, {first.isoformat()} … {last.isoformat()}",
            field=field,
            value=stamp.isoformat(),
        )


def to_local_iso(text: str) -> str:
    """An ISO time as Singapore-time ISO (so plans of different buildings line up)."""
    return str(to_local(datetime.fromisoformat(text)).isoformat())


def _check_prices(body: PricesIn) -> None:
    """As many reserve prices as energy prices (the ranges are the schema's)."""
    reserve = body.reserve_price_sgd_per_mwh
    if reserve is not None and len(reserve) != len(body.energy_price_sgd_per_mwh):
        raise InputError(
            "must have as many periods as energy_price_sgd_per_mwh",
            field="reserve_price_sgd_per_mwh",
            value=len(reserve),
        )
