"""A fleet run's comfort bound and its limit windows checked on the controllers' model.

``hvacflex fleet bound --fleet F --start D --days N --out DIR`` computes the least
discomfort the fleet's buildings can have over the run under its feeder limits (windows
included) on the controllers' own model: from the closed loop's initial state at ``start``
(the state the first step of ``hvacflex fleet simulate`` plans from) it stacks every
building's open-loop LP over one horizon covering the whole run (the centralised LP of
``hvacflex fleet compare``, :func:`hvacflex.fleet.centralised.centralised_lp`) with the
forecast of the first step taken as exact (**perfect foresight**), **no robust margin**,
**no reserve**, energy and peak free and the comfort slack as the only cost, under the
planning limit in force each period (:meth:`hvacflex.fleet.schema.Fleet.limit_series_kw`
× (1 − ``feeder_margin``), raised to the buildings' summed minimum power where that alone
exceeds it, as the coordination flags such periods). The optimum's slack ε (N, zones) [K]
at the period ends, × 0.5 h and summed over zones, is each building's least discomfort
[K·h], counted as ``results.parquet`` counts it (:func:`hvacflex.kpi.step_discomfort_kelvin_hours`:
period-end violations × Δt, summed over zones). A closed loop that re-plans with forecasts
and robust margins can only do worse on the same model; the bound is the model's, not the
plant's (the plant's power is not the LP's affine secant).

``DIR/bound.csv``: one row per building, columns ``building``, ``discomfort_kelvin_hours``
(over the days run) and ``feasible`` (the LP had a solution under the limits as given: no
period's limit had to be raised to the buildings' minimum power).

The same run model checks the limit windows before a run (:func:`check_limit_windows`): a
window whose limit lies below the buildings' summed minimum power (every flow at its lower
bound, on the controllers' model of the run) in one of its periods cannot be met.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import sparse

from hvacflex.constants import MAX_HORIZON_STEPS, PERIODS_PER_DAY
from hvacflex.control.base import FloatArray
from hvacflex.errors import InputError, SolverError
from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.centralised import centralised_lp, solve_centralised, stacked_lp
from hvacflex.fleet.compare import reference_limit_kw
from hvacflex.fleet.run import _feeder_timeline
from hvacflex.fleet.schema import Fleet, FleetConfigError, load_fleet_document
from hvacflex.opt import RMPCProblem
from hvacflex.opt.solve import solve_lp

BOUND_FILE = "bound.csv"
BOUND_COLUMNS = ("building", "discomfort_kelvin_hours", "feasible")
MAX_BOUND_DAYS = MAX_HORIZON_STEPS // PERIODS_PER_DAY
"""Longest run bounded [days]: the whole run is one horizon."""
COMFORT_ONLY_PENALTY_SGD_PER_KELVIN_HOUR = 1.0
"""The bound's only cost: 1 SGD per K·h of slack (any positive value gives the same plan)."""


@dataclass(frozen=True)
class RunModel:
    """The controllers' model of a whole run, from the closed loop's initial state.

    Attributes
    ----------
    names : (B,) building names.
    problems : (B,) every building's step problem over a horizon of the run's T periods.
    p_min_kw : (B, T) each building's power with every flow at its lower bound [kW].
    index : (T,) the run's period starts (Singapore local time).
    planning_kw : (T,) the planning limit in force [kW]: the limit × (1 − feeder_margin).
    """

    names: tuple[str, ...]
    problems: tuple[RMPCProblem, ...]
    p_min_kw: FloatArray
    index: pd.DatetimeIndex
    planning_kw: FloatArray


def run_settings(fleet: Fleet, start: str, days: float) -> FleetSettings:
    """The settings every building of :func:`run_model` is built with: the fleet's, one
    horizon over the run (≤ 7 days), and the comfort band itself (no plan margins), as
    ``results.parquet`` counts discomfort.

    Raises
    ------
    InputError
        When the run is longer than one horizon can be (:data:`MAX_BOUND_DAYS`).
    """
    steps = round(days * PERIODS_PER_DAY)
    if steps > MAX_HORIZON_STEPS:
        raise InputError(
            f"a run of {days:g} days is longer than one horizon ({MAX_HORIZON_STEPS} periods)",
            field="--days",
            value=days,
            hint=f"bound at most {MAX_BOUND_DAYS} days at a time",
        )
    return dataclasses.replace(
        FleetSettings.of(fleet, start, days),
        horizon_steps=max(steps, 2),
        lower_plan_margin_k=0.0,
        unoccupied_plan_margin_k=0.0,
    )


