from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.fleet.cli import CoordinationWatch
from hvacflex.fleet.coordinate import CoordinationOptions
from hvacflex.fleet.generate import generate_fleet, write_fleet
from hvacflex.fleet.report import whole_fleet_rows
from hvacflex.fleet.run import FleetStepProgress, step_progress
from hvacflex.sim.progress import task_progress


def test_generate_simulate_kpi(tmp_path: Path) -> None:
    runner = CliRunner()
    fleet = tmp_path / "fleet.toml"
    done = runner.invoke(
        app, ["fleet", "generate", "--buildings", "2", "--seed", "4", "--out", str(fleet)]
    )
    assert done.exit_code == 0, done.output
    out = tmp_path / "run"
    done = runner.invoke(
        app,
        [
            "fleet",
            "simulate",
            "--fleet",
            str(fleet),
            "--start",
            "2014-03-03",
            "--days",
            "0.0625",
            "--out",
            str(out),
            "--workers",
            "0",
        ],
    )
    assert done.exit_code == 0, done.output
    assert (out / "results.parquet").is_file() and (out / "report.html").is_file()
    # the envelope is written and plotted in the report
    assert len(pd.read_csv(out / "envelope.csv")) == 3 * 3
    assert (out / "fleet_envelope.png").is_file()
    assert "Flexibility envelope" in (out / "report.html").read_text()
    # the aggregator's offer: the closing line, offers.csv and the report's section
    assert "office-hour periods at or above the minimum bid (100 kW)" in done.output
    assert (out / "offers.csv").is_file() and (out / "fleet_offer.png").is_file()
    assert "The aggregator&#x27;s offer" in (out / "report.html").read_text()
    assert "blank where some building has no comfort-keeping" in (out / "report.html").read_text()
    done = runner.invoke(app, ["kpi", str(out)])
    assert done.exit_code == 0, done.output
    assert "peak_fleet_power_kw" in done.output


def test_the_report_blanks_envelope_rows_that_omit_buildings() -> None:
    rows = pd.DataFrame(
        {
            "min_power_kw": [1.0, 2.0, float("nan")],
            "max_power_kw": [3.0, 4.0, float("nan")],
            "buildings": [2, 1, 0],
        }
    )
    whole = whole_fleet_rows(rows, 2)
    assert whole["min_power_kw"].tolist()[0] == 1.0 and whole["max_power_kw"][0] == 3.0
    assert whole.loc[1:, ["min_power_kw", "max_power_kw"]].isna().all().all()
    assert rows["min_power_kw"][1] == 2.0  # the file's frame is left as it was


def test_bad_fleet_file_exit_2(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nfeeder_limit_kw = 10.0\nbuildings = []\n')
    done = CliRunner().invoke(
        app,
        [
            "fleet",
            "simulate",
            "--fleet",
            str(bad),
            "--out",
            str(tmp_path / "o"),
            "--workers",
            "0",
            "--days",
            "1",
        ],
    )
    assert done.exit_code == 2
    assert "bad.toml" in done.output and "buildings" in done.output


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("reserve_price_scale", 200.0, "moved to [data] reserve_price_scale"),
        ("data", {"reserve_price_correlation": 2.0}, "data.reserve_price_correlation"),
        ("data", {"reserve_source": "r.csv", "reserve_price_scale": 9.0}, "reserve_source"),
    ],
)
@pytest.mark.parametrize("command", ["simulate", "compare"])
def test_bad_fleet_data_exit_2_without_traceback(
    tmp_path: Path, command: str, key: str, value: object, expected: str
) -> None:
    doc = generate_fleet(1, 1)
    doc[key] = value
    path = write_fleet(doc, tmp_path / "old.toml")
    done = CliRunner().invoke(
        app,
        ["fleet", command, "--fleet", str(path), "--out", str(tmp_path / "o")]
        + (["--workers", "0"] if command == "simulate" else []),
    )
    assert done.exit_code == 2, done.output
    assert "Traceback" not in done.output
    assert "old.toml" in done.output and expected in done.output


def _step(done: int, iterations: int, gap: float) -> FleetStepProgress:
    return step_progress(
        done, 4, SimpleNamespace(iterations=iterations, gap=gap), CoordinationOptions(10, 0.002)
    )


