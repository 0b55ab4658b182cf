"""The reproduction produces every artefact, and the figures show what they claim.

The report's tests run :data:`TEST_PLAN`: every job of the quick plan (what ``hvacflex
reproduce --quick`` runs), the scenarios and the PPP sweep over three days instead of seven,
the uncertainty sweep and the hot corner over one instead of two, so the suite stays within
its time. The quick plan itself is built and checked here and in ``test_reproduce_plan.py``,
and ``reproduce --quick`` through the command line in ``test_cli_failures.py``."""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.config import BASELINE_PRESETS, preset
from hvacflex.reproduce import (
    RULE_BASED_SCENARIOS,
    SCENARIO_LABELS,
    STRESS_KEY,
    TARIFF_PEAK_PRICE_SGD_PER_KW,
    Plan,
    plan_groups,
    run_and_report,
    run_folder,
    run_groups,
    scenario_jobs,
    verdict_lines,
)
from hvacflex.results import load_results
from hvacflex.sim.run import run_simulation

TEST_PLAN = replace(Plan.quick(), days=3.0, sweep_days=3.0, uncertainty_days=1.0)
"""The quick plan's every job over 3 days (the hot corner and the uncertainty sweep 1)."""


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("reproduce")
    run_and_report(TEST_PLAN, plan_groups(TEST_PLAN), out, workers=2, log=lambda _: None)
    return out


EXPECTED = [
    "report.html",
    "does_it_pay.csv",
    "table1.csv",
    "table1_vs_paper.csv",
    "kpi_scenarios.csv",
    "figures/fig2_prices.png",
    "figures/fig2_prices.csv",
    "figures/fig5_temperatures.png",
    "figures/fig5_temperatures.csv",
    "figures/fig6_power_reserve.png",
    "figures/fig6_power_reserve.csv",
    "figures/fig7_ppp_sweep.png",
    "figures/fig7_ppp_sweep.csv",
    "figures/comfort.png",
    "figures/comfort_hot_corner.png",
    "figures/robustness_price.png",
    "figures/robustness_price.csv",
]


def test_the_quick_plan_runs_every_baseline_over_the_scenarios_period() -> None:
    plan = Plan.quick()
    jobs = {params["scenario"]: cfg for params, cfg in scenario_jobs(plan)}
    assert set(BASELINE_PRESETS) <= set(jobs) and "thermostat" in jobs
    for name in RULE_BASED_SCENARIOS:
        assert jobs[name].controller.kind != "mpc"
        assert (jobs[name].start, jobs[name].days) == (plan.start, plan.days)
    # (b) runs beside the others with an activation every weekday
    assert jobs[STRESS_KEY].activation.mode == "stress"
    assert jobs[STRESS_KEY].controller == jobs["b"].controller


def test_does_it_pay_ranks_every_scenario_under_one_tariff(quick_report: Path) -> None:
    table = pd.read_csv(quick_report / "does_it_pay.csv")
    kpis = pd.read_csv(quick_report / "kpi_scenarios.csv", index_col=0)
    # every scenario but the stress case (another activation regime) is ranked
    assert set(table["controller"]) == set(kpis.columns) - {SCENARIO_LABELS[STRESS_KEY]}
    assert list(table["rank"]) == list(range(1, len(table) + 1))
    assert table["tariff_cost_sgd_per_month"].is_monotonic_increasing
    reference = table["reference"].iloc[0]
    baselines = {SCENARIO_LABELS[k] for k in RULE_BASED_SCENARIOS}
    assert reference in baselines
    assert set(table.loc[table["rule_based"], "controller"]) == baselines
    # every run's peak is charged at the one φ, whatever it planned with
    for label in ("(a) NMPC", "(c) RMPC + PPP"):
        assert kpis.loc["ppp_charge_monthly_sgd", label] == pytest.approx(
            TARIFF_PEAK_PRICE_SGD_PER_KW * kpis.loc["peak_power_kw", label]
        )
    text = (quick_report / "report.html").read_text()
    assert text.index("Does it pay?") < text.index("Table 1")


