"""``hvacflex reproduce``: the paper's figures and table, regenerated from the shipped data.

One call runs, as Dask jobs (see :mod:`hvacflex.sim.sweep`):

* the paper's scenarios (a) NMPC, (b) RMPC, (c) RMPC + PPP under the product's IL event
  model, the same three under the paper's whole-horizon reserve model, (b) and (c) with
  affine disturbance feedback (whole-horizon model), the 24 °C thermostat and the strong
  rule-based baselines (``thermostat-25.5``, ``trim-respond``, ``demand-limit``, ``gta-dr``;
  docs/baselines.md), over the whole of 2014 (``--quick``: one week) — the "does it pay?"
  table (every run priced with one tariff, :mod:`hvacflex.report.does_it_pay`), Table 1 for
  both models, Fig. 5, Fig. 6 and the comfort figure;
* the PPP sweep 0.5–30 SGD/kW on scenario (c) — Fig. 7;
* the uncertainty sweep 0–50 % of the heat gains for open-loop RMPC (and the affine-feedback
  RMPC) next to NMPC — the price of robustness;

then writes PNGs, the CSV behind every figure and table, and one self-contained
``report.html``. Finished runs are cached by their inputs and the code version, so a second
call with the same code only re-draws. When a run fails the report is still written, marked
incomplete at its top, and :attr:`Reproduction.complete` is False (the CLI exits 1).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex.building.io import load_building
from hvacflex.config import (
    BASELINE_PRESETS,
    DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW,
    PAPER_FEEDBACK_SCENARIOS,
    PAPER_MODEL_SCENARIOS,
    PAPER_SCENARIOS,
    ScenarioConfig,
    preset,
    scaled_uncertainty,
)
from hvacflex.paths import resolve_building
from hvacflex.results import load_results
from hvacflex.sim.sweep import JobOutcome, outcomes_table, run_sweep

ScenarioLabel = str

PPP_VALUES_SGD_PER_KW: tuple[float, ...] = (
    0.5,
    1.0,
    1.5,
    2.0,
    3.0,
    5.0,
    7.5,
    10.0,
    15.0,
    20.0,
    30.0,
)
QUICK_PPP_VALUES_SGD_PER_KW: tuple[float, ...] = (0.5, 1.5, 5.0, 30.0)
UNCERTAINTY_LEVELS: tuple[float, ...] = (0.0, 0.05, 0.1, 0.2, 0.3, 0.5)
QUICK_UNCERTAINTY_LEVELS: tuple[float, ...] = (0.0, 0.25, 0.5)

TARIFF_PEAK_PRICE_SGD_PER_KW = DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW
"""φ of the one tariff every comparison prices every run with [SGD/kW per month]: the
paper's peak-power price, billed on each calendar month's peak whether or not the
controller planned for it."""

SCENARIO_LABELS: dict[str, str] = {
    "a": "(a) NMPC",
    "b": "(b) RMPC",
    "c": "(c) RMPC + PPP",
    "thermostat": "thermostat",
} | {name: name for name in BASELINE_PRESETS}
RULE_BASED_SCENARIOS: tuple[str, ...] = ("thermostat", *BASELINE_PRESETS)
"""Scenario keys of the rule-based runs (the baselines "does it pay?" ranks against)."""
WHOLE_HORIZON_PREFIX = "paper-"
"""Key prefix of the scenarios run with the paper's whole-horizon reserve model."""
SCENARIO_LABELS |= {
    f"{WHOLE_HORIZON_PREFIX}{letter}": f"{SCENARIO_LABELS[letter]}, whole-horizon"
    for letter in PAPER_MODEL_SCENARIOS
}
FEEDBACK_PREFIX = "feedback-"
"""Key prefix of the robust scenarios run with affine disturbance feedback."""
SCENARIO_LABELS |= {
    f"{FEEDBACK_PREFIX}{letter}": f"{SCENARIO_LABELS[letter]}, affine feedback, whole-horizon"
    for letter in PAPER_FEEDBACK_SCENARIOS
}


