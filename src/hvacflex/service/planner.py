"""Planning off the request path: a measurement is acknowledged once stored, and planned by
a worker.

Where a plan is made is the ``plans`` given: the :class:`~hvacflex.service.runtime.Runtime`
itself (threads of the server process: the in-process default, and an SQLite database in
memory), or :class:`~hvacflex.service.plan_processes.PlanProcesses` (``hvacflex serve``'s
default): worker processes, each building pinned to one, which keep its warm controller.
In threads, a plan's LP construction in Python competes with the request threads for the
GIL and the cores (issue 56: reads p99 0.4–2.8 s while 10 buildings planned); in processes
a request waits for neither. The planner's threads then only wait for the processes.

The rules that keep the loop's semantics of a synchronous service:

* **One queue per building, first in first out**; buildings are planned in parallel on a
  pool of ``workers`` threads, but a building's jobs never overtake each other (its
  controller is stepped forward in order).
* **A measurement is acknowledged with the revision its plan will have** (202). The
  revision is reserved when it is acknowledged; no other job stores a plan for that
  building while one of its measurements waits: a boundary or activation job that meets a
  waiting measurement goes back to the end of the queue, behind it — as it was when the
  measurement was planned on its request.
* **The server keeps each building's latest plan in memory**
  (:class:`~hvacflex.service.plan_cache.LatestPlans`, ``Planner.latest_plans``): a plan is
  offered there when it comes back, before its waiters get it, so reads are answered
  without the database and never show a plan older than one already handed out.
* **Restart safety**: the measurement is committed before it is acknowledged; a measurement
  without its plan (trigger ``measurement``) is queued again when the service starts
  (:meth:`Planner.recover`), so an acknowledged measurement is planned after a crash.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import datetime
from functools import partial
from typing import Any, Protocol

from sqlalchemy import func, select

from hvacflex.service.db import Measurement, PlanRow
from hvacflex.service.plan_cache import LatestPlans
from hvacflex.service.runtime import Runtime
from hvacflex.service.schemas import MeasurementIn

DEFAULT_PLAN_WORKERS = 2
"""Planning threads: one per core of a small server (a solve releases the GIL)."""
OPERATOR_WAIT_S = 300.0
"""How long an operator's clock or activation request waits for the plans it triggers [s]
(a plan's solve is capped at ``MAX_TIME_LIMIT_S``; this leaves room for a queue)."""

LOG = logging.getLogger("hvacflex.service.planner")

Plan = dict[str, Any]


class PlanJobs(Protocol):
    """Where plans are made: the jobs of :class:`~hvacflex.service.runtime.Runtime` (in
    threads of this process) or of :class:`~hvacflex.service.plan_processes.PlanProcesses`
    (in worker processes)."""

    def plan_measurement(self, building_id: str, k: int, revision: int) -> Plan: ...

    def boundary_building(self, building_id: str, time: datetime) -> Plan | None: ...

    def activation_building(self, building_id: str) -> Plan | None: ...


@dataclass(frozen=True)
class Ack:
    """A measurement's acknowledgement: its period and the revision of its plan.

    ``plan`` is the stored plan when the measurement was planned before (a repeated body);
    otherwise ``future`` resolves to the plan once the worker has stored it.
    """

    building_id: str
    period: int
    time: str
    revision: int
    new: bool
    plan: Plan | None = None
    future: Future[Plan] | None = field(default=None, compare=False)

    def wait(self, timeout_s: float) -> Plan | None:
        """The plan, waiting up to ``timeout_s`` [s] for it (None when not done by then).

        Raises
        ------
        Exception : whatever planning raised (an input error maps to a 4xx).
        """
        if self.plan is not None:
            return self.plan
        assert self.future is not None
        if timeout_s <= 0 and not self.future.done():
            return None
        try:
            return self.future.result(timeout=max(timeout_s, 0.0))
        except TimeoutError:
            return None


@dataclass
class _Job:
    work: Callable[[], Any]
    future: Future[Any]
    measurement: tuple[str, int] | None = None


class Planner:
    """The service's planning workers over a :class:`~hvacflex.service.runtime.Runtime`."""

    def __init__(
        self,
        runtime: Runtime,
        workers: int = DEFAULT_PLAN_WORKERS,
        plans: PlanJobs | None = None,
    ) -> None:
        self.runtime = runtime
        self.plans: PlanJobs = runtime if plans is None else plans
        """Where the jobs run (the runtime itself: threads of this process)."""
        self._pool = ThreadPoolExecutor(max(1, workers), thread_name_prefix="hvacflex-plan")
        self._lock = threading.Lock()
        self._queues: dict[str, deque[_Job]] = {}
        self._draining: set[str] = set()
        self._waiting: dict[tuple[str, int], int] = {}
        """Measurements acknowledged and not yet planned: (building, period) → revision."""
        self._busy_other: set[str] = set()
        """Buildings running a boundary or activation job now (it may store one plan)."""
        self._running_futures: dict[tuple[str, int], Future[Plan]] = {}
        """The futures of the measurements being planned now."""
        self.latest_plans = LatestPlans()
        """Each building's latest plan, as every job's plan comes back (the reads' copy)."""

    # -- measurements -------------------------------------------------------------------
    def acknowledge(self, building_id: str, body: MeasurementIn) -> Ack:
        """Store the measurement (committed before this returns) and queue its plan.

        Raises
        ------
        InputError, ConflictError : as :meth:`Runtime.store_measurement`.
        """
        with self._lock:
            waiting = [k for (b, k) in self._waiting if b == building_id]
        stored = self.runtime.store_measurement(
            building_id, body, not_before=max(waiting, default=-1)
        )
        k, time = stored.period, stored.time
        with self._lock:
            revision = self._waiting.get((building_id, k))
            if revision is not None:  # acknowledged before, still waiting
                return Ack(
                    building_id, k, time, revision, False, future=self._future_of(k, building_id)
                )
            plan = stored.plan
            if plan is None and not stored.new:  # planned since it was read, or failed
                with self.runtime.sessions() as session:
                    plan = self.runtime.own_plan(session, building_id, k)
            if plan is not None:
                return Ack(building_id, k, time, int(plan["revision"]), False, plan=plan)
            future, revision = self._queue_measurement(building_id, k)
        return Ack(building_id, k, time, revision, stored.new, future=future)

    def _queue_measurement(self, building_id: str, k: int) -> tuple[Future[Plan], int]:
        """Reserve the plan's revision and queue the plan (the caller holds ``_lock``)."""
        with self.runtime.sessions() as session:
            latest = session.scalar(
                select(func.max(PlanRow.revision)).where(
                    PlanRow.building_id == building_id, PlanRow.period == k
                )
            )
        # a boundary or activation job running now may still store one plan of period k
        revision = (latest or 0) + 1 + (building_id in self._busy_other)
        self._waiting[(building_id, k)] = revision

        def work() -> Plan:
            return self.plans.plan_measurement(building_id, k, revision)

        job = _Job(work, Future(), measurement=(building_id, k))
        self._enqueue(building_id, job)
        return job.future, revision

    def _future_of(self, k: int, building_id: str) -> Future[Plan]:
        for job in self._queues.get(building_id, ()):
            if job.measurement == (building_id, k):
                return job.future
        running: Future[Plan] = self._running_futures[(building_id, k)]
        return running

    # -- operator triggers --------------------------------------------------------------
    def boundary(self, time: datetime) -> list[Plan]:
        """The 30-min boundary trigger (:meth:`Runtime.boundary_building`) for every
        building, planned by the workers; waits for the plans."""
        with self.runtime.sessions() as session:
            ids = self.runtime.building_ids(session)
        futures = [self.submit(b, partial(self.plans.boundary_building, b, time)) for b in ids]
        return _results(futures)

    def activation(self, building_ids: list[str]) -> list[Plan]:
        """Re-plan the buildings whose activation state changed
        (:meth:`Runtime.activation_building`); waits for the plans."""
        futures = [self.submit(b, partial(self.plans.activation_building, b)) for b in building_ids]
        return _results(futures)

    def submit(self, building_id: str, work: Callable[[], Plan | None]) -> Future[Plan | None]:
        """Run ``work`` (a boundary or activation job) in the building's queue."""
        job = _Job(work, Future())
        with self._lock:
            self._enqueue(building_id, job)
        return job.future

    # -- start and stop -----------------------------------------------------------------
    def recover(self) -> int:
        """Queue every stored measurement that has no plan of its own yet (a crash between
        acknowledgement and plan); returns how many."""
        with self.runtime.sessions() as session:
            planned = (
                select(PlanRow.id)
                .where(
                    PlanRow.building_id == Measurement.building_id,
                    PlanRow.period == Measurement.period,
                    PlanRow.trigger == "measurement",
                )
                .exists()
            )
            rows = session.execute(
                select(Measurement.building_id, Measurement.period)
                .where(~planned)
                .order_by(Measurement.building_id, Measurement.period)
            ).all()
        with self._lock:
            for building_id, k in rows:
                self._queue_measurement(building_id, int(k))
        if rows:
            LOG.info("queued %d measurements acknowledged before the restart", len(rows))
        return len(rows)

    def shutdown(self) -> None:
        """Stop taking jobs; jobs not started stay in the database and are recovered."""
        self._pool.shutdown(wait=True, cancel_futures=True)
        stop = getattr(self.plans, "shutdown", None)
        if self.plans is not self.runtime and stop is not None:
            stop()

    # -- the queues ---------------------------------------------------------------------
    def _enqueue(self, building_id: str, job: _Job) -> None:
        """Append a job (the caller holds ``_lock``) and start the building's drain."""
        self._queues.setdefault(building_id, deque()).append(job)
        if building_id not in self._draining:
            self._draining.add(building_id)
            self._pool.submit(self._drain, building_id)

    def _drain(self, building_id: str) -> None:
        """Run the building's jobs in order until its queue is empty."""
        while True:
            with self._lock:
                queue = self._queues.get(building_id)
                if not queue:
                    self._draining.discard(building_id)
                    return
                job = queue.popleft()
                if job.measurement is None:
                    if any(b == building_id for (b, _) in self._waiting):
                        queue.append(job)  # behind the waiting measurement(s)
                        continue
                    self._busy_other.add(building_id)
                else:
                    self._running_futures[job.measurement] = job.future
            self._run(building_id, job)

    def _run(self, building_id: str, job: _Job) -> None:
        try:
            result = job.work()
        except BaseException as exc:  # the waiter gets the error; the queue goes on
            if job.measurement is not None:
                LOG.exception("planning %s failed", job.measurement)
            self.latest_plans.forget(building_id)  # its plan may be stored or not
            self._finish(building_id, job)
            job.future.set_exception(exc)
            return
        if result is not None:  # committed: the reads' copy before any waiter has it
            self._offer(building_id, result)
        self._finish(building_id, job)
        job.future.set_result(result)

    def _offer(self, building_id: str, plan: Plan) -> None:
        """Keep ``plan`` as the building's latest; a plan the reads' copy cannot take (it
        is stored: the database answers) drops the building's copy instead."""
        try:
            self.latest_plans.offer(building_id, plan)
        except Exception:
            LOG.exception("the plan of %s not kept in memory: reads use the database", building_id)
            self.latest_plans.forget(building_id)

    def _finish(self, building_id: str, job: _Job) -> None:
        with self._lock:
            if job.measurement is None:
                self._busy_other.discard(building_id)
            else:
                self._waiting.pop(job.measurement, None)
                self._running_futures.pop(job.measurement, None)


def _results(futures: list[Future[Plan | None]]) -> list[Plan]:
    """The plans the jobs made, in order (jobs that planned nothing left out)."""
    plans = [f.result(timeout=OPERATOR_WAIT_S) for f in futures]
    return [p for p in plans if p is not None]
