"""``hvacflex report``: hand-computed costs, KPIs per m², the page in a real headless Chromium."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.errors import InputError
from hvacflex.report.run_report import (
    ReportRun,
    change_vs_baseline_pct,
    cost_breakdown,
    formatted_kpi_table,
    kpi_table,
    load_runs,
    tariff_peak_price_sgd_per_kw,
    write_run_report,
)
from hvacflex.results import RESULTS_FILENAME, write_results

Factory = Callable[..., pd.DataFrame]

OFFICE5_FLOOR_AREA_M2 = 1296.0
"""36 m × 36 m (docs/explanation/buildings.md)."""


def _constant_run(power_kw: float, *, peak_price: float = 0.0) -> pd.DataFrame:
    """One day at constant power 10 kW-like loads: energy price 100 SGD/MWh, reserve 2 kW at
    10 SGD/MWh, no activation."""
    index = pd.date_range("2014-03-04", periods=48, freq="30min", tz="Asia/Singapore")
    return pd.DataFrame(
        {
            "energy_price_sgd_per_mwh": 100.0,
            "reserve_price_sgd_per_mwh": 10.0,
            "peak_price_sgd_per_kw": peak_price,
            "power_kw": power_kw,
            "reserve_kw": 2.0,
            "temp_z_degc": 24.0,
            "temp_end_z_degc": 24.0,
            "comfort_lower_z_degc": 23.0,
            "comfort_upper_z_degc": 26.0,
            "solve_status": "optimal",
            "solve_time_s": 0.01,
            "fallback": False,
            "planned_slack_max_k": 0.0,
            "delta_max_k": 0.0,
        },
        index=index,
    )


def _save_run(folder: Path, frame: pd.DataFrame, building: str = "office5") -> Path:
    folder.mkdir(parents=True)
    write_results(frame, folder / RESULTS_FILENAME, {"config": json.dumps({"building": building})})
    return folder


def test_cost_breakdown_by_hand() -> None:
    run = ReportRun("a", _constant_run(10.0), OFFICE5_FLOOR_AREA_M2, "office5")
    costs = cost_breakdown([run], peak_price_sgd_per_kw=2.0).loc["a"]
    # 10 kW × 24 h = 240 kWh at 0.1 SGD/kWh; peak 10 kW × 2 SGD/kW for March, one day of its
    # 31 billed; 2 kW × 24 h × 0.01 SGD/kWh of reserve, none of it activated: unsettled
    assert costs["energy_cost_sgd"] == pytest.approx(24.0)
    assert costs["ppp_charge_sgd"] == pytest.approx(20.0 / 31)
    assert costs["reserve_revenue_settled_sgd"] == 0.0
    assert costs["reserve_revenue_unsettled_sgd"] == pytest.approx(0.48)
    assert costs["il_penalty_sgd"] == 0.0
    assert costs["total_cost_sgd"] == pytest.approx(24.0 + 20.0 / 31)
    assert costs["total_with_unsettled_sgd"] == pytest.approx(24.0 + 20.0 / 31 - 0.48)


def test_one_tariff_is_the_largest_peak_price_recorded() -> None:
    runs = [
        ReportRun("flat", _constant_run(10.0, peak_price=0.0), None, ""),
        ReportRun("ppp", _constant_run(8.0, peak_price=1.5), None, ""),
    ]
    assert tariff_peak_price_sgd_per_kw(runs) == 1.5
    costs = cost_breakdown(runs, tariff_peak_price_sgd_per_kw(runs))
    # the run planned without a peak charge is billed for its peak too
    assert costs.loc["flat", "ppp_charge_sgd"] == pytest.approx(15.0 / 31)
    assert costs.loc["ppp", "ppp_charge_sgd"] == pytest.approx(12.0 / 31)


def test_kpis_per_m2_and_change_against_baseline() -> None:
    runs = [
        ReportRun("base", _constant_run(10.0), OFFICE5_FLOOR_AREA_M2, "office5"),
        ReportRun("half", _constant_run(5.0), OFFICE5_FLOOR_AREA_M2, "office5"),
        ReportRun("unknown", _constant_run(5.0), None, ""),
    ]
    table = kpi_table(runs, peak_price_sgd_per_kw=0.0)
    assert table.loc["energy_kwh", "base"] == pytest.approx(240.0)
    assert table.loc["energy_kwh_per_m2", "base"] == pytest.approx(240.0 / 1296.0)
    assert table.loc["peak_power_w_per_m2", "half"] == pytest.approx(5000.0 / 1296.0)
    assert np.isnan(table.loc["energy_kwh_per_m2", "unknown"])
    changes = change_vs_baseline_pct(table, "base")
    assert list(changes.columns) == ["half vs base", "unknown vs base"]
    assert changes.loc["energy_kwh", "half vs base"] == pytest.approx(-50.0)
    assert np.isnan(changes.loc["discomfort_occupied_kelvin_hours", "half vs base"])  # base 0
    with pytest.raises(InputError):
        change_vs_baseline_pct(table, "nope")
    shown = formatted_kpi_table(table, changes)
    assert shown.loc["il_events", "base"] == "0" and shown.loc["energy_kwh", "base"] == "240.00"
    assert shown.loc["violation_share", "half"] == "0.00 %"
    assert shown.loc["energy_kwh", "Δ half vs base"] == "-50.0 %"
    # no floor area: per m² is not available, never a number or a bare dash
    assert shown.loc["energy_kwh_per_m2", "unknown"] == "not available"
    assert shown.loc["energy_kwh_per_m2", "half"] == f"{120.0 / 1296.0:.2f}"
    # no events: no delivery ratio, and no Δ of one
    assert shown.loc["il_delivered_ratio"].to_list() == ["–"] * 5
    assert "facility_energy_kwh" not in table.index  # no run's plant meters the facility


def test_load_runs_reads_the_building_floor_area(tmp_path: Path, make_results: Factory) -> None:
    known = _save_run(tmp_path / "known", make_results(days=1.0))
    moved = _save_run(tmp_path / "moved", make_results(days=1.0), building="/gone/b.toml")
    runs = load_runs([known, moved, known / RESULTS_FILENAME])
    assert [run.name for run in runs] == ["known", "moved", "known#2"]
    assert runs[0].floor_area_m2 == OFFICE5_FLOOR_AREA_M2
    assert runs[1].floor_area_m2 is None
    with pytest.raises(InputError):
        load_runs([])


def _runs(tmp_path: Path, make_results: Factory) -> tuple[Path, Path]:
    run = _save_run(tmp_path / "rmpc", make_results(days=2.0, seed=1))
    base = _save_run(tmp_path / "thermostat", make_results(days=2.0, seed=2, power_scale=1.3))
    return run, base


def test_page_is_self_contained(tmp_path: Path, make_results: Factory) -> None:
    run, base = _runs(tmp_path, make_results)
    page = write_run_report([run], tmp_path / "out" / "page.html", baseline=base).read_text()
    images = re.findall(r'<img src="([^"]+)"', page)
    assert len(images) == 3 and all(src.startswith("data:image/png;base64,") for src in images)
    assert not re.search(r"(src|href)=\"(https?:)?//", page)
    assert "<script" not in page
    for needle in (
        "Cost under one tariff",
        "Total [SGD]",
        "Unsettled reserve (availability) [SGD]",
        "Δ rmpc vs thermostat",
        "1,296",
        "HVAC energy [kWh]",
        "Occupied discomfort [K·h]",
        "Plans needing comfort slack (planned_slack_share)",
    ):
        assert needle in page


def test_cli_report_and_its_errors(tmp_path: Path, make_results: Factory) -> None:
    run, base = _runs(tmp_path, make_results)
    out = tmp_path / "r.html"
    ok = CliRunner().invoke(app, ["report", str(run), "--baseline", str(base), "--out", str(out)])
    assert ok.exit_code == 0, ok.output
    assert out.is_file() and str(out) in ok.output
    missing = CliRunner().invoke(app, ["report", str(tmp_path / "nope"), "--out", str(out)])
    assert missing.exit_code == 2
    assert "results file not found" in missing.output and "Traceback" not in missing.output
    flat = _constant_run(5.0)
    zoneless = _save_run(tmp_path / "fleet", flat.drop(columns=flat.filter(like="_z_").columns))
    refused = CliRunner().invoke(app, ["report", str(zoneless), "--out", str(out)])
    assert refused.exit_code == 2
    assert "no zone temperature column" in refused.output and "Traceback" not in refused.output


def test_simulate_writes_its_report_unless_told_not_to(tmp_path: Path) -> None:
    common = ["simulate", "--scenario", "thermostat", "--days", "0.25", "-q"]
    with_report = CliRunner().invoke(app, [*common, "--out", str(tmp_path / "a")])
    assert with_report.exit_code == 0, with_report.output
    assert (tmp_path / "a" / "report.html").is_file()
    without = CliRunner().invoke(app, [*common, "--out", str(tmp_path / "b"), "--no-report"])
    assert without.exit_code == 0, without.output
    assert (tmp_path / "b" / RESULTS_FILENAME).is_file()
    assert not (tmp_path / "b" / "report.html").exists()


def test_page_in_headless_chromium(chromium: Any, tmp_path: Path, make_results: Factory) -> None:
    """Renders, every figure loads, no console error, nothing requested from elsewhere."""
    run, base = _runs(tmp_path, make_results)
    page_file = write_run_report([run], tmp_path / "page.html", baseline=base)
    page = chromium.new_page(viewport={"width": 1280, "height": 900})
    errors: list[str] = []
    requests: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("request", lambda r: requests.append(r.url))
    page.goto(page_file.as_uri(), wait_until="load")
    loaded = page.eval_on_selector_all(
        "img", "imgs => imgs.map(i => i.complete && i.naturalWidth > 0)"
    )
    assert loaded == [True, True, True]
    assert page.locator("h2", has_text="Cost under one tariff").is_visible()
    assert page.locator("table.hvacflex").count() == 2
    assert errors == []
    assert [url for url in requests if not url.startswith(("file:", "data:"))] == []
    shots = os.environ.get("HVACFLEX_SCREENSHOT_DIR")
    page.screenshot(path=str(Path(shots or tmp_path) / "run_report.png"), full_page=True)
    page.close()


def test_a_baseline_given_as_a_run_too_is_shown_once(tmp_path: Path, make_results: Factory) -> None:
    run, base = _runs(tmp_path, make_results)
    page = write_run_report([run, base], tmp_path / "p.html", baseline=base).read_text()
    assert "Δ rmpc vs thermostat" in page
    assert "vs thermostat (baseline)" not in page and "Δ thermostat vs" not in page
    alone = write_run_report([base], tmp_path / "q.html", baseline=base).read_text()
    assert "Δ" not in alone


def test_a_floor_area_that_is_not_finite_is_unknown() -> None:
    from hvacflex.report.run_report import known_floor_area_m2

    assert known_floor_area_m2(float("nan")) is None and known_floor_area_m2(0.0) is None
    assert known_floor_area_m2(None) is None and known_floor_area_m2(511.0) == 511.0


def test_delivery_ratio_without_activations_is_no_number() -> None:
    table = pd.DataFrame(
        {"mpc": [0.0, 1.0, 336.0], "ev": [2.0, 0.75, 336.0]},
        index=pd.Index(["il_events", "il_delivered_ratio", "steps"], name="kpi"),
    )
    shown = formatted_kpi_table(table, None)
    assert shown.loc["il_delivered_ratio"].to_list() == ["–", "0.75"]
    assert shown.loc["steps"].to_list() == ["336", "336"]  # counts whole, not 336.00