STRESS_KEY = "stress-b"
"""Key of scenario (b) (``rmpc``) run with ``[activation] mode = "stress"``: one activation
every weekday in office hours, so that Table 1 shows the reserve delivered and settled."""
SCENARIO_LABELS[STRESS_KEY] = "(b) RMPC, stress activations"


def stress_config(name: str, *, start: str, days: float) -> ScenarioConfig:
    """Preset ``name`` over the period with an activation every weekday (``stress``)."""
    cfg = preset(name, start=start, days=days)
    return replace(
        cfg, name=f"{cfg.name}-stress", activation=replace(cfg.activation, mode="stress")
    )


def model_names() -> dict[str, str]:
    """Reserve model → its name in the report, with the product presets' D, α and R."""
    reserve = preset(PAPER_SCENARIOS["a"]).reserve
    return {
        "event": f"the event model (D = {reserve.event_max_steps}, "
        f"α = {reserve.event_allowance_k:g} K, R = {reserve.event_recovery_steps})",
        "whole-horizon": "the paper's whole-horizon model",
    }


@dataclass(frozen=True)
class Plan:
    """What a reproduction runs: periods and sweep values."""

    start: str
    days: float
    sweep_start: str
    sweep_days: float
    uncertainty_days: float
    ppp_values: tuple[float, ...]
    uncertainty_levels: tuple[float, ...]
    with_feedback: bool

    @classmethod
    def full(cls) -> Plan:
        return cls(
            start="2014-01-01",
            days=365.0,
            sweep_start="2014-03-03",
            sweep_days=28.0,
            uncertainty_days=3.0,
            ppp_values=PPP_VALUES_SGD_PER_KW,
            uncertainty_levels=UNCERTAINTY_LEVELS,
            with_feedback=True,
        )

    @classmethod
    def quick(cls) -> Plan:
        return cls(
            start="2014-03-03",
            days=7.0,
            sweep_start="2014-03-03",
            sweep_days=7.0,
            uncertainty_days=2.0,
            ppp_values=QUICK_PPP_VALUES_SGD_PER_KW,
            uncertainty_levels=QUICK_UNCERTAINTY_LEVELS,
            with_feedback=False,
        )


def scenario_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """Scenarios (a), (b), (c) with each reserve model, (b) and (c) with affine feedback, the
    thermostat and the strong baselines, and (b) under stress activations, over the plan's
    period (keys ``a``, ``paper-a``, …, ``feedback-b``, ``feedback-c``, ``thermostat``, the
    baselines' preset names and :data:`STRESS_KEY`)."""
    whole_horizon = [
        (f"{WHOLE_HORIZON_PREFIX}{letter}", name) for letter, name in PAPER_MODEL_SCENARIOS.items()
    ]
    feedback = [
        (f"{FEEDBACK_PREFIX}{letter}", name) for letter, name in PAPER_FEEDBACK_SCENARIOS.items()
    ]
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    baselines = [(name, name) for name in RULE_BASED_SCENARIOS]
    runs = [*PAPER_SCENARIOS.items(), *whole_horizon, *feedback, *baselines]
    for letter, name in runs:
        cfg = preset(name, start=plan.start, days=plan.days)
        jobs.append(({"scenario": letter}, cfg))
    stress = stress_config(PAPER_SCENARIOS["b"], start=plan.start, days=plan.days)
    jobs.append(({"scenario": STRESS_KEY}, stress))
    return jobs


def ppp_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """Scenario (c) with each peak-power price of the sweep."""
    base = preset("rmpc-ppp", start=plan.sweep_start, days=plan.sweep_days)
    return [
        (
            {"peak_price_sgd_per_kw": phi},
            replace(
                base,
                name=f"ppp-{phi:g}",
                controller=replace(base.controller, peak_price_sgd_per_kw=phi),
            ),
        )
        for phi in plan.ppp_values
    ]


def uncertainty_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """NMPC and open-loop RMPC (and feedback RMPC) at each uncertainty level."""
    controllers = ["nmpc", "rmpc"] + (["rmpc-feedback"] if plan.with_feedback else [])
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    for controller in controllers:
        for level in plan.uncertainty_levels:
            cfg = scaled_uncertainty(
                preset(controller, start=plan.sweep_start, days=plan.uncertainty_days), level
            )
            cfg = replace(cfg, name=f"{controller}-unc{round(100 * level)}")
            jobs.append(({"controller": controller, "uncertainty_level": level}, cfg))
    return jobs


