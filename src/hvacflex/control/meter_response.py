"""How the meter answers the plan: the ratio that puts reserve offers on the metered scale.

An offer is sized on the controller's power model (docs/explanation/il_events.md, "Offers that can
be delivered"): the plan's curtailed power must lie below every baseline an activation could be
settled against by the offer. The market settles against the meter, and a power model whose
power moves more than the meter's sheds on the meter only part of what its plan says — an
identified model fitted on other weeks (docs/guide/identify.md §6.1: in April the 5ZoneAirCooled
meter moves 0.5–0.6 kW for each kW the March-fitted plan moves), or a setpoint-actuated
plant whose own loops track part of a planned change.

That part is measured in normal operation, every period, without waiting for activations
(which are rare, and an estimate from them alone falls to zero after one bad event and stays
there): the least-squares slope through the origin of the metered power's change against the
plan's,

    ρ = Σ ΔP̂ ΔM / Σ ΔP̂²,   ΔP̂ = P̂_k − P̂_{k−L},  ΔM = M_k − M_{k−L},  L = 1 … D,

over the pairs of *usable* periods (occupied, served — not curtailed —, decided by a fresh
plan, the meter read) among the last :data:`WINDOW_PERIODS`; P̂_k is the plan's own power for
period k (``Action.planned_power_kw``), M_k the metered power. Differences, not levels: a
delivery is the meter's change from the baseline period to the event's, and the plan's offset
from the meter (the fan secant, a fitted intercept) cancels in them. ρ is clipped to [0, 1]
(an offer is never scaled above the model's lower bound q·r) and is 1 — the model's own
scale — while fewer than :data:`MIN_PAIRS` pairs exist or the plan's changes are below
:data:`MIN_RMS_CHANGE_KW` (nothing to learn from).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from hvacflex.control.base import FloatArray
from hvacflex.control.problem_builder import pull_down_steps

WINDOW_PERIODS = 240
"""Periods of history the ratio is taken over (5 days of 30-min periods) [periods]."""
MIN_PAIRS = 16
"""Fewest pairs of usable periods before the ratio departs from 1."""
MIN_RMS_CHANGE_KW = 0.1
"""Smallest root-mean-square change of the plan's power over the pairs [kW]."""
OFFSET_PERIODS = 20
"""Usable periods the meter's offset from the model is averaged over (about a day's office
hours) [periods]."""
MIN_OFFSET_PERIODS = 8
"""Fewest usable periods before the offset departs from 0."""
MIN_SAME_PERIOD_DAYS = 2
"""Fewest usable periods at the same time of day before that time's own offset is used."""


def meter_response_ratio(
    planned_kw: FloatArray,
    metered_kw: FloatArray,
    max_lag_steps: int,
    *,
    min_pairs: int = MIN_PAIRS,
    min_rms_change_kw: float = MIN_RMS_CHANGE_KW,
) -> float:
    """ρ in [0, 1] from consecutive periods' plan and meter (T,) each [kW], NaN where a period
    is not usable, over lags 1 … ``max_lag_steps`` (see the module docstring); 1 without
    evidence."""
    planned = np.asarray(planned_kw, dtype=float)
    metered = np.asarray(metered_kw, dtype=float)
    cross = square = 0.0
    pairs = 0
    for lag in range(1, max(max_lag_steps, 1) + 1):
        if lag >= planned.size:
            break
        d_plan = planned[lag:] - planned[:-lag]
        d_meter = metered[lag:] - metered[:-lag]
        ok = np.isfinite(d_plan) & np.isfinite(d_meter)
        cross += float(d_plan[ok] @ d_meter[ok])
        square += float(d_plan[ok] @ d_plan[ok])
        pairs += int(ok.sum())
    if pairs < min_pairs or square < pairs * min_rms_change_kw**2:
        return 1.0
    return float(np.clip(cross / square, 0.0, 1.0))


def meter_offset_kw(
    planned_kw: FloatArray,
    metered_kw: FloatArray,
    *,
    periods: int = OFFSET_PERIODS,
    min_periods: int = MIN_OFFSET_PERIODS,
) -> float:
    """The meter's offset from the power model [kW]: the mean of metered − planned power over
    the last ``periods`` usable periods (both finite) of the history (T,) each [kW]; 0 while
    fewer than ``min_periods`` exist.

    ``[controller] power_level = "meter"`` adds it to the LP's power rows in occupied
    periods: the power model's output made offset-free against the meter, as the Kalman
    filter's offsets make the zones' (docs/explanation/estimation.md). ``planned_kw`` must be
    the model's own power (without an offset added before), so that the mean is the whole
    offset, not its change.
    """
    planned = np.asarray(planned_kw, dtype=float)
    metered = np.asarray(metered_kw, dtype=float)
    residual = metered - planned
    usable = residual[np.isfinite(residual)][-max(periods, 1) :]
    if usable.size < min_periods:
        return 0.0
    return float(np.mean(usable))


