"""``hvacflex reproduce``: the paper's figures and table, regenerated from the shipped data.

One call runs, as Dask jobs (see :mod:`hvacflex.sim.sweep`; the plan is
:mod:`hvacflex.reproduce_plan`):

* the paper's scenarios (a) NMPC, (b) RMPC, (c) RMPC + PPP under the product's IL event
  model, the same three under the paper's whole-horizon reserve model, (b) and (c) with
  affine disturbance feedback (whole-horizon model), the 24 °C thermostat and the strong
  rule-based baselines (``thermostat-25.5``, ``trim-respond``, ``demand-limit``, ``gta-dr``;
  docs/explanation/baselines.md), over the whole of 2014 (``--quick``: one week);
* the PPP sweep 0.5–30 SGD/kW on scenario (c) — Fig. 7;
* the uncertainty sweep 0–50 % of the heat gains for open-loop RMPC (and the affine-feedback
  RMPC) next to NMPC — the price of robustness — and the hot-corner runs;
* with ``--energyplus``, (a), (b), (c) and the two thermostats over the period on EnergyPlus
  office5 beside the RC plant (:mod:`hvacflex.reproduce_energyplus`);

then writes the report (:mod:`hvacflex.reproduce_report`: the verdict first), its PNGs, the
CSV behind every figure and table, and one self-contained ``report.html``.

**Run folders.** Every run lives in a stable folder named after it, ``OUT/runs/<run name>``
(:func:`run_folder`: ``rmpc``, ``paper-rmpc``, ``ppp-1.5``, ``energyplus-rmpc``, …), so a
second call updates each in place: a finished run of the same inputs and code is re-used, an
interrupted one resumes from its checkpoint, and a folder holding another configuration of
that name (the year after ``--quick``) is emptied and run again. When a run fails the report
is still written, marked incomplete at its top, and :attr:`Reproduction.complete` is False
(the CLI exits 1).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hvacflex.config import ScenarioConfig
from hvacflex.errors import InputError
from hvacflex.reproduce_plan import (
    RULE_BASED_SCENARIOS,
    SCENARIO_LABELS,
    STRESS_KEY,
    TARIFF_PEAK_PRICE_SGD_PER_KW,
    JobGroups,
    Plan,
    corner_jobs,
    plan_groups,
    ppp_jobs,
    scenario_jobs,
    uncertainty_jobs,
)
from hvacflex.sim.progress import clock_text
from hvacflex.sim.sweep import JobOutcome, SweepClock, backend, relative_cost, run_sweep

__all__ = [
    "RULE_BASED_SCENARIOS",
    "SCENARIO_LABELS",
    "STRESS_KEY",
    "TARIFF_PEAK_PRICE_SGD_PER_KW",
    "Plan",
    "Reproduction",
    "corner_jobs",
    "plan_groups",
    "ppp_jobs",
    "prepare_run_folders",
    "reproduce",
    "run_folder",
    "run_groups",
    "scenario_jobs",
    "uncertainty_jobs",
    "verdict_lines",
]


@dataclass(frozen=True)
class Reproduction:
    """What :func:`reproduce` did.

    Attributes
    ----------
    report : path of ``report.html``.
    outcomes : every run's outcome, in the order of the plan.
    """

    report: Path
    outcomes: list[JobOutcome]

    @property
    def failed(self) -> list[JobOutcome]:
        return [o for o in self.outcomes if not o.ok]

    @property
    def complete(self) -> bool:
        """True when every run finished."""
        return not self.failed


RUNS_FOLDER = "runs"
"""Folder of the reproduction's runs inside its output folder."""


def run_folder(out_dir: str | Path, config: ScenarioConfig) -> Path:
    """The stable folder of one reproduction run: ``<out_dir>/runs/<run name>``.

    The run name says what the run is (``rmpc``, ``paper-rmpc``, ``thermostat-25.5``,
    ``ppp-1.5``, ``rmpc-unc25``, ``nmpc-hot-corner``, ``energyplus-rmpc``, ``week-rmpc``;
    docs/explanation/reproduction.md lists them) and is unique within a plan, so ``hvacflex kpi
    results/reproduce/runs/rmpc`` works and a second reproduction updates each folder in
    place.
    """
    return Path(out_dir) / RUNS_FOLDER / config.name


def prepare_run_folders(
    out_dir: Path, jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]], log: Callable[[str], None]
) -> list[Path]:
    """The stable folder of every job (:func:`run_folder`); a folder holding the run of
    another configuration (another plan, an edited preset) is emptied first, so that it is
    updated in place, while a folder of the same configuration keeps its finished results
    (re-used when the code is the same) or its checkpoint (resumed).

    Raises
    ------
    InputError
        When two jobs would share a folder.
    """
    from hvacflex.errors import StoredStateError
    from hvacflex.sim.run_files import check_out_dir

    folders = [run_folder(out_dir, cfg) for _, cfg in jobs]
    names = [folder.name for folder in folders]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise InputError(
            "two reproduction runs would share a folder",
            field="name",
            value=repeated,
            hint="give every job of the plan its own configuration name",
        )
    for folder, (_, cfg) in zip(folders, jobs, strict=True):
        try:
            check_out_dir(folder, cfg, fresh=False)
        except StoredStateError as exc:
            log(f"  replacing {folder}: {exc}")
            check_out_dir(folder, cfg, fresh=True)
    return folders