HOT_CORNER_LEVEL = 0.1
"""Box half-width (fraction of heat gains) of the hot-corner comfort comparison."""


def corner_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """NMPC and RMPC with every forecast error at the hot corner of a ±10 % box."""
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    for controller in ("nmpc", "rmpc"):
        cfg = scaled_uncertainty(
            preset(controller, start=plan.sweep_start, days=plan.uncertainty_days),
            HOT_CORNER_LEVEL,
        )
        cfg = replace(
            cfg,
            name=f"{controller}-hot-corner",
            realisation=replace(cfg.realisation, mode="worst-upper"),
        )
        jobs.append(({"scenario": controller}, cfg))
    return jobs


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


def incomplete_section(failed: Sequence[JobOutcome], total: int) -> Any:
    """The section at the top of an incomplete report: which runs failed and why."""
    from hvacflex.report.html import Section

    return Section(
        title=f"INCOMPLETE — {len(failed)} of {total} runs failed",
        paragraphs=[
            "This report is incomplete: the runs below failed, so the figures, tables and "
            "sentences that need them are missing or rest on the other runs only.",
            "\n".join(f"- {o.label} ({o.params}): {o.error}" for o in failed),
        ],
    )


def reproduce(
    out_dir: str | Path,
    *,
    quick: bool = False,
    scheduler: str | None = None,
    workers: int = 2,
    log: Callable[[str], None] = print,
    fresh: bool = False,
) -> Reproduction:
    """Run everything and write the report (also when runs fail: marked incomplete).

    ``fresh`` ignores finished results and checkpoints and simulates every run again.
    """
    from hvacflex.report.html import write_report

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    plan = Plan.quick() if quick else Plan.full()
    groups = {
        "scenarios": scenario_jobs(plan),
        "ppp": ppp_jobs(plan),
        "uncertainty": uncertainty_jobs(plan),
        "corner": corner_jobs(plan),
    }
    all_jobs = [job for jobs in groups.values() for job in jobs]
    log(f"running {len(all_jobs)} closed-loop simulations on Dask ({workers} workers)…")
    done = 0

    def progress(outcome: JobOutcome) -> None:
        nonlocal done
        done += 1
        if outcome.ok:
            state = "ok (cached)" if outcome.cached else "ok"
        else:
            state = f"FAILED: {outcome.error}"
        log(f"  [{done}/{len(all_jobs)}] {outcome.label} {state}")

    outcomes = run_sweep(
        all_jobs,
        out,
        scheduler=scheduler,
        n_workers=workers,
        on_done=progress,
        fresh=fresh,
        progress=True,  # the bar over all runs: done/total, elapsed, ETA
    )
    failed = [o for o in outcomes if not o.ok]
    by_group: dict[str, list[JobOutcome]] = {}
    position = 0
    for group, jobs in groups.items():
        by_group[group] = outcomes[position : position + len(jobs)]
        position += len(jobs)
    sections = build_sections(plan, by_group, out)
    title = "hvacflex — reproduction of Hanif et al. (2016)"
    if failed:
        sections.insert(0, incomplete_section(failed, len(all_jobs)))
        title += " (INCOMPLETE)"
    path = write_report(out, title=title, sections=sections)
    if failed:
        log(f"report (INCOMPLETE, {len(failed)} of {len(all_jobs)} runs failed): {path}")
    else:
        log(f"report: {path}")
    return Reproduction(report=path, outcomes=list(outcomes))


def _frames(outcomes: Sequence[JobOutcome]) -> dict[str, pd.DataFrame]:
    frames = {}
    for outcome in outcomes:
        if outcome.ok:
            frame = load_results(outcome.out_dir)
            frames[str(outcome.params.get("scenario", outcome.label))] = frame
    return frames