def run_model(fleet: Fleet, document: dict[str, Any], start: str, days: float) -> RunModel:
    """Build every building at ``start`` with a horizon of the whole run (≤ 7 days;
    :func:`run_settings`).

    Raises
    ------
    InputError
        When the run is longer than one horizon can be (:data:`MAX_BOUND_DAYS`).
    """
    steps = round(days * PERIODS_PER_DAY)
    settings = run_settings(fleet, start, days)
    group = BuildingGroup(document, list(range(len(fleet.buildings))), settings)
    p_min, _, _ = group.begin_step()
    index, _, planning = _feeder_timeline(fleet, start, days, 0)
    return RunModel(
        tuple(agent.name for agent in group.agents),
        tuple(agent.problem for agent in group.agents),
        p_min[:, :steps],
        index,
        planning[:steps],
    )


def comfort_only(problem: RMPCProblem) -> RMPCProblem:
    """``problem`` with the comfort slack as its only cost: no prices, no reserve (no
    reserve input, no IL event rows), no robust margin (the forecast taken as exact), no cap
    on the slack, :data:`COMFORT_ONLY_PENALTY_SGD_PER_KELVIN_HOUR`."""
    zeros = np.zeros(problem.horizon)
    return dataclasses.replace(
        problem,
        energy_price_sgd_per_mwh=zeros,
        reserve_price_sgd_per_mwh=zeros,
        peak_price_sgd_per_kw=0.0,
        peak_floor_kw=0.0,
        d_sigma=np.zeros_like(problem.d_sigma),
        robust="none",
        comfort_penalty_sgd_per_kelvin_hour=COMFORT_ONLY_PENALTY_SGD_PER_KELVIN_HOUR,
        reserve_mask=np.zeros(problem.u_min.shape[1], dtype=bool),
        slack_max_kelvin=None,
        comfort_knee=None,
        events=None,
        commitments=None,
        offer_baselines=None,
    )


@dataclass(frozen=True)
class ComfortBound:
    """The bound's answer: (B,) least discomfort per building over the run [K·h], (B, T)
    per period [K·h], whether the LP solved under the limits as given (no period raised to
    the minimum power), and how many periods were raised."""

    names: tuple[str, ...]
    discomfort_kelvin_hours: FloatArray
    per_period_kelvin_hours: FloatArray
    feasible: bool
    raised_periods: int

    def frame(self) -> pd.DataFrame:
        """``bound.csv``'s rows."""
        return pd.DataFrame(
            {
                "building": list(self.names),
                "discomfort_kelvin_hours": self.discomfort_kelvin_hours,
                "feasible": self.feasible,
            }
        )


def comfort_bound(model: RunModel) -> ComfortBound:
    """Solve the bound's LP on ``model`` (see the module docstring)."""
    problems = [comfort_only(p) for p in model.problems]
    limit = reference_limit_kw(model.planning_kw, model.p_min_kw)
    raised = int(np.sum(limit > model.planning_kw))
    cost, matrix, lower, upper, col_lo, col_hi, _, layouts = centralised_lp(problems, limit)
    result = solve_lp(cost, matrix, lower, upper, col_lo, col_hi)
    x = result.x if result.status.ok else None
    return _bound_of(model, problems, layouts, x, raised)


def _slack_k(x: FloatArray, layouts: Any) -> list[FloatArray]:
    """Each building's slack ε (T, ny) [K] in the stacked LP's solution ``x``."""
    return [x[np.asarray(layout.plan.eps) + first] for first, layout in layouts]


