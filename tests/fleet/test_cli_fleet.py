from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from hvacflex.cli import app


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
    done = runner.invoke(app, ["kpi", str(out)])
    assert done.exit_code == 0, done.output
    assert "peak_fleet_power_kw" in done.output


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
