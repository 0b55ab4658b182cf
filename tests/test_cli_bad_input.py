"""Every kind of bad command-line input exits 2 with a message naming what is wrong, before
any long work starts, and never with a traceback (issue 29 item 8, issue 28 item 4).

The cases are those found by trying each command with bad output paths, numbers, dates and
files; each is a command line (``{tmp}``, ``{file}`` and ``{folder}`` filled in) and the words
its message must contain.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.config import preset
from hvacflex.fleet.generate import generate_fleet, write_fleet
from hvacflex.paths import resources_dir

SHIPPED_IDF = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"

SCENARIOS = {
    "huge_horizon.toml": "days = 0.5\n[controller]\nhorizon_steps = 100000000\n",
    "frozen.toml": "days = 0.5\ninitial_temp_degc = -500\n",
    "hot_band.toml": "days = 0.5\n[comfort]\noccupied_degc = [200, 300]\n",
    "cold_band.toml": "days = 0.5\n[comfort]\noccupied_degc = [10, 12]\n",
    "cold_reference.toml": "days = 0.5\n[controller]\nlinearisation_temp_degc = 5\n",
    "hot_setpoint.toml": "days = 0.5\n[controller]\nthermostat_setpoint_degc = 240\n",
    "tiny.toml": "days = 1e-9\n",
    "us_date.toml": 'start = "04/03/2014"\ndays = 0.5\n',
}
"""Scenario files of the cases, written into the test's folder."""

SIM = ["simulate", "-q", "--days", "0.5"]
FLEET_SIM = ["fleet", "simulate", "--fleet", "{tmp}/valid_fleet.toml", "--out", "{tmp}/fr"]
FLEET_BOUND = ["fleet", "bound", "--fleet", "{tmp}/valid_fleet.toml", "--out", "{tmp}/fb"]
FLEET_COMPARE = ["fleet", "compare", "--fleet", "{tmp}/valid_fleet.toml", "--out", "{tmp}/fc"]
COLLECT = ["identify", "collect", "--idf", str(SHIPPED_IDF), "--start", "2014-03-03", "--days", "1"]
REPORT = ["report", "{tmp}/none", "--out", "{tmp}/r.html"]
FIT = ["identify", "fit", "--data", "{tmp}/none.csv", "--out", "{tmp}/m.toml"]

