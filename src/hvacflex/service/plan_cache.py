"""Each building's latest plan in the server's memory, as the bytes of its answer.

``GET /v1/buildings/{id}/plan`` is the read the buildings' systems and dashboards poll; read
from the database, each costs the server a trip through the threadpool, a connection and
the plan's JSON parsed and serialised again (issue 56: 2.4–3.2 ms of CPU per read). The
:class:`LatestPlans` answer it on the event loop instead, from the bytes of the answer
``{"status": 200, "message": "ok", "payload": plan}`` made once per plan.

Where the copy comes from, and why it is never older than what a client has seen:

* **Every plan is made by the planner** (:class:`~hvacflex.service.planner.Planner`: in its
  threads or its processes), committed there, and comes back to the server process; the
  planner offers it here (:meth:`LatestPlans.offer`) *before* anyone waiting for it (a
  measurement's ``wait_s``, the clock, an activation) gets it. A plan job that fails
  forgets the building's copy (:meth:`LatestPlans.forget`): its plan may have been committed
  without coming back.
* **The latest plan is the largest (period, revision)**, as the database orders them (a
  building's plans go forward: a later period, or a new revision of the same one), so an
  older plan offered late never replaces a newer one.
* **A building not offered yet** (after a restart) is read from the database once
  (:meth:`LatestPlans.fill`), with the token taken before the read
  (:meth:`LatestPlans.token`): a fill that raced with :meth:`~LatestPlans.forget` is
  dropped. A registered building without a plan is remembered as such (:data:`NO_PLAN`).

One server process plans a database (as the planner's revisions assume); a plan written by
another process would not be seen here until this process plans the building again.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any, Final

from hvacflex.service.schemas import Envelope, Plan


@dataclass(frozen=True)
class CachedPlan:
    """A building's latest plan: its period, its revision and the answer's bytes (UTF-8
    JSON of the envelope)."""

    period: int
    revision: int
    body: bytes

    @property
    def order(self) -> tuple[int, int]:
        """(period, revision): the later plan is the larger."""
        return self.period, self.revision


class _NoPlan:
    """The marker of a registered building without a plan yet."""

    def __repr__(self) -> str:
        return "NO_PLAN"


NO_PLAN: Final = _NoPlan()
"""A registered building that has no plan yet (its read is a 404)."""

Entry = CachedPlan | _NoPlan


def plan_answer(plan: dict[str, Any]) -> CachedPlan:
    """A stored plan's payload (as the planner returns it and ``plan.payload_json`` holds)
    as its answer's bytes, validated as the route's model :class:`Plan` (as a read from the
    database is)."""
    envelope = Envelope(status=200, message="ok", payload=Plan(**plan))
    body = envelope.model_dump_json().encode()
    return CachedPlan(int(plan["period"]), int(plan["revision"]), body)


class LatestPlans:
    """The latest plan of each building (thread-safe; reads take no lock)."""

    def __init__(self) -> None:
        self._entries: dict[str, Entry] = {}
        self._tokens: dict[str, int] = {}
        self._lock = threading.Lock()

    def get(self, building_id: str) -> Entry | None:
        """The building's latest plan, :data:`NO_PLAN`, or None when it is not known here
        (read it from the database)."""
        return self._entries.get(building_id)

    def offer(self, building_id: str, plan: dict[str, Any]) -> None:
        """A plan just committed (the planner's result): kept unless a later one is."""
        answer = plan_answer(plan)  # outside the lock: the plan's validation and JSON
        with self._lock:
            current = self._entries.get(building_id)
            if not isinstance(current, CachedPlan) or answer.order >= current.order:
                self._entries[building_id] = answer

    def forget(self, building_id: str) -> None:
        """Drop the building's copy (a plan job failed: its plan may be stored or not); the
        next read goes to the database."""
        with self._lock:
            self._entries.pop(building_id, None)
            self._tokens[building_id] = self._tokens.get(building_id, 0) + 1

    def token(self, building_id: str) -> int:
        """Take before reading the building's latest plan from the database (for
        :meth:`fill`)."""
        with self._lock:
            return self._tokens.get(building_id, 0)

    def fill(self, building_id: str, entry: Entry, token: int) -> None:
        """The building's latest plan as read from the database (:func:`plan_answer`, or
        :data:`NO_PLAN`: registered, no plan yet), read after :meth:`token` returned
        ``token``. Dropped if the building was forgotten since, or a plan at least as late
        is known."""
        with self._lock:
            if self._tokens.get(building_id, 0) != token:
                return
            current = self._entries.get(building_id)
            if current is None or (
                isinstance(entry, CachedPlan)
                and (not isinstance(current, CachedPlan) or entry.order > current.order)
            ):
                self._entries[building_id] = entry
