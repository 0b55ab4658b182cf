"""The reserve-price sensitivity sweep: its jobs, its tables, and a tiny grid end to end
(``hvacflex reproduce --sensitivity --seeds --quick`` with half-day grids, on Dask)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.config import PAPER_SCENARIOS
from hvacflex.data.market import RESERVE_PRICE_SCALE
from hvacflex.robustness import FINDINGS, SeedPlan
from hvacflex.sensitivity import (
    SensitivityGrid,
    findings_sentence,
    points_table,
    revenue_findings,
    sensitivity_jobs,
)

TINY_GRID = SensitivityGrid(
    (RESERVE_PRICE_SCALE, 4 * RESERVE_PRICE_SCALE), (0.0, 1.0), ("2014-04-21",), 0.5
)
TINY_SEEDS = SeedPlan(("2014-04-21",), 0.5, (1, 2))


def test_jobs_cover_the_grid_with_distinct_runs() -> None:
    grid = SensitivityGrid((10.0, 20.0), (0.0, 1.0), ("2014-04-21", "2014-07-14"), 1.0)
    jobs = sensitivity_jobs(grid)
    assert len(jobs) == 2 * 2 * 2 * len(PAPER_SCENARIOS)
    assert len({cfg.config_hash() for _, cfg in jobs}) == len(jobs)
    for params, cfg in jobs:
        assert cfg.data.reserve_price_scale == params["reserve_price_scale"]
        assert cfg.data.reserve_price_correlation == params["reserve_price_correlation"]
        assert cfg.name.startswith(PAPER_SCENARIOS[params["scenario"]])
    quick, full = SensitivityGrid.quick(), SensitivityGrid.full()
    assert RESERVE_PRICE_SCALE in quick.scales_sgd_per_mwh and 1.0 in quick.correlations
    assert len(quick.points()) == 6 and len(quick.weeks) == 1
    assert len(full.points()) > len(quick.points()) and len(full.weeks) == 4


def _runs() -> pd.DataFrame:
    """Two weeks of one point: (a) earns 1 SGD a week, (b) 2, (c) 0.5."""
    rows = []
    for week in ("w1", "w2"):
        for letter, revenue in (("a", 1.0), ("b", 2.0), ("c", 0.5)):
            rows.append(
                {
                    "point": 0,
                    "reserve_price_scale": 15.0,
                    "reserve_price_correlation": 1.0,
                    "week_start": week,
                    "scenario": letter,
                    "controller": PAPER_SCENARIOS[letter],
                    "energy_cost_sgd": 100.0,
                    "reserve_revenue_sgd": revenue,
                    "il_penalty_sgd": 0.0,
                    "net_cost_sgd": 100.0 - revenue,
                    "peak_power_kw": 30.0 if week == "w1" else 35.0,
                    "reserve_offered_mean_kw": 1.0 if week == "w1" else 3.0,
                    "reserve_price_mean_sgd_per_mwh": 10.0,
                    "reserve_usep_pearson": 0.5,
                    "steps": 336 if week == "w1" else 48,
                }
            )
    return pd.DataFrame(rows)


def test_points_sum_over_weeks_by_hand() -> None:
    points = points_table(_runs()).set_index("scenario")
    b = points.loc["b"]
    assert b["weeks"] == 2 and b["energy_cost_sgd"] == 200.0 and b["reserve_revenue_sgd"] == 4.0
    assert b["revenue_share"] == pytest.approx(0.02)
    assert b["peak_power_kw"] == 35.0  # the highest week's
    assert b["reserve_offered_mean_kw"] == pytest.approx((336 * 1 + 48 * 3) / 384)


def test_revenue_finding_holds_only_where_both_rise() -> None:
    findings = revenue_findings(points_table(_runs()))
    row = findings.iloc[0]
    assert bool(row["rises_in_b"]) and not bool(row["rises_in_c"])
    assert not bool(row["revenue_rises_in_b_and_c"])
    assert "at 0 of 1 grid points" in findings_sentence(findings)


@pytest.fixture(scope="module")
def tiny_studies(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``hvacflex reproduce --sensitivity --seeds --quick`` with the tiny half-day grids."""
    out = tmp_path_factory.mktemp("studies")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(SensitivityGrid, "quick", classmethod(lambda cls: TINY_GRID))
        patch.setattr(SeedPlan, "quick", classmethod(lambda cls: TINY_SEEDS))
        args = ["reproduce", "--sensitivity", "--seeds", "--quick", "--workers", "2"]
        result = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_tiny_sensitivity_grid_end_to_end(tiny_studies: Path) -> None:
    folder = tiny_studies / "sensitivity"
    points = pd.read_csv(folder / "sensitivity.csv")
    assert len(points) == len(TINY_GRID.points()) * len(PAPER_SCENARIOS)
    for column in ("point", "reserve_price_scale", "reserve_price_correlation", "controller"):
        assert points[column].notna().all()
    share = points["reserve_revenue_sgd"] / points["energy_cost_sgd"]
    np.testing.assert_allclose(points["revenue_share"], share)
    # the realised correlation with USEP falls with ρ; the mean price rises with the scale
    by_rho = points.groupby("reserve_price_correlation")["reserve_usep_pearson"].mean()
    assert by_rho.loc[0.0] < by_rho.loc[1.0]
    mean_price = points.groupby("reserve_price_scale")["reserve_price_mean_sgd_per_mwh"].mean()
    assert mean_price.iloc[-1] == pytest.approx(4 * mean_price.iloc[0], rel=1e-9)
    findings = pd.read_csv(folder / "sensitivity_findings.csv")
    assert len(findings) == len(TINY_GRID.points())
    assert (folder / "sensitivity_figure.png").stat().st_size > 0
    assert len(pd.read_csv(folder / "sensitivity_figure.csv")) == len(points)
    assert (folder / "sensitivity.csv").exists() and (folder / "sensitivity_runs.csv").exists()


