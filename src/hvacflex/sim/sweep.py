"""Sweeps: many independent closed-loop runs, on Dask or on local processes.

Each job is one :func:`~hvacflex.sim.run.run_simulation` in its own folder named after
the scenario and its configuration hash, so finished runs are re-used and an interrupted
sweep picks up where it stopped. With the ``dask`` extra installed, jobs run on a
``dask.distributed`` cluster: a ``LocalCluster`` of single-threaded worker processes on this
machine by default, or any scheduler given by address (``tcp://host:8786``). Without it they
run on a ``concurrent.futures`` pool of worker processes (one worker: in this process); a
scheduler address then needs the extra (:class:`~hvacflex.errors.MissingExtraError`). A job
that fails is reported with its error; the others still finish and are gathered into one
table.
"""

from __future__ import annotations

import itertools
import logging
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex.config import ScenarioConfig, with_overrides
from hvacflex.errors import ConfigError, InputError, has_extra, require_extra

JobCallback = Callable[["JobOutcome"], None]
_JobResult = tuple[dict[str, float], bool, float]
"""A finished job's KPIs, whether it was cached, and its CPU time [s]."""

_FEEDBACK_COST = 4.0
"""Cost of an affine-feedback MPC day relative to an open-loop one (the 2014 year: 63
against 15 CPU-min on the RC plant)."""
_RULE_BASED_COST = 0.05
"""Cost of a rule-based controller's day (no LP) relative to an open-loop MPC's (the 2014
year: five rule-based years in 184 CPU-s against ≈ 15 CPU-min for one MPC year)."""
_ENERGYPLUS_COST = 2.0
"""Cost of a day on EnergyPlus office5 relative to the RC plant (the 2014 year: 26–36
against 15–18 min wall for the same MPC)."""
_PEAK_PRICE_COST = 1.3
"""Cost of a day of an open-loop MPC that prices its peak (``peak_price_sgd_per_kw`` > 0)
relative to one that does not (the 2014 year on the RC plant, 2026-12-07: ``rmpc-ppp`` 75.3
against ``rmpc``'s 59.8 ms CPU per period). Not applied to affine feedback, whose peak-priced
year was the cheaper one (40 against 63 CPU-min, docs/explanation/reproduction.md)."""


def relative_cost(config: ScenarioConfig) -> float:
    """A run's expected machine time in open-loop-MPC days on the RC plant: what the sweep
    orders its jobs by, longest first, so a long run does not start last and hold the
    sweep's end (longest-processing-time scheduling)."""
    cost = config.days
    if config.controller.kind != "mpc":
        cost *= _RULE_BASED_COST
    elif config.controller.robust == "feedback":
        cost *= _FEEDBACK_COST  # measured with and without a peak price alike
    elif config.controller.peak_price_sgd_per_kw > 0:
        cost *= _PEAK_PRICE_COST
    if config.plant.kind == "energyplus":
        cost *= _ENERGYPLUS_COST
    return cost


@dataclass(frozen=True)
class JobOutcome:
    """What one sweep job returned: its KPIs, or its error."""

    label: str
    config_hash: str
    params: dict[str, Any]
    out_dir: str
    summary: dict[str, float] | None
    error: str | None
    cached: bool = False
    """True when the job re-used finished results of the same inputs and code."""
    cpu_s: float | None = None
    """CPU time of the process that ran the job, over the job [s]; None for a failed job.
    Every thread of that process counts: on a Dask scheduler whose workers run several
    threads, jobs running beside it in the same worker are counted too."""

    @property
    def ok(self) -> bool:
        return self.error is None


class SweepClock:
    """Elapsed time and ETA of a sweep, its jobs weighted by :func:`relative_cost`.

    ``clock = SweepClock(costs)``; ``clock.finished(cost, cached)`` as each job ends →
    (elapsed [s], ETA [s] or None). The ETA scales the elapsed time by the cost still to run
    over the cost run so far; re-used (cached) runs cost nothing, so before the first job
    that really ran there is no ETA (None).
    """

    def __init__(self, costs: Sequence[float]) -> None:
        self.remaining = float(sum(costs))
        self.ran = 0.0
        self.t0 = time.perf_counter()

    def finished(self, cost: float, cached: bool) -> tuple[float, float | None]:
        self.remaining = max(self.remaining - cost, 0.0)
        if not cached:
            self.ran += cost
        elapsed = time.perf_counter() - self.t0
        if self.remaining == 0.0:
            return elapsed, 0.0
        return elapsed, (elapsed * self.remaining / self.ran if self.ran > 0 else None)


