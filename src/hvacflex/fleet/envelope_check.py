"""The flexibility envelope checked in closed loop: the fleet holds its envelope's ends.

:func:`check_holds` runs a fleet's buildings (in this process) from ``start`` with every
building planning alone (no feeder price, no cap: the unlimited fleet); at each of the given
periods it takes the fleet's envelope (:mod:`hvacflex.fleet.envelope`) for a duration, and
from a copy of the state then runs the fleet **holding** the envelope's least and, from the
same state again, its most power for that duration: every building holds its own level, its
flows re-planned every period from the plant's state over the periods left of the hold
(:meth:`hvacflex.fleet.agent.BuildingAgent.advance_held`) and applied to its RC plant. The
plants' metered power and period-end zone temperatures grade the envelope: the fleet's
metered power against the envelope's level, and the zones against their comfort band.

The state is the plant's own (perfect state information: the fleet path runs no Kalman
filter), so the check grades the hold and the power model, not an estimator. A start where
some building has no comfort-keeping hold of the duration is refused (ValueError).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from hvacflex import kpi as kpis
from hvacflex.constants import PERIOD, PERIODS_PER_DAY
from hvacflex.control.base import FloatArray
from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.envelope import DURATIONS_MIN, duration_steps
from hvacflex.fleet.schema import Fleet

HOLD_COLUMNS = (
    "time",
    "end",
    "duration_min",
    "envelope_kw",
    "metered_min_kw",
    "metered_max_kw",
    "error_pct",
    "discomfort_kelvin_hours",
    "max_violation_k",
)
"""One row per hold: its start, ``min`` or ``max``, the duration, the fleet's envelope level
[kW], the fleet's metered power over the hold (least, largest) [kW], the largest |metered −
envelope| / envelope over the hold's periods [%] (NaN for a 0-kW envelope, where a
percentage means nothing: the metered power says how far it is), the fleet's discomfort
over the hold [K·h] and the largest period-end zone violation of any building over the hold [K]."""


@dataclass(frozen=True)
class _Hold:
    """A hold's result: the envelope's level (fleet) [kW], metered fleet power (h,) [kW],
    fleet discomfort [K·h] and largest zone violation [K] over the hold."""

    level_kw: float
    metered_kw: FloatArray
    discomfort_kelvin_hours: float
    max_violation_k: float


def _plan_alone(group: BuildingGroup) -> None:
    """One period of the unlimited fleet: every building plans alone and advances."""
    _, _, energy = group.begin_step()
    zero = np.zeros(energy.shape[1])
    group.finalize(zero, np.full((len(group.agents), energy.shape[1]), np.inf))
    group.advance(False)


def _hold(group: BuildingGroup, levels_kw: FloatArray, steps: int) -> _Hold:
    """Hold ``levels_kw`` (B,) for ``steps`` periods from the group's state (the first
    period's step begun); the fleet's figures over the hold."""
    start = group.agents[0].loop.k
    metered = []
    for j in range(steps):
        if j > 0:
            group.begin_step()
        metered.append(float(np.sum(group.advance_held(levels_kw, steps - j)["power_kw"])))
    frames = [agent.frame().iloc[start : start + steps] for agent in group.agents]
    discomfort = sum(float(kpis.step_discomfort_kelvin_hours(f).sum()) for f in frames)
    violation = max(float(kpis.max_violation_k(f).max()) for f in frames)
    return _Hold(float(np.sum(levels_kw)), np.array(metered), discomfort, violation)


def check_holds(
    fleet: Fleet,
    document: dict[str, Any],
    start: str,
    hold_starts: Sequence[int],
    duration_min: int = 60,
) -> pd.DataFrame:
    """Hold the envelope's least and most power for ``duration_min`` (one of
    :data:`hvacflex.fleet.envelope.DURATIONS_MIN`) from each of the periods ``hold_starts``
    (steps after ``start``, increasing); one row per hold (:data:`HOLD_COLUMNS`)."""
    if duration_min not in DURATIONS_MIN:
        raise ValueError(
            f"duration_min {duration_min!r} is not a hold duration of the envelope; "
            f"use one of {', '.join(str(d) for d in DURATIONS_MIN)} [min]"
        )
    steps_all = duration_steps()
    which = DURATIONS_MIN.index(duration_min)
    steps = steps_all[which]
    days = (max(hold_starts) + steps + 1) / PERIODS_PER_DAY
    settings = FleetSettings.of(fleet, start, days)
    group = BuildingGroup(document, list(range(len(fleet.buildings))), settings)
    rows = []
    for k in range(max(hold_starts) + 1):
        if k not in hold_starts:
            _plan_alone(group)
            continue
        saved = group.get_state()
        group.begin_step()
        (envelope,) = group.envelope(steps_all)
        time = settings_index(settings, k)
        _refuse_uncomfortable(envelope[:, which], time, duration_min)
        for end, column in (("min", 0), ("max", 1)):
            group.set_state(saved)
            group.begin_step()
            held = _hold(group, envelope[:, which, column], steps)
            error = _error_fraction(held.metered_kw, held.level_kw)
            rows.append(
                (
                    time,
                    end,
                    duration_min,
                    held.level_kw,
                    float(held.metered_kw.min()),
                    float(held.metered_kw.max()),
                    100.0 * float(error.max()),
                    held.discomfort_kelvin_hours,
                    held.max_violation_k,
                )
            )
        group.set_state(saved)
        _plan_alone(group)
    return pd.DataFrame(rows, columns=list(HOLD_COLUMNS))


def _error_fraction(metered_kw: FloatArray, level_kw: float) -> FloatArray:
    """|metered − level| / level per period (h,); NaN for a 0-kW level."""
    if level_kw == 0.0:
        return np.full(metered_kw.shape, np.nan)
    return np.abs(metered_kw - level_kw) / abs(level_kw)


def _refuse_uncomfortable(ranges_kw: FloatArray, time: pd.Timestamp, duration_min: int) -> None:
    """Refuse a hold start where a building's range (B, 2) [kW] is NaN (no hold keeps
    comfort, :func:`hvacflex.fleet.envelope.building_envelope`)."""
    missing = np.flatnonzero(np.isnan(ranges_kw).any(axis=1))
    if missing.size:
        raise ValueError(
            f"from {time:%Y-%m-%d %H:%M} building(s) {', '.join(str(i) for i in missing)} "
            f"cannot hold any level for {duration_min} min in comfort; choose another "
            "hold start or a shorter duration"
        )


def settings_index(settings: FleetSettings, k: int) -> pd.Timestamp:
    """The start of period ``k`` of a run of ``settings`` (Singapore local time)."""
    return pd.Timestamp(settings.start) + k * PERIOD