def _bound_of(
    model: RunModel,
    problems: list[RMPCProblem],
    layouts: Any,
    x: FloatArray | None,
    raised: int,
) -> ComfortBound:
    """The :class:`ComfortBound` of the stacked LP's solution ``x`` (None: no optimum, NaN
    and not feasible): per building and period the slack ε summed over zones × Δt [K·h]."""
    if x is None:
        nan = np.full(len(problems), np.nan)
        return ComfortBound(model.names, nan, np.full(model.p_min_kw.shape, np.nan), False, raised)
    per_period = np.array(  # (B, T)
        [eps.sum(axis=1) * p.dt_h for eps, p in zip(_slack_k(x, layouts), problems, strict=True)]
    )
    return ComfortBound(model.names, per_period.sum(axis=1), per_period, raised == 0, raised)


def _write_bound(bound: ComfortBound, out_dir: str | Path) -> None:
    """``out_dir/bound.csv`` (:data:`BOUND_FILE`) of ``bound``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    bound.frame().to_csv(out / BOUND_FILE, index=False)


def bound_fleet(
    fleet_path: str | Path, start: str, days: float, out_dir: str | Path
) -> ComfortBound:
    """``hvacflex fleet bound``: compute the bound and write ``out_dir/bound.csv``."""
    fleet, document = load_fleet_document(fleet_path)
    bound = comfort_bound(run_model(fleet, document, start, days))
    _write_bound(bound, out_dir)
    return bound


@dataclass(frozen=True)
class BudgetedBound:
    """The least discomfort within an energy budget and an excursion cap
    (:func:`budgeted_bound`).

    Attributes
    ----------
    bound : the buildings' least discomfort (:class:`ComfortBound`; NaN and not feasible
        when no plan meets the budget and the cap).
    budget_kwh : the fleet's energy budget over the run [kWh] (inf = none).
    max_excursion_k : the cap on every zone's slack ε [K] (None = none).
    energy_kwh : the plan's fleet energy over the run [kWh] (the LP's affine power; NaN
        unless solved).
    largest_slack_k : the plan's largest ε over buildings, zones and periods [K].
    power_kw : (T,) the plan's fleet power per period [kW].
    """

    bound: ComfortBound
    budget_kwh: float
    max_excursion_k: float | None
    energy_kwh: float
    largest_slack_k: float
    power_kw: FloatArray

    @property
    def solved(self) -> bool:
        """Whether some plan met the limits, the budget and the cap."""
        return bool(np.isfinite(self.energy_kwh))


def priced_only(problem: RMPCProblem) -> RMPCProblem:
    """``problem`` with its own prices and comfort penalty but no reserve (no reserve input,
    no IL event rows) and no robust margin: the controllers' objective with perfect
    foresight, for the unlimited plan :func:`unlimited_energy_kwh` measures."""
    return dataclasses.replace(
        problem,
        d_sigma=np.zeros_like(problem.d_sigma),
        robust="none",
        reserve_price_sgd_per_mwh=np.zeros(problem.horizon),
        reserve_mask=np.zeros(problem.u_min.shape[1], dtype=bool),
        events=None,
        commitments=None,
        offer_baselines=None,
    )


def unlimited_energy_kwh(model: RunModel) -> float:
    """The fleet's energy over the run [kWh] in the centralised plan of :func:`priced_only`
    problems without any limit (nan if it has no solution): "the unlimited days" of the
    energy criterion, on the controllers' model."""
    problems = [priced_only(p) for p in model.problems]
    result = solve_centralised(problems, np.full(model.p_min_kw.shape[1], np.inf))
    if not result.status.ok:
        return float("nan")
    return float(problems[0].dt_h * result.power_kw.sum())


@dataclass(frozen=True)
class _ComfortLP:
    """The bound's problems with every zone's slack capped (:func:`_comfort_lp`), their
    stacked LP, how many periods' limits were raised to the minimum power, and the (1, cols)
    energy row Σ_b Σ_k P_b,k Δt [kWh] and (B, cols) discomfort rows Σ_k Σ_zones ε Δt [K·h]."""

    problems: list[RMPCProblem]
    stacked: Any
    raised: int
    energy: Any
    discomfort: Any


