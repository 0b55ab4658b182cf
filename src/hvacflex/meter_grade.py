"""The plan graded by the meter: what a run promised against what its meter did.

A plan makes two promises a grid operator or a utility relies on: the energy it expects to
draw (the LP's first-step power, ``planned_power_kw``) and, when it prices the peak, the cap it
commits to (``committed_peak_kw``). This module grades both against the plant's meter
(``power_kw``): planned over metered HVAC energy in the occupied and the unoccupied periods,
each weekday's metered peak against that day's largest committed cap, and each month's
metered peak against the largest planned first-step power of the month
(docs/explanation/model.md, "The committed peak").

The functions are pure and take the results frame of one run (one row per 30-min period;
``docs/reference/results.md``) and a (T,) occupied mask: the schedule's occupied periods, a
period being occupied when some zone's band in force is its occupied band
(:func:`hvacflex.kpi.occupied_mask`, which :func:`hvacflex.kpi.summary` passes in). A rule
without a plan (``planned_power_kw`` NaN) and a plan that prices no peak (no finite
``committed_peak_kw``) grade NaN where they promise nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

PEAK_TOLERANCE = 1.05
"""A metered peak keeps its promise when it is at most this × the cap or plan it is graded
against (the 5 % a meter's half-hour mean may exceed a cap the guard holds within a period)."""


def planned_metered_kwh(
    results: pd.DataFrame, occupied: np.ndarray, step_h: float
) -> dict[str, float]:
    """Planned and metered HVAC energy [kWh] in the occupied and unoccupied periods, and
    their ratios (planned / metered; NaN without a plan or without metered energy).

    Both sums are over the periods that have a plan (a finite ``planned_power_kw``): a period
    without one (a fallback to the rule, a locked IL event period that the plan's first step
    does not describe) is graded by neither; ``unplanned_periods`` counts them.

    Parameters
    ----------
    results : one run's results (``power_kw``, ``planned_power_kw``).
    occupied : (T,) bool, the schedule's occupied periods.
    step_h : the period length [h].
    """
    metered = results["power_kw"].to_numpy(dtype=np.float64)
    planned = results["planned_power_kw"].to_numpy(dtype=np.float64)
    occupied = np.asarray(occupied, dtype=bool)
    planned_ok = np.isfinite(planned)
    out: dict[str, float] = {"unplanned_periods": int(np.sum(~planned_ok))}
    for name, mask in (("occupied", occupied), ("unoccupied", ~occupied)):
        graded = mask & planned_ok
        planned_kwh = float(np.sum(planned[graded]) * step_h) if graded.any() else math.nan
        metered_kwh = float(np.sum(metered[graded]) * step_h) if graded.any() else math.nan
        out[f"planned_{name}_kwh"] = planned_kwh
        out[f"metered_{name}_kwh"] = metered_kwh
        out[f"planned_over_metered_{name}"] = (
            planned_kwh / metered_kwh if metered_kwh > 0 else math.nan
        )
    return out


def weekday_peaks(results: pd.DataFrame) -> pd.DataFrame:
    """One row per weekday (Monday to Friday, local date) that has a committed cap:
    ``metered_peak_kw`` (the day's largest ``power_kw``), ``committed_peak_kw`` (the day's
    largest ``committed_peak_kw``) and their ``ratio``. Empty without a committed cap."""
    columns = ["metered_peak_kw", "committed_peak_kw", "ratio"]
    if "committed_peak_kw" not in results or not isinstance(results.index, pd.DatetimeIndex):
        return pd.DataFrame(columns=columns, dtype=np.float64)
    frame = pd.DataFrame(
        {"metered_peak_kw": results["power_kw"], "committed_peak_kw": results["committed_peak_kw"]}
    )
    index = results.index
    frame = frame[index.day_of_week < 5]
    days = frame.groupby(index[index.day_of_week < 5].normalize()).max()
    days = days[np.isfinite(days["committed_peak_kw"]) & (days["committed_peak_kw"] > 0)]
    days["ratio"] = days["metered_peak_kw"] / days["committed_peak_kw"]
    days.index.name = "date"
    out: pd.DataFrame = days[columns]
    return out


def monthly_peaks(results: pd.DataFrame) -> pd.DataFrame:
    """One row per calendar month (local time) that has a plan: ``metered_peak_kw`` (the
    month's largest ``power_kw``), ``planned_peak_kw`` (its largest ``planned_power_kw``,
    the plan's first-step power) and their ``ratio``."""
    columns = ["metered_peak_kw", "planned_peak_kw", "ratio"]
    if not isinstance(results.index, pd.DatetimeIndex):
        return pd.DataFrame(columns=columns, dtype=np.float64)
    frame = pd.DataFrame(
        {"metered_peak_kw": results["power_kw"], "planned_peak_kw": results["planned_power_kw"]}
    )
    local = results.index.tz_localize(None) if results.index.tz is not None else results.index
    months = frame.groupby(local.to_period("M")).max()
    months = months[np.isfinite(months["planned_peak_kw"]) & (months["planned_peak_kw"] > 0)]
    months["ratio"] = months["metered_peak_kw"] / months["planned_peak_kw"]
    months.index.name = "month"
    out: pd.DataFrame = months[columns]
    return out


def summary(results: pd.DataFrame, occupied: np.ndarray, step_h: float) -> dict[str, float]:
    """The meter's grade of the plan as flat KPIs (:func:`hvacflex.kpi.summary` merges them):

    * :func:`planned_metered_kwh`'s seven keys;
    * ``weekday_peak_over_committed_max``: the largest weekday ratio of :func:`weekday_peaks`,
      and ``weekday_peak_within_commitment_share``: the share of those weekdays whose ratio is
      ≤ :data:`PEAK_TOLERANCE` (NaN without a committed cap);
    * ``monthly_peak_over_planned_max``: the largest monthly ratio of :func:`monthly_peaks`
      (NaN without a plan).
    """
    out = planned_metered_kwh(results, occupied, step_h)
    days = weekday_peaks(results)
    ratios = days["ratio"].to_numpy(dtype=np.float64)
    out["weekday_peak_over_committed_max"] = float(ratios.max()) if ratios.size else math.nan
    out["weekday_peak_within_commitment_share"] = (
        float(np.mean(ratios <= PEAK_TOLERANCE)) if ratios.size else math.nan
    )
    months = monthly_peaks(results)["ratio"].to_numpy(dtype=np.float64)
    out["monthly_peak_over_planned_max"] = float(months.max()) if months.size else math.nan
    return out
