"""The report of ``hvacflex reproduce``: one function per section, from the runs' results.

:func:`build_sections` lays out, from the outcomes of the plan's runs by group: the verdict
(the paper's findings judged from the runs, :mod:`hvacflex.report.verdicts`, and the answers
to "does peak shaving pay?" and "does selling reserve work?"), the "does it pay?" table,
Fig. 2, 5, 6, Table 1 for both reserve models, comfort, Fig. 7, the price of robustness, the
section on EnergyPlus (:mod:`hvacflex.reproduce_energyplus`), the validation links and the
notes. Every table that compares with the paper states its basis (a week scaled to a month,
or the year).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex.building.io import load_building
from hvacflex.config import (
    PAPER_FEEDBACK_SCENARIOS,
    PAPER_MODEL_SCENARIOS,
    PAPER_SCENARIOS,
    preset,
)
from hvacflex.paths import resolve_building
from hvacflex.report.run_report import REPORT_KPIS
from hvacflex.reproduce_energyplus import ENERGYPLUS_SCENARIOS, fig7_energyplus_part
from hvacflex.reproduce_plan import (
    FEEDBACK_PREFIX,
    HOT_CORNER_LEVEL,
    RULE_BASED_SCENARIOS,
    SCENARIO_LABELS,
    STRESS_KEY,
    TARIFF_PEAK_PRICE_SGD_PER_KW,
    WHOLE_HORIZON_PREFIX,
    Plan,
    model_names,
    ppp_energyplus_jobs,
)
from hvacflex.results import load_results
from hvacflex.sim.sweep import JobOutcome, outcomes_table


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


def basis_text(plan: Plan) -> str:
    """What the scenario runs' numbers rest on, for every table that compares with the
    paper (issue 28: a week scaled to a month is not the paper's year)."""
    forecast = "; statistical weather forecast, stochastic occupancy" if plan.realistic else ""
    if plan.days >= DAYS_PER_YEAR:
        return f"RC plant, {plan.days:g} days from {plan.start}, monthly averages{forecast}"
    return (
        f"RC plant, {plan.days:g} days from {plan.start} scaled to a month — not the "
        f"paper's year 2014{forecast}"
    )


DAYS_PER_YEAR = 365.0


def build_sections(plan: Plan, by_group: dict[str, list[JobOutcome]], out: Path) -> list[Any]:
    """Figures, tables and text of the report: the verdict first, then "does it pay?", the
    paper's figures and Table 1, comfort, Fig. 7, robustness, EnergyPlus, notes."""
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
    corner = _frames(by_group["corner"])
    ppp = outcomes_table([o for o in by_group["ppp"] if o.ok])
    stress = {k: f for k, f in scenario_frames.items() if k == STRESS_KEY}
    sections: list[Any] = []
    pay_table: pd.DataFrame | None = None
    if any(k in RULE_BASED_SCENARIOS for k in scenario_frames):
        usual = {k: f for k, f in scenario_frames.items() if k not in stress}
        pay_table, pay_section = does_it_pay_section(plan, usual, out)
        sections.append(pay_section)
    energyplus = energyplus_part(plan, by_group.get("energyplus", []), scenario_frames, out)
    if paper:
        sections.insert(0, verdict_section(plan, paper, corner, ppp, pay_table, out))
        sections.append(paper_figures_section(paper, figures))
        sections.append(table1_section(plan, paper, whole, out, feedback=feedback, stress=stress))
    if scenario_frames:
        sections.append(comfort_section(plan, scenario_frames, corner, out, figures))
    if not ppp.empty:
        sections.append(ppp_section(plan, ppp, figures))
    unc = outcomes_table([o for o in by_group["uncertainty"] if o.ok])
    if not unc.empty:
        sections.append(uncertainty_section(plan, unc, figures))
    if energyplus is not None:
        sections.append(energyplus)
    fig7_energyplus = fig7_energyplus_part(
        {params["forecast"]: cfg for params, cfg in ppp_energyplus_jobs(plan)},
        by_group.get("ppp_energyplus", []),
        figures,
        period=f"{plan.sweep_days:g} days from {plan.sweep_start}",
    )
    if fig7_energyplus is not None:
        sections.append(fig7_energyplus)
    sections.append(validation_section(sections, energyplus))
    sections.append(notes.differences_section())
    sections.append(notes.configuration_section(by_group))
    return sections


def energyplus_part(
    plan: Plan,
    outcomes: Sequence[JobOutcome],
    scenario_frames: Mapping[str, pd.DataFrame],
    out: Path,
) -> Any:
    """The EnergyPlus section (:func:`hvacflex.reproduce_energyplus.energyplus_section`), or
    None without EnergyPlus runs. The RC side is the scenario runs when they cover the
    EnergyPlus week, else the ``week-*`` runs."""
    from hvacflex.reproduce_energyplus import energyplus_section

    eplus = _frames([o for o in outcomes if o.params.get("plant") == "energyplus"])
    if not eplus:
        return None
    if plan.energyplus_week_is_scenario_period:
        rc = {k: f for k, f in scenario_frames.items() if k in ENERGYPLUS_SCENARIOS}
    else:
        rc = _frames([o for o in outcomes if o.params.get("plant") == "rc"])
    return energyplus_section(
        eplus,
        rc,
        labels=SCENARIO_LABELS,
        peak_price_sgd_per_kw=TARIFF_PEAK_PRICE_SGD_PER_KW,
        period=f"{plan.energyplus_days:g} days from {plan.energyplus_start}",
        out=out,
        figures=out / "figures",
    )


VALIDATION_TITLE = "Validation of the building model"


def validation_section(sections: Sequence[Any], energyplus: Any) -> Any:
    """Where hvacflex's building model is checked against independent references: ASHRAE
    Standard 140 and EnergyPlus (with a link to this report's EnergyPlus section)."""
    from hvacflex.report.html import Section, section_anchor

    links = []
    if energyplus is not None:
        position = [id(section) for section in sections].index(id(energyplus))
        links.append(
            (
                "The controllers on EnergyPlus, this report",
                "#" + section_anchor(energyplus.title, position + 1),
            )
        )
    return Section(
        title=VALIDATION_TITLE,
        paragraphs=[
            "Every number above outside the EnergyPlus section is measured on hvacflex's own RC "
            "plant. The envelope model is checked against ASHRAE Standard 140 (BESTEST: "
            "hvacflex validate bestest; the table in docs/explanation/validation.md of the "
            "hvacflex source) "
            "and against EnergyPlus 25.2 on office5's own IDF export (hvacflex validate "
            "energyplus office5: zone-air RMSE, cooling energy and HVAC electricity per case; "
            "docs/explanation/validation.md and docs/guide/energyplus.md). Run hvacflex "
            "reproduce --energyplus for the controllers graded by EnergyPlus.",
        ],
        links=links,
    )


def verdict_section(
    plan: Plan,
    paper: Mapping[str, pd.DataFrame],
    corner: Mapping[str, pd.DataFrame],
    ppp: pd.DataFrame,
    pay_table: pd.DataFrame | None,
    out: Path,
) -> Any:
    """The report's opening: the answers to "does peak shaving pay?" and "does selling
    reserve work?" and the verdict on each paper finding (:mod:`hvacflex.report.verdicts`);
    writes ``verdicts.csv``."""
    from hvacflex import kpi
    from hvacflex.report import verdicts
    from hvacflex.report.html import Section

    basis = basis_text(plan)
    summary = {k: kpi.summary(f) for k, f in paper.items()}
    found: list[verdicts.Verdict] = []
    if "a" in summary:
        found.append(verdicts.cost_level(summary["a"]["monthly_avg_energy_cost_sgd"], basis))
    found += verdicts.scenario_verdicts(
        summary,
        basis,
        comfort_basis=f"{basis}; the default box, errors drawn uniformly",
        comfort_case="default box",
        revenue_basis=f"{basis}; {model_names()['event']}",
    )
    if "nmpc" in corner and "rmpc" in corner:
        found.append(
            verdicts.robust_keeps_comfort(
                kpi.total_discomfort_kelvin_hours(corner["nmpc"]),
                kpi.total_discomfort_kelvin_hours(corner["rmpc"]),
                f"RC plant, {plan.uncertainty_days:g} days from {plan.sweep_start}, every error "
                f"at the hot corner of a ±{100 * HOT_CORNER_LEVEL:.0f} % box",
                case="hot corner",
            )
        )
    if "a" in summary:
        a = summary["a"]
        found.append(verdicts.reserve_share(a["reserve_revenue_sgd"], a["energy_cost_sgd"], basis))
    if not ppp.empty:
        found.append(
            verdicts.peak_reduction_saturates(
                ppp["peak_price_sgd_per_kw"].astype(float).tolist(),
                ppp["peak_power_kw"].astype(float).tolist(),
                f"RC plant, scenario (c), {plan.sweep_days:g} days from {plan.sweep_start}",
            )
        )
    table = verdicts.verdict_table(found)
    table.to_csv(out / "verdicts.csv")
    counts = table["verdict"].value_counts()
    paragraphs = [
        "Verdict: of the paper's findings tested here, "
        + ", ".join(f"{int(counts.get(v, 0))} {v}" for v in verdicts.VERDICTS)
        + ". Each row gives the paper's number, ours and what ours rest on; the verdicts are "
        "computed from the runs of this report.",
    ]
    labels = [SCENARIO_LABELS[k] for k in ("a", "b", "c")]
    if pay_table is not None and set(labels) <= set(pay_table["controller"]):
        paragraphs.append(verdicts.peak_shaving_answer(pay_table, labels[2], labels[1]))
        whole = SCENARIO_LABELS[f"{WHOLE_HORIZON_PREFIX}b"]
        if whole in set(pay_table["controller"]):
            paragraphs.append(verdicts.reserve_answer(pay_table, labels[1], whole))
    return Section(
        title="Verdict",
        paragraphs=paragraphs,
        tables=[table],
        table_captions=[f"The paper's findings against ours ({basis})"],
    )


def floor_area_m2() -> float:
    """Conditioned floor area of the reproduction's building [m²]."""
    building = load_building(resolve_building(preset(PAPER_SCENARIOS["a"]).building))
    return float(sum(zone.floor_area_m2 for zone in building.zones))


def does_it_pay_section(
    plan: Plan, scenario_frames: Mapping[str, pd.DataFrame], out: Path
) -> tuple[pd.DataFrame, Any]:
    """The "does it pay?" table (:mod:`hvacflex.report.does_it_pay`) and its section; writes
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
    return table, Section(
        title="Does it pay? — every controller under one tariff",
        paragraphs=[
            f"Simulated {plan.days:g} days from {plan.start}, scaled to a month. Every run is "
            "priced with the same tariff on money settled against the meter: HVAC energy at "
            f"USEP + φ × each month's billed HVAC peak (φ = {TARIFF_PEAK_PRICE_SGD_PER_KW:g} "
            "SGD/kW, whatever φ the controller planned with) + IL non-delivery penalties − "
            "reserve revenue of the activated periods (settled against the meter). Availability "
            "payments for reserve no activation tested stand beside it as unsettled reserve "
            "and do not rank (they rest on the SYNTHETIC reserve price). Comfort is graded on "
            "the occupied periods; the unoccupied excursions stand beside it. "
            + (
                f"Per m² over {area_m2:g} m² of floor. "
                if math.isfinite(area_m2) and area_m2 > 0
                else "Per m²: not available (the building's floor area is not known). "
            )
            + "The reference is the cheapest rule-based baseline that "
            f"keeps occupied comfort: {reference}. The plant is hvacflex's own RC model.",
            "Cheaper than the reference without more occupied discomfort: "
            + (", ".join(paying) if paying else "none")
            + ".",
        ],
        tables=[table],
        table_captions=[f"Every controller under one tariff, per month ({basis_text(plan)})"],
        table_details=[pay.DETAIL_COLUMNS],
    )


def paper_figures_section(paper: Mapping[str, pd.DataFrame], figures: Path) -> Any:
    """Fig. 2 and 5 over the two displayed days of the paper's scenarios; Fig. 6 on each
    run's own peak day."""
    from hvacflex.report import plots
    from hvacflex.report.html import Section

    any_frame = next(iter(paper.values()))
    start, end = display_days(any_frame)
    labelled = {SCENARIO_LABELS[k]: f for k, f in paper.items()}
    window = {label: f[(f.index >= start) & (f.index < end)] for label, f in labelled.items()}
    reference = next(iter(window.values()))
    fig2 = plots.plot_prices(reference, figures / "fig2_prices.png")
    fig5 = plots.plot_temperatures(
        window,
        figures / "fig5_temperatures.png",
        title="Zone temperatures, realised and planned (served and worst IL event)",
        series=("temp_end", "temp_served", "event_worst"),
    )
    fig6 = plots.plot_power_reserve(labelled, figures / "fig6_power_reserve.png")
    peaks = ", ".join(
        f"{label} {float(f['power_kw'].max()):.1f} kW on {plots.peak_day(f).index[0]:%a %d %b}"
        for label, f in labelled.items()
    )
    return Section(
        title="Fig. 2, 5, 6 — prices, temperatures, power and reserve",
        paragraphs=[
            f"Fig. 2 and 5 show {start:%a %d %b %Y} and the day after — the working days with "
            "the highest energy price in the simulated period, where the controllers differ "
            "most; Fig. 6 shows each run on its own peak day, where the peak-power price acts "
            f"(peaks: {peaks}). The reserve price is SYNTHETIC (no public history of NEMS IL "
            "prices exists; see the data notes).",
            f"Scenarios under {model_names()['event']}.",
        ],
        figures=[fig2, fig5, fig6],
        figure_captions=[
            "Fig. 2 — the energy price (NEMS USEP 2014, real) and the synthetic reserve price "
            "over the two displayed days.",
            "Fig. 5 — left: every zone's realised temperature over the shaded comfort band; "
            "right: the warmest zone's realised temperature with the plan's served prediction "
            "(dashed) and its worst prediction over every IL event it plans for and every "
            "disturbance in the box (dash-dot; it may exceed the upper bound by α during and "
            "after an event).",
            "Fig. 6 — each run on its own peak day: the power drawn with its peak marked and "
            "the reserve band (served power down to the power drawn if the offered reserve is "
            "called), the energy price on the right axis; below each run that offered reserve "
            "that day, the reserve offered (a run without any gets no empty panel).",
        ],
    )


def _feedback_rows_text(plan: Plan) -> str:
    if not plan.feedback_scenarios:
        return " (the affine-feedback runs were left out: --no-feedback)"
    return (
        ", and rmpc-feedback, rmpc-feedback-ppp (affine disturbance feedback, zone-local; "
        "the feedback LP plans for the whole-horizon model only)"
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
            f"inside the strict band for the whole horizon{_feedback_rows_text(plan)}. Each "
            "model's % changes are against its own (a). The second table sets each model's "
            "rows beside the published Table 1.",
            " ".join(scenario_sentences(paper_summaries)),
            " ".join(revenue_sentences(revenue)),
        ],
        tables=[table1, comparison],
        table_captions=[
            f"Table 1 from our runs, HVAC energy and reserve per month ({basis_text(plan)})",
            f"Our Table 1 beside the published one (ours: {basis_text(plan)}; the paper: "
            "the year 2014)",
        ],
        table_details=[
            [*tables.TABLE1_IL_COLUMNS, "months", "days"],
            [
                "paper_scenario",
                *(
                    f"{column} ({side})"
                    for column in tables.TABLE1_COLUMNS
                    if column.startswith("reserve") or column == "energy_cost_change_pct"
                    for side in ("ours", "paper")
                ),
            ],
        ],
        table_labels=[tables.TABLE1_LABELS, tables.TABLE1_LABELS],
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
    from hvacflex.report.run_report import PLANNED_SLACK_TEXT, formatted_kpi_table, labelled

    all_frames = {SCENARIO_LABELS.get(k, k): f for k, f in scenario_frames.items()}
    summary = pd.DataFrame(
        {name: kpi.summary(f, TARIFF_PEAK_PRICE_SGD_PER_KW) for name, f in all_frames.items()}
    )
    summary.to_csv(out / "kpi_scenarios.csv")
    fig_comfort = plots.plot_discomfort(all_frames, figures / "comfort.png")
    figures_comfort = [fig_comfort]
    captions = [
        "Discomfort of every run over the scenario period [K·h], stacked by zone, with "
        "its total at the end of each bar."
    ]
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
        captions.append(
            f"NMPC and RMPC over {plan.uncertainty_days:g} days from {plan.sweep_start} with "
            f"every forecast error at the hot corner of a ±{100 * HOT_CORNER_LEVEL:.0f} % box "
            "[K·h], stacked by zone."
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
            PLANNED_SLACK_TEXT,
        ],
        figures=figures_comfort,
        figure_captions=captions,
        tables=[
            labelled(
                formatted_kpi_table(
                    summary.loc[[k for k in SHOWN_KPIS if k in summary.index]], None
                )
            )
        ],
        table_details=[[name for name in summary.columns if WHOLE_HORIZON_TEXT in str(name)]],
        table_captions=[
            f"KPIs of every run over the scenario period, not scaled (peak billed at φ = "
            f"{TARIFF_PEAK_PRICE_SGD_PER_KW:g} SGD/kW; {basis_text(plan)}; every KPI in "
            "kpi_scenarios.csv)"
        ],
    )


