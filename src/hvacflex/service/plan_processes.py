"""Planning in worker processes, so that requests never wait behind a solve.

A plan builds its LP in Python and solves it in HiGHS; in the server's process both compete
with the request threads for the GIL and the cores (issue 56: reads p99 0.4–2.8 s while 10
buildings planned). :class:`PlanProcesses` runs the plans in ``processes`` worker
processes instead: the server process only stores measurements, answers reads and queues
plans (:class:`~hvacflex.service.planner.Planner`, unchanged: one queue per building, its
jobs in order).

* **Each building is pinned to one process** (the least loaded when the building is first
  planned), which keeps the building's warm controller in memory between periods — the
  HiGHS session, its basis, the previous plan, the filter and the IL event state — exactly
  as the server process did. A process rebuilds a building from the database on its first
  plan (:meth:`Runtime.get <hvacflex.service.runtime.Runtime.get>`: the stored controller
  state), so a process that died is replaced and continues from the last stored plan.
* **The database is the one channel of data**: a job names the building and the period; the
  process reads the measurement, plans, and commits the plan and the controller state in one
  transaction, as the server did; only the plan (a JSON-able dict) comes back.
* **Planning yields to requests**: the processes run at a lower priority (``niceness``,
  default :data:`PLAN_NICENESS`), so on a busy machine the server's requests get the cores
  first. Under Linux's autogroup scheduling a niceness counts only against the processes of
  the same session — the server's own threads — which is the competition that matters.
* A process exits when the server process does (even after ``kill -9``: it watches its
  parent), so nothing plans behind a restarted server.

An SQLite database in memory cannot be shared between processes: ``processes`` = 0 (or such
a database) plans in threads of the server process (:class:`Runtime` itself runs the jobs).
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import pickle
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from datetime import datetime
from typing import Any

from hvacflex.service.db import make_engine, session_factory, sqlite_file
from hvacflex.service.runtime import Runtime

PLAN_NICENESS = 19
"""How much lower the planning processes' CPU priority is than the server's (``nice``, by
default the lowest): a read waits for no solve. Measured (docs/reference/performance.md):
with 5, reads p99 was several times the 50 ms target while 10 buildings planned."""
MAX_NICENESS = 19
"""The lowest priority a process can take (``nice`` 19)."""
PARENT_POLL_S = 0.2
"""How often a planning process checks that the server process still runs [s]."""
START_TIMEOUT_S = 120.0
"""How long :meth:`PlanProcesses.start` waits for the processes to be ready [s]."""

LOG = logging.getLogger("hvacflex.service.plan_processes")

Plan = dict[str, Any]

_RUNTIME: Runtime | None = None
"""The planning process's runtime (its buildings' warm controllers)."""


def shares_processes(db_url: str) -> bool:
    """Whether several processes can use the database of ``db_url`` (not SQLite in memory)."""
    return not db_url.startswith("sqlite") or sqlite_file(db_url) is not None


def _start_process(db_url: str, live: bool, parent_pid: int, niceness: int) -> None:
    """A planning process's start: ``niceness`` lower priority, its own engine, the parent
    watched."""
    global _RUNTIME
    try:
        os.nice(niceness)
    except OSError:  # pragma: no cover - not permitted here: plan at the same priority
        pass
    _RUNTIME = Runtime(session_factory(make_engine(db_url)), live=live)

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(PARENT_POLL_S)
        os._exit(0)  # the server is gone: plan nothing behind its back

    threading.Thread(target=watch, name="hvacflex-parent-watch", daemon=True).start()


def _ready() -> tuple[int, int]:
    """The planning process's id and its niceness (it has started)."""
    return os.getpid(), os.nice(0)