def parse_param(text: str) -> tuple[str, list[Any]]:
    """``"peak_price_sgd_per_kw=0.5,1,2"`` → ``("peak_price_sgd_per_kw", [0.5, 1.0, 2.0])``."""
    if "=" not in text:
        raise ConfigError(
            "a sweep parameter needs the form NAME=V1,V2,...",
            field="--param",
            value=text,
            hint="e.g. --param peak_price_sgd_per_kw=0.5,1,2,5",
        )
    name, _, values = text.partition("=")
    parsed = [_parse_value(v.strip()) for v in values.split(",") if v.strip()]
    if not parsed:
        raise ConfigError("no values given", field=name, value=text)
    return name.strip(), parsed


def _parse_value(text: str) -> Any:
    lowered = text.lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def expand_grid(
    base: ScenarioConfig, params: Mapping[str, Sequence[Any]]
) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """Every combination of the parameter values applied to ``base`` (validated)."""
    names = list(params)
    jobs = []
    for values in itertools.product(*(params[n] for n in names)):
        overrides = dict(zip(names, values, strict=True))
        jobs.append((overrides, with_overrides(base, overrides)))
    return jobs


def run_dir(out_root: Path, config: ScenarioConfig) -> Path:
    """Folder of one run: ``<out_root>/runs/<name>-<config hash>``."""
    return out_root / "runs" / f"{config.name}-{config.config_hash()}"


def _run_job(config: ScenarioConfig, out_dir: str, fresh: bool = False) -> _JobResult:
    """Worker side of a job (module-level so it pickles): its KPIs, whether it was cached
    and the CPU time it took [s]."""
    from hvacflex.sim.run import run_simulation

    tick = time.process_time()
    result = run_simulation(config, out_dir, progress=False, resume=not fresh)
    return result.summary, result.cached, time.process_time() - tick


DASK_LOG_LEVEL = "error"
"""Level of Dask's own loggers in hvacflex runs: its warnings (ports, worker restarts that
hvacflex recovers from, long GC pauses) are not the user's business; errors still show."""


log = logging.getLogger(__name__)


def quiet_dask_logs() -> None:
    """Set Dask's ``distributed`` loggers to :data:`DASK_LOG_LEVEL`, here and (through the
    configuration a ``LocalCluster`` hands its workers) in the worker processes."""
    import dask

    dask.config.set({"logging": {"distributed": DASK_LOG_LEVEL}})
    logging.getLogger("distributed").setLevel(DASK_LOG_LEVEL.upper())


SILENCE_WORKERS_TIMEOUT_S = 10.0
"""How long :func:`close_dask` waits for the workers to silence their logs [s] (a worker
stuck in a long GC pause or gone half-way must not hang the end of a finished run)."""


def _silence_distributed() -> None:
    """In a worker process: Dask's ``distributed`` loggers to critical (the cluster closes)."""
    logging.getLogger("distributed").setLevel(logging.CRITICAL)


DASHBOARD_ADDRESS = ":0"
"""Where a local cluster's scheduler serves HTTP: any free port. (``None`` still serves on
8787 and warns "Port 8787 is already in use" when it is.)"""


def start_local_dask(n_workers: int) -> tuple[Any, Any]:
    """(cluster, client): a ``LocalCluster`` of ``n_workers`` single-threaded worker
    processes on this machine and a client of it. The scheduler's HTTP server (the
    dashboard, which nothing shows) takes a free port (:data:`DASHBOARD_ADDRESS`), so a busy
    8787 — another cluster, another user — raises no warning. The cluster is closed again if
    the client cannot connect, so no worker processes are left behind."""
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(  # type: ignore[no-untyped-call]
        n_workers=n_workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=DASHBOARD_ADDRESS,
    )
    try:
        return cluster, Client(cluster)  # type: ignore[no-untyped-call]
    except BaseException:
        cluster.close()
        raise


