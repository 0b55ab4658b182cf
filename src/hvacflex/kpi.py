"""Key performance indicators of a closed-loop run.

Every function takes the results DataFrame of one run (one row per control step; the column
schema is the columns of ``docs/reference/results.md``) and returns a number, a
Series or a small DataFrame whose unit is in its name. The functions are pure: they never modify
their input and never read files (:func:`hvacflex.results.load_results` reads one). Column names
come from the schema in :mod:`hvacflex.results`; they work on any frame with those columns
(a fleet's totals too: :mod:`hvacflex.fleet.kpi`).

Conventions
-----------
* Row ``k`` describes the period ``[t_k, t_k + Δt)``; the index holds the period starts
  (tz-aware, Asia/Singapore). ``Δt`` is the median spacing of the index in hours,
  :data:`DEFAULT_STEP_H` (30 min) when the index is not a ``DatetimeIndex`` or has fewer
  than two rows.
* Zones are discovered from the ``temp_<zone>_degc`` columns (``temp_end_``, ``temp_served_``
  and ``temp_curtailed_`` columns of the same zones are not zones themselves;
  :func:`hvacflex.results.zone_names`).
* Energy is ``Σ_k P_k Δt``; energy cost ``Σ_k c_k P_k Δt / 1000`` with ``c`` in SGD/MWh;
  reserve revenue ``Σ_k b_k R_k Δt / 1000`` for the capacity ``R`` offered (paid whether or
  not the interruptible load is activated).
* Net cost is energy cost − reserve revenue + IL penalty: the paper's Table 1 "Total" (the
  paper has no penalty). The peak-power charge (PPP) is reported separately, as the paper
  does.
  ``ppp_charge_sgd`` is the charge prorated to the days the run covers (a one-day run bears
  1/30 of its month's charge), ``ppp_charge_monthly_sgd`` the months billed whole.
* Reserve revenue splits into **settled** (the activated periods: delivery checked against the
  meter) and **unsettled** availability payments (every other period: nothing metered shows
  the capacity was there).
* Occupied periods are the schedule's, read from the comfort columns: a zone's narrowest band
  in the run is its occupied band (:func:`occupied_mask`).
* IL settlement against metered power (:mod:`hvacflex.settlement`,
``docs/explanation/il_events.md``):
  in an activated period (``il_activated``) the building **delivers** ``il_delivered_kw`` =
  max(0, ``il_baseline_power_kw`` − ``power_kw``); the **shortfall** ``il_shortfall_kw`` =
  max(0, ``reserve_kw`` − delivered) is charged at ``il_penalty_price_sgd_per_mwh`` plus the
  forfeited reserve price ``il_forfeited_price_sgd_per_mwh``. Results without the
  settlement columns are settled here with the ``pre-event`` baseline; without
  ``il_activated`` (older runs) they have no IL events.
* Peaks are taken on 30-min average power (the billing interval): steps shorter than
  30 min are averaged into 30-min intervals; longer steps are used as they are.
* Months are calendar months in the index's local time.
* Discomfort follows BOPTEST's ``tdis``: the time integral of the deviation of the zone
  temperature outside ``[lower, upper]``. Sampled here at period end
  (``temp_end_<zone>_degc`` against the band in force at period end) times ``Δt`` —
  a right-endpoint rectangle rule [K·h].
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from hvacflex import meter_grade, settlement
from hvacflex import results as schema
from hvacflex.errors import DataError
from hvacflex.units import KWH_PER_MWH

DEFAULT_STEP_H = 0.5
"""Step length assumed when the index does not tell it [h]."""

BILLING_INTERVAL_H = 0.5
"""Averaging interval of power for peak and PPP [h] (the NEMS settlement period)."""

VIOLATION_TOLERANCE_K = 0.01
"""A step counts as a comfort violation when some zone is more than this outside its band [K]."""

PLANNED_SLACK_TOLERANCE_K = 1e-6
"""A plan counts as needing slack when its largest slack exceeds this [K] (LP tolerance)."""


_HOURS_PER_DAY = 24.0


def _column(results: pd.DataFrame, name: str) -> pd.Series:
    if name not in results.columns:
        raise DataError(
            "results frame lacks a required column",
            source="results",
            field=name,
            hint="see the columns in docs/reference/results.md for the column schema",
        )
    return results[name]


def _values(results: pd.DataFrame, name: str) -> np.ndarray:
    return np.asarray(_column(results, name), dtype=float)


def _require_datetime_index(results: pd.DataFrame) -> pd.DatetimeIndex:
    index = results.index
    if not isinstance(index, pd.DatetimeIndex):
        raise DataError(
            "monthly KPIs need a DatetimeIndex of period starts",
            source="results",
            field="time (index)",
            value=type(index).__name__,
            hint="set the 'time' column as the index",
        )
    return index


def _month_index(index: pd.DatetimeIndex) -> pd.PeriodIndex:
    """Calendar month of each period start, in the index's local time."""
    local = index.tz_localize(None) if index.tz is not None else index
    return local.to_period("M").rename("month")


def zone_names(results: pd.DataFrame) -> list[str]:
    """Zone names, in column order, from the ``temp_<zone>_degc`` columns.

    Raises
    ------
    DataError
        When the frame has no zone temperature column.
    """
    zones = schema.zone_names(results.columns)
    if not zones:
        raise DataError(
            "results frame has no zone temperature column 'temp_<zone>_degc'",
            source="results",
            field="temp_<zone>_degc",
        )
    return zones


def step_hours(results: pd.DataFrame) -> float:
    """Control step Δt [h]: median spacing of a ``DatetimeIndex``, else :data:`DEFAULT_STEP_H`."""
    index = results.index
    if not isinstance(index, pd.DatetimeIndex) or len(index) < 2:
        return DEFAULT_STEP_H
    spacing_h = np.diff(index.to_numpy()) / np.timedelta64(1, "h")
    return float(np.median(spacing_h))


# ----------------------------------------------------------------------------- money and energy