OCCUPIED, PULL_DOWN, IDLE = 0, 1, 2
"""A period's class for the meter's offsets: occupied (the schedule's), the unoccupied steps of
a morning pull-down (:func:`hvacflex.control.problem_builder.pull_down_steps`), the other
unoccupied ones (nights, weekends, holidays). −1: no usable row."""
IDLE_WINDOW_PERIODS = 384
"""Periods of history the unoccupied offsets are taken over (8 days: a weekend's hours reach
the next weekend's) [periods]."""


def period_classes(occupied: np.ndarray, horizon: int) -> np.ndarray:
    """(horizon,) int: each period's class for the meter's offsets — :data:`OCCUPIED` where
    ``occupied`` (≥ horizon,) bool, the schedule's occupied periods from now on, is true;
    :data:`PULL_DOWN` in the unoccupied steps of a morning pull-down; :data:`IDLE` else."""
    occ = np.asarray(occupied, dtype=bool)[:horizon]
    classes = np.where(pull_down_steps(occupied, horizon)[: occ.size], PULL_DOWN, IDLE)
    return np.where(occ, OCCUPIED, classes)


class MeterHistory:
    """The plan's and the meter's power of a building's recent periods, one row a period.

    A period's planned power is known when it is decided (:meth:`open`), its metered power
    when the next period is (:meth:`advance`, with the power the building posts); periods
    nobody decided, or whose meter was not read, are NaN rows, so lags stay lags in time.
    Each row carries its period's class (:data:`OCCUPIED`, :data:`PULL_DOWN`, :data:`IDLE`):
    ρ and the occupied offsets read the occupied rows of the last ``window_periods``, the
    unoccupied offsets their own class's rows of the last ``idle_window_periods``.
    """

    def __init__(
        self, window_periods: int = WINDOW_PERIODS, idle_window_periods: int = IDLE_WINDOW_PERIODS
    ) -> None:
        self.window_periods = window_periods
        self.kept_periods = max(window_periods, idle_window_periods)
        self.model_kw = np.zeros(0)
        """(≤ kept,) the plan's own power of each row [kW] (NaN: not usable)."""
        self.meter_kw = np.zeros(0)
        """(≤ kept,) the metered power of each row [kW] (NaN: not read)."""
        self.period_class = np.zeros(0, dtype=np.int8)
        """(≤ kept,) each row's class (−1 where the row is not usable)."""
        self.next_period = -1
        """The first period without a row (−1: none started yet)."""
        self.open_period = -1
        """The latest period decided, whose meter is not read yet (−1: none)."""
        self.open_planned_kw = math.nan
        """Its planned power [kW] (NaN: not usable)."""
        self.open_class = OCCUPIED
        """Its class."""

    @property
    def planned_kw(self) -> FloatArray:
        """(≤ window,) the occupied rows' planned power of the last ``window_periods`` [kW],
        NaN in the others."""
        occupied = self.period_class[-self.window_periods :] == OCCUPIED
        return np.where(occupied, self.model_kw[-self.window_periods :], math.nan)

    @property
    def metered_kw(self) -> FloatArray:
        """(≤ window,) the metered power of the last ``window_periods`` rows [kW]."""
        return self.meter_kw[-self.window_periods :]

    def open(self, period: int, planned_kw: float, period_class: int = OCCUPIED) -> None:
        """Period ``period`` was decided; ``planned_kw``: the plan's power for it [kW], NaN
        where the period does not count (curtailed, no fresh plan); ``period_class``: its
        class."""
        self.open_period, self.open_planned_kw = period, float(planned_kw)
        self.open_class = period_class

    def advance(self, period: int, previous_power_kw: float | None) -> None:
        """Period ``period`` starts: every period from :attr:`next_period` to period − 1 gets
        its row — the open period's planned power with ``previous_power_kw``, the metered
        power of period − 1 [kW] (None or NaN: not read), where it is period − 1; NaN rows
        for the others (nobody decided them, or their meter was not read)."""
        first = period if self.next_period < 0 else self.next_period
        count = min(period - first, self.kept_periods)
        if count <= 0:  # the first period, or one that has its rows already
            self.next_period = max(self.next_period, period)
            return
        planned = np.full(count, math.nan)
        metered = np.full(count, math.nan)
        period_class = np.full(count, -1, dtype=np.int8)
        if self.open_period == period - 1:
            planned[-1] = self.open_planned_kw
            metered[-1] = math.nan if previous_power_kw is None else float(previous_power_kw)
            period_class[-1] = self.open_class if math.isfinite(self.open_planned_kw) else -1
        keep = self.kept_periods
        self.model_kw = np.concatenate([self.model_kw, planned])[-keep:]
        self.meter_kw = np.concatenate([self.meter_kw, metered])[-keep:]
        self.period_class = np.concatenate([self.period_class, period_class])[-keep:]
        self.next_period = period
        self.open_period, self.open_planned_kw, self.open_class = -1, math.nan, OCCUPIED

    def ratio(self, max_lag_steps: int) -> float:
        """:func:`meter_response_ratio` of the occupied rows."""
        return meter_response_ratio(self.planned_kw, self.metered_kw, max_lag_steps)

    def offset_kw(self) -> float:
        """:func:`meter_offset_kw` of the occupied rows."""
        return meter_offset_kw(self.planned_kw, self.metered_kw)

    def offsets_kw(
        self, horizon: int, periods_per_day: int, period_class: np.ndarray | None = None
    ) -> FloatArray:
        """(horizon,) the meter's offset from the model for the periods from
        :attr:`next_period` on [kW]: for each, the mean residual (metered − planned) of the
        usable rows of its class at the same time of day (the model's error follows the day:
        the morning's pull-down, the hot afternoon, the night's fans), where at least
        :data:`MIN_SAME_PERIOD_DAYS` exist; else the mean of the class's last
        :data:`OFFSET_PERIODS` usable rows (:func:`meter_offset_kw`; 0 while fewer than
        :data:`MIN_OFFSET_PERIODS`). Occupied rows are read over the last ``window_periods``,
        unoccupied ones over the whole history. ``period_class``: (horizon,) each period's
        class (default: all :data:`OCCUPIED`)."""
        classes = np.full(horizon, OCCUPIED) if period_class is None else period_class
        out = np.zeros(horizon)
        for cls in np.unique(classes):
            rows = slice(-self.window_periods, None) if cls == OCCUPIED else slice(None)
            mine = self.period_class[rows] == cls
            planned = np.where(mine, self.model_kw[rows], math.nan)
            at = classes == cls
            offsets = self._class_offsets(planned, self.meter_kw[rows], horizon, periods_per_day)
            out[at] = offsets[at]
        return out

    def _class_offsets(
        self, planned_kw: FloatArray, metered_kw: FloatArray, horizon: int, periods_per_day: int
    ) -> FloatArray:
        """(horizon,) :meth:`offsets_kw` over the rows ``planned_kw``, ``metered_kw`` (the
        history's last rows, NaN where not of the class)."""
        fallback = meter_offset_kw(planned_kw, metered_kw)
        out = np.full(horizon, fallback)
        if fallback == 0.0 or self.next_period < 0:
            return out
        residual = metered_kw - planned_kw
        rows = residual.size
        time_of_day = (self.next_period - rows + np.arange(rows)) % periods_per_day
        for j in range(horizon):
            same = residual[(time_of_day == (self.next_period + j) % periods_per_day)]
            same = same[np.isfinite(same)]
            if same.size >= MIN_SAME_PERIOD_DAYS:
                out[j] = float(np.mean(same))
        return out

    def get_state(self) -> dict[str, Any]:
        return {
            "model_kw": self.model_kw.copy(),
            "meter_kw": self.meter_kw.copy(),
            "period_class": self.period_class.copy(),
            "next_period": self.next_period,
            "open_period": self.open_period,
            "open_planned_kw": self.open_planned_kw,
            "open_class": self.open_class,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`get_state`'s state; a state stored before the rows had classes (a
        service's stored controller) has its usable rows read as occupied ones."""
        if "model_kw" not in state:
            planned = np.asarray(state["planned_kw"], dtype=float)
            state = state | {
                "model_kw": planned,
                "meter_kw": state["metered_kw"],
                "period_class": np.where(np.isfinite(planned), OCCUPIED, -1),
                "open_class": OCCUPIED,
            }
        self.model_kw = np.asarray(state["model_kw"], dtype=float).copy()
        self.meter_kw = np.asarray(state["meter_kw"], dtype=float).copy()
        self.period_class = np.asarray(state["period_class"], dtype=np.int8).copy()
        self.next_period = int(state["next_period"])
        self.open_period = int(state["open_period"])
        self.open_planned_kw = float(state["open_planned_kw"])
        self.open_class = int(state["open_class"])
