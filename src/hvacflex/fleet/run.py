"""A fleet's closed-loop run on Dask: building groups as actors, one coordinator.

Every 30 min the coordinator (this process) asks every group for its buildings' power
ranges, runs the price iterations of :func:`hvacflex.fleet.coordinate.coordinate` (each
iteration one call per group, the groups solving in parallel on their workers), fixes the
plans inside the caps, and advances every plant. The groups are Dask actors
(``client.submit(BuildingGroup, ..., actor=True)``): the building agents, their warm-started
HiGHS solvers included, live on the workers across steps and only prices, powers and rows
travel.

Checkpoints: every ``checkpoint_every`` steps the coordinator collects every building's
state (:meth:`ClosedLoop.get_state`) and the fleet rows and writes ``checkpoint.npz``
(data only, :mod:`hvacflex.state`)
atomically. If a worker is lost mid-run, the step fails; the coordinator re-creates the
groups on the workers there are, restores every building from the last checkpoint and goes
on from there (the run is deterministic, so the result is the same). Started again with the
same fleet file, period and code, a run resumes from its checkpoint.

Files written to ``out``: ``results.parquet`` (one row per step, fleet columns; schema in
:mod:`hvacflex.results` and docs/guide/fleet.md), ``buildings.parquet`` (long format: the
single-building columns of every building plus ``building``), ``summary.json`` (fleet KPIs),
``buildings_summary.csv`` (per-building KPIs), ``config.json``, ``envelope.csv`` (the
fleet's flexibility envelope at every step's start, :mod:`hvacflex.fleet.envelope`).
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex import kpi as kpis
from hvacflex import results as schema
from hvacflex import state
from hvacflex.constants import PERIOD, PERIOD_S, TIMEZONE
from hvacflex.control.base import FloatArray
from hvacflex.errors import HvacflexError
from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.aggregation import (
    OFFERS_FILE,
    FleetOffer,
    aggregate_offer,
    building_delivery_kw,
    dispatched_kw,
    offers_table,
    visible_offers_kw,
)
from hvacflex.fleet.bidding import fleet_activation_schedule, settle_fleet
from hvacflex.fleet.bundle import coordinate_caps
from hvacflex.fleet.coordinate import CoordinationOptions, CoordinationResult, coordinate
from hvacflex.fleet.envelope import (
    DURATIONS_MIN,
    ENVELOPE_FILE,
    duration_steps,
    envelope_frame,
    fleet_envelope,
)
from hvacflex.fleet.guard import guard_caps_kw
from hvacflex.fleet.schema import Fleet, load_fleet_document
from hvacflex.sim.run_files import (
    check_checkpoint_code,
    input_files,
    load_checkpoint,
    refuse_old_checkpoint,
    update_with_files,
    write_summary,
)
from hvacflex.sim.sweep import close_dask
from hvacflex.units import SECONDS_PER_HOUR
from hvacflex.version import atomic_write_text, code_version

CHECKPOINT_FILE = "checkpoint.npz"
SUMMARY_FILE = "summary.json"
STEP = PERIOD
"""The fleet's control step (the building agents' ``dt_s``)."""
DT_H = PERIOD_S / SECONDS_PER_HOUR
"""The control step [h], for the coordination's energy terms."""
DEFAULT_CHECKPOINT_EVERY = 12
MAX_RECOVERIES = 3
BUILD_ATTEMPTS = 3
"""Tries at re-creating the building groups after a lost worker (each waits
``ACTOR_TIMEOUT_S`` for the actors)."""
ACTOR_TIMEOUT_S = 60.0
ACTOR_TIMEOUT_PER_BUILDING_S = 2.0
"""A group call is checked for a lost worker every max(ACTOR_TIMEOUT_S, this × the group's
buildings) [s]: a group's call solves each of its buildings once (≈ 0.05–0.5 s each at
D = 4; a cold first step of 100 buildings on a loaded machine took longer than 200 s)."""
ACTOR_MAX_WAITS = 20
"""A group call whose workers are all still there is waited for this many such periods
before the step fails (and is retried from the last checkpoint)."""


class WorkerLostError(RuntimeError):
    """A Dask worker holding building groups is gone."""


FLOAT_COLUMNS = tuple(schema.FLEET_FLOAT_UNITS)
ACTIVATED = schema.FLEET_FLAG_COLUMNS.index("il_activated")
"""A smaller aggregate reserve [kW] is no bid (solver round-off), whatever ``min_bid_mw``."""
"""Index of the IL-activated flag in the flags table."""
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FleetStepProgress:
    """What the progress display shows after each fleet step.

    Attributes
    ----------
    done, steps : steps done and in all.
    iterations : price iterations of this step's coordination.
    gap : its relative duality gap, (Σ cost − bound) / |Σ cost|.
    at_iteration_limit : the coordination stopped at ``max_iterations`` with the gap above
        ``gap_tolerance`` (not converged: the plans keep the last prices and caps).
    max_iterations, gap_tolerance : the fleet's coordination settings.
    """

    done: int
    steps: int
    iterations: int
    gap: float
    at_iteration_limit: bool
    max_iterations: int
    gap_tolerance: float