def _comfort_lp(model: RunModel, max_excursion_k: float | None) -> _ComfortLP:
    """The bound's LP with every zone's slack ≤ ``max_excursion_k`` (None: uncapped)."""
    problems = [
        dataclasses.replace(comfort_only(p), slack_max_kelvin=max_excursion_k)
        for p in model.problems
    ]
    limit = reference_limit_kw(model.planning_kw, model.p_min_kw)
    stacked = stacked_lp(problems, limit)
    energy = sparse.lil_matrix((1, stacked.cost.size))
    discomfort = sparse.lil_matrix((len(problems), stacked.cost.size))
    for b, (problem, cols, (first, layout)) in enumerate(
        zip(problems, stacked.power_cols, stacked.layouts, strict=True)
    ):
        energy[0, cols] = problem.dt_h
        discomfort[b, np.asarray(layout.plan.eps).ravel() + first] = problem.dt_h
    raised = int(np.sum(limit > model.planning_kw))
    return _ComfortLP(problems, stacked, raised, energy.tocsr(), discomfort.tocsr())


def _solve_budgeted(
    model: RunModel,
    lp: _ComfortLP,
    cost: FloatArray,
    rows: Any,
    rows_upper: FloatArray,
    budget: tuple[float, float | None],
) -> BudgetedBound:
    """Solve ``lp`` (:func:`_comfort_lp`) with ``cost`` and the extra ``rows`` ≤
    ``rows_upper``; ``budget`` = (budget [kWh], excursion cap [K]) as recorded."""
    problems, stacked = lp.problems, lp.stacked
    result = solve_lp(
        cost,
        sparse.vstack([stacked.matrix, rows]).tocsr(),
        np.append(stacked.row_lower, np.full(rows.shape[0], -np.inf)),
        np.append(stacked.row_upper, rows_upper),
        stacked.col_lower,
        stacked.col_upper,
    )
    x = result.x if result.status.ok else None
    bound = _bound_of(model, problems, stacked.layouts, x, lp.raised)
    if x is None:
        nan = float("nan")
        return BudgetedBound(bound, *budget, nan, nan, np.full(model.p_min_kw.shape[1], nan))
    power = np.sum([x[cols] for cols in stacked.power_cols], axis=0)
    return BudgetedBound(
        bound,
        *budget,
        float(problems[0].dt_h * power.sum()),
        float(max(eps.max() for eps in _slack_k(x, stacked.layouts))),
        power,
    )


def budgeted_bound(
    model: RunModel, budget_kwh: float, *, max_excursion_k: float | None = None
) -> BudgetedBound:
    """The bound's LP (:func:`comfort_bound`) with the fleet's energy over the run at most
    ``budget_kwh`` [kWh] (one row Σ_b Σ_k P_b,k Δt ≤ budget on the LP's affine power) and,
    if ``max_excursion_k`` [K] is given, every zone's slack ε ≤ it: the least discomfort
    the fleet can have within an energy budget and an excursion cap, on the controllers'
    model with perfect foresight. Swept over budgets, it is the trade-off curve of
    discomfort against energy (``scripts/fleet_tradeoff.py``)."""
    lp = _comfort_lp(model, max_excursion_k)
    return _solve_budgeted(
        model, lp, lp.stacked.cost, lp.energy, np.array([budget_kwh]), (budget_kwh, max_excursion_k)
    )


LEAST_ENERGY_TIE_BREAK = 1e-4
"""Weight of the comfort slack [relative to 1 kWh per K·h] in :func:`least_energy_for_comfort`:
among the plans of least energy, the least discomfort."""


def least_energy_for_comfort(
    model: RunModel, allowed_kelvin_hours: FloatArray, *, max_excursion_k: float | None = None
) -> BudgetedBound:
    """The least fleet energy over the run [kWh] of a plan in which each building's
    discomfort is at most ``allowed_kelvin_hours`` (B,) [K·h over the run] and, if
    ``max_excursion_k`` [K] is given, every zone's slack ε ≤ it (same model and limits as
    :func:`comfort_bound`): what meeting a comfort target costs in energy, at best.
    ``budget_kwh`` of the answer is inf (no budget; the energy is the objective)."""
    lp = _comfort_lp(model, max_excursion_k)
    cost = np.asarray(lp.energy.toarray()).ravel() + LEAST_ENERGY_TIE_BREAK * lp.stacked.cost
    allowed = np.asarray(allowed_kelvin_hours, dtype=float)
    return _solve_budgeted(model, lp, cost, lp.discomfort, allowed, (np.inf, max_excursion_k))