def test_tiny_seed_study_end_to_end(tiny_studies: Path) -> None:
    folder = tiny_studies / "seeds"
    runs = pd.read_csv(folder / "seeds_runs.csv")
    assert len(runs) == len(TINY_SEEDS.seeds) * len(PAPER_SCENARIOS)
    spread = pd.read_csv(folder / "seeds_spread.csv")
    net = spread[spread["kpi"] == "net_cost_sgd"].set_index("scenario")
    for letter in ("a", "b", "c"):
        values = runs.loc[runs["scenario"] == letter, "net_cost_sgd"]
        assert net.loc[letter, "min"] == pytest.approx(values.min())
        assert net.loc[letter, "max"] == pytest.approx(values.max())
    # the seeds draw different occupants: the energy bought differs between them
    energy = runs[runs["scenario"] == "a"]["energy_kwh"]
    assert energy.nunique() == len(TINY_SEEDS.seeds)
    verdicts = pd.read_csv(folder / "seeds_verdicts.csv")
    assert list(verdicts["key"]) == list(FINDINGS) and (verdicts["of"] == 2).all()
    assert (folder / "seeds_spread_figure.png").stat().st_size > 0
    assert list(spread.columns) == [
        "scenario",
        "controller",
        "kpi",
        "n",
        "mean",
        "min",
        "max",
        "std",
    ]


def test_second_call_reuses_the_runs(tiny_studies: Path) -> None:
    results = sorted((tiny_studies / "seeds" / "runs").glob("*/results.parquet"))
    assert len(results) == len(TINY_SEEDS.seeds) * len(PAPER_SCENARIOS)
    written = [path.stat().st_mtime_ns for path in results]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(SeedPlan, "quick", classmethod(lambda cls: TINY_SEEDS))
        args = ["reproduce", "--seeds", "--quick", "--workers", "1", "--out", str(tiny_studies)]
        result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert [path.stat().st_mtime_ns for path in results] == written  # not simulated again
    runs = pd.read_csv(tiny_studies / "seeds" / "seeds_runs.csv")
    assert len(runs) == len(TINY_SEEDS.seeds) * len(PAPER_SCENARIOS)


def test_bad_output_folder_exits_2(tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    result = CliRunner().invoke(app, ["reproduce", "--sensitivity", "--out", str(blocker)])
    assert result.exit_code == 2
    assert "--out" in result.output and "Traceback" not in result.output