def run_groups(
    groups: JobGroups,
    out_dir: Path,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    log: Callable[[str], None] = print,
    fresh: bool = False,
) -> dict[str, list[JobOutcome]]:
    """Run every group's jobs in their stable folders (:func:`prepare_run_folders`) on Dask
    or on local processes (:func:`run_sweep`); the outcomes by group, in the order of the
    jobs. Finished runs of the same inputs and code are re-used, interrupted ones resume from
    their checkpoint; ``fresh`` simulates every run again."""
    all_jobs = [job for jobs in groups.values() for job in jobs]
    folders = prepare_run_folders(out_dir, all_jobs, log)
    log(f"running {len(all_jobs)} closed-loop simulations on {backend(scheduler, workers)}…")
    cost = {
        str(folder): relative_cost(cfg) for folder, (_, cfg) in zip(folders, all_jobs, strict=True)
    }
    clock = SweepClock(list(cost.values()))
    done = 0

    def progress(outcome: JobOutcome) -> None:
        nonlocal done
        done += 1
        if outcome.ok:
            state = "ok (cached)" if outcome.cached else "ok"
        else:
            state = f"FAILED: {outcome.error}"
        elapsed_s, eta_s = clock.finished(cost[outcome.out_dir], outcome.cached)
        eta = "?" if eta_s is None else clock_text(eta_s)
        log(
            f"  [{done}/{len(all_jobs)}] {outcome.label} {state} · elapsed "
            f"{clock_text(elapsed_s)} · ETA {eta}"
        )

    outcomes = run_sweep(
        all_jobs,
        out_dir,
        scheduler=scheduler,
        n_workers=workers,
        on_done=progress,
        fresh=fresh,
        progress=True,  # the bar over all runs: done/total, elapsed, ETA
        out_dirs=folders,
    )
    by_group: dict[str, list[JobOutcome]] = {}
    position = 0
    for group, jobs in groups.items():
        by_group[group] = outcomes[position : position + len(jobs)]
        position += len(jobs)
    return by_group


def reproduce(
    out_dir: str | Path,
    *,
    quick: bool = False,
    energyplus: bool = False,
    feedback: bool = True,
    scheduler: str | None = None,
    workers: int = 2,
    log: Callable[[str], None] = print,
    fresh: bool = False,
) -> Reproduction:
    """Run everything and write the report (also when runs fail: marked incomplete).

    ``energyplus`` adds the section on EnergyPlus office5 (needs the ``energyplus`` extra);
    ``feedback=False`` leaves out (b) and (c) with affine feedback over the period;
    ``fresh`` ignores finished results and checkpoints and simulates every run again.

    Raises
    ------
    InputError
        With ``energyplus`` when the extra is not installed (before any run).
    """
    if energyplus:
        from hvacflex.energyplus.api import engine_dir

        engine_dir()  # a missing extra is said before an hour of runs
    plan = (Plan.quick if quick else Plan.full)(energyplus=energyplus, feedback=feedback)
    return run_and_report(
        plan, plan_groups(plan), out_dir, scheduler=scheduler, workers=workers, log=log, fresh=fresh
    )


def run_and_report(
    plan: Plan,
    groups: JobGroups,
    out_dir: str | Path,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    log: Callable[[str], None] = print,
    fresh: bool = False,
) -> Reproduction:
    """Run ``groups`` (the plan's, or a part of them) in their stable folders
    (:func:`run_groups`) and write the report on ``plan`` from their outcomes, marked
    incomplete when a run failed."""
    from hvacflex.report.html import write_report
    from hvacflex.reproduce_report import build_sections, incomplete_section

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    by_group = run_groups(groups, out, scheduler=scheduler, workers=workers, log=log, fresh=fresh)
    outcomes = [o for group in by_group.values() for o in group]
    failed = [o for o in outcomes if not o.ok]
    sections = build_sections(plan, by_group, out)
    title = "hvacflex — reproduction of Hanif et al. (2016)"
    if failed:
        sections.insert(0, incomplete_section(failed, len(outcomes)))
        title += " (INCOMPLETE)"
    path = write_report(out, title=title, sections=sections)
    if failed:
        log(f"report (INCOMPLETE, {len(failed)} of {len(outcomes)} runs failed): {path}")
    else:
        log(f"report: {path}")
    for line in verdict_lines(sections):
        log(line)
    return Reproduction(report=path, outcomes=outcomes)


VERDICT_PREFIX = "verdict: "
"""What each of the console's closing lines starts with (:func:`verdict_lines`)."""


def verdict_lines(sections: Sequence[Any]) -> list[str]:
    """The report's verdict for the console, one line each, every line starting
    :data:`VERDICT_PREFIX`: the count of the paper's findings that hold, the answers to "does
    peak shaving pay?" and "does selling reserve work?", then one line per finding (its
    verdict, the paper's number and ours). From the report's "Verdict" section (its
    paragraphs and table, :func:`hvacflex.reproduce_report.verdict_section`); none when the
    report has none (runs failed before it could be judged)."""
    section = next((s for s in sections if getattr(s, "title", None) == "Verdict"), None)
    if section is None:
        return []
    lines = []
    for paragraph in section.paragraphs:
        text = " ".join(paragraph.split())
        if text.lower().startswith("verdict:"):
            text = text[len("verdict:") :].strip().split(". ")[0].rstrip(".") + "."
        lines.append(VERDICT_PREFIX + text)
    for table in section.tables[:1]:
        for finding, row in table.iterrows():
            lines.append(
                f"{VERDICT_PREFIX}{row['verdict']}: {finding} (paper {row['paper']}; ours "
                f"{row['ours']})"
            )
    return lines