def energy_kwh(results: pd.DataFrame) -> float:
    """Electric energy drawn by the plant, ``Σ_k P_k Δt`` [kWh] (column ``power_kw``)."""
    return float(np.sum(_values(results, "power_kw")) * step_hours(results))


FACILITY_POWER_COLUMN = "facility_power_kw"
"""Whole-facility electric power [kW], metered by a plant that meters it (EnergyPlus)."""


def facility_metered(results: pd.DataFrame) -> bool:
    """Whether the plant metered the whole facility (``facility_power_kw`` finite in every
    step; NaN on the RC plant, which models the HVAC only)."""
    if FACILITY_POWER_COLUMN not in results.columns or results.empty:
        return False
    return bool(np.all(np.isfinite(_values(results, FACILITY_POWER_COLUMN))))


def facility_summary(results: pd.DataFrame) -> dict[str, float]:
    """``facility_energy_kwh`` [kWh] and ``facility_peak_power_kw`` [kW] (largest 30-min
    average) of the whole facility where the plant meters it (:func:`facility_metered`);
    {} otherwise. Every other energy and peak KPI is the HVAC's (``power_kw``)."""
    if not facility_metered(results):
        return {}
    facility = results[[FACILITY_POWER_COLUMN]].rename(columns={FACILITY_POWER_COLUMN: "power_kw"})
    return {
        "facility_energy_kwh": energy_kwh(facility),
        "facility_peak_power_kw": peak_power_kw(facility),
    }


def energy_cost_sgd(results: pd.DataFrame) -> float:
    """Energy cost ``Σ_k c_k P_k Δt / 1000`` [SGD].

    Uses ``power_kw`` [kW] and ``energy_price_sgd_per_mwh`` [SGD/MWh].
    """
    power_kw = _values(results, "power_kw")
    price_sgd_per_mwh = _values(results, "energy_price_sgd_per_mwh")
    return float(np.sum(power_kw * price_sgd_per_mwh) * step_hours(results) / KWH_PER_MWH)


def reserve_revenue_sgd(results: pd.DataFrame) -> float:
    """Reserve revenue ``Σ_k b_k R_k Δt / 1000`` for the capacity offered [SGD].

    Uses ``reserve_kw`` [kW] and ``reserve_price_sgd_per_mwh`` [SGD/MWh].
    """
    reserve_kw = _values(results, "reserve_kw")
    price_sgd_per_mwh = _values(results, "reserve_price_sgd_per_mwh")
    return float(np.sum(reserve_kw * price_sgd_per_mwh) * step_hours(results) / KWH_PER_MWH)


def reserve_revenue_settled_sgd(results: pd.DataFrame) -> float:
    """Reserve revenue of the activated periods [SGD]: ``Σ_{k activated} b_k R_k Δt / 1000``,
    the payments whose delivery was settled against the meter (delivered or charged as a
    shortfall, :mod:`hvacflex.settlement`). 0 without activations."""
    reserve_kw = np.where(_activated(results), _values(results, "reserve_kw"), 0.0)
    price_sgd_per_mwh = _values(results, "reserve_price_sgd_per_mwh")
    return float(np.sum(reserve_kw * price_sgd_per_mwh) * step_hours(results) / KWH_PER_MWH)


def reserve_revenue_unsettled_sgd(results: pd.DataFrame) -> float:
    """Availability payments no meter ever settled [SGD]: the reserve revenue of the periods
    without an activation (:func:`reserve_revenue_sgd` − :func:`reserve_revenue_settled_sgd`).
    Nothing in the run shows that this capacity could have been delivered; with the shipped
    (synthetic) reserve price it is hvacflex's own estimate of a market payment."""
    return reserve_revenue_sgd(results) - reserve_revenue_settled_sgd(results)


def net_cost_sgd(results: pd.DataFrame) -> float:
    """Energy cost − reserve revenue + IL penalty [SGD]: Table 1 "Total" (PPP excluded)."""
    return energy_cost_sgd(results) - reserve_revenue_sgd(results) + il_penalty_sgd(results)


# ----------------------------------------------------------------------------- IL settlement


def _optional(results: pd.DataFrame, name: str, fill: float) -> np.ndarray:
    """A column as floats, or ``fill`` everywhere when the frame lacks it (older results)."""
    if name not in results.columns:
        return np.full(len(results), fill)
    return np.asarray(results[name], dtype=float)


def _flag(results: pd.DataFrame, name: str) -> np.ndarray:
    return _optional(results, name, 0.0) > 0.5


def _activated(results: pd.DataFrame) -> np.ndarray:
    return _flag(results, "il_activated")


def _settled(results: pd.DataFrame, name: str) -> np.ndarray:
    """A settlement column (:mod:`hvacflex.settlement`), or — for results written before
    it existed — the same column computed from the frame with the ``pre-event`` baseline."""
    if name in results.columns:
        values: np.ndarray = np.nan_to_num(np.asarray(results[name], dtype=float))
        return values
    return settlement.settlement_columns(results)[name].to_numpy(dtype=float)


def il_delivered_kw(results: pd.DataFrame) -> np.ndarray:
    """(T,) reserve delivered against the metered baseline [kW]: ``il_delivered_kw`` =
    max(0, ``il_baseline_power_kw`` − ``power_kw``) in activated periods, 0 elsewhere."""
    return _settled(results, settlement.DELIVERED_COLUMN)


def il_shortfall_kw(results: pd.DataFrame) -> np.ndarray:
    """(T,) reserve paid for but not delivered in activated periods, ``max(R − delivered,
    0)`` [kW] (column ``il_shortfall_kw``)."""
    return _settled(results, settlement.SHORTFALL_COLUMN)


def il_offered_kwh(results: pd.DataFrame) -> float:
    """Reserve energy due over the activated periods, ``Σ reserve_kw · Δt`` [kWh]."""
    offered = _values(results, "reserve_kw")[_activated(results)]
    return float(np.sum(offered) * step_hours(results))


