"""The revenue findings against the synthetic reserve price: a sweep of its scale and its
correlation with USEP.

No public NEMS reserve-price history exists, so the reserve price is synthetic
(:func:`hvacflex.data.market.synthetic_reserve_prices`): its scale was calibrated to the
paper's ≈ 1 % revenue share and its link to USEP is a modelling choice. ``hvacflex reproduce
--sensitivity`` runs (a) NMPC, (b) RMPC and (c) RMPC + PPP at every point of a grid of
``data.reserve_price_scale`` × ``data.reserve_price_correlation`` over a few weeks
(:data:`hvacflex.robustness.REPRESENTATIVE_WEEKS`), as Dask jobs (:mod:`hvacflex.sim.sweep`:
cached by inputs and code, resumable), and writes:

* ``sensitivity_runs.csv`` — one row per point × week × scenario;
* ``sensitivity.csv`` — one row per point × scenario, summed over the weeks: ``point``,
  ``reserve_price_scale``, ``reserve_price_correlation``, ``scenario``, ``controller``,
  ``energy_cost_sgd``, ``reserve_revenue_sgd``, ``revenue_share`` (revenue / energy cost),
  ``il_penalty_sgd``, ``net_cost_sgd``, ``peak_power_kw`` (the highest week's),
  ``reserve_offered_mean_kw``, ``reserve_price_mean_sgd_per_mwh`` and
  ``reserve_usep_pearson`` (the realised correlation of the simulated periods' prices);
* ``sensitivity_findings.csv`` — per point: whether revenue rises in (b) and in (c) against (a)
  (:func:`hvacflex.report.text.rises`, the report's rule, which there also calls a point
  where (a) earns nothing "not comparable"; here a revenue above nothing rises) and the
  paper's finding (both);
* ``sensitivity_figure.png`` — revenue share against scale, one line per correlation, per
  scenario (its data in ``sensitivity_figure.csv``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.config import PAPER_SCENARIOS, ScenarioConfig, preset
from hvacflex.data.market import RESERVE_PRICE_CORRELATION, RESERVE_PRICE_SCALE
from hvacflex.report.text import rises
from hvacflex.results import load_results
from hvacflex.robustness import (
    QUICK_DAYS,
    REPRESENTATIVE_WEEKS,
    WEEK_DAYS,
    run_study_jobs,
    runs_table,
    write_tables,
)
from hvacflex.sim.sweep import JobOutcome

SCALE_FACTORS: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0, 4.0)
"""Scales of the full grid, as multiples of the calibrated :data:`RESERVE_PRICE_SCALE`."""

QUICK_SCALE_FACTORS: tuple[float, ...] = (0.5, 1.0, 2.0)
"""Scales of ``--quick`` (multiples of :data:`RESERVE_PRICE_SCALE`)."""

CORRELATIONS: tuple[float, ...] = (0.0, 0.5, RESERVE_PRICE_CORRELATION)
"""Weights ρ of the USEP-driven part of the full grid (1 = the calibrated series)."""

QUICK_CORRELATIONS: tuple[float, ...] = (0.0, RESERVE_PRICE_CORRELATION)
"""Weights ρ of ``--quick``."""

RUN_KPIS: tuple[str, ...] = (
    "energy_cost_sgd",
    "reserve_revenue_sgd",
    "il_penalty_sgd",
    "net_cost_sgd",
    "peak_power_kw",
    "reserve_offered_mean_kw",
    "steps",
)
"""KPIs (:func:`hvacflex.kpi.summary` keys) kept per run."""

_SUMMED = ("energy_cost_sgd", "reserve_revenue_sgd", "il_penalty_sgd", "net_cost_sgd")


@dataclass(frozen=True)
class SensitivityGrid:
    """The sweep: reserve-price scales [SGD/MWh] × correlations ρ, over weeks × days."""

    scales_sgd_per_mwh: tuple[float, ...]
    correlations: tuple[float, ...]
    weeks: tuple[str, ...]
    days: float

    @classmethod
    def full(cls) -> SensitivityGrid:
        """Five scales × three correlations over the four representative weeks."""
        return cls(
            tuple(f * RESERVE_PRICE_SCALE for f in SCALE_FACTORS),
            CORRELATIONS,
            tuple(w.start for w in REPRESENTATIVE_WEEKS),
            WEEK_DAYS,
        )

    @classmethod
    def quick(cls) -> SensitivityGrid:
        """Three scales × two correlations over the first :data:`QUICK_DAYS` days of one
        week (the hottest season's)."""
        return cls(
            tuple(f * RESERVE_PRICE_SCALE for f in QUICK_SCALE_FACTORS),
            QUICK_CORRELATIONS,
            (REPRESENTATIVE_WEEKS[1].start,),
            QUICK_DAYS,
        )

    def points(self) -> list[tuple[int, float, float]]:
        """``(point, scale, correlation)`` of every grid point, numbered from 0."""
        pairs = [(s, r) for s in self.scales_sgd_per_mwh for r in self.correlations]
        return [(i, s, r) for i, (s, r) in enumerate(pairs)]


def sensitivity_jobs(grid: SensitivityGrid) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """(a), (b), (c) at every point × week of ``grid`` (params: ``point``,
    ``reserve_price_scale``, ``reserve_price_correlation``, ``week_start``, ``scenario``)."""
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    for point, scale, correlation in grid.points():
        for week in grid.weeks:
            for letter, name in PAPER_SCENARIOS.items():
                cfg = preset(name, start=week, days=grid.days)
                data = replace(
                    cfg.data, reserve_price_scale=scale, reserve_price_correlation=correlation
                )
                cfg = replace(cfg, name=f"{name}-s{scale:g}-rho{correlation:g}-{week}", data=data)
                params = {
                    "point": point,
                    "reserve_price_scale": scale,
                    "reserve_price_correlation": correlation,
                    "week_start": week,
                    "scenario": letter,
                }
                jobs.append((params, cfg))
    return jobs


def price_statistics(out_dir: str | Path) -> dict[str, float]:
    """Mean reserve price [SGD/MWh] and its Pearson correlation with USEP over a run's
    periods (NaN when either price is constant)."""
    frame = load_results(out_dir)
    energy = frame["energy_price_sgd_per_mwh"].to_numpy(dtype=float)
    reserve = frame["reserve_price_sgd_per_mwh"].to_numpy(dtype=float)
    constant = np.std(energy) == 0 or np.std(reserve) == 0
    pearson = math.nan if constant else float(np.corrcoef(energy, reserve)[0, 1])
    return {
        "reserve_price_mean_sgd_per_mwh": float(reserve.mean()),
        "reserve_usep_pearson": pearson,
    }


def points_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per point × scenario: the SGD KPIs summed over the weeks, ``revenue_share``, the highest
    week's peak, and the step-weighted mean offered reserve, price and correlation."""
    keys = ["point", "reserve_price_scale", "reserve_price_correlation", "scenario", "controller"]
    rows = []
    for values, group in runs.groupby(keys, sort=True):
        weights = group["steps"].to_numpy(dtype=float)
        row: dict[str, Any] = dict(zip(keys, values, strict=True))
        row["weeks"] = len(group)
        row |= {key: float(group[key].sum()) for key in _SUMMED}
        energy = row["energy_cost_sgd"]
        row["revenue_share"] = row["reserve_revenue_sgd"] / energy if energy else math.nan
        row["peak_power_kw"] = float(group["peak_power_kw"].max())
        for key in (
            "reserve_offered_mean_kw",
            "reserve_price_mean_sgd_per_mwh",
            "reserve_usep_pearson",
        ):
            row[key] = float(np.average(group[key].to_numpy(dtype=float), weights=weights))
        rows.append(row)
    return pd.DataFrame(rows)


def revenue_findings(points: pd.DataFrame) -> pd.DataFrame:
    """Per grid point: reserve revenue of (a), (b), (c) [SGD], whether it rises in (b) and in
    (c) against (a), and ``revenue_rises_in_b_and_c`` (the paper's finding: both)."""
    rows = []
    for (point, scale, correlation), group in points.groupby(
        ["point", "reserve_price_scale", "reserve_price_correlation"], sort=True
    ):
        revenue = dict(zip(group["scenario"], group["reserve_revenue_sgd"], strict=True))
        if not all(letter in revenue for letter in ("a", "b", "c")):
            continue
        rises_b = rises(revenue["b"], revenue["a"])
        rises_c = rises(revenue["c"], revenue["a"])
        rows.append(
            {
                "point": point,
                "reserve_price_scale": scale,
                "reserve_price_correlation": correlation,
                "revenue_a_sgd": revenue["a"],
                "revenue_b_sgd": revenue["b"],
                "revenue_c_sgd": revenue["c"],
                "rises_in_b": rises_b,
                "rises_in_c": rises_c,
                "revenue_rises_in_b_and_c": rises_b and rises_c,
            }
        )
    return pd.DataFrame(rows)


def findings_sentence(findings: pd.DataFrame) -> str:
    """The revenue finding's dependence on the reserve price, from :func:`revenue_findings`."""
    if not len(findings):
        return "No grid point finished all three scenarios."
    holds = findings[findings["revenue_rises_in_b_and_c"].astype(bool)]
    where = ", ".join(
        f"scale {row.reserve_price_scale:g} SGD/MWh, ρ = {row.reserve_price_correlation:g}"
        for row in holds.itertuples()
    )
    return (
        f"Reserve revenue rises in (b) and (c) against (a) at {len(holds)} of "
        f"{len(findings)} grid points"
        + (f" ({where})." if len(holds) else ".")
        + f" It rises in (b) at {int(findings['rises_in_b'].sum())} and in (c) at "
        f"{int(findings['rises_in_c'].sum())} points."
    )


@dataclass(frozen=True)
class SensitivityStudy:
    """What :func:`run_sensitivity` wrote and measured (tables of the module docstring;
    ``elapsed_s`` the study's wall-clock time [s], cached runs counting as done)."""

    out_dir: Path
    outcomes: list[JobOutcome]
    points: pd.DataFrame
    findings: pd.DataFrame
    sentence: str
    elapsed_s: float

    @property
    def failed(self) -> list[JobOutcome]:
        return [o for o in self.outcomes if not o.ok]


def _runs_with_prices(outcomes: Sequence[JobOutcome]) -> pd.DataFrame:
    runs = runs_table(outcomes, RUN_KPIS)
    if not len(runs):
        return runs
    stats = pd.DataFrame([price_statistics(path) for path in runs["out_dir"]], index=runs.index)
    return pd.concat([runs, stats], axis=1)


def run_sensitivity(
    out_dir: str | Path,
    grid: SensitivityGrid,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    fresh: bool = False,
    log: Callable[[str], None] = print,
) -> SensitivityStudy:
    """Run ``grid`` on Dask or local processes (progress bar with ETA) and write the tables
    and the figure."""
    from hvacflex.report.sensitivity_plots import plot_reserve_sensitivity

    started = time.perf_counter()
    jobs = sensitivity_jobs(grid)
    log(
        f"reserve-price sensitivity: {len(grid.scales_sgd_per_mwh)} scales × "
        f"{len(grid.correlations)} correlations × {len(grid.weeks)} weeks × "
        f"{len(PAPER_SCENARIOS)} scenarios = {len(jobs)} runs of {grid.days:g} days"
    )
    out, outcomes = run_study_jobs(out_dir, jobs, scheduler=scheduler, workers=workers, fresh=fresh)
    runs = _runs_with_prices(outcomes)
    points = points_table(runs) if len(runs) else pd.DataFrame()
    findings = revenue_findings(points) if len(points) else pd.DataFrame()
    sentence = findings_sentence(findings)
    write_tables(
        out,
        {
            "sensitivity_runs.csv": runs,
            "sensitivity.csv": points,
            "sensitivity_findings.csv": findings,
        },
    )
    if len(points):
        plot_reserve_sensitivity(points, out / "sensitivity_figure.png")
    log(f"  {sentence}")
    return SensitivityStudy(
        out, list(outcomes), points, findings, sentence, time.perf_counter() - started
    )