def display_days(frame: pd.DataFrame, days: int = 2) -> tuple[pd.Timestamp, pd.Timestamp]:
    """The ``days`` consecutive weekdays with the highest energy price inside the run.

    Price spikes are where the controllers differ most (load shifting, reserve, peak), so the
    displayed window is chosen around the largest spike on a working day.
    """
    index = pd.DatetimeIndex(frame.index)
    price = frame["energy_price_sgd_per_mwh"]
    daily_max = price.groupby(index.normalize()).max()
    weekdays = daily_max[[d.weekday() < 5 for d in daily_max.index]]
    candidates = weekdays if len(weekdays) >= days else daily_max
    all_days = [pd.Timestamp(day) for day in daily_max.index]
    best = pd.Timestamp(candidates.idxmax())  # type: ignore[arg-type]
    pos = min(all_days.index(best), max(len(all_days) - days, 0))
    start = all_days[pos]
    return start, start + pd.Timedelta(days=days)


def build_sections(plan: Plan, by_group: dict[str, list[JobOutcome]], out: Path) -> list[Any]:
    """Figures, tables and text of the report."""
    from hvacflex.report import notes

    figures = out / "figures"
    figures.mkdir(exist_ok=True)
    scenario_frames = _frames(by_group["scenarios"])
    paper = {k: v for k, v in scenario_frames.items() if k in PAPER_SCENARIOS}
    whole = {
        k: scenario_frames[f"{WHOLE_HORIZON_PREFIX}{k}"]
        for k in PAPER_MODEL_SCENARIOS
        if f"{WHOLE_HORIZON_PREFIX}{k}" in scenario_frames
    }
    feedback = {
        k: scenario_frames[f"{FEEDBACK_PREFIX}{k}"]
        for k in PAPER_FEEDBACK_SCENARIOS
        if f"{FEEDBACK_PREFIX}{k}" in scenario_frames
    }
    stress = {k: f for k, f in scenario_frames.items() if k == STRESS_KEY}
    sections: list[Any] = []
    if any(k in RULE_BASED_SCENARIOS for k in scenario_frames):
        usual = {k: f for k, f in scenario_frames.items() if k not in stress}
        sections.append(does_it_pay_section(plan, usual, out))
    if paper:
        sections.append(paper_figures_section(paper, figures))
        sections.append(table1_section(plan, paper, whole, out, feedback=feedback, stress=stress))
    if scenario_frames:
        corner = _frames(by_group["corner"])
        sections.append(comfort_section(plan, scenario_frames, corner, out, figures))
    ppp = outcomes_table([o for o in by_group["ppp"] if o.ok])
    if not ppp.empty:
        sections.append(ppp_section(plan, ppp, figures))
    unc = outcomes_table([o for o in by_group["uncertainty"] if o.ok])
    if not unc.empty:
        sections.append(uncertainty_section(plan, unc, figures))
    sections.append(notes.differences_section())
    sections.append(notes.configuration_section(by_group))
    return sections


def floor_area_m2() -> float:
    """Conditioned floor area of the reproduction's building [m²]."""
    building = load_building(resolve_building(preset(PAPER_SCENARIOS["a"]).building))
    return float(sum(zone.floor_area_m2 for zone in building.zones))


def does_it_pay_section(plan: Plan, scenario_frames: Mapping[str, pd.DataFrame], out: Path) -> Any:
    """The "does it pay?" table (:mod:`hvacflex.report.does_it_pay`); writes
    ``does_it_pay.csv``."""
    from hvacflex.report import does_it_pay as pay
    from hvacflex.report.html import Section

    labelled = {SCENARIO_LABELS.get(k, k): f for k, f in scenario_frames.items()}
    rule_based = {SCENARIO_LABELS.get(k, k) for k in RULE_BASED_SCENARIOS}
    area_m2 = floor_area_m2()
    table = pay.does_it_pay(
        labelled,
        rule_based,
        peak_price_sgd_per_kw=TARIFF_PEAK_PRICE_SGD_PER_KW,
        floor_area_m2=area_m2,
    )
    pay.write_does_it_pay(table, out)
    reference = str(table["reference"].iloc[0])
    paying = [str(c) for c in table.loc[table["pays"], "controller"]]
    return Section(
        title="Does it pay? — every controller under one tariff",
        paragraphs=[
            f"Simulated {plan.days:g} days from {plan.start}, scaled to a month. Every run is "
            "priced with the same tariff: energy at USEP + φ × each month's billed peak "
            f"(φ = {TARIFF_PEAK_PRICE_SGD_PER_KW:g} SGD/kW, whatever φ the controller "
            "planned with) + IL non-delivery penalties − reserve revenue; per m² over "
            f"{area_m2:g} m² of floor. The reference is the cheapest rule-based baseline "
            f"that keeps comfort: {reference}. The reserve revenue rests on the SYNTHETIC "
            "reserve price, and the plant is hvacflex's own RC model.",
            "Cheaper than the reference without more discomfort: "
            + (", ".join(paying) if paying else "none")
            + ".",
        ],
        tables=[table],
    )


