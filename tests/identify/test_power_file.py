"""``hvacflex identify power``: a designed building's power model from a plant's meter,
written as the building file's table, and bad input refused (exit 2) before anything is
written."""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.building.io import building_from_dict
from hvacflex.cli import app
from hvacflex.identify.power_file import read_power_table
from hvacflex.identify.trend import write_trend
from hvacflex.paths import resources_dir


@pytest.fixture(scope="module")
def trend(
    tmp_path_factory: pytest.TempPathFactory, synthetic_trend: Callable[..., pd.DataFrame]
) -> Path:
    path = tmp_path_factory.mktemp("power_file") / "trend.csv"
    write_trend(synthetic_trend(days=6, seed=1, noise_k=0.02), path)
    return path


def _power(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["identify", "power", *args])
    return result.exit_code, result.output


def test_the_table_it_writes_is_the_building_file_s_and_plans_its_plant(
    trend: Path, tmp_path: Path
) -> None:
    out = tmp_path / "fit" / "power.toml"
    code, output = _power(
        "--data", str(trend), "--plant", "energyplus", "--out", str(out),
        "--train", "2014-03-03..2014-03-07", "--test", "2014-03-08..2014-03-08",
    )  # fmt: skip
    assert code == 0, output
    report = pd.read_csv(out.parent / "power_report.csv")
    every = report[report["day"] == "test days"].set_index("hours")
    assert every.loc["all", "power_rmse_kw"] < 0.05  # the meter is the model's own form
    assert {"occupied", "unoccupied"} <= set(every.index)
    power = read_power_table(out, "energyplus")
    assert power.kw_per_kw_cooling == pytest.approx(0.3, abs=2e-3)
    office5 = tomllib.loads((resources_dir() / "buildings" / "office5.toml").read_text())
    office5["power_models"] = tomllib.loads(out.read_text())["power_models"]
    building = building_from_dict(office5)
    assert building.with_power_model_for("energyplus").metered_power == power
    assert building.with_power_model_for("rc").metered_power is None  # design curves


def test_a_trend_without_a_meter_exits_2_naming_the_column(trend: Path, tmp_path: Path) -> None:
    frame = pd.read_csv(trend).drop(columns=["hvac_power_kw"])
    bare = tmp_path / "bare.csv"
    frame.to_csv(bare, index=False)
    out = tmp_path / "power.toml"
    code, output = _power("--data", str(bare), "--plant", "rc", "--out", str(out))
    assert code == 2 and "hvac_power_kw" in output and "bare.csv" in output
    assert "Traceback" not in output and not out.exists()


def test_too_few_running_periods_exit_2_before_writing(trend: Path, tmp_path: Path) -> None:
    out = tmp_path / "power.toml"
    code, output = _power(
        "--data", str(trend), "--plant", "rc", "--out", str(out),
        "--train", "2014-03-03..2014-03-03", "--test", "2014-03-04..2014-03-04",
    )  # fmt: skip
    assert code == 2 and "--train" in output and "48 periods" in output
    assert not out.exists() and not (tmp_path / "power_report.csv").exists()


def test_an_unknown_plant_and_results_without_their_building_exit_2(
    trend: Path, tmp_path: Path
) -> None:
    code, output = _power("--data", str(trend), "--plant", "boptest", "--out", "x.toml")
    assert code == 2 and "--plant" in output and "rc or energyplus" in output
    results = tmp_path / "run"
    results.mkdir()
    code, output = _power("--data", str(results), "--plant", "rc", "--out", "x.toml")
    assert code == 2 and "--building" in output