def teststep_progress_flags_an_unconverged_stop_at_the_limit() -> None:
    assert _step(1, 10, 0.44).at_iteration_limit
    assert not _step(1, 10, 0.001).at_iteration_limit  # converged on the last iteration
    assert not _step(1, 3, 0.44).at_iteration_limit  # stopped early: feasible and tight
    assert _step(1, 10, float("nan")).at_iteration_limit  # no bound: not converged


def test_coordination_watch_warns_once_and_sums_up(capsys: pytest.CaptureFixture[str]) -> None:
    watch = CoordinationWatch()
    with task_progress(False, "fleet", 4) as update:
        watch.update = update
        for done, iterations, gap in [(1, 10, 0.44), (2, 4, 0.001), (3, 10, 0.5), (4, 10, 0.3)]:
            watch(_step(done, iterations, gap))
    assert update.completed == 4
    err = capsys.readouterr().err
    assert err.count("warning:") == 1 and "step 1: coordination stopped at its iteration" in err
    assert watch.at_limit == 3 and watch.worst_gap == 0.5
    assert "in 3 of 4 steps (largest gap 0.5, tolerance 0.002)" in watch.summary()


def test_simulate_prints_the_guarantee_outside_the_flagged_periods(tmp_path: Path) -> None:
    """Under 60 kW two buildings' minimum powers alone exceed the limit from 08:00: the
    closing line says how many periods were flagged and how far the others went over it
    (what the feeder guarantee is judged on)."""
    fleet = tmp_path / "fleet.toml"
    generate = ["fleet", "generate", "--buildings", "2", "--seed", "3", "--out", str(fleet)]
    done = CliRunner().invoke(app, [*generate, "--feeder-limit-kw", "60"])
    assert done.exit_code == 0, done.output
    simulate = ["fleet", "simulate", "--fleet", str(fleet), "--start", "2014-03-03T07:00"]
    options = ["--days", "0.0625", "--workers", "0", "--out", str(tmp_path / "run")]
    done = CliRunner().invoke(app, [*simulate, *options])
    assert done.exit_code == 0, done.output
    assert "1 periods flagged infeasible (outside them: planned over limit max" in done.output


def test_workers_without_the_dask_extra_exit_2_with_its_install_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "dask" else real(name)
    )
    fleet = tmp_path / "fleet.toml"
    runner = CliRunner()
    done = runner.invoke(
        app, ["fleet", "generate", "--buildings", "2", "--seed", "4", "--out", str(fleet)]
    )
    assert done.exit_code == 0, done.output
    args = ["fleet", "simulate", "--fleet", str(fleet), "--days", "0.0625"]
    done = runner.invoke(app, [*args, "--out", str(tmp_path / "run"), "--workers", "2"])
    assert done.exit_code == 2, done.output
    assert 'pip install -e ".[dask]"' in done.output and "--workers 0" in done.output
    assert not (tmp_path / "run" / "results.parquet").exists()


def _fleet_options(command: str) -> dict[str, Any]:
    """``hvacflex fleet <command>``'s click options by their flag."""
    import typer.main

    group = typer.main.get_command(app)
    fleet = group.commands["fleet"]  # type: ignore[attr-defined]
    return {p.opts[0]: p for p in fleet.commands[command].params}


def test_the_shared_options_are_declared_once_with_each_command_s_default() -> None:
    simulate, bound, compare = (_fleet_options(c) for c in ("simulate", "bound", "compare"))
    for flag in ("--fleet", "--start", "--days", "--out"):
        assert flag in simulate and flag in bound
    for flag in ("--fleet", "--start", "--out", "--scheduler", "--workers"):
        assert flag in compare
    assert simulate["--fleet"].help == bound["--fleet"].help == compare["--fleet"].help
    assert simulate["--fleet"].required and simulate["--out"].required
    assert bound["--start"].help == compare["--start"].help != simulate["--start"].help
    assert simulate["--workers"].help == compare["--workers"].help
    assert (simulate["--workers"].default, compare["--workers"].default) == (2, 0)
    assert (simulate["--days"].default, bound["--days"].default) == (7.0, 1.0)
    # the callbacks travel with the shared declarations: a start off the period grid is refused
    done = CliRunner().invoke(
        app, ["fleet", "bound", "--fleet", "f.toml", "--start", "2014-03-03T08:10", "--out", "o"]
    )
    assert done.exit_code == 2 and "--start" in done.output