def paper_figures_section(paper: Mapping[str, pd.DataFrame], figures: Path) -> Any:
    """Fig. 2, 5 and 6 over the two displayed days of the paper's scenarios."""
    from hvacflex.report import plots
    from hvacflex.report.html import Section

    any_frame = next(iter(paper.values()))
    start, end = display_days(any_frame)
    window = {SCENARIO_LABELS[k]: f[(f.index >= start) & (f.index < end)] for k, f in paper.items()}
    reference = next(iter(window.values()))
    fig2 = plots.plot_prices(reference, figures / "fig2_prices.png")
    fig5 = plots.plot_temperatures(
        window,
        figures / "fig5_temperatures.png",
        title="Served and worst-IL-event zone temperatures",
        series=("temp_end", "temp_served", "event_worst"),
    )
    fig6 = plots.plot_power_reserve(window, figures / "fig6_power_reserve.png")
    return Section(
        title="Fig. 2, 5, 6 — prices, temperatures, power and reserve",
        paragraphs=[
            f"Displayed days: {start:%a %d %b %Y} and the day after — the working "
            "days with the highest energy price in the simulated period, where the "
            "controllers differ most. The reserve price is SYNTHETIC (no public "
            "history of NEMS IL prices exists; see the data notes).",
            f"Scenarios under {model_names()['event']}. Fig. 5 draws, per zone, the realised "
            "temperature, the plan's served prediction and its worst prediction over every "
            "IL event it plans for and every disturbance in the box (dash-dot; it may exceed "
            "the upper bound by α during and after an event). Fig. 6 draws the reserve band: "
            "from the served power down to the power drawn if the offered reserve is called.",
        ],
        figures=[fig2, fig5, fig6],
    )


