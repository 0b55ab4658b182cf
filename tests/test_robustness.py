"""The seed study: findings decided from KPIs, the spread, the jobs it runs."""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

import pandas as pd
import pytest

from hvacflex.config import PAPER_SCENARIOS
from hvacflex.report import verdicts
from hvacflex.report.text import rises
from hvacflex.robustness import (
    FINDINGS,
    REPRESENTATIVE_WEEKS,
    SeedPlan,
    finding_verdicts,
    findings_table,
    seed_jobs,
    spread_table,
    verdict_counts,
    write_tables,
)


def _kpis(energy: float, revenue: float, peak: float, discomfort: float) -> dict[str, float]:
    return {
        "energy_cost_sgd": energy,
        "net_cost_sgd": energy - revenue,
        "reserve_revenue_sgd": revenue,
        "peak_power_kw": peak,
        "discomfort_kelvin_hours": discomfort,
    }


PAPER_LIKE = {
    "a": _kpis(100.0, 1.0, 40.0, 2.0),
    "b": _kpis(103.0, 1.5, 40.0, 0.0),
    "c": _kpis(105.0, 1.2, 30.0, 0.0),
}
"""A triple where every finding of the paper holds."""


def test_the_findings_are_the_reports_verdicts_in_its_order() -> None:
    """One set of rules: the seed study's findings are the report's scenario verdicts."""
    found = verdicts.scenario_verdicts(PAPER_LIKE, "RC plant")
    assert {v.key: v.finding for v in found} == FINDINGS
    assert [v.key for v in found] == list(FINDINGS)


def test_every_finding_holds_on_a_paper_like_triple() -> None:
    assert finding_verdicts(PAPER_LIKE) == dict.fromkeys(FINDINGS, True)


@pytest.mark.parametrize(
    ("letter", "change", "broken"),
    [
        ("b", {"energy_cost_sgd": 99.0}, "robustness_premium"),  # cheaper
        ("b", {"energy_cost_sgd": 125.0, "discomfort_kelvin_hours": 0.0}, "robustness_premium"),
        ("c", {"energy_cost_sgd": 103.0}, "ppp_costs_more"),
        ("c", {"peak_power_kw": 40.0}, "ppp_lowers_peak"),
        ("a", {"discomfort_kelvin_hours": 0.0}, "robust_keeps_comfort"),  # NMPC kept it
        ("b", {"discomfort_kelvin_hours": 0.5}, "robust_keeps_comfort"),  # > 10 % of NMPC's
        ("c", {"reserve_revenue_sgd": 1.0}, "revenue_rises"),
    ],
)
def test_each_finding_fails_on_its_own_counterexample(
    letter: str, change: dict[str, float], broken: str
) -> None:
    triple = {k: dict(v) for k, v in PAPER_LIKE.items()}
    triple[letter] |= change
    if letter == "b" and broken == "robustness_premium" and change["energy_cost_sgd"] > 103:
        triple["c"]["energy_cost_sgd"] = 130.0  # (c) still costs more than (b)
    found = finding_verdicts(triple)
    assert found[broken] is False
    assert all(found[key] for key in FINDINGS if key != broken)


def test_a_finding_that_is_not_comparable_does_not_hold() -> None:
    triple = {k: dict(v) for k, v in PAPER_LIKE.items()}
    triple["a"]["reserve_revenue_sgd"] = 0.0  # (a) earns nothing: the rise is not comparable
    assert finding_verdicts(triple)["revenue_rises"] is False


def test_rises_needs_more_than_noise() -> None:
    assert rises(1.0, 0.0) and not rises(0.0, 0.0)
    assert not rises(100.05, 100.0) and rises(100.2, 100.0)
    assert rises(-1.0, -2.0) and not rises(-2.0, -1.0)


def test_representative_weeks_are_mondays_one_per_season() -> None:
    starts = [dt.date.fromisoformat(w.start) for w in REPRESENTATIVE_WEEKS]
    assert all(day.weekday() == 0 and day.year == 2014 for day in starts)
    assert len({w.season for w in REPRESENTATIVE_WEEKS}) == 4
    assert len({(day.month - 1) // 3 for day in starts}) == 4  # one per quarter


def test_seed_jobs_vary_the_occupants_and_nothing_else() -> None:
    plan = SeedPlan(("2014-04-21", "2014-07-14"), 1.0, (1, 2))
    jobs = seed_jobs(plan)
    assert len(jobs) == 2 * 2 * len(PAPER_SCENARIOS)
    assert len({cfg.config_hash() for _, cfg in jobs}) == len(jobs)
    for params, cfg in jobs:
        assert cfg.realisation.occupancy == "stochastic"
        assert cfg.realisation.occupancy_seed == params["occupancy_seed"]
        assert cfg.start_timestamp.date().isoformat() == params["week_start"]
        assert cfg.days == 1.0
    seeds = {cfg.seed for _, cfg in jobs}
    assert len(seeds) == 1  # reserve prices, activations and w keep the scenario's seed
    assert SeedPlan.full().seeds == (1, 2, 3, 4, 5) and len(SeedPlan.full().weeks) == 4


def _runs() -> pd.DataFrame:
    rows = []
    for week, seed, scale in (("w1", 1, 1.0), ("w1", 2, 1.1), ("w2", 1, 0.9)):
        for letter, kpis in PAPER_LIKE.items():
            rows.append(
                {"week_start": week, "occupancy_seed": seed, "scenario": letter}
                | {"controller": PAPER_SCENARIOS[letter]}
                | {k: scale * v for k, v in kpis.items()}
            )
    rows[-1]["peak_power_kw"] = 40.0  # (c) of the last week-seed: no lower peak
    return pd.DataFrame(rows)


def test_spread_table_by_hand() -> None:
    spread = spread_table(_runs(), ("energy_cost_sgd",)).set_index("scenario")
    row = spread.loc["a"]
    values = [100.0, 110.0, 90.0]
    assert row["n"] == 3 and row["mean"] == pytest.approx(100.0)
    assert row["min"] == pytest.approx(90.0) and row["max"] == pytest.approx(110.0)
    mean = sum(values) / 3
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / 2)
    assert row["std"] == pytest.approx(std)


def test_findings_and_verdict_counts() -> None:
    findings = findings_table(_runs(), ("week_start", "occupancy_seed"))
    assert len(findings) == 3
    counts = verdict_counts(findings).set_index("key")
    assert counts.loc["robustness_premium", "holds"] == 3
    assert counts.loc["ppp_lowers_peak", "holds"] == 2
    assert (counts["of"] == 3).all()
    incomplete = _runs().iloc[:-1]  # the last week-seed lacks (c): not judged
    assert len(findings_table(incomplete, ("week_start", "occupancy_seed"))) == 2


def test_the_study_tables_are_written_as_named_csv_files(tmp_path: Path) -> None:
    runs = pd.DataFrame({"scenario": ["A", "B"], "net_cost_sgd": [1.5, 2.25]})
    empty = pd.DataFrame(columns=["finding"])
    write_tables(tmp_path, {"runs.csv": runs, "findings.csv": empty})
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "runs.csv"), runs)
    assert (tmp_path / "findings.csv").read_text().strip() == "finding"  # no index column
    assert sorted(p.name for p in tmp_path.iterdir()) == ["findings.csv", "runs.csv"]
