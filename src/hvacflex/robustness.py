"""Robustness of the paper's findings over representative weeks and occupancy seeds.

``hvacflex reproduce --seeds`` runs (a) NMPC, (b) RMPC and (c) RMPC + PPP (the product
presets of :data:`hvacflex.config.PAPER_SCENARIOS`) with the plant seeing the stochastic
occupancy model (``[realisation] occupancy = "stochastic"``) over
:data:`REPRESENTATIVE_WEEKS` × :data:`SEEDS` (``[realisation] occupancy_seed``; every other
draw keeps the scenario's seed, so the spread is the occupants' alone), as Dask jobs
(:mod:`hvacflex.sim.sweep`: cached by inputs and code, resumable). It writes:

* ``seeds_runs.csv`` — one row per week × seed × scenario: the KPIs of :data:`SPREAD_KPIS`;
* ``seeds_spread.csv`` — per scenario and KPI: mean, min, max, std over the week-seeds;
* ``seeds_findings.csv`` — per week-seed: whether each of :data:`FINDINGS` holds;
* ``seeds_verdicts.csv`` — per finding: in how many week-seeds it holds;
* ``seeds_spread_figure.png`` — the spread figure (:mod:`hvacflex.report.sensitivity_plots`).

The findings are decided by :func:`finding_verdicts` from the KPIs of one (a), (b), (c) triple
(run over the same days with the same seeds), by the same rules as the reproduction's report
(:func:`hvacflex.report.verdicts.scenario_verdicts`); :mod:`hvacflex.sensitivity` uses the
revenue rule (:func:`hvacflex.report.text.rises`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex.config import PAPER_SCENARIOS, ScenarioConfig, preset
from hvacflex.report.verdicts import HOLDS, scenario_verdicts
from hvacflex.sim.sweep import JobOutcome, run_sweep
from hvacflex.version import atomic_write_text


@dataclass(frozen=True)
class RepresentativeWeek:
    """A week of 2014 standing for a season of Singapore's monsoon year.

    Attributes
    ----------
    start : first day (a Monday), ISO 8601.
    season : the monsoon phase it stands for.
    reason : why this week (weather, prices, no public holiday: the office schedule has none).
    """

    start: str
    season: str
    reason: str


REPRESENTATIVE_WEEKS: tuple[RepresentativeWeek, ...] = (
    RepresentativeWeek(
        "2014-01-13",
        "Northeast monsoon (Dec–early Mar)",
        "the coolest, windiest months: the lowest cooling load; mid-January, clear of the "
        "New Year and of Chinese New Year (31 Jan)",
    ),
    RepresentativeWeek(
        "2014-04-21",
        "first inter-monsoon (Apr–May)",
        "the hottest months, afternoon thunderstorms: the highest cooling load and peaks; "
        "after Good Friday (18 Apr), before Labour Day (1 May)",
    ),
    RepresentativeWeek(
        "2014-07-14",
        "Southwest monsoon (Jun–Sep)",
        "warm and drier, pre-dawn squalls; mid-July, before Hari Raya Puasa (28 Jul)",
    ),
    RepresentativeWeek(
        "2014-10-13",
        "second inter-monsoon (Oct–Nov)",
        "thunderstorms and weak winds, humid; before Deepavali (22 Oct)",
    ),
)
"""One Monday-to-Sunday week per monsoon phase (Meteorological Service Singapore's seasons)."""

SEEDS: tuple[int, ...] = (1, 2, 3, 4, 5)
"""Occupancy seeds of the full study."""

QUICK_SEEDS: tuple[int, ...] = (1, 2)
"""Occupancy seeds of ``--quick``."""

WEEK_DAYS = 7.0
"""Length of a representative week [days]."""

QUICK_DAYS = 2.0
"""Days per week of ``--quick`` (its Monday and Tuesday): a check of the tools end to end that
fits a shared machine, not a measurement of the findings."""

SPREAD_KPIS: tuple[str, ...] = (
    "energy_cost_sgd",
    "reserve_revenue_sgd",
    "il_penalty_sgd",
    "net_cost_sgd",
    "peak_power_kw",
    "energy_kwh",
    "discomfort_kelvin_hours",
    "max_violation_k",
    "violation_share",
)
"""KPIs (:func:`hvacflex.kpi.summary` keys) whose spread the study reports."""

FINDINGS: dict[str, str] = {
    "robustness_premium": "Robustness costs a few per cent: (b) RMPC costs more than (a) NMPC",
    "ppp_costs_more": "The peak-power price costs energy: (c) costs more than (b)",
    "ppp_lowers_peak": "The peak-power price lowers the peak: (c) below (b)",
    "robust_keeps_comfort": "NMPC violates comfort under uncertainty, RMPC almost never",
    "revenue_rises": "Reserve revenue rises in (b) and (c) against (a)",
}
"""The paper's findings judged on one (a), (b), (c) triple: the key of each verdict of
:func:`hvacflex.report.verdicts.scenario_verdicts` → its sentence, in that order."""


def finding_verdicts(summaries: Mapping[str, Mapping[str, float]]) -> dict[str, bool]:
    """Whether each of :data:`FINDINGS` holds for one (a), (b), (c) triple, by the rules of
    the reproduction's report (:func:`hvacflex.report.verdicts.scenario_verdicts`: one set of
    rules for the same findings).

    Parameters
    ----------
    summaries : scenario letter (``"a"``, ``"b"``, ``"c"``) → :func:`hvacflex.kpi.summary`
        of its run (``energy_cost_sgd``, ``reserve_revenue_sgd`` [SGD], ``peak_power_kw``
        [kW], ``discomfort_kelvin_hours`` [K·h]), all over the same period.

    Returns
    -------
    finding key → holds. A finding that is not comparable (revenue when (a) earns none)
    does not hold.
    """
    found = scenario_verdicts(summaries, basis="seed study")
    return {v.key: v.verdict == HOLDS for v in found}


@dataclass(frozen=True)
class SeedPlan:
    """What the seed study runs: weeks (start dates), days per week and occupancy seeds."""

    weeks: tuple[str, ...]
    days: float
    seeds: tuple[int, ...]

    @classmethod
    def full(cls) -> SeedPlan:
        """Four representative weeks × five seeds (60 week-long runs)."""
        return cls(tuple(w.start for w in REPRESENTATIVE_WEEKS), WEEK_DAYS, SEEDS)

    @classmethod
    def quick(cls) -> SeedPlan:
        """The four weeks' first :data:`QUICK_DAYS` days × two seeds (24 runs)."""
        return cls(tuple(w.start for w in REPRESENTATIVE_WEEKS), QUICK_DAYS, QUICK_SEEDS)


def seed_jobs(plan: SeedPlan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """(a), (b), (c) with stochastic occupancy for every week × seed of ``plan``
    (params: ``week_start``, ``occupancy_seed``, ``scenario``)."""
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    for week in plan.weeks:
        for seed in plan.seeds:
            for letter, name in PAPER_SCENARIOS.items():
                cfg = preset(name, start=week, days=plan.days)
                cfg = replace(
                    cfg,
                    name=f"{name}-occ{seed}-{week}",
                    realisation=replace(
                        cfg.realisation, occupancy="stochastic", occupancy_seed=seed
                    ),
                )
                params = {"week_start": week, "occupancy_seed": seed, "scenario": letter}
                jobs.append((params, cfg))
    return jobs


def runs_table(outcomes: Sequence[JobOutcome], keys: Sequence[str]) -> pd.DataFrame:
    """One row per finished job: its parameters, ``controller`` (the preset) and ``kpis``.

    Failed jobs are left out (the caller reports them)."""
    rows = []
    for outcome in outcomes:
        if not outcome.ok or outcome.summary is None:
            continue
        row: dict[str, Any] = dict(outcome.params)
        row["controller"] = PAPER_SCENARIOS.get(str(row.get("scenario")), outcome.label)
        row |= {key: float(outcome.summary.get(key, math.nan)) for key in keys}
        row["out_dir"] = outcome.out_dir
        rows.append(row)
    return pd.DataFrame(rows)


def run_study_jobs(
    out_dir: str | Path,
    jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]],
    *,
    scheduler: str | None,
    workers: int,
    fresh: bool,
) -> tuple[Path, list[JobOutcome]]:
    """The study's folder (made) and the outcomes of its ``jobs`` run there on Dask or local
    processes with a progress bar (:func:`hvacflex.sim.sweep.run_sweep`)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    outcomes = run_sweep(
        jobs, out, scheduler=scheduler, n_workers=workers, fresh=fresh, progress=True
    )
    return out, outcomes


def write_tables(out: Path, tables: Mapping[str, pd.DataFrame]) -> None:
    """Each table as the CSV file ``out``/name (written atomically, no index)."""
    for name, table in tables.items():
        atomic_write_text(out / name, table.to_csv(index=False))


def spread_table(runs: pd.DataFrame, kpis: Sequence[str] = SPREAD_KPIS) -> pd.DataFrame:
    """Per scenario and KPI: ``n``, ``mean``, ``min``, ``max``, ``std`` (sample, ddof 1) over
    the rows of ``runs`` (:func:`runs_table`)."""
    rows = []
    for letter, group in runs.groupby("scenario", sort=True):
        for key in kpis:
            values = group[key].astype(float)
            rows.append(
                {
                    "scenario": letter,
                    "controller": group["controller"].iloc[0],
                    "kpi": key,
                    "n": len(values),
                    "mean": values.mean(),
                    "min": values.min(),
                    "max": values.max(),
                    "std": values.std(ddof=1) if len(values) > 1 else 0.0,
                }
            )
    return pd.DataFrame(rows)


def findings_table(runs: pd.DataFrame, by: Sequence[str]) -> pd.DataFrame:
    """One row per group of ``runs`` (columns ``by``) holding all three scenarios: whether
    each finding holds (:func:`finding_verdicts`); groups missing a scenario are skipped."""
    rows = []
    for key, group in runs.groupby(list(by), sort=True):
        summaries: dict[str, dict[str, float]] = {
            str(row["scenario"]): {str(k): v for k, v in row.items()} for _, row in group.iterrows()
        }
        if not all(letter in summaries for letter in ("a", "b", "c")):
            continue
        values = key if isinstance(key, tuple) else (key,)
        rows.append(dict(zip(by, values, strict=True)) | finding_verdicts(summaries))
    return pd.DataFrame(rows, columns=[*by, *FINDINGS])


def verdict_counts(findings: pd.DataFrame) -> pd.DataFrame:
    """Per finding: ``finding`` (its sentence), ``holds`` (count) and ``of`` (groups)."""
    return pd.DataFrame(
        [
            {
                "key": key,
                "finding": sentence,
                "holds": int(findings[key].astype(bool).sum()) if len(findings) else 0,
                "of": len(findings),
            }
            for key, sentence in FINDINGS.items()
        ]
    )


@dataclass(frozen=True)
class SeedStudy:
    """What :func:`run_seed_study` wrote and measured.

    Attributes
    ----------
    out_dir : folder of the CSV files and the figure.
    outcomes : every job's outcome, in plan order.
    spread, findings, verdicts : the tables of the module docstring.
    elapsed_s : wall-clock time of the study [s] (cached runs count as done).
    """

    out_dir: Path
    outcomes: list[JobOutcome]
    spread: pd.DataFrame
    findings: pd.DataFrame
    verdicts: pd.DataFrame
    elapsed_s: float

    @property
    def failed(self) -> list[JobOutcome]:
        return [o for o in self.outcomes if not o.ok]


def run_seed_study(
    out_dir: str | Path,
    plan: SeedPlan,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    fresh: bool = False,
    log: Callable[[str], None] = print,
) -> SeedStudy:
    """Run ``plan`` on Dask or local processes (progress bar with ETA) and write the tables
    and the figure."""
    from hvacflex.report.sensitivity_plots import plot_seed_spread

    started = time.perf_counter()
    jobs = seed_jobs(plan)
    log(
        f"seed study: {len(plan.weeks)} weeks × {len(plan.seeds)} occupancy seeds × "
        f"{len(PAPER_SCENARIOS)} scenarios = {len(jobs)} runs of {plan.days:g} days"
    )
    out, outcomes = run_study_jobs(out_dir, jobs, scheduler=scheduler, workers=workers, fresh=fresh)
    runs = runs_table(outcomes, SPREAD_KPIS)
    spread = spread_table(runs) if len(runs) else pd.DataFrame()
    findings = (
        findings_table(runs, ("week_start", "occupancy_seed"))
        if len(runs)
        else pd.DataFrame(columns=["week_start", "occupancy_seed", *FINDINGS])
    )
    verdicts = verdict_counts(findings)
    write_tables(
        out,
        {
            "seeds_runs.csv": runs,
            "seeds_spread.csv": spread,
            "seeds_findings.csv": findings,
            "seeds_verdicts.csv": verdicts,
        },
    )
    if len(runs):
        plot_seed_spread(runs, out / "seeds_spread_figure.png")
    for _, row in verdicts.iterrows():
        log(f"  {row['finding']}: holds in {row['holds']} of {row['of']} week-seeds")
    return SeedStudy(out, list(outcomes), spread, findings, verdicts, time.perf_counter() - started)