def table1_section(
    plan: Plan,
    paper: Mapping[str, pd.DataFrame],
    whole: Mapping[str, pd.DataFrame],
    out: Path,
    *,
    feedback: Mapping[str, pd.DataFrame] | None = None,
    stress: Mapping[str, pd.DataFrame] | None = None,
) -> Any:
    """Table 1 (average cost per month) for both reserve models, and beside the paper's,
    with the reserve's settlement (offered, delivered against the metered baseline,
    shortfall, penalty, net revenue) in every row.

    ``paper`` holds the product presets' runs (event model), ``whole`` the ``paper-*``
    presets' (whole-horizon model), ``feedback`` the affine-feedback runs of (b) and (c)
    (whole-horizon model, rows after ``whole``'s in its block), each keyed by scenario
    letter; ``stress`` the run keyed :data:`STRESS_KEY` (last row of the event block).
    Writes ``table1.csv`` (one block of rows per model, each with % against its own (a))
    and ``table1_vs_paper.csv`` (each model's rows beside the published ones).
    """
    from hvacflex import kpi
    from hvacflex.report import tables
    from hvacflex.report.html import Section

    names = model_names()
    labelled = {
        "event": {SCENARIO_LABELS[k]: f for k, f in sorted(paper.items())}
        | {SCENARIO_LABELS[k]: f for k, f in (stress or {}).items()},
        "whole-horizon": {
            SCENARIO_LABELS[f"{WHOLE_HORIZON_PREFIX}{k}"]: f for k, f in sorted(whole.items())
        }
        | {
            SCENARIO_LABELS[f"{FEEDBACK_PREFIX}{k}"]: f for k, f in sorted((feedback or {}).items())
        },
    }
    per_model = {
        model: tables.table1({label: kpi.monthly_table(f) for label, f in frames.items()})
        for model, frames in labelled.items()
        if frames
    }
    table1 = tables.table1_models(per_model)
    table1.to_csv(out / "table1.csv")
    comparison = tables.table1_models(
        {
            model: tables.side_by_side(table, tables.PAPER_TABLE1)
            for model, table in per_model.items()
        }
    )
    comparison.to_csv(out / "table1_vs_paper.csv")
    revenue = {
        model: {k: kpi.summary(f)["reserve_revenue_sgd"] for k, f in frames.items()}
        for model, frames in (("event", paper), ("whole-horizon", whole))
    }
    paper_summaries = {k: kpi.summary(f) for k, f in paper.items()}
    return Section(
        title="Table 1 — average cost per month, both reserve models",
        paragraphs=[
            f"Simulated {plan.days:g} days from {plan.start}. Cost = energy bought at "
            "USEP; revenue = synthetic reserve price × reserve capacity offered; "
            "total = cost − revenue (the paper's definition; the PPP charge is "
            "reported separately below). Reserve settled as the market settles it: "
            "il_offered_kwh is the capacity due in activated periods, "
            "il_delivered_metered_kwh what the meter showed against the pre-event baseline, "
            "il_shortfall_kwh the part not delivered, il_penalty_sgd its penalty "
            "(included in total), il_net_revenue_sgd = revenue − penalty (per month). The "
            "product presets are activated at random (a few events a year); the row "
            f"'{SCENARIO_LABELS[STRESS_KEY]}' activates (b) every weekday in office hours.",
            f"Column reserve_model: event = {names['event']}, the product presets nmpc, "
            f"rmpc, rmpc-ppp; whole-horizon = {names['whole-horizon']}, the presets "
            "paper-nmpc, paper-rmpc, paper-rmpc-ppp, where the curtailed trajectory must stay "
            "inside the strict band for the whole horizon, and rmpc-feedback, "
            "rmpc-feedback-ppp (affine disturbance feedback, zone-local; the feedback LP plans "
            "for the whole-horizon model only). Each model's % changes are against "
            "its own (a). The second table sets each model's rows beside the published "
            "Table 1.",
            " ".join(scenario_sentences(paper_summaries)),
            " ".join(revenue_sentences(revenue)),
        ],
        tables=[table1, comparison],
    )


def revenue_sentences(revenue: Mapping[str, Mapping[str, float]]) -> list[str]:
    """Whether reserve revenue rises in (b) and (c) against (a), per reserve model.

    Parameters
    ----------
    revenue : model (``"event"``, ``"whole-horizon"``) → scenario letter → reserve revenue
        of the run [SGD]; a model missing a scenario is skipped.
    """
    from hvacflex.report import text

    names = model_names()
    return [
        text.revenue_trend(names.get(model, model), by_letter["a"], by_letter["b"], by_letter["c"])
        for model, by_letter in revenue.items()
        if all(letter in by_letter for letter in ("a", "b", "c"))
    ]