def il_delivered_metered_kwh(results: pd.DataFrame) -> float:
    """Reserve energy delivered against the metered baseline, ``Σ il_delivered_kw · Δt``
    [kWh] (activated periods)."""
    return float(np.sum(il_delivered_kw(results)) * step_hours(results))


def il_delivered_counterfactual_kwh(results: pd.DataFrame) -> float:
    """The plant's own reduction over the activated periods, ``Σ max(0, power_served_kw −
    power_kw) · Δt`` [kWh]: the same step without curtailment less the metered power (for
    diagnosis: the market cannot see it). NaN where the plant cannot give the served step
    (a plant that cannot snapshot) in an activated period; 0 without activations."""
    activated = _activated(results)
    served = _optional(results, "power_served_kw", np.nan)[activated]
    if np.any(~np.isfinite(served)):
        return float("nan")
    reduction = np.maximum(served - _values(results, "power_kw")[activated], 0.0)
    return float(np.sum(reduction) * step_hours(results))


def il_shortfall_kwh(results: pd.DataFrame) -> float:
    """Energy of reserve not delivered during activations [kWh]."""
    return float(np.sum(il_shortfall_kw(results)) * step_hours(results))


def il_penalty_step_sgd(results: pd.DataFrame) -> np.ndarray:
    """(T,) non-delivery penalty of each period ``S_k Δt (π_k + f_k) / 1000`` [SGD]: the
    shortfall S at the penalty price π (``il_penalty_price_sgd_per_mwh``) plus the forfeited
    reserve payment f (``il_forfeited_price_sgd_per_mwh``, the reserve price when the
    contract forfeits it); no penalty where the columns are absent."""
    price = _optional(results, "il_penalty_price_sgd_per_mwh", 0.0) + np.nan_to_num(
        _optional(results, "il_forfeited_price_sgd_per_mwh", 0.0)
    )
    penalty: np.ndarray = il_shortfall_kw(results) * price * step_hours(results) / KWH_PER_MWH
    return penalty


def il_penalty_sgd(results: pd.DataFrame) -> float:
    """Non-delivery penalty summed over the run [SGD] (:func:`il_penalty_step_sgd`)."""
    return float(np.sum(il_penalty_step_sgd(results)))


def il_delivered_ratio(results: pd.DataFrame) -> float:
    """Delivered (metered) / offered reserve energy over the activated periods.

    NaN when no reserve was due (no activation, or nothing offered in the activated
    periods): a ratio of nothing to nothing is not a delivery record (shown as "–").
    """
    offered = il_offered_kwh(results)
    if offered <= 0.0:
        return float("nan")
    return il_delivered_metered_kwh(results) / offered


def il_recovery_energy_kwh(results: pd.DataFrame) -> float:
    """Extra energy in the recovery periods after events vs the locked plan [kWh].

    ``Σ (power_kw − il_reference_power_kw) Δt`` over the event-window periods that are not
    curtailed (``il_event_window`` and not ``il_curtailed``) and have a reference.
    """
    recovery = _flag(results, "il_event_window") & ~_flag(results, "il_curtailed")
    extra = _values(results, "power_kw") - _optional(results, "il_reference_power_kw", np.nan)
    return float(np.nansum(extra[recovery]) * step_hours(results))


def _block_count(flags: np.ndarray) -> int:
    """Number of blocks of consecutive true periods."""
    return int(np.sum(flags & ~np.concatenate([[False], flags[:-1]])))


def il_event_count(results: pd.DataFrame) -> int:
    """Number of IL events: blocks of activated periods (``il_activated``; a period activated
    after one that was not), whether or not the building curtailed in them."""
    return _block_count(_activated(results))


def il_curtailment_count(results: pd.DataFrame) -> int:
    """Number of curtailment blocks (``il_curtailed``; a period curtailed after one that was
    not): the events in which the building shed load."""
    return _block_count(_flag(results, "il_curtailed"))


def il_beyond_model_steps(results: pd.DataFrame) -> int:
    """Activated periods past the event length D, when consumption resumed (120-min rule)."""
    return int(np.sum(_flag(results, "il_beyond_model")))


def reserve_offered_mean_kw(results: pd.DataFrame) -> float:
    """Mean reserve capacity offered per period [kW] (0 in periods without an offer)."""
    reserve_kw = _values(results, "reserve_kw")
    return float(np.mean(reserve_kw)) if reserve_kw.size else 0.0


def reserve_period_share(results: pd.DataFrame, tolerance_kw: float = 1e-6) -> float:
    """Share of periods (0–1) with a reserve offer above ``tolerance_kw``."""
    reserve_kw = _values(results, "reserve_kw")
    return float(np.mean(reserve_kw > tolerance_kw)) if reserve_kw.size else 0.0


# ----------------------------------------------------------------------------- peaks and PPP


def power_30min_kw(results: pd.DataFrame) -> pd.Series:
    """Plant power averaged over the 30-min billing intervals [kW].

    Returns ``power_kw`` itself when the step is 30 min or longer (or the index is not a
    ``DatetimeIndex``); otherwise the mean over each 30-min interval aligned to local midnight.
    """
    power = _column(results, "power_kw").astype(float)
    if not isinstance(results.index, pd.DatetimeIndex):
        return power
    if step_hours(results) >= BILLING_INTERVAL_H - 1e-9:
        return power
    return power.resample(pd.Timedelta(hours=BILLING_INTERVAL_H)).mean().dropna()


def _peak_price_30min_sgd_per_kw(
    results: pd.DataFrame, power_30min: pd.Series, peak_price_sgd_per_kw: float | None
) -> pd.Series:
    if peak_price_sgd_per_kw is not None:
        return pd.Series(float(peak_price_sgd_per_kw), index=power_30min.index)
    price = _column(results, "peak_price_sgd_per_kw").astype(float)
    if len(price) == len(power_30min):
        return pd.Series(price.to_numpy(), index=power_30min.index)
    return price.resample(pd.Timedelta(hours=BILLING_INTERVAL_H)).mean().reindex(power_30min.index)