CASES: list[tuple[str, list[str], list[str]]] = [
    # output paths: a file in the way, a folder inside a file, a virtual file system
    ("simulate-out-file", [*SIM, "--out", "{file}"], ["'--out'", "is a file", "{file}"]),
    ("simulate-out-under-file", [*SIM, "--out", "{file}/sub"], ["'--out'", "inside"]),
    ("simulate-out-proc", [*SIM, "--out", "/proc/hvacflex"], ["'--out'", "/proc/hvacflex"]),
    ("reproduce-out-file", ["reproduce", "--quick", "--out", "{file}"], ["'--out'", "is a file"]),
    ("validate-out-file", ["validate", "bestest", "--out", "{file}"], ["'--out'", "is a file"]),
    ("sweep-out-file", ["sweep", "--param", "seed=1", "--out", "{file}"], ["'--out'", "file"]),
    ("fig2-under-file", ["data", "show", "--fig2", "{file}/x.png"], ["'--fig2'", "inside"]),
    ("fleet-out-under-file", ["fleet", "generate", "--buildings", "2", "--out", "{file}/x.toml"],
     ["'--out'", "inside"]),
    ("fleet-out-folder", ["fleet", "generate", "--buildings", "2", "--out", "{folder}"],
     ["'--out'", "folder"]),
    ("fleet-sim-out-file", [*FLEET_SIM[:-1], "{file}", "--days", "0.5"], ["'--out'", "is a file"]),
    ("kpi-csv-under-file", ["kpi", "{tmp}/none", "--csv", "{file}/x.csv"], ["'--csv'", "inside"]),
    ("kpi-csv-folder", ["kpi", "{tmp}/none", "--csv", "{folder}"], ["'--csv'", "folder"]),
    ("identify-collect-out-under-file", [*COLLECT, "--out", "{file}/t.csv"], ["'--out'", "inside"]),
    ("report-out-under-file", ["report", "{tmp}/none", "--out", "{file}/r.html"],
     ["'--out'", "inside"]),
    # sizes and numbers
    ("fleet-buildings-cap", ["fleet", "generate", "--buildings", "1000000000", "--out", "x.toml"],
     ["'--buildings'", "1000"]),
    ("fleet-buildings-zero", ["fleet", "generate", "--buildings", "0", "--out", "x.toml"],
     ["'--buildings'"]),
    ("fleet-feeder-nan", ["fleet", "generate", "--buildings", "2", "--out", "x.toml",
                          "--feeder-limit-kw", "nan"], ["'--feeder-limit-kw'"]),
    ("fleet-days-nan", [*FLEET_SIM, "--days", "nan"], ["'--days'", "finite"]),
    ("fleet-days-fraction", [*FLEET_SIM, "--days", "0.3"], ["'--days'", "whole number"]),
    ("fleet-workers-negative", [*FLEET_SIM, "--workers", "-1"], ["'--workers'", "0"]),
    ("fleet-bound-days-fraction", [*FLEET_BOUND, "--days", "0.3"], ["'--days'", "whole number"]),
    ("fleet-bound-out-file", [*FLEET_BOUND[:-1], "{file}"], ["'--out'", "is a file"]),
    ("fleet-compare-workers-negative", [*FLEET_COMPARE, "--workers", "-1"], ["'--workers'"]),
    ("sweep-workers-zero", ["sweep", "--param", "seed=1,2", "--workers", "0"],
     ["'--workers'", "1"]),
    ("reproduce-workers-zero", ["reproduce", "--workers", "0"], ["'--workers'", "1"]),
    ("kpi-peak-price-nan", ["kpi", "{tmp}/none", "--peak-price", "nan"], ["'--peak-price'"]),
    ("kpi-peak-price-negative", ["kpi", "{tmp}/none", "--peak-price", "-1"], ["'--peak-price'"]),
    ("report-peak-price-nan", [*REPORT, "--peak-price", "nan"], ["'--peak-price'"]),
    ("report-peak-price-negative", [*REPORT, "--peak-price", "-1"],
     ["'--peak-price'", "greater than or equal to 0"]),
    ("report-peak-price-inf", [*REPORT, "--peak-price", "inf"], ["'--peak-price'", "finite"]),
    ("identify-fit-overlap", [*FIT, "--train", "2014-03-03..2014-03-10", "--test",
                              "2014-03-10..2014-03-12"],
     ["overlap", "--train 2014-03-03..2014-03-10", "--test 2014-03-10..2014-03-12"]),
    ("identify-fit-overlap-inside", [*FIT, "--train", "2014-03-03..2014-03-10", "--test",
                                     "2014-03-05..2014-03-06"],
     ["overlap", "2014-03-03..2014-03-10", "2014-03-05..2014-03-06"]),
    ("data-days-huge", ["data", "show", "--days", "100000"], ["'--days'"]),
    ("checkpoint-every-zero", [*SIM, "--checkpoint-every", "0"], ["'--checkpoint-every'"]),
    # the scenario file: capped, physical ranges, the field the user wrote
    ("horizon-cap", [*SIM, "--config", "{tmp}/huge_horizon.toml"],
     ["controller.horizon_steps", "336", "100000000"]),
    ("initial-temp", [*SIM, "--config", "{tmp}/frozen.toml"], ["initial_temp_degc", "-500"]),
    ("absurd-band", [*SIM, "--config", "{tmp}/hot_band.toml"],
     ["hot_band.toml", "comfort.occupied_degc", "200"]),
    ("band-below-supply", [*SIM, "--config", "{tmp}/cold_band.toml"],
     ["cold_band.toml", "comfort.occupied_degc", "supply-air"]),
    ("reference-below-supply", [*SIM, "--config", "{tmp}/cold_reference.toml"],
     ["cold_reference.toml", "controller.linearisation_temp_degc", "5"]),
    ("setpoint-range", [*SIM, "--config", "{tmp}/hot_setpoint.toml"],
     ["controller.thermostat_setpoint_degc", "240"]),
    ("days-tiny-in-file", ["simulate", "-q", "--config", "{tmp}/tiny.toml"],
     ["field 'days'", "30-min period"]),
    # dates: ISO 8601 only, everywhere
    ("simulate-us-date", [*SIM, "--start", "04/03/2014"], ["'--start'", "ISO 8601"]),
    ("sweep-us-date", ["sweep", "--param", "seed=1", "--start", "04/03/2014"], ["'--start'"]),
    ("data-us-date", ["data", "show", "--start", "04/03/2014"], ["'--start'", "ISO 8601"]),
    ("fleet-us-date", [*FLEET_SIM, "--start", "04/03/2014"], ["'--start'", "ISO 8601"]),
    ("file-us-date", ["simulate", "-q", "--config", "{tmp}/us_date.toml"],
     ["us_date.toml", "field 'start'", "ISO 8601"]),
    ("sweep-param-us-date", ["sweep", "--param", "start=04/03/2014"], ["'start'", "ISO 8601"]),
    ("start-off-grid", [*SIM, "--start", "2014-03-04T08:10"], ["'--start'", "30-min period"]),
    ("start-not-a-day", [*SIM, "--start", "2014-02-30"], ["'--start'", "calendar"]),
    # another configuration's run in the output folder
    ("other-config-folder", [*SIM, "--out", "{tmp}/thermostat_run"],
     ["another configuration", "controller.kind", "--fresh"]),
    # scheduler addresses: malformed, or nothing listening (Dask waits 30 s, then a traceback)
    ("sweep-scheduler-not-an-address", ["sweep", "--param", "seed=1", "--scheduler", "not a url"],
     ["'--scheduler'", "not a url"]),
    ("sweep-scheduler-closed-port", ["sweep", "--param", "seed=1", "--scheduler",
                                     "tcp://127.0.0.1:1"], ["'--scheduler'", "no scheduler"]),
    ("reproduce-scheduler-closed-port", ["reproduce", "--scheduler", "127.0.0.1:1"],
     ["'--scheduler'", "127.0.0.1:1"]),
    ("reproduce-studies-scheduler-closed-port",
     ["reproduce", "--sensitivity", "--seeds", "--scheduler", "127.0.0.1:1"],
     ["'--scheduler'", "127.0.0.1:1"]),
    ("fleet-scheduler-closed-port", [*FLEET_SIM, "--scheduler", "tcp://127.0.0.1:1"],
     ["'--scheduler'", "no scheduler"]),
    ("fleet-seed-negative", ["fleet", "generate", "--buildings", "2", "--seed", "-1",
                             "--out", "x.toml"], ["'--seed'"]),
    ("scenario-seed-negative", ["sweep", "--param", "seed=-1"], ["'seed'", "≥ 0"]),
    # files
    ("config-missing", [*SIM, "--config", "{tmp}/none.toml"], ["none.toml", "not found"]),
    ("config-folder", [*SIM, "--config", "{folder}"], ["{folder}"]),
    ("fleet-missing", ["fleet", "simulate", "--fleet", "{tmp}/fleet.toml", "--out", "{tmp}/fr",
                       "--days", "0.5"], ["fleet.toml", "not found"]),
    ("building-file-missing", ["data", "show", "--building-file", "{tmp}/none.toml"],
     ["building", "none.toml"]),
]  # fmt: skip