def comfort_section(
    plan: Plan,
    scenario_frames: Mapping[str, pd.DataFrame],
    corner: Mapping[str, pd.DataFrame],
    out: Path,
    figures: Path,
) -> Any:
    """Discomfort of every scenario (and the hot-corner runs); writes kpi_scenarios.csv,
    whose ``ppp_charge_sgd`` and ``net_cost_with_ppp_sgd`` price every run at the one
    tariff's φ (:data:`TARIFF_PEAK_PRICE_SGD_PER_KW`)."""
    from hvacflex import kpi
    from hvacflex.report import plots, text
    from hvacflex.report.html import Section

    all_frames = {SCENARIO_LABELS.get(k, k): f for k, f in scenario_frames.items()}
    summary = pd.DataFrame(
        {name: kpi.summary(f, TARIFF_PEAK_PRICE_SGD_PER_KW) for name, f in all_frames.items()}
    )
    summary.to_csv(out / "kpi_scenarios.csv")
    fig_comfort = plots.plot_discomfort(all_frames, figures / "comfort.png")
    figures_comfort = [fig_comfort]
    if corner:
        labels = {"nmpc": "NMPC, hot corner", "rmpc": "RMPC, hot corner"}
        figures_comfort.append(
            plots.plot_discomfort(
                {labels.get(k, k): f for k, f in corner.items()},
                figures / "comfort_hot_corner.png",
                title=f"Discomfort with every error at the hot corner of a "
                f"±{100 * HOT_CORNER_LEVEL:.0f} % box",
            )
        )
    corner_discomfort = {k: kpi.total_discomfort_kelvin_hours(f) for k, f in corner.items()}
    scenario_discomfort = {
        k: kpi.total_discomfort_kelvin_hours(f) for k, f in scenario_frames.items()
    }
    return Section(
        title="Comfort under the same realised disturbances",
        paragraphs=[
            "All scenarios face the same forecast errors (drawn uniformly in the "
            "uncertainty box with the same seed). Discomfort is the BOPTEST "
            "definition: the time integral of the deviation outside the band [K·h]; "
            f"up to {text.COMFORT_TOLERANCE_KELVIN_HOURS:g} K·h counts as keeping "
            "the band.",
            " ".join(comfort_sentences(scenario_discomfort, corner_discomfort, plan)),
        ],
        figures=figures_comfort,
        tables=[summary],
    )


def ppp_section(plan: Plan, ppp: pd.DataFrame, figures: Path) -> Any:
    """Fig. 7: cost and peak against the peak-power price, from the sweep's outcomes."""
    from hvacflex.report import plots
    from hvacflex.report.html import Section

    ppp = ppp.sort_values("peak_price_sgd_per_kw")
    ppp["total_cost_sgd"] = ppp["net_cost_sgd"]
    ppp_csv = ppp[
        ["peak_price_sgd_per_kw", "total_cost_sgd", "peak_power_kw", "net_cost_with_ppp_sgd"]
    ]
    fig7 = plots.plot_ppp_sweep(ppp_csv, figures / "fig7_ppp_sweep.png")
    return Section(
        title="Fig. 7 — peak-power price sweep",
        paragraphs=[
            f"Scenario (c) from {plan.sweep_start} for {plan.sweep_days:g} days at "
            f"φ ∈ {list(plan.ppp_values)} SGD/kW. Normalised total cost = "
            "cost_j / max(cost) with cost = energy − reserve revenue (operational "
            "cost, without the PPP charge itself); normalised peak = peak_j / "
            "max(peak), the peak of the 30-min plant power over the period.",
            ppp_sentence(ppp_csv),
        ],
        figures=[fig7],
        tables=[ppp_csv.reset_index(drop=True)],
    )


def uncertainty_section(plan: Plan, unc: pd.DataFrame, figures: Path) -> Any:
    """The price of robustness: KPIs against the uncertainty level, per controller."""
    from hvacflex.report import plots
    from hvacflex.report.html import Section

    unc_csv = unc[
        [
            "controller",
            "uncertainty_level",
            "net_cost_sgd",
            "reserve_revenue_sgd",
            "discomfort_kelvin_hours",
            "planned_slack_share",
            "max_delta_vs_half_band",
        ]
    ].sort_values(["controller", "uncertainty_level"])
    fig_unc = plots.plot_robustness_price(unc_csv, figures / "robustness_price.png")
    return Section(
        title="The price of robustness",
        paragraphs=[
            "Cost, reserve revenue, discomfort and the share of steps whose plan "
            "needed comfort slack against the uncertainty level (σ as a fraction of "
            "solar and internal gains; the realised errors are drawn in the same "
            "box), from "
            f"{plan.sweep_start} for {plan.uncertainty_days:g} days.",
        ],
        figures=[fig_unc],
        tables=[unc_csv.reset_index(drop=True)],
    )