@dataclass(frozen=True)
class FleetRunResult:
    out_dir: Path
    frame: pd.DataFrame
    summary: dict[str, float]
    recoveries: int
    resumed_from_step: int | None


def live_workers(client: Any) -> set[str]:
    """The addresses of the workers the scheduler holds now, asked of the scheduler itself
    (``client.nthreads()``: an error if it cannot answer, never a stale answer).

    Not ``client.scheduler_info()["workers"]``: the client refreshes that cache every 2 s
    with the cluster's totals only (an empty ``workers``), and ``scheduler_info`` returns
    the cache when its own fetch fails (it logs the ``OSError`` at debug level: a comm
    timeout on a loaded machine) — every worker then seems to have left at once. That is
    the likely cause of the one such "loss" seen, both workers of a 5-day fleet run at
    load 3, after which the run restored from its checkpoint for nothing."""
    return set(client.nthreads())


class _Groups:
    """The building groups: in-process objects, or Dask actors on a cluster."""

    def __init__(
        self, doc: dict[str, Any], settings: FleetSettings, n: int, client: Any | None
    ) -> None:
        self.doc, self.settings, self.client = doc, settings, client
        self.n = n
        self.groups: list[Any] = []
        self.workers: list[str] = []
        self.indices: list[list[int]] = []
        self.build()

    def build(self) -> None:
        if self.client is None:
            self.indices = [list(range(self.n))]
            self.groups = [BuildingGroup(self.doc, self.indices[0], self.settings)]
            return
        workers = sorted(live_workers(self.client))
        count = max(1, min(len(workers), self.n))
        self.indices = [list(range(self.n))[i::count] for i in range(count)]
        futures = [
            self.client.submit(
                BuildingGroup, self.doc, idx, self.settings, actor=True, workers=[w], pure=False
            )
            for idx, w in zip(self.indices, workers, strict=False)
        ]
        try:  # a worker that has just died may still be listed: do not wait on it forever
            self.groups = [f.result(timeout=ACTOR_TIMEOUT_S) for f in futures]
        except TimeoutError:
            self.client.cancel(futures)
            raise
        self.workers = list(workers[:count])

    def check_alive(self) -> None:
        """Raise ``WorkerLostError`` when the scheduler answers without a worker that holds
        a group. A scheduler that does not answer (a comm error or timeout on a loaded
        machine) proves no loss: the run goes on, and a worker really gone fails its calls."""
        if self.client is None:
            return
        try:
            present = live_workers(self.client)
        except (OSError, TimeoutError) as exc:  # distributed's CommClosedError is an OSError
            log.info("the scheduler did not say which workers are there (%s); going on", exc)
            return
        lost = [w for w in self.workers if w not in present]
        if lost:
            raise WorkerLostError(f"worker(s) {lost} left the cluster")

    def call(self, method: str, *args_per_group: Sequence[Any]) -> list[Any]:
        calls = [
            getattr(g, method)(*(a[i] for a in args_per_group)) for i, g in enumerate(self.groups)
        ]
        if self.client is None:
            return calls
        results = []
        largest = max(len(idx) for idx in self.indices)
        timeout_s = max(ACTOR_TIMEOUT_S, ACTOR_TIMEOUT_PER_BUILDING_S * largest)
        for c in calls:
            for wait in range(1, ACTOR_MAX_WAITS + 1):
                try:
                    results.append(c.result(timeout=timeout_s))
                    break
                except TimeoutError:
                    self.check_alive()  # a lost worker: the step fails, recovered
                    if wait == ACTOR_MAX_WAITS:
                        raise
                    log.info("%s: still waiting on a group after %.0f s", method, wait * timeout_s)
        return results

    def broadcast(self, method: str, *args: Any) -> list[Any]:
        return self.call(method, *([arg] * len(self.groups) for arg in args))

    def stacked(self, method: str, *args: Any) -> tuple[np.ndarray, ...]:
        """Call on every group and reassemble (B, …) arrays in fleet building order."""
        parts = self.broadcast(method, *args)
        order = np.argsort(np.concatenate(self.indices))
        return tuple(np.concatenate([p[j] for p in parts])[order] for j in range(len(parts[0])))

    def split(self, array: np.ndarray) -> list[np.ndarray]:
        return [array[idx] for idx in self.indices]

    def get_states(self) -> list[dict[str, Any]]:
        states: list[dict[str, Any]] = [{}] * self.n
        for idx, part in zip(self.indices, self.broadcast("get_state"), strict=True):
            for i, one in zip(idx, part, strict=True):
                states[i] = one
        return states

    def set_states(self, states: list[dict[str, Any]]) -> None:
        self.call("set_state", [[states[i] for i in idx] for idx in self.indices])

    def checkpoint_states(self) -> list[dict[str, Any]]:
        """:meth:`get_states`, then every building's solver restarted from its basis as a
        restore by :meth:`set_states` restarts it, so that the run goes on from here as a
        run resumed from this checkpoint does, bit for bit."""
        states = self.get_states()
        self.broadcast("restart_warm")
        return states


