"""``hvacflex fleet compare``: the coordinated plan against the centralised LP, step by step.

From the fleet's initial states at ``start``, every step builds each building's problem
once (:meth:`BuildingAgent.begin_step`), solves the **centralised LP** of the whole fleet
(:class:`hvacflex.fleet.centralised.CentralisedSolver`: the buildings' LPs stacked with the
feeder rows, each raised to the buildings' summed minimum power where that alone exceeds the
limit, :func:`reference_limit_kw`; warm-started across steps from the previous step's basis
rotated by one step) and the **coordinated** scheme of the fleet file (``[coordination]
scheme``, :func:`hvacflex.fleet.run.coordinate_ranges`) from those same problems and the
same planning limit (the limit in force, windows included, × (1 − ``feeder_margin``)), then
applies the coordinated plan's first step to every plant through the fleet's guard at the
limit in force, so that the next step starts from the states a fleet run would have. The
buildings run where ``fleet simulate``'s run (in this process, or as Dask actors on
``workers`` local processes or a ``scheduler``); their problems travel to this process for
the centralised LP (practical for ≤ 20 buildings).

``compare.csv``, one row per step: ``step`` (0 = the start); for each part of the objective
(:func:`hvacflex.fleet.centralised.objective_split`, Σ over buildings of the step's horizon
[SGD]) — ``energy_peak`` (energy cost + peak charge), ``reserve`` (−reserve revenue, ≤ 0)
and ``comfort`` (comfort penalty) — ``centralised_<part>_sgd``, ``coordinated_<part>_sgd``
and ``gap_<part>_pct`` = 100 × (coordinated − centralised) / |centralised| (NaN where the
centralised part is 0; positive: the coordination pays more on that part); then
``centralised_sgd`` and ``coordinated_sgd`` (the whole objectives, the centralised one with
the reserve tie-break), ``gap`` (coordinated / centralised − 1) and
``coordinated_max_over_limit_kw`` (largest Σ_b P_b,k − F_k over the horizon's periods that
are not feeder-infeasible, 0 if none is over [kW]); plus ``time``, ``coordination_rounds``,
``coordination_time_s``, ``centralised_time_s``, ``centralised_iterations`` (simplex) and
``centralised_warm`` for diagnosis.
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
from hvacflex.fleet.centralised import CentralisedSolver
from hvacflex.fleet.coordinate import CoordinationResult
from hvacflex.fleet.run import (
    DT_H,
    _coordination_options,
    _feeder_timeline,
    _Groups,
    _start_dask,
    coordinate_ranges,
    guarded_advance,
    step_planning_kw,
)
from hvacflex.fleet.schema import Fleet, load_fleet_document
from hvacflex.sim.sweep import close_dask

COMPARE_FILE = "compare.csv"
SPLIT_TERMS = ("energy_peak", "reserve", "comfort")
"""The objective's parts compared (:func:`hvacflex.fleet.centralised.objective_split`)."""
COMPARE_COLUMNS = (
    "step",
    *(
        f"{kind}_{term}_{unit}"
        for term in SPLIT_TERMS
        for kind, unit in (("centralised", "sgd"), ("coordinated", "sgd"), ("gap", "pct"))
    ),
    "centralised_sgd",
    "coordinated_sgd",
    "gap",
    "coordinated_max_over_limit_kw",
)
"""The columns the issues name, in this order (diagnostics follow them)."""
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


def gap_pct(coordinated_sgd: float, centralised_sgd: float) -> float:
    """100 × (coordinated − centralised) / |centralised| [%]; NaN when the centralised term
    is 0 (no gap can be stated: nothing to compare against)."""
    if centralised_sgd == 0 or not np.isfinite(centralised_sgd):
        return float("nan")
    return 100.0 * (coordinated_sgd - centralised_sgd) / abs(centralised_sgd)