def peak_power_kw(results: pd.DataFrame) -> float:
    """Largest 30-min average plant power over the whole run [kW]."""
    return float(np.max(power_30min_kw(results).to_numpy()))


def monthly_peak_power_kw(results: pd.DataFrame) -> pd.Series:
    """Largest 30-min average plant power in each calendar month [kW].

    Returns
    -------
    Series indexed by a monthly ``PeriodIndex`` named ``month``.
    """
    _require_datetime_index(results)
    power = power_30min_kw(results)
    months = _month_index(pd.DatetimeIndex(power.index))
    return power.groupby(months).max().rename("peak_power_kw")


def monthly_ppp_charge_sgd(
    results: pd.DataFrame, peak_price_sgd_per_kw: float | None = None
) -> pd.Series:
    """Peak-power charge of each calendar month [SGD].

    With a constant price φ [SGD/kW]: φ × the month's largest 30-min average power. With
    ``peak_price_sgd_per_kw=None`` the column of that name is used; when it varies in time the
    charge is ``max_k φ_k P_k`` over the month (docs/explanation/model.md §2), which equals φ × peak
    when constant.

    Returns
    -------
    Series indexed by a monthly ``PeriodIndex`` named ``month``.
    """
    _require_datetime_index(results)
    power = power_30min_kw(results)
    price = _peak_price_30min_sgd_per_kw(results, power, peak_price_sgd_per_kw)
    months = _month_index(pd.DatetimeIndex(power.index))
    return (power * price).groupby(months).max().rename("ppp_charge_sgd")


def ppp_charge_monthly_sgd(
    results: pd.DataFrame, peak_price_sgd_per_kw: float | None = None
) -> float:
    """Peak-power charge of the calendar months the run touches, each billed whole [SGD]:
    ``Σ_month`` :func:`monthly_ppp_charge_sgd` (what the utility bills for those months; a
    one-day run is billed its month's charge in full).

    See :func:`monthly_ppp_charge_sgd` for the price φ (argument, else the
    ``peak_price_sgd_per_kw`` column).
    """
    return float(monthly_ppp_charge_sgd(results, peak_price_sgd_per_kw).sum())


def ppp_charge_sgd(results: pd.DataFrame, peak_price_sgd_per_kw: float | None = None) -> float:
    """Peak-power charge prorated to the days the run covers [SGD]:
    ``Σ_month charge_month × days covered / days in that month`` (a whole month is billed its
    charge, a one-day run 1/30 of it), so that it adds up with the energy cost of the same
    days. :func:`ppp_charge_monthly_sgd` is the charge of the months billed whole.

    See :func:`monthly_ppp_charge_sgd` for the price φ (argument, else the
    ``peak_price_sgd_per_kw`` column).
    """
    charge = monthly_ppp_charge_sgd(results, peak_price_sgd_per_kw)
    fraction = month_fraction(results).reindex(charge.index).fillna(0.0)
    return float((charge * fraction).sum())


def month_fraction(results: pd.DataFrame) -> pd.Series:
    """Share (0–1) of each calendar month the run covers: steps × Δt / 24 / days in month.

    Returns
    -------
    Series indexed by a monthly ``PeriodIndex`` named ``month``.
    """
    index = _require_datetime_index(results)
    months = _month_index(index)
    days = pd.Series(step_hours(results) / _HOURS_PER_DAY, index=months).groupby(level=0).sum()
    days_in_month = np.asarray(pd.PeriodIndex(days.index).days_in_month, dtype=float)
    fraction: pd.Series = (days / days_in_month).rename("month_fraction")
    return fraction


# ----------------------------------------------------------------------------- Table 1


def monthly_table(
    results: pd.DataFrame, peak_price_sgd_per_kw: float | None = None
) -> pd.DataFrame:
    """Per-month sums, the rows behind the paper's Table 1.

    Returns
    -------
    DataFrame indexed by a monthly ``PeriodIndex`` named ``month`` with columns

    * ``days``: days of the month covered by the run (steps × Δt / 24),
    * ``month_fraction``: ``days`` / days in that calendar month (1.0 for a complete month),
    * ``energy_cost_sgd``, ``reserve_revenue_sgd``, ``il_penalty_sgd``, ``net_cost_sgd``,
      ``energy_kwh``, and the IL settlement of the activated periods: ``il_offered_kwh``,
      ``il_delivered_metered_kwh``, ``il_shortfall_kwh`` and ``il_net_revenue_sgd``
      (reserve revenue − penalty): sums over the covered part of the month,
    * ``peak_power_kw``, ``ppp_charge_sgd``: the month's peak and its PPP charge.

    Use :func:`monthly_average` for the "average per month" of Table 1.
    """
    index = _require_datetime_index(results)
    dt_h = step_hours(results)
    months = _month_index(index)
    power_kw = _values(results, "power_kw")
    activated = _activated(results)
    frame = pd.DataFrame(
        {
            "days": np.full(len(results), dt_h / _HOURS_PER_DAY),
            "energy_cost_sgd": power_kw
            * _values(results, "energy_price_sgd_per_mwh")
            * dt_h
            / KWH_PER_MWH,
            "reserve_revenue_sgd": _values(results, "reserve_kw")
            * _values(results, "reserve_price_sgd_per_mwh")
            * dt_h
            / KWH_PER_MWH,
            "il_penalty_sgd": il_penalty_step_sgd(results),
            "energy_kwh": power_kw * dt_h,
            "il_offered_kwh": np.where(activated, _values(results, "reserve_kw"), 0.0) * dt_h,
            "il_delivered_metered_kwh": il_delivered_kw(results) * dt_h,
            "il_shortfall_kwh": il_shortfall_kw(results) * dt_h,
        },
        index=months,
    )
    table = frame.groupby(level="month").sum()
    table["il_net_revenue_sgd"] = table["reserve_revenue_sgd"] - table["il_penalty_sgd"]
    table["net_cost_sgd"] = (
        table["energy_cost_sgd"] - table["reserve_revenue_sgd"] + table["il_penalty_sgd"]
    )
    days_in_month = np.asarray(pd.PeriodIndex(table.index).days_in_month, dtype=float)
    table.insert(1, "month_fraction", table["days"].to_numpy() / days_in_month)
    table["peak_power_kw"] = monthly_peak_power_kw(results)
    table["ppp_charge_sgd"] = monthly_ppp_charge_sgd(results, peak_price_sgd_per_kw)
    columns = [
        "days",
        "month_fraction",
        "energy_cost_sgd",
        "reserve_revenue_sgd",
        "il_penalty_sgd",
        "net_cost_sgd",
        "energy_kwh",
        *MONTHLY_IL_COLUMNS,
        "peak_power_kw",
        "ppp_charge_sgd",
    ]
    return table[columns]