@pytest.mark.parametrize("name", EXPECTED)
def test_every_artefact_is_written(quick_report: Path, name: str) -> None:
    path = quick_report / name
    assert path.is_file() and path.stat().st_size > 0


VOID_ELEMENTS = frozenset("area base br col embed hr img input link meta source track wbr".split())


class StrictHTML(HTMLParser):
    """Fails on what the standard parser forgives: a closing tag that does not match the
    open element, an unclosed element at the end, a closed void element."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.open: list[tuple[str, tuple[int, int]]] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag not in VOID_ELEMENTS:
            self.open.append((tag, self.getpos()))

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag not in VOID_ELEMENTS:
            raise AssertionError(f"self-closed non-void <{tag}/> at {self.getpos()}")

    def handle_endtag(self, tag: str) -> None:
        if tag in VOID_ELEMENTS:
            raise AssertionError(f"end tag of void element </{tag}> at {self.getpos()}")
        if not self.open:
            raise AssertionError(f"</{tag}> at {self.getpos()} closes nothing")
        expected, where = self.open.pop()
        if expected != tag:
            raise AssertionError(f"</{tag}> at {self.getpos()} closes <{expected}> of {where}")

    def check(self, document: str) -> None:
        self.feed(document)
        self.close()
        if self.open:
            raise AssertionError(f"unclosed elements: {self.open}")


@pytest.mark.parametrize(
    "broken",
    [
        "<html><body><p>text</b></p></body></html>",
        "<html><body><section><p>text</p></body></html>",
        "<html><body><div/></body></html>",
        "<html><body><table><tr><td>1</tr></table></body></html>",
    ],
)
def test_the_strict_parser_rejects_broken_html(broken: str) -> None:
    with pytest.raises(AssertionError):
        StrictHTML().check(broken)


def test_report_is_valid_self_contained_html(quick_report: Path) -> None:
    text = (quick_report / "report.html").read_text()
    StrictHTML().check(text)
    assert text.startswith("<!DOCTYPE html>")
    assert "INCOMPLETE" not in text
    assert text.count("data:image/png;base64,") >= 7
    assert "Differences from the paper" in text
    assert "synthetic" in text.lower()


def test_peak_price_lowers_the_peak(quick_report: Path) -> None:
    kpis = pd.read_csv(quick_report / "kpi_scenarios.csv", index_col=0)
    assert kpis.loc["peak_power_kw", "(c) RMPC + PPP"] < kpis.loc["peak_power_kw", "(b) RMPC"]
    sweep = pd.read_csv(quick_report / "figures" / "fig7_ppp_sweep.csv")
    sweep = sweep.sort_values("peak_price_sgd_per_kw")
    assert sweep["peak_power_kw"].iloc[-1] < sweep["peak_power_kw"].iloc[0]


def test_robust_costs_more_than_nominal(quick_report: Path) -> None:
    table = pd.read_csv(quick_report / "table1.csv", index_col=0)
    cost = table["energy_cost_sgd"]
    assert cost.loc["(b) RMPC"] > cost.loc["(a) NMPC"]


def test_table1_has_rows_for_both_reserve_models(quick_report: Path) -> None:
    table = pd.read_csv(quick_report / "table1.csv", index_col=0)
    models = table["reserve_model"]
    assert models.to_list() == ["event"] * 4 + ["whole-horizon"] * 5
    assert table.index[3] == SCENARIO_LABELS[STRESS_KEY]
    feedback_rows = [label for label in table.index if "affine feedback" in label]
    assert feedback_rows == [
        "(b) RMPC, affine feedback, whole-horizon",
        "(c) RMPC + PPP, affine feedback, whole-horizon",
    ]
    for model in ("event", "whole-horizon"):
        block = table[models == model]
        assert np.isfinite(block["energy_cost_sgd"]).all() and (block["energy_cost_sgd"] > 0).all()
        assert block["energy_cost_change_pct"].iloc[0] == 0.0  # against its own (a)
    # each row is its own run's monthly average
    kpis = pd.read_csv(quick_report / "kpi_scenarios.csv", index_col=0)
    for label in table.index:
        for quantity in ("energy_cost_sgd", "reserve_revenue_sgd", "net_cost_sgd"):
            expected = kpis.loc[f"monthly_avg_{quantity}", label]
            assert table.loc[label, quantity] == pytest.approx(expected), (label, quantity)
    # the reserve settled as the market settles it, in every row; the stress case is activated
    for label in table.index:
        row = table.loc[label]
        assert row["il_net_revenue_sgd"] == pytest.approx(
            row["reserve_revenue_sgd"] - row["il_penalty_sgd"]
        )
        assert row["il_shortfall_kwh"] <= row["il_offered_kwh"] + 1e-9
    stress = table.loc[SCENARIO_LABELS[STRESS_KEY]]
    assert stress["il_offered_kwh"] > 0.0 and stress["il_delivered_metered_kwh"] > 0.0
    versus = pd.read_csv(quick_report / "table1_vs_paper.csv", index_col=0)
    assert versus.loc["(b) RMPC, whole-horizon", "energy_cost_sgd (paper)"] == 1530.0
    assert versus.loc["(b) RMPC", "energy_cost_sgd (paper)"] == 1530.0
    assert np.isnan(versus.loc[feedback_rows, "energy_cost_sgd (paper)"]).all()


def _run_dir(report: Path, name: str) -> Path:
    """The stable folder ``runs/<name>`` of one run."""
    return report / "runs" / name


def test_every_run_has_its_stable_folder(quick_report: Path) -> None:
    plan = Plan.quick()
    names = {cfg.name for jobs in plan_groups(plan).values() for _, cfg in jobs}
    assert {p.name for p in (quick_report / "runs").iterdir()} == names
    assert {"rmpc", "paper-rmpc", "ppp-1.5", "rmpc-unc25", "nmpc-hot-corner"} <= names
    result = CliRunner().invoke(app, ["kpi", str(quick_report / "runs" / "rmpc")])
    assert result.exit_code == 0, result.output  # issue 28: this failed on hash-suffixed names


def test_worst_event_temperature_is_recorded_for_every_plan(quick_report: Path) -> None:
    for run in ("nmpc", "rmpc", "paper-rmpc"):
        frame = load_results(_run_dir(quick_report, run))
        zones = [c.removeprefix("temp_end_") for c in frame.columns if c.startswith("temp_end_")]
        worst = frame[[f"event_worst_{z}" for z in zones]].to_numpy()
        served = frame[[f"temp_served_{z}" for z in zones]].to_numpy()
        planned = (frame["solve_status"] == "optimal").to_numpy() & ~frame["fallback"].to_numpy()
        assert planned.any()
        assert np.isfinite(worst[planned]).all(), run
        assert (worst[planned] >= served[planned] - 1e-9).all(), run
    thermostat = load_results(_run_dir(quick_report, "thermostat"))
    assert thermostat.filter(like="event_worst_").isna().all().all()


def test_fig5_draws_the_worst_event_and_fig6_a_reserve_band(quick_report: Path) -> None:
    temps = pd.read_csv(quick_report / "figures" / "fig5_temperatures.csv")
    assert temps["event_worst_degc"].notna().any()
    band = pd.read_csv(quick_report / "figures" / "fig6_power_reserve.csv")
    offered = band["reserve_kw"] > 0
    assert offered.any()  # the event model offers reserve
    height = band["reserve_band_upper_kw"] - band["reserve_band_lower_kw"]
    assert height.to_numpy() == pytest.approx(band["reserve_kw"].to_numpy())
    assert (height[offered] > 0).all()


def test_curtailed_prediction_is_never_cooler_than_served(quick_report: Path) -> None:
    temps = pd.read_csv(quick_report / "figures" / "fig5_temperatures.csv")
    both = temps.dropna(subset=["temp_served_degc", "temp_curtailed_degc"])
    assert len(both) > 0
    # cooling: offering reserve means less supply air when activated, so never cooler
    assert (both["temp_curtailed_degc"] >= both["temp_served_degc"] - 1e-6).all()


def test_report_sentences_state_what_the_numbers_show(quick_report: Path) -> None:
    text = " ".join((quick_report / "report.html").read_text().split())
    kpis = pd.read_csv(quick_report / "kpi_scenarios.csv", index_col=0)
    nominal, robust = kpis.loc["net_cost_sgd", "(a) NMPC"], kpis.loc["net_cost_sgd", "(b) RMPC"]
    direction = "more" if robust > nominal else "less"
    pct = 100 * abs(robust - nominal) / nominal
    assert f"(b) RMPC costs {pct:.1f} % {direction} than (a) NMPC" in text
    labels = ["(a) NMPC", "(b) RMPC", "(c) RMPC + PPP"]
    zero = [label for label in labels if kpis.loc["reserve_revenue_sgd", label] == 0]
    for label in labels:
        if label not in zero:
            assert f"{label} earns {kpis.loc['reserve_revenue_sgd', label]:,.2f} SGD" in text
    if zero:
        names = zero[0] if len(zero) == 1 else f"{', '.join(zero[:-1])} and {zero[-1]}"
        assert f"{names} earn{'s' if len(zero) == 1 else ''} no reserve revenue" in text


def test_second_run_reuses_cached_simulations(quick_report: Path) -> None:
    outputs = ["table1.csv", "kpi_scenarios.csv", "figures/fig7_ppp_sweep.csv"]
    before = {name: (quick_report / name).read_bytes() for name in outputs}
    results = sorted((quick_report / "runs").glob("*/results.parquet"))
    mtimes = {path: path.stat().st_mtime_ns for path in results}
    logs: list[str] = []
    again = run_and_report(
        TEST_PLAN, plan_groups(TEST_PLAN), quick_report, workers=1, log=logs.append
    )
    # 21 + the five strong baselines (BASELINE_PRESETS) + (b) under stress activations
    assert again.complete and len(again.outcomes) == 27
    assert all(o.cached for o in again.outcomes)
    assert sum("ok (cached)" in line for line in logs) == 27
    # the console ends with the verdict: the count, the two answers, one line per finding
    verdicts = pd.read_csv(quick_report / "verdicts.csv")
    closing = [line for line in logs if line.startswith("verdict: ")]
    assert logs[-len(closing) :] == closing and len(closing) >= len(verdicts) + 2
    assert "of the paper's findings tested here" in closing[0]
    assert any(line.startswith("verdict: Does peak shaving pay?") for line in closing)
    assert len(results) == 27 and {p: p.stat().st_mtime_ns for p in results} == mtimes
    assert {name: (quick_report / name).read_bytes() for name in outputs} == before


@pytest.mark.slow
def test_report_opens_in_a_headless_browser(quick_report: Path, tmp_path: Path) -> None:
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("no chromium on this machine (apt-get install chromium)")
    shot = tmp_path / "report.png"
    result = subprocess.run(
        [
            browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
            "--no-first-run", "--disable-background-networking", "--disable-component-update",
            "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}",
            f"--screenshot={shot}", "--window-size=1200,3000",
            (quick_report / "report.html").as_uri(),
        ],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert shot.is_file() and shot.stat().st_size > 10_000


def test_hot_corner_nominal_mpc_runs_over_the_band_robust_does_not(quick_report: Path) -> None:
    table = pd.read_csv(quick_report / "figures" / "comfort_hot_corner.csv", index_col=0)
    assert table.loc["NMPC, hot corner", "total"] > 0.5
    assert table.loc["RMPC, hot corner", "total"] < 0.01


def test_an_interrupted_reproduction_resumes_and_updates_in_place(tmp_path: Path) -> None:
    """Finished runs are re-used as they are, an interrupted run resumes from its checkpoint
    to the results of an uninterrupted one, and a folder holding another configuration of the
    same run name (another plan) is replaced in place."""
    start = "2014-03-04"
    finished = preset("thermostat", start=start, days=1.0)
    interrupted = preset("trim-respond", start=start, days=1.0)
    stale = preset("demand-limit", start=start, days=1.0)
    out = tmp_path / "reproduce"
    run_simulation(finished, run_folder(out, finished), progress=False)
    finished_mtime = (run_folder(out, finished) / "results.parquet").stat().st_mtime_ns
    run_simulation(
        interrupted,
        run_folder(out, interrupted),
        progress=False,
        checkpoint_every=8,
        stop_after_steps=20,
    )
    assert (run_folder(out, interrupted) / "checkpoint.npz").is_file()
    run_simulation(replace(stale, days=0.5), run_folder(out, stale), progress=False)
    groups = {
        "scenarios": [({"scenario": cfg.name}, cfg) for cfg in (finished, interrupted, stale)]
    }
    logs: list[str] = []
    by_group = run_groups(groups, out, workers=1, log=logs.append)
    outcomes = {o.label: o for o in by_group["scenarios"]}
    assert all(o.ok for o in outcomes.values())
    assert [o.out_dir for o in by_group["scenarios"]] == [
        str(run_folder(out, cfg)) for cfg in (finished, interrupted, stale)
    ]
    assert outcomes["thermostat"].cached
    assert (run_folder(out, finished) / "results.parquet").stat().st_mtime_ns == finished_mtime
    assert not outcomes["trim-respond"].cached
    assert not (run_folder(out, interrupted) / "checkpoint.npz").exists()
    run_simulation(interrupted, tmp_path / "uninterrupted", progress=False)
    whole = load_results(tmp_path / "uninterrupted")
    resumed = load_results(run_folder(out, interrupted))
    columns = [c for c in whole.columns if c.startswith(("temp_end_", "power_kw", "flow_"))]
    assert len(columns) > 10
    pd.testing.assert_frame_equal(resumed[columns], whole[columns])
    assert any("replacing" in line and "demand-limit" in line for line in logs), logs
    # a line per finished run, with the elapsed time and an ETA (none left after the last)
    done = [line for line in logs if re.match(r"  \[\d/3\] ", line)]
    assert len(done) == 3 and all(" · elapsed " in line for line in done)
    assert done[-1].endswith("· ETA 0:00")
    assert len(load_results(run_folder(out, stale))) == 48  # the 1-day run, not the old 12 h


def test_verdict_lines_close_the_console_one_finding_a_line() -> None:
    from hvacflex.report.html import Section

    table = pd.DataFrame(
        {
            "paper": ["+4.0 %", "+2.2 %"],
            "ours": ["+1.3 %", "−0.4 %"],
            "verdict": ["holds", "does not hold"],
            "basis": ["RC plant", "RC plant"],
        },
        index=pd.Index(["(b) costs a few % more than (a)", "(c) costs more than (b)"]),
    )
    section = Section(
        title="Verdict",
        paragraphs=[
            "Verdict: of the paper's findings tested here, 1 holds, 1 does not hold, 0 not "
            "comparable. Each row gives the paper's number, ours and what ours rest on.",
            "Does peak shaving pay? No: under one tariff (c) costs more.",
        ],
        tables=[table],
    )
    lines = verdict_lines([Section(title="Does it pay?"), section])
    assert lines == [
        "verdict: of the paper's findings tested here, 1 holds, 1 does not hold, 0 not comparable.",
        "verdict: Does peak shaving pay? No: under one tariff (c) costs more.",
        "verdict: holds: (b) costs a few % more than (a) (paper +4.0 %; ours +1.3 %)",
        "verdict: does not hold: (c) costs more than (b) (paper +2.2 %; ours −0.4 %)",
    ]
    assert verdict_lines([Section(title="Incomplete")]) == []