def _run(kind: str, building_id: str, args: tuple[Any, ...]) -> Plan | None:
    """Run one job of ``kind`` in the planning process (a :class:`Runtime` method); an
    error that cannot travel back to the server is replaced by a ``RuntimeError`` with its
    text."""
    assert _RUNTIME is not None, "not a planning process"
    methods: dict[str, Callable[..., Plan | None]] = {
        "measurement": _RUNTIME.plan_measurement,
        "boundary": _RUNTIME.boundary_building,
        "activation": _RUNTIME.activation_building,
    }
    method = methods[kind]
    try:
        plan: Plan | None = method(building_id, *args)
    except Exception as exc:
        try:
            pickle.loads(pickle.dumps(exc))
        except Exception:
            raise RuntimeError(f"{type(exc).__name__}: {exc}") from None
        raise
    return plan


class PlanProcesses:
    """Runs the planner's jobs in ``processes`` worker processes (the same three methods
    as :class:`~hvacflex.service.runtime.Runtime`: the :class:`Planner`'s ``plans``), each
    ``niceness`` (0–19) lower in CPU priority than the server."""

    def __init__(
        self, db_url: str, processes: int, *, live: bool = False, niceness: int = PLAN_NICENESS
    ) -> None:
        if processes < 1:
            raise ValueError(f"processes must be ≥ 1, got {processes}")
        if not 0 <= niceness <= MAX_NICENESS:
            raise ValueError(f"niceness must be in [0, {MAX_NICENESS}], got {niceness}")
        self.db_url, self.live, self.niceness = db_url, live, niceness
        self._context = multiprocessing.get_context("spawn")
        self._lock = threading.Lock()
        self._pools = [self._new_pool() for _ in range(processes)]
        self._pinned: dict[str, int] = {}

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            1,
            mp_context=self._context,
            initializer=_start_process,
            initargs=(self.db_url, self.live, os.getpid(), self.niceness),
        )

    def start(self) -> list[tuple[int, int]]:
        """Start every process now (not at the first plan) and wait until each is ready;
        their process ids and niceness values."""
        futures = [pool.submit(_ready) for pool in self._pools]
        return [f.result(timeout=START_TIMEOUT_S) for f in futures]

    @property
    def processes(self) -> int:
        return len(self._pools)

    def process_of(self, building_id: str) -> int:
        """The index of the process the building is pinned to (the one with the fewest
        buildings when it is first asked for)."""
        with self._lock:
            index = self._pinned.get(building_id)
            if index is None:
                counts = [0] * len(self._pools)
                for pinned in self._pinned.values():
                    counts[pinned] += 1
                index = counts.index(min(counts))
                self._pinned[building_id] = index
            return index

    # -- the jobs (as Runtime's) --------------------------------------------------------
    def plan_measurement(self, building_id: str, k: int, revision: int) -> Plan:
        plan = self._call("measurement", building_id, (k, revision))
        assert plan is not None
        return plan

    def boundary_building(self, building_id: str, time: datetime) -> Plan | None:
        return self._call("boundary", building_id, (time,))

    def activation_building(self, building_id: str) -> Plan | None:
        return self._call("activation", building_id, ())

    def _call(self, kind: str, building_id: str, args: tuple[Any, ...]) -> Plan | None:
        """Run a job in the building's process and wait for it (the waiting thread holds
        no lock and barely the GIL). A process that died is replaced and the job tried once
        more there (it rebuilds the building from the last stored plan)."""
        index = self.process_of(building_id)
        for attempt in (1, 2):
            with self._lock:
                pool = self._pools[index]
            try:
                return pool.submit(_run, kind, building_id, args).result()
            except BrokenProcessPool:
                with self._lock:
                    if self._pools[index] is pool:
                        LOG.error("planning process %d died; starting a new one", index)
                        self._pools[index] = self._new_pool()
                if attempt == 2:
                    raise RuntimeError(
                        f"the planning process of building {building_id} died twice "
                        f"planning it ({kind})"
                    ) from None
        raise AssertionError("unreachable")  # pragma: no cover

    def shutdown(self) -> None:
        """Stop the processes (a job running finishes first)."""
        with self._lock:
            pools = list(self._pools)
        for pool in pools:
            pool.shutdown(wait=True, cancel_futures=True)