MONTHLY_IL_COLUMNS = (
    "il_offered_kwh",
    "il_delivered_metered_kwh",
    "il_shortfall_kwh",
    "il_net_revenue_sgd",
)
"""The IL settlement columns of :func:`monthly_table` (activated periods; revenue − penalty)."""

MONTHLY_SUM_COLUMNS = (
    "energy_cost_sgd",
    "reserve_revenue_sgd",
    "il_penalty_sgd",
    "net_cost_sgd",
    "energy_kwh",
    *MONTHLY_IL_COLUMNS,
)
"""Columns of :func:`monthly_table` that are sums over the covered days (averaged per month)."""


def monthly_average(table: pd.DataFrame) -> pd.Series:
    """Average per month of a :func:`monthly_table`: the numbers of the paper's Table 1.

    Each sum column is divided by the number of *month-equivalents* covered,
    ``Σ month_fraction``. For complete months this is the plain mean over months of the
    per-month sums (a whole year: annual sum / 12). A partial month counts as the fraction of
    its calendar month that the run covers, so a one-week run is extrapolated to a month of
    the same calendar length. Peaks are averaged over months plainly (a partial month's peak
    is the peak so far); ``ppp_charge_sgd`` likewise.

    Returns
    -------
    Series with the sum columns, ``peak_power_kw``, ``ppp_charge_sgd``, ``days`` (total days
    covered) and ``months`` (month-equivalents).
    """
    months = float(table["month_fraction"].sum())
    sums = [col for col in MONTHLY_SUM_COLUMNS if col in table.columns]  # older tables: no IL
    averages = {col: float(table[col].sum()) / months for col in sums}
    averages["peak_power_kw"] = float(table["peak_power_kw"].mean())
    averages["ppp_charge_sgd"] = float(table["ppp_charge_sgd"].mean())
    averages["days"] = float(table["days"].sum())
    averages["months"] = months
    return pd.Series(averages, name="monthly_average")


# ----------------------------------------------------------------------------- comfort


def _comfort_deviation_k(results: pd.DataFrame, allowance_k: float = 0.0) -> pd.DataFrame:
    """(T, m) deviation outside the band at period end [K], ≥ 0, one column per zone.

    ``allowance_k`` > 0 widens the upper bound by the column ``il_allowance_k`` (the IL
    allowance α in event and recovery periods) times that factor.
    """
    widen = allowance_k * np.nan_to_num(_optional(results, "il_allowance_k", 0.0))
    deviations = {}
    for zone in zone_names(results):
        temp = _values(results, schema.TEMP_END.name(zone))
        lower = _values(results, schema.COMFORT_LOWER.name(zone))
        upper = _values(results, schema.COMFORT_UPPER.name(zone)) + widen
        deviations[zone] = np.maximum(lower - temp, 0.0) + np.maximum(temp - upper, 0.0)
    return pd.DataFrame(deviations, index=results.index)


OCCUPIED_BAND_TOLERANCE_K = 1e-6
"""Two comfort bands whose widths differ by less than this are the same band [K]."""


def occupied_mask(results: pd.DataFrame) -> pd.DataFrame:
    """(T, m) bool: the periods in which each zone's band in force is its **occupied** band.

    "Occupied" is the schedule's occupied periods, read from the comfort columns (the band
    the KPIs grade against), not the stochastic occupancy the plant may realise. The
    occupied band of a zone is its narrowest band in the run (``comfort_upper`` −
    ``comfort_lower``; the occupied band is the tight one). A zone whose band never changes
    over the run is graded occupied throughout (a run within office hours, or a scenario
    with one band).
    """
    occupied = {}
    for zone in zone_names(results):
        width = _values(results, schema.COMFORT_UPPER.name(zone)) - _values(
            results, schema.COMFORT_LOWER.name(zone)
        )
        finite = np.isfinite(width)
        narrowest = float(np.min(width[finite])) if finite.any() else np.nan
        occupied[zone] = finite & (width <= narrowest + OCCUPIED_BAND_TOLERANCE_K)
    return pd.DataFrame(occupied, index=results.index)


def discomfort_occupied_kelvin_hours(results: pd.DataFrame) -> float:
    """Discomfort in the occupied periods (:func:`occupied_mask`) [K·h], all zones: what the
    occupants feel. With :func:`discomfort_unoccupied_kelvin_hours` it sums to
    :func:`total_discomfort_kelvin_hours`."""
    deviation = _comfort_deviation_k(results).to_numpy()
    return float(np.sum(deviation[occupied_mask(results).to_numpy()]) * step_hours(results))


def discomfort_unoccupied_kelvin_hours(results: pd.DataFrame) -> float:
    """Discomfort outside the occupied periods [K·h], all zones: excursions past the night
    and weekend band while nobody is meant to be in."""
    deviation = _comfort_deviation_k(results).to_numpy()
    return float(np.sum(deviation[~occupied_mask(results).to_numpy()]) * step_hours(results))


def max_violation_occupied_k(results: pd.DataFrame) -> float:
    """Largest deviation outside the band in an occupied period, all zones [K] (0 when never
    outside it, or never occupied)."""
    return _max_violation_k(results, occupied=True)


