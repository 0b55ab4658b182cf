"""The identified model's calibrated box: the quantile rule of calibrate_box, its coverage,
and the scenario file that reads it back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.config import load_config
from hvacflex.identify.box import (
    calibrate_model_error,
    write_baseline_scenario,
    write_model_errors,
    write_scenario,
)
from hvacflex.paths import resolve_idf, resources_dir
from hvacflex.results import PREDICTION_ERROR, read_results


def test_the_margin_is_the_next_higher_sample_at_the_quantile() -> None:
    # 20 errors 0.05, 0.10, …, 1.00 K (signs alternating): q = 0.9 at position 19 · 0.9 =
    # 17.1 of the sorted samples, the next higher is the 19th (0.95 K)
    magnitudes = np.arange(1, 21) * 0.05
    test = (magnitudes * np.where(np.arange(20) % 2 == 0, 1.0, -1.0))[:, None]
    train = np.array([[0.1], [0.95], [2.0], [-0.5]])
    box = calibrate_model_error(("a",), test, train, quantile=0.9)
    assert box.model_error_k[0] == np.sort(magnitudes)[18]
    assert box.coverage_test[0] == 19 / 20
    assert box.coverage_train[0] == 3 / 4  # 0.1, 0.95 and −0.5 inside ±0.95 K
    assert list(box.frame().columns) == [
        "zone",
        "model_error_k",
        "coverage_test",
        "coverage_train",
        "quantile",
    ]


def test_the_scenario_reads_the_model_and_the_errors_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    index = pd.date_range("2014-03-18", periods=96, freq="30min", tz="Asia/Singapore")
    errors = np.random.default_rng(1).normal(0, 0.2, (96, 2))
    fitted = tmp_path / "fitted"
    fitted.mkdir()
    path = write_model_errors(("a", "b"), index, errors, fitted / "model_errors.parquet")
    frame, _ = read_results(path)
    np.testing.assert_array_equal(frame[PREDICTION_ERROR.name("b")].to_numpy(), errors[:, 1])
    model = fitted / "model.toml"
    model.write_text("", encoding="utf-8")
    idf = tmp_path / "plant.idf"
    weather = tmp_path / "site.epw"
    scenario = write_scenario(
        fitted / "scenario.toml", model, path, "2014-03-18..2014-03-19", 0.95, idf, weather
    )
    text = scenario.read_text(encoding="utf-8")
    # relative to the scenario's folder: the folder can move, the run starts anywhere
    assert str(tmp_path) not in text
    assert 'building = "model.toml"' in text and 'idf = "../plant.idf"' in text
    monkeypatch.chdir(tmp_path.parent)
    config = load_config(scenario)
    assert Path(config.data.weather_file).resolve() == weather.resolve()  # the fit's site
    assert Path(config.building).resolve() == model.resolve()
    calibrate = config.uncertainty.calibrate
    assert calibrate is not None and calibrate.quantile == 0.95
    assert calibrate.prediction_errors is not None
    assert Path(calibrate.prediction_errors).resolve() == path.resolve()
    assert Path(config.plant.idf).resolve() == idf.resolve()
    assert config.plant.kind == "energyplus" and config.plant.actuation == "setpoint"
    assert config.controller.robust == "tightening" and config.estimation.mode == "full-state"


def test_the_baseline_runs_the_buildings_own_control_on_the_same_plant(tmp_path: Path) -> None:
    model = tmp_path / "model.toml"
    model.write_text("", encoding="utf-8")
    shipped = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"
    baseline = write_baseline_scenario(tmp_path / "baseline.toml", model, shipped)
    text = baseline.read_text(encoding="utf-8")
    assert 'idf = "5ZoneAirCooled"' in text  # a shipped model by its name, not its path
    config = load_config(baseline)
    assert config.controller.kind == "plant" and config.plant.kind == "energyplus"
    assert config.plant.idf == "5ZoneAirCooled" and config.plant.resolved_actuation == "setpoint"
    assert resolve_idf(config.plant.idf) == shipped
    assert Path(config.building).resolve() == model.resolve()