@pytest.fixture
def workdir(tmp_path: Path) -> Path:
    """A folder with a plain file, a folder, the cases' scenario files, a valid fleet file
    and a run folder of the thermostat scenario (only its config.json: the check reads
    nothing else)."""
    (tmp_path / "a_file").write_text("not a folder\n")
    (tmp_path / "a_folder").mkdir()
    for name, text in SCENARIOS.items():
        (tmp_path / name).write_text(text)
    write_fleet(generate_fleet(2, 1), tmp_path / "valid_fleet.toml")
    run = tmp_path / "thermostat_run"
    run.mkdir()
    stored = preset("thermostat", days=0.5).to_dict()
    (run / "config.json").write_text(json.dumps(stored))
    return tmp_path


def _fill(text: str, workdir: Path) -> str:
    return text.format(tmp=workdir, file=workdir / "a_file", folder=workdir / "a_folder")


@pytest.mark.parametrize(("args", "expected"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_exits_2_naming_it_without_a_traceback(
    workdir: Path, monkeypatch: pytest.MonkeyPatch, args: list[str], expected: list[str]
) -> None:
    monkeypatch.chdir(workdir)
    began = time.perf_counter()
    result = CliRunner().invoke(app, [_fill(a, workdir) for a in args], env={"COLUMNS": "400"})
    seconds = time.perf_counter() - began
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit), result.exception  # no uncaught error
    assert "Traceback" not in result.output
    for words in expected:
        assert _fill(words, workdir) in result.output, result.output
    assert seconds < 30, f"refused only after {seconds:.0f} s of work"


def test_no_case_leaves_results_behind(workdir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(workdir)
    for _name, args, _expected in CASES:
        if args[0] == "simulate":
            CliRunner().invoke(app, [_fill(a, workdir) for a in args])
    assert not list(workdir.rglob("results.parquet"))
    assert not list(workdir.rglob("summary.json"))
    stored = json.loads((workdir / "thermostat_run" / "config.json").read_text())
    assert stored["controller"]["kind"] == "thermostat"  # the other run was left alone


def test_a_bad_fleet_file_is_said_before_the_output_folder_is_made(
    workdir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(workdir)
    args = ["fleet", "simulate", "--fleet", "none.toml", "--out", "new_out", "--days", "1"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2 and "none.toml" in result.output, result.output
    assert not (workdir / "new_out").exists()