def max_violation_unoccupied_k(results: pd.DataFrame) -> float:
    """Largest deviation outside the band in an unoccupied period, all zones [K]: the night
    and weekend excursions (0 when never outside it, or never unoccupied)."""
    return _max_violation_k(results, occupied=False)


def _max_violation_k(results: pd.DataFrame, *, occupied: bool) -> float:
    deviation = _comfort_deviation_k(results).to_numpy()
    mask = occupied_mask(results).to_numpy()
    chosen = deviation[mask if occupied else ~mask]
    return float(np.max(chosen)) if chosen.size else 0.0


def discomfort_event_kelvin_hours(results: pd.DataFrame) -> float:
    """Discomfort in IL event windows against the normal band [K·h], all zones.

    Over the periods of ``il_event_window`` (curtailment and recovery), the deviation at
    period end from the strict band — what the occupants feel, allowance or not; split by
    :func:`discomfort_event_within_allowance_kelvin_hours` and
    :func:`discomfort_event_beyond_allowance_kelvin_hours`. 0 without events.
    """
    window = _flag(results, "il_event_window")
    deviation = _comfort_deviation_k(results).to_numpy()
    return float(np.sum(deviation[window]) * step_hours(results))


def discomfort_event_beyond_allowance_kelvin_hours(results: pd.DataFrame) -> float:
    """Discomfort in IL event windows beyond the allowance [K·h], all zones: the deviation
    from the band whose upper bound is widened by α (``il_allowance_k``), what the contract
    does not allow. 0 without events."""
    window = _flag(results, "il_event_window")
    deviation = _comfort_deviation_k(results, allowance_k=1.0).to_numpy()
    return float(np.sum(deviation[window]) * step_hours(results))


def discomfort_event_within_allowance_kelvin_hours(results: pd.DataFrame) -> float:
    """Discomfort in IL event windows that the allowance covers [K·h]: against the normal
    band less beyond the allowance (the warming the contract allows and the occupants
    still feel)."""
    return discomfort_event_kelvin_hours(results) - discomfort_event_beyond_allowance_kelvin_hours(
        results
    )


def discomfort_outside_events_kelvin_hours(results: pd.DataFrame) -> float:
    """Discomfort outside IL event windows [K·h], all zones, against the strict band."""
    window = _flag(results, "il_event_window")
    deviation = _comfort_deviation_k(results).to_numpy()
    return float(np.sum(deviation[~window]) * step_hours(results))


def discomfort_kelvin_hours(results: pd.DataFrame) -> pd.Series:
    """Thermal discomfort per zone [K·h] (BOPTEST ``tdis``, sampled at period end).

    ``Σ_k Δt (max(lower_k − T_end,k, 0) + max(T_end,k − upper_k, 0))`` from the columns
    ``temp_end_<zone>_degc``, ``comfort_lower_<zone>_degc``, ``comfort_upper_<zone>_degc``.

    Returns
    -------
    Series indexed by zone name.
    """
    return (_comfort_deviation_k(results).sum() * step_hours(results)).rename(
        "discomfort_kelvin_hours"
    )


def step_discomfort_kelvin_hours(results: pd.DataFrame) -> pd.Series:
    """(T,) discomfort of each period summed over zones [K·h] (the terms of
    :func:`total_discomfort_kelvin_hours`): ``Δt Σ_zone deviation at period end``.

    Returns
    -------
    Series on the frame's index, named ``discomfort_kelvin_hours``.
    """
    step_h = step_hours(results)
    deviation = _comfort_deviation_k(results)
    total = np.zeros(len(results))
    for zone in deviation.columns:  # zone order, as the fleet's column always summed
        total += deviation[zone].to_numpy() * step_h
    return pd.Series(total, index=results.index, name="discomfort_kelvin_hours")


def total_discomfort_kelvin_hours(results: pd.DataFrame) -> float:
    """Discomfort summed over zones [K·h] (BOPTEST ``tdis_tot``)."""
    return float(discomfort_kelvin_hours(results).sum())


def max_violation_k(results: pd.DataFrame) -> pd.Series:
    """Largest deviation outside the comfort band per zone [K] (0 when never outside).

    Returns
    -------
    Series indexed by zone name.
    """
    return _comfort_deviation_k(results).max().rename("max_violation_k")


def violation_share(results: pd.DataFrame, tolerance_k: float = VIOLATION_TOLERANCE_K) -> float:
    """Share of steps (0–1) in which some zone is more than ``tolerance_k`` outside its band."""
    deviation = _comfort_deviation_k(results).to_numpy()
    if deviation.shape[0] == 0:
        return 0.0
    return float(np.mean(np.any(deviation > tolerance_k, axis=1)))


# ----------------------------------------------------------------------------- controller health


def fallback_count(results: pd.DataFrame) -> int:
    """Number of steps in which the controller used its fallback (column ``fallback``)."""
    return int(np.sum(_column(results, "fallback").fillna(False).astype(bool).to_numpy()))


def model_extrapolation_steps(results: pd.DataFrame) -> int:
    """Number of periods planned outside an identified model's validity range (column
    ``model_extrapolation``: a zone's planned end temperature or the forecast outdoor
    temperature beyond the training data's; docs/guide/identify.md). 0 for results written before
    the column existed."""
    if "model_extrapolation" not in results.columns:
        return 0
    flags = results["model_extrapolation"].fillna(False).astype(bool).to_numpy()
    return int(np.sum(flags))


def peak_guard_steps(results: pd.DataFrame) -> int:
    """Number of periods in which the in-period peak guard shed load to hold the committed
    peak (column ``peak_guard_active``; docs/explanation/model.md, the committed peak). 0 for
    results written before the column existed."""
    if "peak_guard_active" not in results.columns:
        return 0
    flags = results["peak_guard_active"].fillna(False).astype(bool).to_numpy()
    return int(np.sum(flags))


