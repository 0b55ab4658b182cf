"""Interruptible-load settlement against metered power, as the market settles it.

NEMS settles an interruptible-load (IL) activation on the load's **metered** power against a
**baseline** of what the load would have drawn, not on the provider's own plan. For every
activated period k (column ``il_activated``):

* metered ``P_k`` = ``power_kw`` (the plant's electric power in the period);
* baseline ``B_k`` (``il_baseline_power_kw``) by one of :data:`BASELINE_RULES`:

  - ``"pre-event"`` (the default): the metered power of the period before the activation
    started, held for every period of the event (a block of consecutive activated periods).
    An event in the run's first period has no period before it: no baseline (NaN);
  - ``"similar-days"``: the mean of the metered power of the same period of the day on the
    last :data:`SIMILAR_DAYS` earlier days of the same kind (weekday / weekend) in the run on
    which that period was not activated itself; with none such in the run (its first day),
    the pre-event baseline;

* delivered ``D_k = max(0, B_k − P_k)`` (``il_delivered_kw``; not capped at the offer; 0
  without a baseline: nothing can be shown to be delivered);
* shortfall ``S_k = max(0, R_k − D_k)`` (``il_shortfall_kw``) with ``R_k`` = ``reserve_kw``
  the capacity the period was paid for;
* penalty ``S_k Δt (π_k + f·b_k) / 1000`` [SGD]: the shortfall energy at the non-delivery
  price π (``il_penalty_price_sgd_per_mwh``, default the NEMS price cap 4,500 SGD/MWh), plus
  the period's reserve payment b_k R_k for the part not delivered when the contract forfeits
  it (f = 1: ``il_forfeited_price_sgd_per_mwh`` = b_k; f = 0: that column is 0).

Outside activated periods the baseline is NaN and delivered and shortfall are 0. Everything
here is a pure function of the per-period series (``docs/explanation/il_events.md``): the closed
loop fills the columns with :func:`settlement_columns`, and :mod:`hvacflex.kpi` sums them.
"""

from __future__ import annotations

from typing import Literal, get_args

import numpy as np
import numpy.typing as npt
import pandas as pd

from hvacflex.errors import ConfigError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

BaselineRule = Literal["pre-event", "similar-days"]
BASELINE_RULES: tuple[str, ...] = get_args(BaselineRule)
"""The baseline rules ``[reserve] il_baseline`` accepts."""

SIMILAR_DAYS = 5
"""Days the ``similar-days`` baseline averages (the last ones of the same kind)."""

BASELINE_COLUMN = "il_baseline_power_kw"
DELIVERED_COLUMN = "il_delivered_kw"
SHORTFALL_COLUMN = "il_shortfall_kw"
SETTLEMENT_COLUMNS: tuple[str, ...] = (BASELINE_COLUMN, DELIVERED_COLUMN, SHORTFALL_COLUMN)
"""The results columns :func:`settlement_columns` fills [kW]."""


def event_starts(activated: BoolArray) -> npt.NDArray[np.int64]:
    """(T,) index of the first period of the activation block each period belongs to
    (−1 outside activations)."""
    active = np.asarray(activated, dtype=bool)
    start = np.full(active.size, -1, dtype=np.int64)
    current = -1
    for k, on in enumerate(active.tolist()):
        if on and current < 0:
            current = k
        elif not on:
            current = -1
        start[k] = current
    return start


def pre_event_baseline_kw(power_kw: FloatArray, activated: BoolArray) -> FloatArray:
    """(T,) the ``pre-event`` baseline [kW]: in each activated period the metered power of
    the period before its event started; NaN outside activations and for an event that
    starts in period 0.

    Parameters
    ----------
    power_kw : (T,) metered power [kW].
    activated : (T,) IL activated in the period.
    """
    power = np.asarray(power_kw, dtype=float)
    start = event_starts(activated)
    baseline = np.full(power.size, np.nan)
    has_before = start > 0
    baseline[has_before] = power[start[has_before] - 1]
    return baseline


