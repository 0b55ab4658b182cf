"""The public API (``hvacflex.api``, exposed lazily by ``import hvacflex``)."""

from __future__ import annotations

import inspect
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from typer.testing import CliRunner

import hvacflex
from hvacflex import api
from hvacflex.building.io import load_building as load_building_file
from hvacflex.cli import app
from hvacflex.cli import simulate as cli_simulate
from hvacflex.errors import ConfigError, DataError
from hvacflex.paths import buildings_dir
from hvacflex.sim.run_files import read_summary

SRC = Path(hvacflex.__file__).resolve().parents[1]
"""The source folder of the hvacflex under test (a subprocess must import the same one)."""

PUBLIC_NAMES = [
    "Building",
    "Controller",
    "Forecaster",
    "Plant",
    "RunResult",
    "Scenario",
    "Simulation",
    "SimulationResult",
    "__version__",
    "kpi_summary",
    "load_building",
    "load_config",
    "preset",
    "simulate",
]

HEAVY_MODULES = ("numpy", "pandas", "scipy", "highspy", "pydantic", "pyarrow", "typer")
"""What ``import hvacflex`` must not import: the public API loads them on first use."""

START, DAYS = "2014-03-03", 1
"""The done-when run of issue 23: one day of the rmpc preset."""

TIMING_COLUMNS = ("solve_time_s",)
"""Results columns that measure wall time, not the simulation."""


def _is_timing_key(key: str) -> bool:
    """Summary keys that measure wall time (they differ between two identical runs)."""
    return key == "steps_per_s" or key.startswith(("time_", "solve_time_"))


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def test_all_is_pinned_and_every_name_resolves() -> None:
    assert hvacflex.__all__ == PUBLIC_NAMES
    assert api.__all__ == [name for name in PUBLIC_NAMES if name != "__version__"]
    for name in PUBLIC_NAMES:
        assert name in dir(hvacflex)
    assert hvacflex.simulate is api.simulate and hvacflex.preset is api.preset
    assert hvacflex.RunResult.__module__ == "hvacflex.sim.run"  # one RunResult only
    with pytest.raises(AttributeError, match="no attribute 'simulte'"):
        _ = hvacflex.simulte


def test_import_hvacflex_stays_cheap() -> None:
    code = (
        "import sys, hvacflex; hvacflex.__version__; "
        f"print(','.join(m for m in {HEAVY_MODULES!r} if m in sys.modules))"
    )
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]),
    }
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == ""


def test_out_defaults_to_the_command_lines_folder() -> None:
    api_default = inspect.signature(api.simulate).parameters["out"].default
    cli_default = inspect.signature(cli_simulate).parameters["out"].default.default
    assert Path(api_default) == cli_default == Path("results/run")


@pytest.fixture(scope="module")
def done_when_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[api.RunResult, Path]:
    """The API's run and the command line's run folder, same scenario, different folders."""
    root = tmp_path_factory.mktemp("api")
    run = hvacflex.simulate("rmpc", start=START, days=DAYS, out=root / "api", quiet=True)
    args = ["simulate", "--scenario", "rmpc", "--start", START, "--days", str(DAYS)]
    result = CliRunner().invoke(app, [*args, "--out", str(root / "cli"), "-q"])
    assert result.exit_code == 0, result.output
    return run, root / "cli"


def test_simulate_gives_the_summary_of_the_command_line(
    done_when_runs: tuple[api.RunResult, Path],
) -> None:
    run, cli_dir = done_when_runs
    cli_summary = read_summary(cli_dir / "summary.json")  # NaN is written as null
    assert set(run.summary) == set(cli_summary)
    compared = [key for key in cli_summary if not _is_timing_key(key)]
    assert len(compared) > 30 and "net_cost_sgd" in compared
    differ = {k: (run.summary[k], cli_summary[k]) for k in compared}
    assert {k: v for k, v in differ.items() if not _same(*v)} == {}
    assert run.summary["steps"] == 48 and run.summary["energy_kwh"] > 0


def test_the_run_result_holds_the_files_it_wrote(
    done_when_runs: tuple[api.RunResult, Path],
) -> None:
    run, cli_dir = done_when_runs
    stored = read_summary(run.out_dir / "summary.json")
    assert stored.keys() == run.summary.keys()
    assert all(_same(stored[k], run.summary[k]) for k in stored)
    assert run.results is run.frame and len(run.results) == 48
    assert run.results.index[0] == pd.Timestamp(START, tz="Asia/Singapore")
    on_disk = pd.read_parquet(run.out_dir / "results.parquet")
    pd.testing.assert_frame_equal(on_disk, run.results, check_freq=False)
    cli_frame = pd.read_parquet(cli_dir / "results.parquet")
    pd.testing.assert_frame_equal(
        cli_frame.drop(columns=list(TIMING_COLUMNS)),
        run.results.drop(columns=list(TIMING_COLUMNS)),
        check_freq=False,
    )


def test_kpi_summary_of_a_run_its_folder_and_its_frame_agree(
    done_when_runs: tuple[api.RunResult, Path],
) -> None:
    run, _ = done_when_runs
    of_run = hvacflex.kpi_summary(run)
    same = [  # as JSON: NaN (a delivery ratio without reserve due) equals NaN
        json.dumps(summary, sort_keys=True)
        for summary in (
            of_run,
            hvacflex.kpi_summary(run.out_dir),
            hvacflex.kpi_summary(run.results),
        )
    ]
    assert same[0] == same[1] == same[2]
    # summary.json adds the timings and what the run was graded on (plant, plant_idf, ...)
    assert {k for k in run.summary if k not in of_run} == {
        k for k in run.summary if k == "steps_per_s" or k.startswith(("time_", "plant"))
    }
    assert run.summary["plant"] == "rc"
    assert of_run["energy_kwh"] == run.summary["energy_kwh"]
    doubled = hvacflex.kpi_summary(run, peak_price_sgd_per_kw=2.0)
    assert doubled["ppp_charge_monthly_sgd"] == pytest.approx(2.0 * of_run["peak_power_kw"])