def planned_slack_share(
    results: pd.DataFrame, tolerance_k: float = PLANNED_SLACK_TOLERANCE_K
) -> float:
    """Share of steps (0–1) whose plan needed comfort slack > ``tolerance_k`` [K].

    Column ``planned_slack_max_k``; steps without a plan (NaN, e.g. a fallback or a
    rule-based controller) count as not needing slack but stay in the denominator.
    """
    slack_k = _values(results, "planned_slack_max_k")
    if slack_k.size == 0:
        return 0.0
    return float(np.mean(np.nan_to_num(slack_k, nan=0.0) > tolerance_k))


def max_delta_vs_half_band(results: pd.DataFrame) -> float:
    """Largest robust margin δ over the narrowest comfort half-band (dimensionless).

    ``max_k delta_max_k / min_{k, zone} (upper − lower) / 2``. Above 1 the margin cannot fit
    inside the tightest band (typically the occupied one) and the plan must use slack there.
    NaN when no step has a δ.
    """
    delta_k = _values(results, "delta_max_k")
    if delta_k.size == 0 or bool(np.all(np.isnan(delta_k))):
        return float("nan")
    half_band_k = min(
        float(
            np.nanmin(
                _values(results, schema.COMFORT_UPPER.name(zone))
                - _values(results, schema.COMFORT_LOWER.name(zone))
            )
        )
        / 2.0
        for zone in zone_names(results)
    )
    return float(np.nanmax(delta_k)) / half_band_k


def solve_time_stats_s(results: pd.DataFrame) -> dict[str, float]:
    """Mean, 95th percentile and maximum of ``solve_time_s`` [s], ignoring NaN.

    Returns
    -------
    ``{"mean": ..., "p95": ..., "max": ...}``; NaN values when no step has a solve time.
    """
    times_s = _values(results, "solve_time_s")
    times_s = times_s[~np.isnan(times_s)]
    if times_s.size == 0:
        return dict.fromkeys(("mean", "p95", "max"), float("nan"))
    return {
        "mean": float(np.mean(times_s)),
        "p95": float(np.percentile(times_s, 95.0)),
        "max": float(np.max(times_s)),
    }


# ----------------------------------------------------------------------------- summary

COUNT_KPIS = (
    "steps",
    "il_events",
    "il_curtailments",
    "il_curtailed_steps",
    "il_activated_steps",
    "il_beyond_model_steps",
    "fallback_count",
    "model_extrapolation_steps",
    "peak_guard_steps",
    "unplanned_periods",
)
"""Keys of :func:`summary` that count things: integers (``int``) in the summary, its JSON
and CSV, and printed as whole numbers."""


def summary(results: pd.DataFrame, peak_price_sgd_per_kw: float | None = None) -> dict[str, float]:
    """All KPIs of one run as a flat ``{name: value}`` mapping, units in the names.

    Keys: ``steps``, ``days``, ``energy_kwh``, ``energy_cost_sgd``, ``reserve_revenue_sgd``,
    ``reserve_revenue_settled_sgd``, ``reserve_revenue_unsettled_sgd``, ``il_penalty_sgd``,
    ``net_cost_sgd``, ``facility_energy_kwh`` and ``facility_peak_power_kw`` (only where the
    plant meters the facility: :func:`facility_summary`; every other energy and peak is the
    HVAC's), ``ppp_charge_sgd`` (prorated to the days covered),
    ``ppp_charge_monthly_sgd`` (the months billed whole), ``net_cost_with_ppp_sgd``,
    ``peak_power_kw``, ``monthly_avg_energy_cost_sgd``, ``monthly_avg_reserve_revenue_sgd``,
    ``monthly_avg_net_cost_sgd``, ``discomfort_kelvin_hours`` (total),
    ``discomfort_occupied_kelvin_hours``, ``discomfort_unoccupied_kelvin_hours`` (they sum to
    the total), ``discomfort_<zone>_kelvin_hours``, ``max_violation_k`` (all zones),
    ``max_violation_occupied_k``, ``max_violation_unoccupied_k``, ``max_violation_<zone>_k``,
    ``violation_share``, the IL keys of :func:`il_summary`, ``fallback_count``,
    ``model_extrapolation_steps``, ``peak_guard_steps``, the plan graded by the meter
    (:func:`hvacflex.meter_grade.summary`; only with a ``planned_power_kw`` column),
    ``planned_slack_share``, ``max_delta_vs_half_band``, ``solve_time_mean_s``,
    ``solve_time_p95_s``, ``solve_time_max_s``, ``prediction_error_*``
    (:func:`prediction_error_summary`; NaN for a rule). Monthly averages are omitted when the index
    is not a ``DatetimeIndex``, as are the PPP charges and ``net_cost_with_ppp_sgd``. The counts
    (:data:`COUNT_KPIS`) are ``int``.
    """
    out: dict[str, float] = {
        "steps": len(results),
        "days": len(results) * step_hours(results) / _HOURS_PER_DAY,
        "energy_kwh": energy_kwh(results),
        "energy_cost_sgd": energy_cost_sgd(results),
        "reserve_revenue_sgd": reserve_revenue_sgd(results),
        "reserve_revenue_settled_sgd": reserve_revenue_settled_sgd(results),
        "reserve_revenue_unsettled_sgd": reserve_revenue_unsettled_sgd(results),
        "il_penalty_sgd": il_penalty_sgd(results),
        "net_cost_sgd": net_cost_sgd(results),
    }
    out["peak_power_kw"] = peak_power_kw(results)
    out |= facility_summary(results)
    if isinstance(results.index, pd.DatetimeIndex):
        out["ppp_charge_sgd"] = ppp_charge_sgd(results, peak_price_sgd_per_kw)
        out["ppp_charge_monthly_sgd"] = ppp_charge_monthly_sgd(results, peak_price_sgd_per_kw)
        out["net_cost_with_ppp_sgd"] = out["net_cost_sgd"] + out["ppp_charge_sgd"]
        average = monthly_average(monthly_table(results, peak_price_sgd_per_kw))
        for col in ("energy_cost_sgd", "reserve_revenue_sgd", "net_cost_sgd"):
            out[f"monthly_avg_{col}"] = float(average[col])
    discomfort = discomfort_kelvin_hours(results)
    out["discomfort_kelvin_hours"] = float(discomfort.sum())
    out["discomfort_occupied_kelvin_hours"] = discomfort_occupied_kelvin_hours(results)
    out["discomfort_unoccupied_kelvin_hours"] = discomfort_unoccupied_kelvin_hours(results)
    out |= {f"discomfort_{zone}_kelvin_hours": float(v) for zone, v in discomfort.items()}
    violation = max_violation_k(results)
    out["max_violation_k"] = float(violation.max())
    out["max_violation_occupied_k"] = max_violation_occupied_k(results)
    out["max_violation_unoccupied_k"] = max_violation_unoccupied_k(results)
    out |= {f"max_violation_{zone}_k": float(v) for zone, v in violation.items()}
    out["violation_share"] = violation_share(results)
    out |= il_summary(results)
    out["fallback_count"] = fallback_count(results)
    out["model_extrapolation_steps"] = model_extrapolation_steps(results)
    out["peak_guard_steps"] = peak_guard_steps(results)
    if "planned_power_kw" in results:
        occupied = np.asarray(occupied_mask(results).to_numpy().any(axis=1), dtype=bool)
        out |= meter_grade.summary(results, occupied, step_hours(results))
    out["planned_slack_share"] = planned_slack_share(results)
    out["max_delta_vs_half_band"] = max_delta_vs_half_band(results)
    out |= {f"solve_time_{stat}_s": v for stat, v in solve_time_stats_s(results).items()}
    return out | prediction_error_summary(results)


