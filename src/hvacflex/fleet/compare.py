"""``hvacflex fleet compare``: the coordinated plan against the centralised LP, step by step.

From the fleet's initial states at ``start``, every step builds each building's problem
once (:meth:`BuildingAgent.begin_step`), solves the **centralised LP** of the whole fleet
(:func:`hvacflex.fleet.centralised.solve_centralised`, the buildings' LPs stacked with the
feeder rows, each raised to the buildings' summed minimum power where that alone exceeds the
limit: :func:`reference_limit_kw`) and the **coordinated** scheme of the fleet file
(``[coordination] scheme``, :func:`hvacflex.fleet.run.coordinate_ranges`) from those same
problems and the same planning limit, then applies the coordinated plan's first step to every
plant, so that the next step starts from the states a fleet run would have. The buildings run
in this process (the centralised LP needs every problem in one place; practical for ≤ 10
buildings).

``compare.csv`` columns: ``step`` (0 = the start), ``centralised_sgd`` and
``coordinated_sgd`` (the step's horizon objective: Σ over buildings [SGD]), ``gap``
(coordinated / centralised − 1) and ``coordinated_max_over_limit_kw`` (largest
Σ_b P_b,k − F_k over the horizon's periods that are not feeder-infeasible, 0 if none is over
[kW]); plus ``time``, ``coordination_rounds``, ``coordination_time_s`` and
``centralised_time_s`` for diagnosis.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.control.base import FloatArray
from hvacflex.errors import InputError
from hvacflex.fleet.agent import FleetSettings
from hvacflex.fleet.centralised import solve_centralised
from hvacflex.fleet.coordinate import CoordinationResult
from hvacflex.fleet.run import (
    DT_H,
    _coordination_options,
    _feeder_timeline,
    _Groups,
    coordinate_ranges,
)
from hvacflex.fleet.schema import load_fleet_document

COMPARE_FILE = "compare.csv"
COMPARE_COLUMNS = (
    "step",
    "centralised_sgd",
    "coordinated_sgd",
    "gap",
    "coordinated_max_over_limit_kw",
)
"""The columns the issue names, in this order (diagnostics follow them)."""
MAX_COMPARE_BUILDINGS = 20
"""Largest fleet compared: the centralised LP stacks every building's LP."""


def max_over_limit_kw(result: CoordinationResult, limit_kw: FloatArray) -> float:
    """Largest Σ_b P_b,k − F_k [kW] over the feasible periods of the horizon (≥ 0)."""
    over = result.power_kw.sum(axis=0) - limit_kw
    feasible = ~result.infeasible & np.isfinite(limit_kw)
    return float(max(np.max(over[feasible], initial=0.0), 0.0))


def reference_limit_kw(limit_kw: FloatArray, p_min_kw: FloatArray) -> FloatArray:
    """(N,) the feeder rows of the centralised LP [kW]: the limit, raised to the buildings'
    summed minimum power Σ_b P_min,b,k (``p_min_kw`` (B, N)) in the periods where that alone
    exceeds it — where the coordination flags the period infeasible and runs every building
    at its minimum (:func:`hvacflex.fleet.coordinate.coordinate`), so that both solve the
    same problem and the centralised LP has a solution to compare with."""
    floor: FloatArray = np.maximum(limit_kw, np.asarray(p_min_kw).sum(axis=0))
    return floor


def _check_size(buildings: int, path: Path) -> None:
    if buildings > MAX_COMPARE_BUILDINGS:
        raise InputError(
            f"the centralised LP of {buildings} buildings is too large to compare",
            source=str(path),
            field="buildings",
            value=buildings,
            hint=f"compare a fleet of at most {MAX_COMPARE_BUILDINGS} buildings",
        )


def compare_fleet(
    fleet_path: str | Path, start: str, steps: int, out_dir: str | Path
) -> pd.DataFrame:
    """Run the comparison (see the module docstring); write and return ``compare.csv``.

    Parameters
    ----------
    fleet_path : the fleet TOML file.
    start : first period (Singapore local time, ISO 8601, may carry a time).
    steps : number of steps (30-min periods) compared, ≥ 1.
    out_dir : folder for ``compare.csv`` (made).
    """
    path = Path(fleet_path)
    fleet, document = load_fleet_document(path)
    _check_size(len(fleet.buildings), path)
    days = steps * DT_H / 24.0
    settings = FleetSettings.of(fleet, start, days)
    horizon = settings.horizon_steps
    index, _, planning = _feeder_timeline(fleet, start, days, horizon)
    options = _coordination_options(fleet)
    groups = _Groups(document, settings, len(fleet.buildings), None)
    agents = groups.groups[0].agents
    rows: list[dict[str, Any]] = []
    price = np.zeros(horizon)
    for k in range(steps):
        limit = planning[k : k + horizon]
        p_min, p_max, energy = groups.stacked("begin_step")
        tick = time.perf_counter()
        central = solve_centralised([a.problem for a in agents], reference_limit_kw(limit, p_min))
        central_s = time.perf_counter() - tick
        tick = time.perf_counter()
        result = coordinate_ranges(groups, (p_min, p_max, energy), limit, options, price)
        coordinated_s = time.perf_counter() - tick
        groups.broadcast("advance")
        coordinated = float(np.sum(result.cost_sgd))
        rows.append(
            {
                "step": k,
                "centralised_sgd": central.objective_sgd,
                "coordinated_sgd": coordinated,
                "gap": coordinated / central.objective_sgd - 1.0,
                "coordinated_max_over_limit_kw": max_over_limit_kw(result, limit),
                "time": index[k].isoformat(),
                "coordination_rounds": result.iterations,
                "coordination_time_s": coordinated_s,
                "centralised_time_s": central_s,
            }
        )
        price = np.append(result.price_sgd_per_mwh[1:], result.price_sgd_per_mwh[-1])
    frame = pd.DataFrame(rows)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(out / COMPARE_FILE, index=False)
    return frame