def fleet_key(fleet: Fleet, fleet_path: Path, start: str, days: float) -> str:
    """Identity of a fleet run's inputs: the fleet file's bytes, the period, and the bytes of
    the files it names (``[data]``, ``[activation]``, ``feeder_limit_csv``), so that editing
    one of them does not resume a checkpoint made with the old one."""
    digest = hashlib.sha256(fleet_path.read_bytes())
    digest.update(f"{start}|{days}".encode())
    files = input_files(fleet.data, fleet.activation)
    if fleet.feeder_limit_path is not None:
        files.append(fleet.feeder_limit_path)
    update_with_files(digest, files)
    return digest.hexdigest()[:16]


def _run_dir(out_dir: str | Path, resume: bool) -> Path:
    """The run's folder, made; one holding an older hvacflex's pickle checkpoint is refused
    when resuming."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if resume:
        refuse_old_checkpoint(out)
    return out


def run_fleet(
    fleet_path: str | Path,
    out_dir: str | Path,
    *,
    start: str,
    days: float,
    scheduler: str | None = None,
    workers: int | None = 2,
    checkpoint_every: int = DEFAULT_CHECKPOINT_EVERY,
    resume: bool = True,
    progress: Callable[[FleetStepProgress], None] | None = None,
    on_step: Callable[[int, Any], None] | None = None,
    loaded: tuple[Fleet, dict[str, Any]] | None = None,
) -> FleetRunResult:
    """Simulate a fleet (see the module docstring).

    Parameters
    ----------
    fleet_path : the fleet TOML file.
    out_dir : folder for the results, summary and checkpoint.
    start, days : the simulated period (Singapore local time).
    scheduler : a Dask scheduler address; None = a ``LocalCluster`` of ``workers`` worker
        processes (one thread each); ``workers=0`` runs in this process without Dask.
    checkpoint_every : steps between checkpoints.
    resume : resume from a checkpoint of the same inputs and code.
    progress : called after each step with its :class:`FleetStepProgress`.
    on_step : called with (steps done, the run's group handle) after each step (tests).
    loaded : (fleet, document) of ``fleet_path`` as ``load_fleet_document`` read it, or None.
    """
    path = Path(fleet_path)
    fleet, doc = load_fleet_document(path) if loaded is None else loaded
    out = _run_dir(out_dir, resume)
    settings = FleetSettings.of(fleet, start, days)
    horizon = settings.horizon_steps
    index, limit, planning_limit = _feeder_timeline(fleet, start, days, horizon)
    steps = len(index)
    options = _coordination_options(fleet)
    key = fleet_key(fleet, path, start, days)
    checkpoint_path = out / CHECKPOINT_FILE
    _write_config(out, path, start, days, key)

    cluster, client, own_client = _start_dask(scheduler, workers)
    try:
        groups = _Groups(doc, settings, n := len(fleet.buildings), client)
        holds = envelope_steps(fleet)  # () when the envelope is off
        values, flags, iterations, envelope, offers = _empty_tables(steps, n, len(holds))
        col = {name: i for i, name in enumerate(FLOAT_COLUMNS)}
        checkpoint = _matching_checkpoint(checkpoint_path, key) if resume else None
        k, price = (
            (0, np.zeros(horizon))
            if checkpoint is None
            else (_restore(checkpoint, groups, values, flags, iterations, offers))
        )
        resumed_from = None if checkpoint is None else _restore_envelope(checkpoint, envelope)

        def snapshot() -> dict[str, Any]:
            return _snapshot(
                key, k, price, (values, flags, iterations, offers), groups, envelope[:k]
            )

        checkpoint = checkpoint or snapshot()
        recoveries, schedule = 0, fleet_activation_schedule(fleet, index)
        min_bid_kw = 1000.0 * fleet.spec.min_bid_mw
        while k < steps:
            try:
                tick = time.perf_counter()
                context = _context(k, schedule, flags, min_bid_kw, float(limit[k]), holds)
                seen = step_planning_kw(fleet, planning_limit, index, k, horizon)
                outcome = _fleet_step(groups, seen, options, price, context)
            except HvacflexError:
                raise
            except Exception as exc:  # a lost worker surfaces as comm/actor errors
                recoveries += 1
                if client is None or recoveries > MAX_RECOVERIES:
                    raise
                k, price = _recover(exc, k, client, groups, checkpoint)
                continue
            result = outcome.result
            flags[k] = _record_step(values[k], col, outcome, limit[k])
            values[k, col["step_time_s"]] = time.perf_counter() - tick
            iterations[k], offers[k], envelope[k] = _step_rows(outcome)
            price = np.append(result.price_sgd_per_mwh[1:], result.price_sgd_per_mwh[-1])
            k += 1
            _notify(progress, on_step, step_progress(k, steps, result, options), groups)
            if k % checkpoint_every == 0 and k < steps:
                checkpoint = snapshot()
                state.save(checkpoint_path, checkpoint)

        long = _collect_buildings(groups, fleet, values, col)
    finally:
        if own_client is not None:
            close_dask(own_client, cluster)

    rule = settings.il_events.il_baseline
    frame = settle_fleet(_results_frame(values, flags, iterations, index), rule)
    table = _settle_buildings(frame, long, fleet, offers, rule)
    summary = _write_outputs(out, (frame, long, table), fleet, key, recoveries)
    _write_envelope(out, index, envelope)
    checkpoint_path.unlink(missing_ok=True)
    return FleetRunResult(out, frame, summary, recoveries, resumed_from)


def _notify(
    progress: Callable[[FleetStepProgress], None] | None,
    on_step: Callable[[int, Any], None] | None,
    step: FleetStepProgress,
    groups: Any,
) -> None:
    """Tell the progress display and the test hook that ``step.done`` steps are done."""
    if progress is not None:
        progress(step)
    if on_step is not None:
        on_step(step.done, groups)


def step_progress(
    done: int, steps: int, result: Any, options: CoordinationOptions
) -> FleetStepProgress:
    """The :class:`FleetStepProgress` of a step whose coordination gave ``result``."""
    gap = float(result.gap)
    return FleetStepProgress(
        done=done,
        steps=steps,
        iterations=int(result.iterations),
        gap=gap,
        at_iteration_limit=result.iterations >= options.max_iterations
        and not gap <= options.gap_tolerance,
        max_iterations=options.max_iterations,
        gap_tolerance=options.gap_tolerance,
    )


def _feeder_timeline(
    fleet: Any, start: str, days: float, horizon: int
) -> tuple[pd.DatetimeIndex, FloatArray, FloatArray]:
    """(simulated period starts, feeder limit [kW] and planning limit [kW] over the run plus
    one horizon)."""
    steps = round(days * 24.0 / DT_H)
    index = pd.date_range(pd.Timestamp(start, tz=TIMEZONE), periods=steps, freq=STEP)
    full_index = pd.date_range(index[0], periods=steps + horizon, freq=STEP)
    limit = fleet.limit_series_kw(full_index)
    return index, limit, limit * (1.0 - fleet.spec.feeder_margin)


def step_planning_kw(
    fleet: Fleet, planning_kw: FloatArray, index: pd.DatetimeIndex, k: int, horizon: int
) -> FloatArray:
    """(horizon,) the planning limit [kW] step ``k`` plans against: ``planning_kw`` (the run's
    planning limit plus one horizon, :func:`_feeder_timeline`) over the step's horizon, less
    the limit windows not yet seen at the step's start (``window_lookahead_h``,
    :meth:`hvacflex.fleet.schema.Fleet.limit_series_kw`); the limit in force at the step's
    own period is always seen."""
    if math.isinf(fleet.spec.window_lookahead_h):
        return planning_kw[k : k + horizon]
    periods = pd.date_range(index[k], periods=horizon, freq=STEP)
    seen: FloatArray = fleet.limit_series_kw(periods, seen_at=index[k])
    return seen * (1.0 - fleet.spec.feeder_margin)


def minimum_power_warning(fleet: Fleet, start: str, days: float) -> str | None:
    """A warning when the buildings' design minimum powers
    (:func:`hvacflex.fleet.generate.design_min_power_kw`, occupied ventilation flows on the
    design day) exceed the feeder limit somewhere in the run, else None."""
    from hvacflex.fleet.generate import design_min_power_kw

    _, limit, _ = _feeder_timeline(fleet, start, days, 0)
    minimum = sum(design_min_power_kw(b.building) for b in fleet.buildings)
    lowest = float(np.min(limit))
    if minimum <= lowest:
        return None
    return (
        f"{fleet.source or fleet.name}: the buildings' minimum powers on the design day sum to "
        f"{minimum:.1f} kW, above the feeder limit of {lowest:.1f} kW: periods where the "
        "minima exceed it are flagged infeasible (every building at its minimum); raise "
        "feeder_limit_kw (hvacflex fleet generate --feeder-limit-kw) or the [[feeder_limits]] "
        "window's limit_kw to avoid them"
    )


def _write_envelope(out: Path, index: pd.DatetimeIndex, envelope: FloatArray) -> None:
    """``envelope.csv`` of the fleet's envelope (steps, D, 3); with no durations (D = 0, the
    envelope switched off) none, and none left of an earlier run in the folder."""
    if envelope.shape[1]:
        envelope_frame(index, envelope).to_csv(out / ENVELOPE_FILE, index=False)
    else:
        (out / ENVELOPE_FILE).unlink(missing_ok=True)


def _empty_tables(
    steps: int, buildings: int, holds: int = len(DURATIONS_MIN)
) -> tuple[FloatArray, Any, Any, FloatArray, FloatArray]:
    """(float columns (steps, FLOAT_COLUMNS), flags bid_accepted/feeder_infeasible, iterations,
    the envelope (steps, D, 3) of D = ``holds`` durations: least, most power [kW], buildings
    summed, and every building's metered-visible offer (steps, B) [kW])."""
    return (
        np.full((steps, len(FLOAT_COLUMNS)), np.nan),
        np.zeros((steps, len(schema.FLEET_FLAG_COLUMNS)), dtype=bool),
        np.zeros(steps, dtype=np.int64),
        np.full((steps, holds, 3), np.nan),
        np.zeros((steps, buildings)),
    )


def _step_rows(outcome: _StepOutcome) -> tuple[int, FloatArray, FloatArray]:
    """A step's coordination iterations, the buildings' visible offers (B,) [kW] and the
    fleet's envelope (D, 3)."""
    return outcome.result.iterations, outcome.visible_kw, outcome.envelope_kw


def _coordination_options(fleet: Any) -> CoordinationOptions:
    """The fleet file's ``[coordination]`` settings."""
    cs = fleet.spec.coordination
    return CoordinationOptions(
        cs.max_iterations,
        cs.gap_tolerance,
        cs.feasibility_tolerance,
        cs.step_sgd_per_mwh,
        cap_rounds=cs.cap_rounds,
        scheme=cs.scheme,
        plan_tolerance_kw=cs.plan_tolerance_kw,
    )


def _write_config(out: Path, path: Path, start: str, days: float, key: str) -> None:
    """``config.json``: the fleet file, the period and the run key."""
    atomic_write_text(
        out / "config.json",
        json.dumps({"fleet": str(path), "start": start, "days": days, "key": key}, indent=2),
    )


def _snapshot(
    key: str,
    k: int,
    price: FloatArray,
    tables: tuple[FloatArray, Any, Any, FloatArray],
    groups: Any,
    envelope: FloatArray,
) -> dict[str, Any]:
    """The checkpoint after ``k`` steps (``tables``: the fleet's float columns, flags,
    iterations and the buildings' visible offers (steps, B); ``envelope`` (k, D, 2): the
    iterations and the buildings' visible offers (steps, B); ``envelope`` (k, D, 3): the
    envelope's rows)."""
    values, flags, iterations, offers = tables
    return {
        "envelope": envelope.copy(),
        "config_hash": key,
        "code_version": code_version(),
        "k": k,
        "price": price.copy(),
        "values": values[:k].copy(),
        "flags": flags[:k].copy(),
        "iterations": iterations[:k].copy(),
        "offers": offers[:k].copy(),
        "buildings": groups.checkpoint_states(),
    }


def _restore_envelope(checkpoint: dict[str, Any], envelope: FloatArray) -> int:
    """Restore the envelope's rows (k, D, 3) from ``checkpoint`` into ``envelope``; k."""
    k = int(checkpoint["k"])
    envelope[:k] = checkpoint["envelope"]
    return k


def _restore(
    checkpoint: dict[str, Any],
    groups: Any,
    values: FloatArray,
    flags: Any,
    iterations: Any,
    offers: FloatArray,
) -> tuple[int, FloatArray]:
    """Restore the buildings and the tables from ``checkpoint``; (step, feeder price)."""
    groups.set_states(checkpoint["buildings"])
    k = int(checkpoint["k"])
    offers[:k] = checkpoint["offers"]
    values[:k], flags[:k], iterations[:k] = (
        checkpoint["values"],
        checkpoint["flags"],
        checkpoint["iterations"],
    )
    return k, checkpoint["price"].copy()


def _recover(
    exc: Exception, k: int, client: Any, groups: Any, checkpoint: dict[str, Any]
) -> tuple[int, FloatArray]:
    """Rebuild the building groups after a lost worker; (step, price) of the checkpoint."""
    log.warning("fleet step %d failed (%s); restoring from step %d", k, exc, checkpoint["k"])
    for attempt in range(1, BUILD_ATTEMPTS + 1):
        client.wait_for_workers(1, timeout=120)
        try:
            groups.build()
            break
        except TimeoutError:  # the lost worker was still listed: ask again
            if attempt == BUILD_ATTEMPTS:
                raise
            log.warning("rebuilding the groups timed out (attempt %d); again", attempt)
            time.sleep(1.0)
    groups.set_states(checkpoint["buildings"])
    return int(checkpoint["k"]), checkpoint["price"].copy()


def _results_frame(
    values: FloatArray, flags: Any, iterations: Any, index: pd.DatetimeIndex
) -> pd.DataFrame:
    """The fleet's per-step results table."""
    frame = pd.DataFrame(values, index=index, columns=list(FLOAT_COLUMNS))
    frame.index.name = schema.INDEX_NAME
    for j, name in enumerate(schema.FLEET_FLAG_COLUMNS):
        frame[name] = flags[:, j]
    frame[schema.FLEET_ITERATIONS_COLUMN] = iterations
    return frame


def _matching_checkpoint(path: Path, key: str) -> dict[str, Any] | None:
    """The checkpoint at ``path`` if it is of the same inputs (refused if of other code)."""
    if not path.is_file():
        return None
    state: dict[str, Any] = load_checkpoint(path)
    if state["config_hash"] != key:
        return None
    check_checkpoint_code(state, path)
    return state


def _coordinate_step(
    groups: Any,
    feeder_kw: FloatArray,
    options: CoordinationOptions,
    price: FloatArray,
    continuing: bool = False,
) -> tuple[Any, FloatArray]:
    """One step's coordination over all buildings: (its result, minimum powers (B, N)).
    ``continuing``: an accepted IL activation goes on (locked buildings keep their power)."""
    groups.check_alive()
    p_min, p_max, energy = groups.stacked("begin_step", continuing)
    return coordinate_ranges(groups, (p_min, p_max, energy), feeder_kw, options, price), p_min


@dataclass(frozen=True)
class _StepOutcome:
    """One fleet step: the coordination, the minimum powers (B, N) [kW], the buildings'
    rows ((B,) arrays), the fleet's offer and bid, every building's metered-visible offer
    (B,) [kW], whether IL was activated, and the coordination's wall time [s]."""

    result: CoordinationResult
    p_min: FloatArray
    merged: dict[str, FloatArray]
    offer: FleetOffer
    visible_kw: FloatArray
    activated: bool
    coordination_s: float
    envelope_kw: FloatArray
    """(D, 3) the fleet's flexibility envelope at the step's start: the least and the most
    power [kW] its comfort-keeping buildings hold for each of
    :data:`hvacflex.fleet.envelope.DURATIONS_MIN`, and how many they are
    (:func:`hvacflex.fleet.envelope.fleet_envelope`)."""


@dataclass(frozen=True)
class _StepContext:
    """What one fleet step needs to know of the run so far.

    Attributes
    ----------
    scheduled : the grid operator activates IL in this period.
    before : (it did in the last period, the fleet was activated then); None at the start.
    min_bid_kw : the market's minimum bid [kW].
    limit_kw : the feeder limit in force in the period [kW] (inf: none), which the fleet's
        guard holds the predicted power to; the plans hold to it × (1 − ``feeder_margin``),
        so the margin is headroom for the power model's error, not a lower limit.
    envelope_steps : the holds of the flexibility envelope [periods] (:func:`envelope_steps`;
        empty: the envelope is off).
    """

    scheduled: bool
    before: tuple[bool, bool] | None
    min_bid_kw: float
    limit_kw: float
    envelope_steps: tuple[int, ...] = ()


def envelope_steps(fleet: Fleet) -> tuple[int, ...]:
    """The holds of the fleet's flexibility envelope [periods] (:data:`DURATIONS_MIN`), none
    where the fleet file switches it off (``envelope = false``: no ``envelope.csv``)."""
    return duration_steps(DT_H) if fleet.spec.envelope else ()


def _context(
    k: int,
    schedule: Any,
    flags: Any,
    min_bid_kw: float,
    limit_kw: float,
    holds: tuple[int, ...] = (),
) -> _StepContext:
    """The :class:`_StepContext` of step ``k`` from the flags of the steps before
    (``limit_kw``: the limit in force in period k [kW]; ``holds``: the envelope's,
    :func:`envelope_steps`)."""
    before = None if k == 0 else (bool(schedule[k - 1]), bool(flags[k - 1, ACTIVATED]))
    return _StepContext(bool(schedule[k]), before, min_bid_kw, limit_kw, holds)


def _fleet_step(
    groups: Any,
    feeder_kw: FloatArray,
    options: CoordinationOptions,
    price: FloatArray,
    context: _StepContext,
) -> _StepOutcome:
    """Coordinate, bid, activate and advance one step.

    The fleet offers Σ of its buildings' metered-visible offers (each staged first-period
    offer cut to what the building's own meter would show,
    :func:`hvacflex.fleet.aggregation.visible_offers_kw`) and bids it when it clears the
    minimum bid. An activation that starts in this period reaches the fleet only if its
    bid is accepted; one going on keeps the fleet activated as it was at its start (locked
    buildings keep their locked power, :meth:`BuildingAgent.begin_step`)."""
    before = context.before
    continuing = context.scheduled and before is not None and before[0]
    locked = continuing and before is not None and before[1]
    tick = time.perf_counter()
    result, p_min = _coordinate_step(groups, feeder_kw, options, price, locked)
    coordinated = time.perf_counter() - tick
    offer, curtailed, baseline, envelope = groups.stacked("staged_offer_kw", context.envelope_steps)
    visible = visible_offers_kw(offer, curtailed, baseline)
    fleet_offer = aggregate_offer(visible, context.min_bid_kw)
    activated = locked if continuing else context.scheduled and fleet_offer.accepted
    rows = guarded_advance(groups, context.limit_kw, activated)
    merged = {key_: np.concatenate([r[key_] for r in rows]) for key_ in rows[0]}
    return _StepOutcome(
        result,
        p_min,
        merged,
        fleet_offer,
        visible,
        activated,
        coordinated,
        fleet_envelope(envelope),
    )


def guarded_advance(groups: Any, limit_kw: float, activated: bool) -> list[Any]:
    """Advance every group's buildings by their staged plans, the fleet's predicted power in
    the period held to ``limit_kw`` [kW] (the limit in force; inf: no guard) by the fleet's
    guard (:mod:`hvacflex.fleet.guard`: the buildings report their predicted powers, each
    gets a cap, the excess over the limit shed where comfort allows first); the groups'
    rows."""
    if not np.isfinite(limit_kw):
        rows: list[Any] = groups.broadcast("advance", activated)
        return rows
    power, free, minimum, room = groups.stacked("guard_view")
    caps = guard_caps_kw(power, free, minimum, room, limit_kw)
    rows = groups.call("advance", [activated] * len(groups.groups), groups.split(caps))
    return rows


def coordinate_ranges(
    groups: Any,
    ranges: tuple[FloatArray, FloatArray, FloatArray],
    feeder_kw: FloatArray,
    options: CoordinationOptions,
    price: FloatArray,
) -> CoordinationResult:
    """Coordinate the step the groups have begun, by ``options.scheme``.

    ``ranges`` = (P_min, P_max (B, N) [kW], energy prices (B, N) [SGD/MWh]) from the groups'
    ``begin_step``; ``feeder_kw`` (N,) the planning limit; ``price`` (N,) the previous
    step's feeder prices, shifted (the price scheme starts from them).
    """
    p_min, p_max, energy = ranges

    def solve_all(lam: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        power, cost, lagrangian = groups.stacked("solve", lam)
        return np.clip(power, p_min, p_max), cost, lagrangian

    order = np.argsort(np.concatenate(groups.indices))
    values_after: list[FloatArray] = []  # the cap values after the last finalize_all

    def finalize_all(
        lam: FloatArray, caps: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        parts = groups.call("finalize_with_values", [lam] * len(groups.groups), groups.split(caps))
        power, cost, lagrangian, values = (
            np.concatenate([p[j] for p in parts])[order] for j in range(4)
        )
        values_after[:] = [values]
        # a building locked to its event plan draws its locked power (P_min₀ = P_max₀)
        return np.clip(power, p_min, p_max), cost, lagrangian

    def cap_values_all() -> FloatArray:
        # the schemes ask for the values right after a finalize_all: they came with it
        return values_after[0]

    if options.scheme != "prices":
        return coordinate_caps(
            solve_all,
            finalize_all,
            cap_values_all,
            feeder_kw,
            p_min,
            p_max,
            DT_H,
            options,
            initial_price=price,
        )
    return coordinate(
        solve_all,
        finalize_all,
        feeder_kw,
        p_min,
        p_max,
        energy,
        DT_H,
        options,
        price,
        cap_values_all=cap_values_all,
    )


def _collect_buildings(
    groups: Any, fleet: Any, values: FloatArray, col: dict[str, int]
) -> pd.DataFrame:
    """Every building's results in long format; fills the fleet's price and comfort columns."""
    frames = groups.broadcast("frames")
    order = np.concatenate(groups.indices)
    building_frames = [f for part in frames for f in part]
    by_index = dict(zip(order.tolist(), building_frames, strict=True))
    n = len(fleet.buildings)
    long: pd.DataFrame = pd.concat(
        [by_index[i].assign(**{schema.BUILDING_COLUMN: fleet.buildings[i].name}) for i in range(n)]
    )
    values[:, col["energy_price_sgd_per_mwh"]] = by_index[0]["energy_price_sgd_per_mwh"]
    values[:, col["reserve_price_sgd_per_mwh"]] = by_index[0]["reserve_price_sgd_per_mwh"]
    values[:, col["discomfort_kelvin_hours"]] = sum(
        kpis.step_discomfort_kelvin_hours(by_index[i]).to_numpy() for i in range(n)
    )
    return long


def _start_dask(scheduler: str | None, workers: int | None) -> tuple[Any, Any, Any]:
    """(cluster we started, client to use, client we own) — all None for an in-process run."""
    if workers == 0 and scheduler is None:
        return None, None, None
    import dask.distributed

    from hvacflex.sim.sweep import quiet_dask_logs, start_local_dask

    distributed: Any = dask.distributed  # untyped package
    quiet_dask_logs()
    if scheduler is None:
        cluster, client = start_local_dask(workers or 1)
        return cluster, client, client
    existing = _existing_client(scheduler)
    if existing is not None:
        return None, existing, None
    client = distributed.Client(scheduler)
    return None, client, client


def _record_step(
    row: FloatArray, col: dict[str, int], outcome: _StepOutcome, limit_kw: float
) -> tuple[bool, bool, bool]:
    """Fill one results row from the buildings' rows; the flags (bid accepted, feeder
    infeasible, IL activated)."""
    merged, result = outcome.merged, outcome.result
    reserve = float(np.sum(merged["reserve_kw"]))
    accepted = outcome.offer.accepted
    row[col["planned_fleet_power_kw"]] = float(np.sum(merged["planned_power_kw"]))
    row[col["fleet_power_kw"]] = float(np.sum(merged["power_kw"]))
    row[col["feeder_limit_kw"]] = limit_kw
    row[col["fleet_reserve_kw"]] = reserve
    row[col["fleet_offer_kw"]] = outcome.offer.offer_kw
    row[col["fleet_bid_kw"]] = outcome.offer.bid_kw
    row[col["settled_reserve_kw"]] = outcome.offer.bid_kw if accepted else 0.0
    row[col["fleet_min_power_kw"]] = float(outcome.p_min[:, 0].sum())
    row[col["feeder_excess_kw"]] = float(result.excess_kw[0])
    row[col["feeder_price_sgd_per_mwh"]] = float(result.price_sgd_per_mwh[0])
    row[col["coordination_gap"]] = result.gap
    row[col["coordination_time_s"]] = outcome.coordination_s
    return accepted, bool(result.infeasible[0]), outcome.activated


def _settle_buildings(
    frame: pd.DataFrame, long: pd.DataFrame, fleet: Any, offers: FloatArray, rule: str
) -> pd.DataFrame:
    """Dispatch the accepted, activated bids to the buildings by their visible offers
    (steps, B) [kW] and settle each on its own meter (:mod:`hvacflex.fleet.aggregation`);
    fills ``frame``'s ``il_dispatched_kw`` and ``il_delivered_buildings_kw`` (Σ over the
    buildings) and returns the long :data:`OFFERS_FILE` table."""
    names = [b.name for b in fleet.buildings]
    power = (
        long.set_index(schema.BUILDING_COLUMN, append=True)["power_kw"]
        .unstack(schema.BUILDING_COLUMN)
        .reindex(index=frame.index, columns=names)
        .to_numpy(float)
    )
    activated = frame["il_activated"].to_numpy(bool)
    dispatched = dispatched_kw(offers, frame["bid_accepted"].to_numpy(bool), activated)
    delivered = building_delivery_kw(
        power, dispatched, activated, pd.DatetimeIndex(frame.index), rule
    )
    frame["il_dispatched_kw"] = dispatched.sum(axis=1)
    frame["il_delivered_buildings_kw"] = delivered.sum(axis=1)
    return offers_table(pd.DatetimeIndex(frame.index), names, offers, dispatched, delivered)


def _write_outputs(
    out: Path,
    tables: tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame],
    fleet: Any,
    key: str,
    recoveries: int,
) -> dict[str, float]:
    """Results, per-building results, offers, summary and per-building table (``tables``:
    the fleet's results, the buildings' in long format, the offers'); the summary."""
    from hvacflex.fleet.kpi import building_table, fleet_summary

    frame, long, offers = tables

    metadata = {
        schema.META_FLEET: fleet.name,
        schema.META_RUN_KEY: key,
        schema.META_VERSION: code_version(),
    }
    schema.write_results(frame, out / schema.RESULTS_FILENAME, metadata)
    long.index.name = schema.INDEX_NAME
    schema.write_results(long, out / schema.BUILDINGS_FILENAME, metadata)
    offers.to_csv(out / OFFERS_FILE, index=False)
    summary = fleet_summary(frame, long, min_bid_kw=1000.0 * fleet.spec.min_bid_mw)
    summary["recoveries"] = float(recoveries)
    write_summary(out / SUMMARY_FILE, summary)
    building_table(long).to_csv(out / "buildings_summary.csv", index_label="building")
    return summary


def _existing_client(address: str) -> Any | None:
    """This process's client of the scheduler at ``address``, if there is one (actors are
    bound to one client: a second client in the same process would not see their results)."""
    import dask.distributed

    distributed: Any = dask.distributed
    try:
        client = distributed.default_client()
    except ValueError:
        return None
    return client if client.scheduler.address == address else None