def compare_fleet(
    fleet_path: str | Path,
    start: str,
    steps: int,
    out_dir: str | Path,
    *,
    workers: int = 0,
    scheduler: str | None = None,
) -> pd.DataFrame:
    """Run the comparison (see the module docstring); write and return ``compare.csv``.

    Parameters
    ----------
    fleet_path : the fleet TOML file.
    start : first period (Singapore local time, ISO 8601, may carry a time).
    steps : number of steps (30-min periods) compared, ≥ 1.
    out_dir : folder for ``compare.csv`` (made).
    workers, scheduler : where the buildings run, as for ``fleet simulate``
        (:func:`hvacflex.fleet.run.run_fleet`): 0 and None = in this process.
    """
    path = Path(fleet_path)
    fleet, document = load_fleet_document(path)
    _check_size(len(fleet.buildings), path)
    days = steps * DT_H / 24.0
    settings = FleetSettings.of(fleet, start, days)
    horizon = settings.horizon_steps
    index, in_force, planning = _feeder_timeline(fleet, start, days, horizon)
    options = _coordination_options(fleet)
    cluster, client, own_client = _start_dask(scheduler, workers)
    try:
        groups = _Groups(document, settings, len(fleet.buildings), client)
        rows = _compare_steps(groups, (fleet, planning), in_force, index, options, steps, horizon)
    finally:
        if own_client is not None:
            close_dask(own_client, cluster)
    frame = pd.DataFrame(rows)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(out / COMPARE_FILE, index=False)
    return frame


def _problems(groups: _Groups) -> list[Any]:
    """Every building's step problem, in fleet order, from the groups (in process or actors)."""
    parts = groups.broadcast("problems")
    by_index: dict[int, Any] = {}
    for idx, part in zip(groups.indices, parts, strict=True):
        by_index.update(zip(idx, part, strict=True))
    return [by_index[i] for i in range(groups.n)]


def _compare_steps(
    groups: _Groups,
    planning: tuple[Fleet, FloatArray],
    in_force_kw: FloatArray,
    index: pd.DatetimeIndex,
    options: Any,
    steps: int,
    horizon: int,
) -> list[dict[str, Any]]:
    """Every step's row of ``compare.csv``; advances the buildings by the coordinated plans.
    ``planning``: (the fleet, its planning limit over the run plus one horizon [kW]), each
    step's limit as the closed loop sees it (:func:`hvacflex.fleet.run.step_planning_kw`);
    ``in_force_kw``: the limit in force over the same periods [kW], which the fleet's guard
    holds each step's first period to."""
    rows: list[dict[str, Any]] = []
    price = np.zeros(horizon)
    central_solver = CentralisedSolver()
    for k in range(steps):
        limit = step_planning_kw(*planning, index, k, horizon)  # the closed loop's
        p_min, p_max, energy = groups.stacked("begin_step")
        tick = time.perf_counter()
        central = central_solver.solve(_problems(groups), reference_limit_kw(limit, p_min))
        central_s = time.perf_counter() - tick
        tick = time.perf_counter()
        result = coordinate_ranges(groups, (p_min, p_max, energy), limit, options, price)
        coordinated_s = time.perf_counter() - tick
        (split,) = groups.stacked("staged_split_sgd")
        guarded_advance(groups, float(in_force_kw[k]), False)
        coordinated = float(np.sum(result.cost_sgd))
        row: dict[str, Any] = {"step": k}
        central_split = (
            np.full(3, np.nan) if central.split_sgd is None else central.split_sgd.sum(axis=0)
        )
        for j, term in enumerate(SPLIT_TERMS):
            ours, best = float(split[:, j].sum()), float(central_split[j])
            row[f"centralised_{term}_sgd"] = best
            row[f"coordinated_{term}_sgd"] = ours
            row[f"gap_{term}_pct"] = gap_pct(ours, best)
        row |= {
            "centralised_sgd": central.objective_sgd,
            "coordinated_sgd": coordinated,
            "gap": coordinated / central.objective_sgd - 1.0,
            "coordinated_max_over_limit_kw": max_over_limit_kw(result, limit),
            "time": index[k].isoformat(),
            "coordination_rounds": result.iterations,
            "coordination_time_s": coordinated_s,
            "centralised_time_s": central_s,
            "centralised_iterations": central.iterations,
            "centralised_warm": central.warm_start,
        }
        rows.append(row)
        price = np.append(result.price_sgd_per_mwh[1:], result.price_sgd_per_mwh[-1])
    return rows