def il_summary(results: pd.DataFrame) -> dict[str, float]:
    """The reserve and IL-event KPIs of :func:`summary` (see the IL settlement section)."""
    return {
        "reserve_offered_mean_kw": reserve_offered_mean_kw(results),
        "reserve_period_share": reserve_period_share(results),
        "il_events": il_event_count(results),
        "il_curtailments": il_curtailment_count(results),
        "il_curtailed_steps": int(np.sum(_flag(results, "il_curtailed"))),
        "il_activated_steps": int(np.sum(_activated(results))),
        "il_offered_kwh": il_offered_kwh(results),
        "il_delivered_metered_kwh": il_delivered_metered_kwh(results),
        "il_delivered_counterfactual_kwh": il_delivered_counterfactual_kwh(results),
        "il_delivered_ratio": il_delivered_ratio(results),
        "il_shortfall_kwh": il_shortfall_kwh(results),
        "il_recovery_energy_kwh": il_recovery_energy_kwh(results),
        "il_beyond_model_steps": il_beyond_model_steps(results),
        "discomfort_event_kelvin_hours": discomfort_event_kelvin_hours(results),
        "discomfort_event_within_allowance_kelvin_hours": (
            discomfort_event_within_allowance_kelvin_hours(results)
        ),
        "discomfort_event_beyond_allowance_kelvin_hours": (
            discomfort_event_beyond_allowance_kelvin_hours(results)
        ),
        "discomfort_outside_events_kelvin_hours": discomfort_outside_events_kelvin_hours(results),
    }


RULE_STATUS = "rule"
"""``solve_status`` of a step a rule-based controller decided (no model, no plan)."""


def is_rule_based(results: pd.DataFrame) -> bool:
    """Whether every step was decided by a rule (``solve_status`` ``"rule"``): a controller
    that plans with no model."""
    if schema.STATUS_COLUMN not in results.columns or results.empty:
        return False
    return bool((results[schema.STATUS_COLUMN].astype(str) == RULE_STATUS).all())


def prediction_error_summary(results: pd.DataFrame) -> dict[str, float]:
    """``prediction_error_rms_k``, ``_max_k`` [K]: RMS and largest |e| over steps and zones of
    the one-step prediction errors ``prediction_error_<zone>_k`` (NaN left out), and
    ``prediction_error_rms_occupied_k`` / ``_unoccupied_k``
    (:func:`prediction_error_rms_by_occupancy_k`); or {}.

    NaN for a rule-based run (:func:`is_rule_based`): the errors are those of hvacflex's model,
    which the rule never uses, so they say nothing about the controller."""
    names = schema.PREDICTION_ERROR.names(zone_names(results))
    if not all(name in results.columns for name in names):
        return {}
    if is_rule_based(results):
        keys = ("rms", "max", "rms_occupied", "rms_unoccupied")
        return {f"prediction_error_{key}_k": float("nan") for key in keys}
    values = np.abs(results[names].to_numpy(dtype=float)).ravel()
    values = values[np.isfinite(values)] if np.isfinite(values).any() else np.array([np.nan])
    rms = float(np.sqrt(np.mean(values**2)))
    return {
        "prediction_error_rms_k": rms,
        "prediction_error_max_k": float(np.max(values)),
        **prediction_error_rms_by_occupancy_k(results),
    }


def prediction_error_rms_by_occupancy_k(results: pd.DataFrame) -> dict[str, float]:
    """``prediction_error_rms_occupied_k`` and ``prediction_error_rms_unoccupied_k`` [K]: the
    RMS of the one-step prediction errors ``prediction_error_<zone>_k`` over every zone and
    every occupied (unoccupied) period — occupied: the zone's comfort band in force is its
    occupied (narrowest) band of the run — NaN left out; NaN when the class has no finite
    error; {} without the error columns."""
    names = schema.PREDICTION_ERROR.names(zone_names(results))
    if not all(name in results.columns for name in names):
        return {}
    errors = results[names].to_numpy(dtype=float)
    occupied = occupied_mask(results).to_numpy(dtype=bool)
    out = {}
    for key, mask in (("occupied", occupied), ("unoccupied", ~occupied)):
        chosen = errors[mask & np.isfinite(errors)]
        rms = float(np.sqrt(np.mean(chosen**2))) if chosen.size else float("nan")
        out[f"prediction_error_rms_{key}_k"] = rms
    return out