def close_dask(client: Any, cluster: Any | None) -> None:
    """Close ``client`` and, if hvacflex started it, ``cluster``.

    A worker whose heartbeat is in flight while the scheduler stops logs "Failed to
    communicate with scheduler during heartbeat", with tracebacks, at ERROR level. This
    happens on loaded machines, after every job has finished. So the workers of a cluster
    hvacflex owns are silenced first, waiting at most :data:`SILENCE_WORKERS_TIMEOUT_S`.
    """
    try:
        if cluster is not None:
            # ``callback_timeout`` bounds the wait of Dask's synchronous call (Client.sync)
            client.run(_silence_distributed, callback_timeout=SILENCE_WORKERS_TIMEOUT_S)
    except Exception:  # a worker gone or too slow to answer: closing goes on regardless
        log.debug("could not silence the workers' logs before closing", exc_info=True)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _submit_longest_first(
    client: Any, jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]], dirs: list[str], fresh: bool
) -> tuple[list[Any], dict[str, int]]:
    """Submit every job longest first (:func:`relative_cost`): in that order and with that
    priority, so neither a worker that takes the first task early nor the scheduler's FIFO
    reorders them. The futures, and each future's key → the job's position in ``jobs``."""
    costs = [relative_cost(cfg) for _, cfg in jobs]
    order = _longest_first(jobs)
    futures = [
        client.submit(
            _run_job,
            jobs[i][1],
            dirs[i],
            fresh,
            pure=False,
            key=f"hvacflex-{i}-{jobs[i][1].config_hash()}",
            priority=costs[i],
        )
        for i in order
    ]
    return futures, {future.key: i for i, future in zip(order, futures, strict=True)}


def run_sweep(
    jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]],
    out_root: str | Path,
    *,
    scheduler: str | None = None,
    n_workers: int = 2,
    on_done: JobCallback | None = None,
    fresh: bool = False,
    progress: bool = False,
    out_dirs: Sequence[Path] | None = None,
) -> list[JobOutcome]:
    """Run ``jobs`` (from :func:`expand_grid`) and return their outcomes in order.

    Parameters
    ----------
    jobs : (overrides, config) pairs.
    out_root : every run goes to ``run_dir(out_root, config)``.
    scheduler : address of a running ``dask.distributed`` scheduler (needs the ``dask``
        extra); None: ``n_workers`` single-threaded processes here — a Dask ``LocalCluster``
        with the ``dask`` extra, else a ``concurrent.futures`` process pool (one worker: this
        process).
    on_done : called with each outcome as it finishes (progress per job).
    fresh : ignore finished results and checkpoints in the run folders (simulate again).
    progress : show a progress bar over the jobs (done/total, elapsed, ETA, failures).
    out_dirs : the folder of each job, in the order of ``jobs`` (e.g. the stable names of
        :mod:`hvacflex.reproduce`); None: ``run_dir(out_root, config)``.

    Jobs start longest first (:func:`relative_cost`); the outcomes keep the order of ``jobs``.

    Raises
    ------
    MissingExtraError : a scheduler address without the ``dask`` extra.
    """
    from hvacflex.sim.progress import task_progress

    if scheduler is not None:
        require_extra("dask", "a sweep on a Dask scheduler (--scheduler)")
    root = Path(out_root)
    if out_dirs is not None and len(out_dirs) != len(jobs):
        raise InputError(
            "one folder per job is needed",
            field="out_dirs",
            value=len(out_dirs),
            hint=f"give {len(jobs)} folders, one for each job",
        )
    dirs = (
        [str(run_dir(root, cfg)) for _, cfg in jobs]
        if out_dirs is None
        else [str(folder) for folder in out_dirs]
    )
    if scheduler is None and not has_extra("dask"):
        finished = _run_local(jobs, dirs, fresh, n_workers)
    else:
        finished = _run_on_dask(jobs, dirs, fresh, scheduler, n_workers)
    outcomes: dict[int, JobOutcome] = {}
    failed = 0
    with task_progress(progress, "sweep", len(jobs)) as update:
        for i, result, error in finished:
            overrides, cfg = jobs[i]
            outcome = JobOutcome(
                label=cfg.name,
                config_hash=cfg.config_hash(),
                params=overrides,
                out_dir=dirs[i],
                summary=None if result is None else result[0],
                error=error,
                cached=False if result is None else result[1],
                cpu_s=None if result is None else result[2],
            )
            outcomes[i] = outcome
            failed += outcome.error is not None
            update(info=f"{failed} failed" if failed else "")
            if on_done is not None:
                on_done(outcome)
    return [outcomes[i] for i in range(len(jobs))]


def backend(scheduler: str | None, n_workers: int) -> str:
    """Where :func:`run_sweep` runs its jobs, in words (for a log line)."""
    if scheduler is not None:
        return f"Dask at {scheduler}"
    if has_extra("dask"):
        return f"Dask ({n_workers} workers)"
    if n_workers <= 1:
        return "this process"
    return f"{n_workers} local processes"