def similar_days_baseline_kw(
    power_kw: FloatArray,
    activated: BoolArray,
    index: pd.DatetimeIndex,
    days: int = SIMILAR_DAYS,
) -> FloatArray:
    """(T,) the ``similar-days`` baseline [kW]: in each activated period the mean metered
    power of the same period of the day on the last ``days`` earlier days of the same kind
    (weekday or weekend, local time of ``index``) on which that period was not activated;
    the :func:`pre_event_baseline_kw` where the run holds no such day.

    Parameters
    ----------
    power_kw : (T,) metered power [kW].
    activated : (T,) IL activated in the period.
    index : (T,) period starts (tz-aware).
    days : how many similar days to average.
    """
    power = np.asarray(power_kw, dtype=float)
    active = np.asarray(activated, dtype=bool)
    baseline = pre_event_baseline_kw(power, active)
    similar = _similar_days_mean_kw(power, active, index, np.flatnonzero(active), days)
    return np.where(np.isfinite(similar), similar, baseline)


def _similar_days_mean_kw(
    power: FloatArray,
    active: BoolArray,
    index: pd.DatetimeIndex,
    periods: npt.NDArray[np.int64],
    days: int,
) -> FloatArray:
    """(T,) for each of ``periods``: the mean metered power of the same period of the day on
    the last ``days`` earlier days of the same kind on which it was not activated (NaN with
    none); NaN in every other period."""
    out = np.full(len(power), np.nan)
    local = index.tz_localize(None) if index.tz is not None else index
    day = np.asarray(local.normalize().asi8)
    time_of_day = np.asarray(local.asi8) - day
    weekend = np.asarray(local.day_of_week >= 5)
    usable = ~active & np.isfinite(power)
    for k in periods.tolist():
        same = (time_of_day == time_of_day[k]) & (weekend == weekend[k]) & (day < day[k]) & usable
        earlier = np.flatnonzero(same)[-days:]
        if earlier.size:
            out[k] = float(np.mean(power[earlier]))
    return out


def similar_days_ahead_kw(
    power_kw: FloatArray, activated: BoolArray, index: pd.DatetimeIndex, days: int = SIMILAR_DAYS
) -> FloatArray:
    """The ``similar-days`` baseline of the coming periods, from the history before them.

    Parameters
    ----------
    power_kw, activated : (k,) the metered power [kW] and activations of the periods so far.
    index : (k + J,) their period starts and those of the J coming periods (tz-aware).
    days : how many similar days to average.

    Returns
    -------
    (J,) the baseline an activation covering period k + j would be settled against [kW],
    whenever it started (the rule does not depend on the start); NaN where the history holds
    no similar day (the settlement then falls back to the pre-event baseline). Periods of the
    day already past today are known from earlier days only, as in the settlement.
    """
    k = len(power_kw)
    coming = len(index) - k
    power = np.append(np.asarray(power_kw, dtype=float), np.full(coming, np.nan))
    active = np.append(np.asarray(activated, dtype=bool), np.ones(coming, dtype=bool))
    periods = np.arange(k, k + coming, dtype=np.int64)
    return _similar_days_mean_kw(power, active, index, periods, days)[k:]


def baseline_power_kw(
    rule: str,
    power_kw: FloatArray,
    activated: BoolArray,
    index: pd.DatetimeIndex,
) -> FloatArray:
    """(T,) the baseline of ``rule`` (one of :data:`BASELINE_RULES`) [kW]; NaN outside
    activated periods.

    Raises
    ------
    ConfigError : an unknown rule.
    """
    if rule == "pre-event":
        return pre_event_baseline_kw(power_kw, activated)
    if rule == "similar-days":
        return similar_days_baseline_kw(power_kw, activated, index)
    raise ConfigError(
        "unknown IL baseline rule",
        field="reserve.il_baseline",
        value=rule,
        hint=f"one of {list(BASELINE_RULES)}",
    )


SIMILAR_DAYS_LOOKBACK_DAYS = 7 * SIMILAR_DAYS
"""Days of history :func:`start_baseline_kw` and :func:`ahead_baselines_kw` search for
similar days (5 weekends span five weeks). The settlement searches the whole run; the two
differ only where more than 20 of the 25 weekdays (5 of 10 weekend days) in the window had
the same period activated."""


def _lookback_start(k: int, index: pd.DatetimeIndex) -> int:
    """The first period of the history searched for similar days before period k."""
    periods_per_day = max(round(pd.Timedelta(days=1) / (index[1] - index[0])), 1)
    return max(0, k - SIMILAR_DAYS_LOOKBACK_DAYS * periods_per_day)


