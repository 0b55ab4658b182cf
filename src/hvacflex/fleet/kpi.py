"""Fleet KPIs from a fleet run's ``results.parquet`` (and ``buildings.parquet``).

The money and energy KPIs are :mod:`hvacflex.kpi`'s functions applied to the fleet frame
seen as one building (:func:`as_kpi_frame`: the fleet's power is ``power_kw``, the settled
bid is ``reserve_kw``), so Δt comes from the index and the SGD/MWh conversion from one place.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex import kpi as kpis
from hvacflex import results as schema
from hvacflex.errors import StoredStateError
from hvacflex.fleet.aggregation import offer_kpis

FLEET_MARKER_COLUMN = "fleet_power_kw"

KPI_COLUMNS = {
    "fleet_power_kw": "power_kw",
    "settled_reserve_kw": "reserve_kw",
    "energy_price_sgd_per_mwh": "energy_price_sgd_per_mwh",
    "reserve_price_sgd_per_mwh": "reserve_price_sgd_per_mwh",
}
"""Fleet column → the :mod:`hvacflex.kpi` column it plays (revenue is the settled bid's)."""


def is_fleet_results(results: pd.DataFrame) -> bool:
    """Whether a results table is a fleet run's (has ``fleet_power_kw``)."""
    return FLEET_MARKER_COLUMN in results.columns


SETTLEMENT_KPI_COLUMNS = (
    "il_activated",
    "il_baseline_power_kw",
    "il_delivered_kw",
    "il_shortfall_kw",
)
"""Fleet settlement columns the :mod:`hvacflex.kpi` functions read under the same names."""


def as_kpi_frame(results: pd.DataFrame) -> pd.DataFrame:
    """The fleet frame's :data:`KPI_COLUMNS` under their :mod:`hvacflex.kpi` names (same
    index), for the single-building KPI functions."""
    settled = [c for c in SETTLEMENT_KPI_COLUMNS if c in results.columns]
    return results[[*KPI_COLUMNS, *settled]].rename(columns=KPI_COLUMNS)


def fleet_summary(
    results: pd.DataFrame,
    buildings: pd.DataFrame | None = None,
    min_bid_kw: float | None = None,
) -> dict[str, float]:
    """Fleet KPIs: energy, cost, settled reserve revenue, the feeder limit, the bid and the
    aggregator's offer, dispatch and delivery (:func:`hvacflex.fleet.aggregation.offer_kpis`;
    ``min_bid_kw`` [kW] sizes the fleet a bid needs)."""
    fleet = as_kpi_frame(results)
    power = results["fleet_power_kw"].to_numpy(float)
    planned = results["planned_fleet_power_kw"].to_numpy(float)
    limit = results["feeder_limit_kw"].to_numpy(float)
    finite = np.isfinite(limit)
    over_planned = np.where(finite, planned - limit, -np.inf)
    over_real = np.where(finite, (power - limit) / np.where(finite, limit, 1.0), -np.inf)
    out = {
        "buildings": int(buildings[schema.BUILDING_COLUMN].nunique())
        if buildings is not None
        else np.nan,
        "steps": len(results),
        "energy_kwh": kpis.energy_kwh(fleet),
        "energy_cost_sgd": kpis.energy_cost_sgd(fleet),
        "reserve_revenue_sgd": kpis.reserve_revenue_sgd(fleet),
        "net_cost_sgd": kpis.net_cost_sgd(fleet),
        "peak_fleet_power_kw": kpis.peak_power_kw(fleet) if len(fleet) else 0.0,
        "max_planned_over_limit_kw": float(np.max(over_planned, initial=-np.inf)),
        "max_realised_over_limit_pct": 100.0 * float(np.max(over_real, initial=-np.inf)),
        "feeder_infeasible_steps": int(results["feeder_infeasible"].sum()),
        "bid_accepted_share": float(results["bid_accepted"].mean()),
        "mean_fleet_reserve_kw": float(results["fleet_reserve_kw"].mean()),
        "coordination_iterations_mean": float(results["coordination_iterations"].mean()),
        "coordination_iterations_max": float(results["coordination_iterations"].max()),
        "coordination_gap_max": float(results["coordination_gap"].max()),
        "discomfort_kelvin_hours": float(results["discomfort_kelvin_hours"].sum()),
    }
    out.update(_unflagged(results, planned, power, limit))
    out.update(
        {
            "il_activated_steps": int(results.get("il_activated", pd.Series(dtype=bool)).sum()),
            "il_offered_kwh": kpis.il_offered_kwh(fleet),
            "il_delivered_kwh": kpis.il_delivered_metered_kwh(fleet),
            "il_shortfall_kwh": kpis.il_shortfall_kwh(fleet),
        }
    )
    count = out["buildings"]
    out.update(offer_kpis(results, int(count) if np.isfinite(count) else None, min_bid_kw))
    if min_bid_kw is not None:
        out["min_bid_kw"] = float(min_bid_kw)
    if "step_time_s" in results:
        out["step_time_s_mean"] = float(results["step_time_s"].mean())
    return out


def _unflagged(
    results: pd.DataFrame, planned: np.ndarray, power: np.ndarray, limit: np.ndarray
) -> dict[str, float]:
    """The limit and comfort KPIs over the periods not flagged feeder-infeasible."""
    keep = np.isfinite(limit) & ~results["feeder_infeasible"].to_numpy(bool)
    safe = np.where(keep, limit, 1.0)
    comfort = results["discomfort_kelvin_hours"].to_numpy(float)
    return {
        "max_planned_over_limit_unflagged_kw": float(
            np.max(np.where(keep, planned - limit, -np.inf), initial=-np.inf)
        ),
        "max_realised_over_limit_unflagged_pct": 100.0
        * float(np.max(np.where(keep, (power - limit) / safe, -np.inf), initial=-np.inf)),
        "discomfort_unflagged_kelvin_hours": float(
            np.sum(comfort[~results["feeder_infeasible"].to_numpy(bool)])
        ),
    }


def building_table(buildings: pd.DataFrame) -> pd.DataFrame:
    """Per-building KPIs (rows: buildings; columns: :func:`hvacflex.kpi.summary`'s)."""
    rows = {
        name: kpis.summary(frame.drop(columns=schema.BUILDING_COLUMN))
        for name, frame in buildings.groupby(schema.BUILDING_COLUMN, sort=True)
    }
    return pd.DataFrame(rows).T


def load_buildings(run_dir: Path) -> pd.DataFrame | None:
    """The run's ``buildings.parquet`` if there is one."""
    path = run_dir / schema.BUILDINGS_FILENAME
    return schema.read_results(path)[0] if path.is_file() else None


def load_fleet_results(path: Path) -> pd.DataFrame | None:
    """A fleet run's results table if ``path`` (a run folder or its results file) holds
    one, else None (not a fleet run)."""
    file = path / schema.RESULTS_FILENAME if path.is_dir() else path
    if not file.is_file():
        return None
    try:
        if schema.META_FLEET not in schema.read_metadata(file):
            return None
    except StoredStateError:  # not Parquet: not a fleet run (the caller says what it is)
        return None
    return schema.read_results(file)[0]