_Finished = Iterator[tuple[int, _JobResult | None, str | None]]
"""(the job's position, its (KPIs, cached, CPU [s]) or None, its error line or None), as jobs
finish."""


def _error_line(exc: BaseException) -> str:
    return "".join(traceback.format_exception_only(type(exc), exc)).strip()


def _longest_first(jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]]) -> list[int]:
    """The jobs' positions, longest first (:func:`relative_cost`)."""
    costs = [relative_cost(cfg) for _, cfg in jobs]
    return sorted(range(len(jobs)), key=lambda i: -costs[i])


def _run_local(
    jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]],
    dirs: list[str],
    fresh: bool,
    n_workers: int,
) -> _Finished:
    """The jobs without Dask: in this process (one worker) or on a ``concurrent.futures``
    pool of ``n_workers`` processes, submitted longest first."""
    order = _longest_first(jobs)
    if n_workers <= 1:
        for i in order:
            try:
                yield i, _run_job(jobs[i][1], dirs[i], fresh), None
            except Exception as exc:  # a failing job must not lose the others
                yield i, None, _error_line(exc)
        return
    with ProcessPoolExecutor(max_workers=n_workers) as pool:
        position: dict[Future[_JobResult], int] = {
            pool.submit(_run_job, jobs[i][1], dirs[i], fresh): i for i in order
        }
        for future in as_completed(position):
            try:
                yield position[future], future.result(), None
            except Exception as exc:
                yield position[future], None, _error_line(exc)


def _run_on_dask(
    jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]],
    dirs: list[str],
    fresh: bool,
    scheduler: str | None,
    n_workers: int,
) -> _Finished:
    """The jobs on Dask: a ``LocalCluster`` of ``n_workers`` processes here, or the
    scheduler at ``scheduler``."""
    from dask.distributed import Client
    from dask.distributed import as_completed as dask_completed

    quiet_dask_logs()
    cluster = None
    if scheduler is None:
        cluster, client = start_local_dask(n_workers)
    else:
        client = Client(scheduler)  # type: ignore[no-untyped-call]
    try:
        futures, position = _submit_longest_first(client, jobs, dirs, fresh)
        for future in dask_completed(futures):  # type: ignore[no-untyped-call]
            try:
                yield position[future.key], future.result(), None
            except Exception as exc:  # a failing job must not lose the others
                yield position[future.key], None, _error_line(exc)
    finally:
        close_dask(client, cluster)


def outcomes_table(outcomes: Sequence[JobOutcome]) -> pd.DataFrame:
    """One row per job: its parameters, its KPIs (or its error)."""
    rows = []
    for outcome in outcomes:
        row: dict[str, Any] = {"label": outcome.label, **outcome.params}
        row["status"] = "ok" if outcome.ok else "failed"
        row["error"] = outcome.error or ""
        row["cached"] = outcome.cached
        row.update(outcome.summary or {})
        row["out_dir"] = outcome.out_dir
        rows.append(row)
    return pd.DataFrame(rows)


SCHEDULER_CONNECT_TIMEOUT_S = 5.0
"""How long :func:`check_scheduler` waits for a TCP connection to the scheduler [s]."""


def check_scheduler(address: str, field: str = "--scheduler") -> None:
    """Refuse, before any work, a Dask scheduler address that is malformed or that nothing
    listens on (a TCP address: ``tcp://host:port`` or ``host:port``); Dask itself would fail
    only after a 30-s timeout, with a traceback.

    Raises
    ------
    InputError
        Naming ``field``, the address and why, with a hint.
    """
    import socket

    require_extra("dask", f"a Dask scheduler ({field})")
    from distributed.comm.addressing import parse_address, parse_host_port

    hint = "give the address of a running scheduler, e.g. tcp://127.0.0.1:8786 (dask scheduler)"
    try:
        protocol, location = parse_address(address)
        if protocol not in ("tcp", "tls"):
            return  # inproc://, ucx://…: left to Dask
        host, port = parse_host_port(location)
    except ValueError as exc:
        raise InputError(
            f"not a scheduler address ({exc})", field=field, value=address, hint=hint
        ) from None
    try:
        with socket.create_connection((host, port), timeout=SCHEDULER_CONNECT_TIMEOUT_S):
            pass
    except OSError as exc:
        raise InputError(
            f"no scheduler answers there ({exc.strerror or type(exc).__name__})",
            field=field,
            value=address,
            hint=hint,
        ) from None
