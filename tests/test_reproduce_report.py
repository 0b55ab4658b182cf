"""The reproduction report's sections from hand-made results: the verdict leads with the
paper's findings judged from the runs, every comparison with the paper states its basis, and
the validation section links the EnergyPlus section of the same page."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest

from hvacflex import kpi
from hvacflex.report.html import Section, render_report, section_anchor
from hvacflex.report.verdicts import VERDICTS
from hvacflex.reproduce_plan import Plan
from hvacflex.reproduce_report import basis_text, validation_section, verdict_section

Factory = Callable[..., pd.DataFrame]


def test_basis_says_week_or_year() -> None:
    assert "scaled to a month — not the paper's year 2014" in basis_text(Plan.quick())
    assert "monthly averages" in basis_text(Plan.full()) and "scaled" not in basis_text(Plan.full())


def test_verdict_section_judges_each_finding_from_the_runs(
    make_results: Factory, tmp_path: Path
) -> None:
    paper = {
        "a": make_results(seed=1, temp_offset_k=0.8),  # warmer: violates the band
        "b": make_results(seed=2, power_scale=1.02),
        "c": make_results(seed=3, power_scale=1.05),
    }
    ppp = pd.DataFrame({"peak_price_sgd_per_kw": [0.5, 5.0, 30.0], "peak_power_kw": [40, 31, 30]})
    section = verdict_section(Plan.quick(), paper, {}, ppp, None, tmp_path)
    table = pd.read_csv(tmp_path / "verdicts.csv", index_col="finding")
    assert set(table["verdict"]) <= set(VERDICTS)
    premium = table.loc["Robustness costs a few per cent: (b) RMPC costs more than (a) NMPC"]
    a_cost, b_cost = (kpi.energy_cost_sgd(paper[k]) for k in ("a", "b"))
    assert f"{100 * (b_cost - a_cost) / a_cost:+.1f} %" in premium["ours"]
    assert table.loc["The peak reduction saturates beyond ~5 SGD/kW", "verdict"] == "holds"
    assert all("scaled to a month" in basis for basis in table["basis"].iloc[:-1])
    assert section.paragraphs[0].startswith("Verdict: of the paper's findings tested here, ")
    counts = table["verdict"].value_counts()
    assert f"{counts.get('holds', 0)} holds" in section.paragraphs[0]
    assert "scaled to a month" in section.table_captions[0]


def test_validation_links_the_energyplus_section_of_the_page() -> None:
    energyplus = Section(title="On EnergyPlus — the same week")
    sections = [Section(title="Verdict"), energyplus]
    validation = validation_section(sections, energyplus)
    ((_, target),) = validation.links
    assert target == "#" + section_anchor(energyplus.title, 2)
    page = render_report(title="t", sections=[*sections, validation])
    assert f'id="{target[1:]}"' in page and f'href="{target}"' in page
    assert validation_section(sections, None).links == []
    assert "ASHRAE Standard 140" in validation.paragraphs[0]


@pytest.mark.parametrize("quick", [True, False])
def test_the_plan_period_enters_the_basis(quick: bool) -> None:
    plan = Plan.quick() if quick else Plan.full()
    assert f"{plan.days:g} days from {plan.start}" in basis_text(plan)