def test_a_table_override_reaches_the_controller(tmp_path: Path) -> None:
    run = hvacflex.simulate(
        "rmpc-ppp",
        tmp_path / "run",
        quiet=True,
        start=START,
        days=0.25,
        controller={"peak_price_sgd_per_kw": 2.5},
    )
    assert run.summary["steps"] == 12
    assert (run.results["peak_price_sgd_per_kw"] == 2.5).all()
    again = hvacflex.simulate(
        "rmpc-ppp", tmp_path / "run", quiet=True, start=START, days=0.25, peak_price_sgd_per_kw=2.5
    )
    assert again.cached  # the same scenario by a leaf name: the finished run is re-used
    fresh = hvacflex.simulate(
        "rmpc-ppp",
        tmp_path / "run",
        quiet=True,
        fresh=True,
        start=START,
        days=0.25,
        controller={"peak_price_sgd_per_kw": 2.5},
    )
    assert not fresh.cached
    assert fresh.summary["energy_kwh"] == run.summary["energy_kwh"]


def test_simulate_takes_a_scenario_file_and_a_config(tmp_path: Path) -> None:
    file = tmp_path / "short.toml"
    file.write_text(f'preset = "nmpc"\nstart = "{START}"\ndays = 0.25\n')
    from_file = hvacflex.simulate(file, tmp_path / "file", quiet=True)
    config = hvacflex.load_config(file)
    from_config = hvacflex.simulate(config, tmp_path / "config", quiet=True)
    assert from_file.summary["steps"] == 12
    assert from_file.summary["net_cost_sgd"] == from_config.summary["net_cost_sgd"]
    assert json.loads((from_file.out_dir / "config.json").read_text())["controller"]["robust"] == (
        "none"
    )


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"controller": {"peak_price": 1.0}}, "controller.peak_price"),
        ({"days": -1}, "days"),
        ({"dayz": 1}, "dayz"),
        ({"start": "2014-13-01"}, "start"),
    ],
)
def test_bad_overrides_raise_a_config_error_naming_the_field(
    tmp_path: Path, overrides: dict[str, Any], field: str
) -> None:
    with pytest.raises(ConfigError) as err:
        hvacflex.simulate("rmpc", tmp_path / "never", **overrides)
    assert err.value.field == field
    assert not (tmp_path / "never").exists()  # refused before anything was written


def test_an_unknown_preset_names_the_presets(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="rmpc-ppp") as err:
        hvacflex.simulate("rmcp", tmp_path / "never")
    assert err.value.field == "scenario"


def test_load_building_takes_a_shipped_name_or_a_file() -> None:
    by_name = hvacflex.load_building("office5")
    assert by_name == load_building_file(buildings_dir() / "office5.toml")
    assert by_name == hvacflex.load_building(buildings_dir() / "office5.toml")
    assert len(by_name.zones) == 5
    with pytest.raises(DataError, match="office5") as err:
        hvacflex.load_building("office55")
    assert err.value.field == "building"


def test_the_types_and_protocols_are_the_packages_own() -> None:
    from hvacflex.building.model import Building
    from hvacflex.config import ScenarioConfig
    from hvacflex.control.base import Controller
    from hvacflex.sim.plant import Plant, RCPlant
    from hvacflex.simulation import Forecaster, Simulation

    assert hvacflex.Scenario is ScenarioConfig and hvacflex.Building is Building
    assert hvacflex.Controller is Controller and hvacflex.Plant is Plant
    assert hvacflex.Forecaster is Forecaster and hvacflex.Simulation is Simulation
    assert isinstance(hvacflex.preset("rmpc"), hvacflex.Scenario)
    office = hvacflex.load_building("office5")
    assert isinstance(office, hvacflex.Building)
    assert isinstance(RCPlant(office), hvacflex.Plant)  # the protocol is runtime-checkable
    assert not isinstance(object(), hvacflex.Forecaster)


API_DOC = Path(__file__).resolve().parents[1] / "docs" / "reference" / "api.md"
RUNNABLE_PYTHON = re.compile(r"<!-- runnable -->\n```python\n(.*?)\n```", re.S)


def test_the_examples_of_docs_api_run(tmp_path: Path) -> None:
    """docs/reference/api.md's runnable blocks, in order, as one script in an empty folder (one
    interpreter: the imports are paid once)."""
    blocks = RUNNABLE_PYTHON.findall(API_DOC.read_text(encoding="utf-8"))
    assert len(blocks) == 3  # stepping, a user's controller, the Gymnasium environment
    script = tmp_path / "api_examples.py"
    script.write_text("\n\n".join(blocks), encoding="utf-8")
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]),
    }
    done = subprocess.run(
        [sys.executable, str(script)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.splitlines()
    assert lines[0].startswith("48 flow ('north'")
    assert any(line.startswith("energy_kwh: hysteresis") for line in lines)
    steps, _, _ = lines[-1].split()
    assert steps == "48"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["api_examples.py"]  # no files left