def start_baseline_kw(
    rule: str, power_kw: FloatArray, activated: BoolArray, index: pd.DatetimeIndex
) -> float:
    """The baseline an activation starting in period k would be settled against [kW], from
    the history before it: ``power_kw`` and ``activated`` (k,), ``index`` (k + 1,) the
    period starts up to and including k. NaN when there is none (k = 0)."""
    k = len(power_kw)
    if k == 0:
        return float("nan")
    if rule == "pre-event":
        return float(power_kw[-1])
    first = _lookback_start(k, index)
    power = np.append(np.asarray(power_kw[first:], dtype=float), np.nan)
    active = np.append(np.asarray(activated[first:], dtype=bool), True)
    baseline = baseline_power_kw(rule, power, active, index[first : k + 1])
    return float(baseline[-1])


def ahead_baselines_kw(
    rule: str, power_kw: FloatArray, activated: BoolArray, index: pd.DatetimeIndex
) -> FloatArray | None:
    """The baselines of the coming periods where the rule fixes them before the activation
    starts: ``similar-days`` (:func:`similar_days_ahead_kw` over the last
    :data:`SIMILAR_DAYS_LOOKBACK_DAYS` days), None under ``pre-event`` (there the baseline
    depends on when the activation starts). ``power_kw``, ``activated`` (k,) the history;
    ``index`` (k + J,) its period starts and those of the J coming periods."""
    if rule != "similar-days":
        return None
    k = len(power_kw)
    if k == 0:
        return np.full(len(index), np.nan)
    first = _lookback_start(k, index)
    return similar_days_ahead_kw(
        np.asarray(power_kw[first:], dtype=float),
        np.asarray(activated[first:], dtype=bool),
        index[first:],
    )


def delivered_kw(baseline_kw: FloatArray, power_kw: FloatArray, activated: BoolArray) -> FloatArray:
    """(T,) delivered reduction ``max(0, B − P)`` in activated periods, 0 elsewhere and
    where there is no baseline [kW]."""
    reduction = np.asarray(baseline_kw, dtype=float) - np.asarray(power_kw, dtype=float)
    delivered = np.maximum(np.nan_to_num(reduction, nan=0.0), 0.0)
    return np.where(np.asarray(activated, dtype=bool), delivered, 0.0)


def shortfall_kw(reserve_kw: FloatArray, delivered: FloatArray, activated: BoolArray) -> FloatArray:
    """(T,) reserve paid for but not delivered ``max(0, R − D)`` in activated periods, 0
    elsewhere [kW]."""
    short = np.maximum(np.asarray(reserve_kw, dtype=float) - delivered, 0.0)
    return np.where(np.asarray(activated, dtype=bool), short, 0.0)


def settlement_columns(frame: pd.DataFrame, rule: str = "pre-event") -> pd.DataFrame:
    """The settlement columns (:data:`SETTLEMENT_COLUMNS`, [kW]) of a results frame.

    Parameters
    ----------
    frame : (T rows) with ``power_kw``, ``reserve_kw``, ``il_activated`` (False when absent)
        and a ``DatetimeIndex`` of period starts (``similar-days``).
    rule : the baseline rule (:data:`BASELINE_RULES`).

    Returns
    -------
    DataFrame on ``frame``'s index: ``il_baseline_power_kw`` (NaN outside activations),
    ``il_delivered_kw``, ``il_shortfall_kw``.
    """
    power = frame["power_kw"].to_numpy(dtype=float)
    activated = (
        frame["il_activated"].to_numpy(dtype=bool)
        if "il_activated" in frame.columns
        else np.zeros(len(frame), dtype=bool)
    )
    index = frame.index
    if rule == "similar-days" and not isinstance(index, pd.DatetimeIndex):
        raise ConfigError(
            "the similar-days baseline needs a DatetimeIndex of period starts",
            field="reserve.il_baseline",
            value=rule,
        )
    dt_index = index if isinstance(index, pd.DatetimeIndex) else pd.DatetimeIndex([])
    baseline = baseline_power_kw(rule, power, activated, dt_index)
    baseline = np.where(activated, baseline, np.nan)
    delivered = delivered_kw(baseline, power, activated)
    short = shortfall_kw(frame["reserve_kw"].to_numpy(dtype=float), delivered, activated)
    return pd.DataFrame(
        {BASELINE_COLUMN: baseline, DELIVERED_COLUMN: delivered, SHORTFALL_COLUMN: short},
        index=frame.index,
    )