def scenario_sentences(summaries: Mapping[str, Mapping[str, float]]) -> list[str]:
    """What Table 1's runs show, computed from their KPIs.

    Parameters
    ----------
    summaries : scenario letter (``"a"``, ``"b"``, ``"c"``, as in :data:`PAPER_SCENARIOS`)
        → :func:`hvacflex.kpi.summary` of its run; missing scenarios are skipped.
    """
    from hvacflex.report import text

    sentences: list[str] = []
    a, b, c = (summaries.get(k) for k in ("a", "b", "c"))
    if a is not None and b is not None:
        sentences.append(text.robustness_cost(a["net_cost_sgd"], b["net_cost_sgd"]))
    if b is not None and c is not None:
        sentences.append(
            text.peak_comparison(
                SCENARIO_LABELS["c"], c["peak_power_kw"], SCENARIO_LABELS["b"], b["peak_power_kw"]
            )
        )
    not_offered: list[str] = []
    unused: list[str] = []
    unused_robust = False
    event_steps = preset(PAPER_SCENARIOS["a"]).reserve.event_max_steps
    for letter, kpis in summaries.items():
        if letter not in PAPER_SCENARIOS:
            continue
        label = SCENARIO_LABELS[letter]
        controller = preset(PAPER_SCENARIOS[letter]).controller
        if kpis["reserve_revenue_sgd"] > 0:
            sentences.append(
                text.reserve_revenue(label, kpis["reserve_revenue_sgd"], kpis["energy_cost_sgd"])
            )
        elif not controller.reserve:
            not_offered.append(label)
        else:
            unused.append(label)
            unused_robust = unused_robust or controller.robust != "none"
    if unused:
        sentences.append(
            text.no_reserve(unused, offered=True, robust=unused_robust, event_steps=event_steps)
        )
    if not_offered:
        sentences.append(text.no_reserve(not_offered, offered=False, robust=False))
    return sentences


def comfort_sentences(
    scenario_discomfort: Mapping[str, float], corner_discomfort: Mapping[str, float], plan: Plan
) -> list[str]:
    """What the comfort figures show, computed from the discomfort [K·h] of each run.

    Parameters
    ----------
    scenario_discomfort : scenario key (``"a"``, ``"b"``, ``"c"``, ``"thermostat"``) → K·h.
    corner_discomfort : ``"nmpc"`` / ``"rmpc"`` at the hot corner → K·h.
    """
    from hvacflex.report import text

    sentences = [
        text.comfort(SCENARIO_LABELS.get(key, key), value)
        for key, value in scenario_discomfort.items()
    ]
    a, b = scenario_discomfort.get("a"), scenario_discomfort.get("b")
    if a is not None and b is not None:
        sentences.append(
            text.nominal_vs_robust_comfort(
                a, b, "Under the default box (errors drawn uniformly, same seed)"
            )
        )
    if a is not None and text.keeps_comfort(a):
        sentences.append(
            "A likely reason the nominal MPC keeps the band here: its linear model is "
            "linearised below the upper comfort bound and under-predicts the cooling of the "
            "supply air near that bound (a small hidden margin), and independent errors "
            "average out over a zone's time constant."
        )
    nominal, robust = corner_discomfort.get("nmpc"), corner_discomfort.get("rmpc")
    if nominal is not None and robust is not None:
        sentences.append(
            text.nominal_vs_robust_comfort(
                nominal,
                robust,
                f"With every error at its hot corner of a ±{100 * HOT_CORNER_LEVEL:.0f} % box "
                f"from {plan.sweep_start} for {plan.uncertainty_days:g} days (second figure)",
            )
        )
    return sentences


def ppp_sentence(ppp: pd.DataFrame) -> str:
    """The peak and cost response over the PPP sweep (``fig7_ppp_sweep.csv`` columns)."""
    from hvacflex.report import text

    ordered = ppp.sort_values("peak_price_sgd_per_kw")
    low, high = ordered.iloc[0], ordered.iloc[-1]
    low_cost = float(low["total_cost_sgd"])
    ratio = float(high["total_cost_sgd"]) / low_cost if low_cost != 0 else float("nan")
    return text.ppp_sweep(
        float(low["peak_price_sgd_per_kw"]),
        float(low["peak_power_kw"]),
        float(high["peak_price_sgd_per_kw"]),
        float(high["peak_power_kw"]),
        ratio,
    )