WHOLE_HORIZON_TEXT = "whole-horizon"
"""In a run's label: the paper's reserve model, whose runs the comfort table shows in its
expandable detail (the product presets' runs and the baselines stay in view)."""

SHOWN_KPIS = (
    *REPORT_KPIS,
    "energy_cost_sgd",
    "reserve_revenue_settled_sgd",
    "reserve_revenue_unsettled_sgd",
    "ppp_charge_sgd",
    "solve_time_mean_s",
)
"""Rows of kpi_scenarios.csv shown in the report's comfort section (the CSV holds all)."""


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
        figure_captions=[
            "Fig. 7 — normalised total cost (energy − reserve revenue, red) and normalised peak "
            "(blue) of scenario (c) against the peak-power price φ it plans with."
        ],
        tables=[ppp_csv.reset_index(drop=True)],
        table_captions=[
            f"Scenario (c), {plan.sweep_days:g} days from {plan.sweep_start} on the RC plant, "
            "totals over the period (not scaled)"
        ],
    )


def uncertainty_section(plan: Plan, unc: pd.DataFrame, figures: Path) -> Any:
    """The price of robustness: KPIs against the uncertainty level, per controller."""
    from hvacflex.report import plots
    from hvacflex.report.html import Section
    from hvacflex.report.run_report import PLANNED_SLACK_TEXT

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
    shown = unc_csv.assign(uncertainty_level_pct=100.0 * unc_csv["uncertainty_level"])
    shown = shown[["controller", "uncertainty_level_pct", *unc_csv.columns[2:]]]
    return Section(
        title="The price of robustness",
        paragraphs=[
            "Cost, reserve revenue, discomfort and the share of steps whose plan "
            "needed comfort slack against the uncertainty level (σ as a fraction of "
            "solar and internal gains; the realised errors are drawn in the same "
            "box), from "
            f"{plan.sweep_start} for {plan.uncertainty_days:g} days.",
            PLANNED_SLACK_TEXT,
        ],
        figures=[fig_unc],
        figure_captions=[
            "Net cost, reserve revenue, discomfort and the share of steps planned on slack "
            "against the box half-width σ [% of the heat gains], one line per controller."
        ],
        tables=[shown.reset_index(drop=True)],
        table_captions=[
            f"Per controller and level σ [%], {plan.uncertainty_days:g} days from "
            f"{plan.sweep_start} on the RC plant, totals over the period"
        ],
        table_labels=[ROBUSTNESS_LABELS],
    )


ROBUSTNESS_LABELS = {
    "uncertainty_level_pct": "Level σ [%]",
    "net_cost_sgd": "HVAC net cost [SGD]",
    "reserve_revenue_sgd": "Reserve revenue [SGD]",
    "discomfort_kelvin_hours": "Discomfort [K·h]",
    "planned_slack_share": "Plans needing slack",
    "max_delta_vs_half_band": "Largest δ / half band",
}
"""Headers of the price-of-robustness table."""


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