def budgeted_fleet_bound(
    fleet_path: str | Path,
    start: str,
    days: float,
    out_dir: str | Path,
    *,
    energy_budget_pct: float | None,
    max_excursion_k: float | None,
) -> BudgetedBound:
    """``hvacflex fleet bound --energy-budget-pct X --max-excursion-k Y``: the bound within
    an energy budget of (1 + X/100) × :func:`unlimited_energy_kwh` (none when X is None)
    and every zone's slack ≤ Y [K] (none when None); writes ``out_dir/bound.csv`` (NaN
    discomfort and ``feasible`` false when no plan meets them)."""
    fleet, document = load_fleet_document(fleet_path)
    model = run_model(fleet, document, start, days)
    budget_kwh = np.inf
    if energy_budget_pct is not None:
        unlimited_kwh = unlimited_energy_kwh(model)
        if not np.isfinite(unlimited_kwh):
            raise SolverError(
                "the fleet's unlimited plan (no limit, the energy budget's reference) has no "
                f"optimum over {days:g} days from {start}: no energy budget can be set from it"
            )
        budget_kwh = (1.0 + energy_budget_pct / 100.0) * unlimited_kwh
    result = budgeted_bound(model, budget_kwh, max_excursion_k=max_excursion_k)
    _write_bound(result.bound, out_dir)
    return result


@dataclass(frozen=True)
class WindowShortfall:
    """A limit window below the fleet's minimum power in one of its periods: the window's
    position in ``[[feeder_limits]]``, its description, the worst period, the planning
    limit there [kW] and the buildings' summed minimum power there [kW]."""

    position: int
    window: str
    time: pd.Timestamp
    limit_kw: float
    minimum_kw: float


def limit_window_shortfalls(fleet: Fleet, model: RunModel) -> list[WindowShortfall]:
    """Every ``[[feeder_limits]]`` window whose planning limit lies below Σ_b P_min,b in
    one of the run's periods in it; its worst period (the largest minimum − limit)."""
    minimum = model.p_min_kw.sum(axis=0)
    shortfalls = []
    for position, window in enumerate(fleet.spec.feeder_limits):
        inside = window.mask(model.index)
        below = inside & (minimum > model.planning_kw)
        if not below.any():
            continue
        worst = int(np.argmax(np.where(below, minimum - model.planning_kw, -np.inf)))
        shortfalls.append(
            WindowShortfall(
                position,
                window.describe(),
                model.index[worst],
                float(model.planning_kw[worst]),
                float(minimum[worst]),
            )
        )
    return shortfalls


def check_limit_windows(
    fleet: Fleet, document: dict[str, Any], start: str, days: float, *, allow: bool
) -> list[str]:
    """Check every limit window of the run against the fleet's minimum feasible power on
    the controllers' model (:func:`limit_window_shortfalls`, at most
    :data:`MAX_BOUND_DAYS` from ``start``).

    Returns
    -------
    One warning per window below the minimum when ``allow`` (its periods are then flagged
    infeasible in the run, every building at its minimum); none when every window is met.

    Raises
    ------
    FleetConfigError
        For the first window below the minimum unless ``allow``: naming the window, the
        period, the limit and the minimum, and the fixes.
    """
    if not fleet.spec.feeder_limits:
        return []
    model = run_model(fleet, document, start, min(days, float(MAX_BOUND_DAYS)))
    messages, margin = [], fleet.spec.feeder_margin
    for short in limit_window_shortfalls(fleet, model):
        text = (
            f"the limit window {short.window} is below the fleet's minimum feasible power: "
            f"at {short.time:%Y-%m-%d %H:%M} the buildings' minimum powers sum to "
            f"{short.minimum_kw:.1f} kW against a planning limit of {short.limit_kw:.1f} kW"
        )
        if not allow:
            raise FleetConfigError(
                text,
                source=fleet.source or fleet.name,
                field=f"feeder_limits[{short.position}].limit_kw",
                value=fleet.spec.feeder_limits[short.position].limit_kw,
                hint=f"raise limit_kw to at least {short.minimum_kw / (1.0 - margin):.1f} kW, "
                "or run with --allow-infeasible-limits (those periods are "
                "flagged infeasible, every building at its minimum)",
            )
        messages.append(f"{text}; those periods are flagged infeasible")
    return messages
