"""The reproduction report's sections from hand-made results: the verdict leads with the
paper's findings judged from the runs, every comparison with the paper states its basis, and
the validation section links the EnergyPlus section of the same page."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from hvacflex import kpi
from hvacflex.report.html import Section, render_report, section_anchor
from hvacflex.report.verdicts import VERDICTS
from hvacflex.reproduce_plan import Plan
from hvacflex.reproduce_report import (
    basis_text,
    does_it_pay_section,
    validation_section,
    verdict_section,
)

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


@pytest.mark.parametrize("width_px", [1280, 1920])
def test_the_deciding_columns_of_does_it_pay_fit_the_window(
    chromium: Any, make_results: Factory, tmp_path: Path, width_px: int
) -> None:
    """In headless Chromium the "does it pay?" table shows rank, controller, tariff cost,
    saving, pays and occupied discomfort within the window, without scrolling sideways; the
    other columns are in an expandable detail below it."""
    from hvacflex.reproduce_plan import RULE_BASED_SCENARIOS

    keys = ["a", "b", "c", "paper-a", "paper-b", "paper-c", *RULE_BASED_SCENARIOS]
    frames = {key: make_results(seed=i, power_scale=1.0 + 0.03 * i) for i, key in enumerate(keys)}
    table, section = does_it_pay_section(Plan.quick(), frames, tmp_path)
    page_file = tmp_path / "page.html"
    page_file.write_text(render_report(title="t", sections=[section]), encoding="utf-8")
    page = chromium.new_page(viewport={"width": width_px, "height": 900})
    page.goto(page_file.as_uri(), wait_until="load")
    headers = page.eval_on_selector_all(
        "section table.hvacflex >> nth=0 >> thead th",
        "cells => cells.map(c => [c.textContent, c.getBoundingClientRect().right])",
    )
    shown = [text for text, _ in headers]
    assert shown[:6] == [
        "Rank",
        "Controller",
        "Tariff cost [SGD/month]",
        "Saving vs reference [%]",
        "Pays",
        "Occupied discomfort [K·h/month]",
    ]
    assert all(right <= width_px for _, right in headers), headers
    box = page.eval_on_selector(
        "div.table-scroll", "d => [d.scrollWidth, d.clientWidth, document.body.scrollWidth]"
    )
    assert box[0] <= box[1] and box[2] <= width_px, box  # no scroll bar, in the table or page
    assert page.locator("details.table-detail summary").first.is_visible()
    hidden = page.locator("details.table-detail table").first
    assert not hidden.is_visible()  # the rest waits behind the summary
    page.locator("details.table-detail summary").first.click()
    assert hidden.is_visible()
    pays = page.eval_on_selector_all(
        "section table.hvacflex >> nth=0 >> tbody tr",
        "rows => rows.map(r => r.cells[4].textContent)",
    )
    assert len(pays) == len(table) == len(keys) and set(pays) <= {"yes", "no"}
    if width_px == 1280:
        page.screenshot(path=str(tmp_path / "does_it_pay.png"), full_page=True)
    page.close()
