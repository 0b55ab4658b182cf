"""prepare(): the one set-up path of every run."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from hvacflex.building.io import load_building
from hvacflex.config import preset
from hvacflex.control.baselines import ThermostatController
from hvacflex.control.mpc import MPCController
from hvacflex.errors import ConfigError
from hvacflex.paths import resolve_building
from hvacflex.sim.run_files import run_key
from hvacflex.sim.setup import make_controller, prepare


def test_prepare_covers_the_run_and_its_last_horizon() -> None:
    cfg = preset("rmpc", start="2014-03-03", days=0.5)
    setup = prepare(cfg)
    horizon = cfg.controller.horizon_steps
    assert setup.exogenous.steps >= cfg.steps + horizon
    last = setup.forecaster.forecast(cfg.steps - 1, horizon + 1)  # the loop's last forecast
    assert last.horizon == horizon + 1
    assert setup.activation.shape == (cfg.steps,)
    assert setup.zone_names == tuple(setup.building.zone_names)
    # the default linearisation point is the occupied upper bound less the margin
    assert setup.linearisation_temp_degc < cfg.comfort.occupied_degc[1]
    assert isinstance(make_controller(setup), MPCController)
    assert isinstance(make_controller(prepare(preset("thermostat"))), ThermostatController)


def test_a_building_given_as_content_replaces_the_file() -> None:
    cfg = preset("rmpc", start="2014-03-03", days=0.25)
    building = load_building(resolve_building(cfg.building))
    smaller = dataclasses.replace(
        building,
        zones=tuple(
            dataclasses.replace(z, floor_area_m2=0.5 * z.floor_area_m2) for z in building.zones
        ),
    )
    setup = prepare(cfg, smaller)
    assert setup.building is smaller
    gains = setup.exogenous.channel_index("internal_gain")
    full = prepare(cfg).exogenous.disturbances[:, gains]
    np.testing.assert_allclose(setup.exogenous.disturbances[:, gains], 0.5 * full)


def test_realistic_forecast_and_stochastic_occupancy() -> None:
    cfg = preset(
        "rmpc",
        start="2014-03-03",
        days=0.5,
        forecast={"weather": "statistical", "train_days": 7},
        realisation={"occupancy": "stochastic", "mode": "zero"},
    )
    setup = prepare(cfg)
    scheduled = prepare(preset("rmpc", start="2014-03-03", days=0.5))
    gains = setup.exogenous.channel_index("internal_gain")
    outdoor = setup.exogenous.channel_index("outdoor_temp")
    # the plant sees stochastic gains, the controller the schedule's
    assert not np.allclose(
        setup.exogenous.disturbances[:, gains], scheduled.exogenous.disturbances[:, gains]
    )
    forecast = setup.forecaster.forecast(4, 20)
    np.testing.assert_array_equal(
        forecast.disturbances[:, gains], scheduled.exogenous.disturbances[4:24, gains]
    )
    # the weather of the plant is the file's; the controller's is a forecast of it
    np.testing.assert_array_equal(
        setup.exogenous.disturbances[:, outdoor], scheduled.exogenous.disturbances[:, outdoor]
    )
    assert not np.allclose(
        forecast.disturbances[:, outdoor], setup.exogenous.disturbances[4:24, outdoor]
    )
    assert (
        prepare(cfg).exogenous.disturbances[:, gains].tolist()
        == setup.exogenous.disturbances[:, gains].tolist()
    )


def test_calibrated_box_replaces_the_scenario_box_and_stress_box_is_separate() -> None:
    cfg = preset(
        "rmpc",
        start="2014-03-10",
        days=0.25,
        forecast={"weather": "statistical", "train_days": 7},
        uncertainty={"calibrate": {"train": "2014-03-03..2014-03-04", "quantile": 0.9}},
        realisation={"mode": "ar1", "box_relative": {"internal_gain": 0.3}},
    )
    setup = prepare(cfg)
    assert setup.calibration is not None and setup.box is setup.calibration.box
    assert setup.calibration.samples == 2 * 48 * cfg.controller.horizon_steps
    outdoor_name = setup.model.channels[setup.exogenous.channel_index("outdoor_temp")[0]].name
    assert setup.box.channel_absolute[outdoor_name] > 0.0
    assert setup.sampling_box.relative == {"internal_gain": 0.3}
    assert not setup.calibration.model_error_k  # no results file given


def test_the_training_results_file_enters_the_run_key(tmp_path: Path) -> None:
    errors = tmp_path / "train.parquet"
    errors.write_bytes(b"first")
    calibrate = {"train": "2014-02-24..2014-02-28", "prediction_errors": str(errors)}
    cfg = preset("rmpc", start="2014-03-03", days=1, uncertainty={"calibrate": calibrate})
    before = run_key(cfg)
    errors.write_bytes(b"second")
    assert run_key(cfg) != before


def test_a_missing_training_results_file_is_a_config_error() -> None:
    calibrate = {"train": "2014-02-24..2014-02-25", "prediction_errors": "no/such.parquet"}
    cfg = preset("rmpc", start="2014-03-03", days=0.25, uncertainty={"calibrate": calibrate})
    with pytest.raises(ConfigError, match="prediction_errors"):
        prepare(cfg)
