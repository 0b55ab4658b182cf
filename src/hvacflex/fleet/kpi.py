"""Fleet KPIs from a fleet run's ``results.parquet`` (and ``buildings.parquet``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex import kpi as kpis

DT_H = 0.5
FLEET_MARKER_COLUMN = "fleet_power_kw"


def is_fleet_results(results: pd.DataFrame) -> bool:
    """Whether a results table is a fleet run's (has ``fleet_power_kw``)."""
    return FLEET_MARKER_COLUMN in results.columns


def fleet_summary(results: pd.DataFrame, buildings: pd.DataFrame | None = None) -> dict[str, float]:
    """Fleet KPIs: energy, cost, settled reserve revenue, the feeder limit and the bid."""
    power = results["fleet_power_kw"].to_numpy(float)
    planned = results["planned_fleet_power_kw"].to_numpy(float)
    limit = results["feeder_limit_kw"].to_numpy(float)
    price = results["energy_price_sgd_per_mwh"].to_numpy(float)
    reserve_price = results["reserve_price_sgd_per_mwh"].to_numpy(float)
    settled = results["settled_reserve_kw"].to_numpy(float)
    finite = np.isfinite(limit)
    over_planned = np.where(finite, planned - limit, -np.inf)
    over_real = np.where(finite, (power - limit) / np.where(finite, limit, 1.0), -np.inf)
    energy_cost = float(np.sum(power * price) * DT_H / 1000.0)
    revenue = float(np.sum(settled * reserve_price) * DT_H / 1000.0)
    out = {
        "buildings": float(buildings["building"].nunique()) if buildings is not None else np.nan,
        "steps": float(len(results)),
        "energy_kwh": float(np.sum(power) * DT_H),
        "energy_cost_sgd": energy_cost,
        "reserve_revenue_sgd": revenue,
        "net_cost_sgd": energy_cost - revenue,
        "peak_fleet_power_kw": float(np.max(power, initial=0.0)),
        "max_planned_over_limit_kw": float(np.max(over_planned, initial=-np.inf)),
        "max_realised_over_limit_pct": 100.0 * float(np.max(over_real, initial=-np.inf)),
        "feeder_infeasible_steps": float(results["feeder_infeasible"].sum()),
        "bid_accepted_share": float(results["bid_accepted"].mean()),
        "mean_fleet_reserve_kw": float(results["fleet_reserve_kw"].mean()),
        "coordination_iterations_mean": float(results["coordination_iterations"].mean()),
        "coordination_iterations_max": float(results["coordination_iterations"].max()),
        "coordination_gap_max": float(results["coordination_gap"].max()),
        "discomfort_kelvin_hours": float(results["discomfort_kelvin_hours"].sum()),
    }
    if "step_time_s" in results:
        out["step_time_s_mean"] = float(results["step_time_s"].mean())
    return out


def building_table(buildings: pd.DataFrame) -> pd.DataFrame:
    """Per-building KPIs (rows: buildings; columns: :func:`hvacflex.kpi.summary`'s)."""
    rows = {
        name: kpis.summary(frame.drop(columns="building"))
        for name, frame in buildings.groupby("building", sort=True)
    }
    return pd.DataFrame(rows).T


def load_buildings(run_dir: Path) -> pd.DataFrame | None:
    """The run's ``buildings.parquet`` if there is one."""
    path = run_dir / "buildings.parquet"
    return pd.read_parquet(path) if path.is_file() else None


def load_fleet_results(path: Path) -> pd.DataFrame | None:
    """A fleet run's results table if ``path`` (a run folder or its results file) holds
    one, else None (not a fleet run)."""
    import pyarrow.parquet as pq

    file = path / "results.parquet" if path.is_dir() else path
    try:
        meta = pq.read_schema(file).metadata or {}
    except (OSError, ValueError):
        return None
    if b"hvacflex.fleet" not in meta:
        return None
    return pd.read_parquet(file)
