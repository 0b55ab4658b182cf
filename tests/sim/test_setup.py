"""prepare(): the one set-up path of every run."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import hvacflex
from hvacflex.building.io import load_building
from hvacflex.config import BASELINE_PRESETS, preset
from hvacflex.control.baselines import ThermostatController
from hvacflex.control.demand_limit import DemandLimitController
from hvacflex.control.gta_dr import GtaDrController
from hvacflex.control.mpc import MPCController
from hvacflex.control.trim_respond import TrimRespondController
from hvacflex.data.occupancy import early_arrival_gain_disturbances
from hvacflex.errors import ConfigError
from hvacflex.paths import resolve_building
from hvacflex.sim.run import run_simulation
from hvacflex.sim.run_files import run_key
from hvacflex.sim.setup import Setup, make_controller, prepare


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
    # the content, planning with its power model for the scenario's plant (the RC plant's)
    assert setup.building == smaller.with_power_model_for("rc")
    assert setup.building.metered_power is smaller.power_models["rc"]
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
    # the plant sees stochastic gains, the controller the schedule's, its mornings (before
    # 08:00) planned for the first arrival's 5 % quantile (issue 55 item 3 (c))
    assert not np.allclose(
        setup.exogenous.disturbances[:, gains], scheduled.exogenous.disturbances[:, gains]
    )
    forecast = setup.forecaster.forecast(4, 20)
    exo = scheduled.exogenous
    early = early_arrival_gain_disturbances(
        exo.disturbances, exo.channels, exo.index, setup.building.gain_floor_areas_m2,
        setup.building.gains,
    )  # fmt: skip
    np.testing.assert_array_equal(forecast.disturbances[:, gains], early[4:24, gains])
    morning = np.asarray(exo.index[4:24].tz_convert("Asia/Singapore").hour) < 8
    np.testing.assert_array_equal(
        forecast.disturbances[~morning][:, gains], exo.disturbances[4:24][~morning][:, gains]
    )
    assert (
        forecast.disturbances[morning][:, gains] > exo.disturbances[4:24][morning][:, gains]
    ).any()
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


# ------------------------------------------------------------------ the rule-based baselines

BASELINE_CONTROLLERS = {
    "thermostat-25.5": ThermostatController,
    "thermostat-25.5-float": ThermostatController,
    "trim-respond": TrimRespondController,
    "demand-limit": DemandLimitController,
    "gta-dr": GtaDrController,
}


@pytest.mark.parametrize("name", BASELINE_PRESETS)
def test_each_baseline_preset_runs_a_closed_loop_day_in_the_results_schema(
    name: str, tmp_path: Path
) -> None:
    controller = make_controller(prepare(preset(name, start="2014-03-03", days=1)))
    assert type(controller) is BASELINE_CONTROLLERS[name]
    run = hvacflex.simulate(name, start="2014-03-03", days=1, out=tmp_path / name, quiet=True)
    frame = run.frame
    reference = hvacflex.simulate(
        "thermostat", start="2014-03-03", days=0.5, out=tmp_path / "thermostat", quiet=True
    ).frame
    assert list(frame.columns) == list(reference.columns)  # the same results schema
    assert len(frame) == 48 and (frame["solve_status"] == "rule").all()
    assert (frame["power_kw"] > 0).any() and frame["power_kw"].notna().all()
    at_occupancy = frame.loc["2014-03-03 07:30"].filter(like="temp_end_").astype(float)
    if name == "trim-respond":
        # the T&R loop responds a period late: the sunlit east zone misses the start of
        # occupancy (so its optimal start learns a longer lead), the day keeps the band
        assert run.summary["violation_share"] < 0.1
        assert run.summary["discomfort_kelvin_hours"] < 3.0
    else:
        # optimal start: every zone inside the occupied band when occupancy starts at 08:00
        assert (at_occupancy <= 26.0 + 0.05).all()
        assert run.summary["discomfort_kelvin_hours"] < 0.05
    offers = frame["reserve_kw"] > 0
    assert offers.any() == (name == "gta-dr")


def test_gta_dr_curtails_its_offer_when_activated(tmp_path: Path) -> None:
    events = tmp_path / "events.csv"
    events.write_text("time,activated\n2014-03-03T14:00,1\n2014-03-03T14:30,1\n")
    run = hvacflex.simulate(
        "gta-dr",
        start="2014-03-03",
        days=1,
        out=tmp_path / "gta",
        quiet=True,
        activation={"mode": "file", "file": str(events)},
    )
    frame = run.frame
    curtailed = frame[frame["il_curtailed"]]
    assert len(curtailed) == 2
    # the plant ran u − r: less power than the served counterfactual, a real reduction
    assert (curtailed["power_kw"] < curtailed["power_served_kw"] - 0.1).all()
    reserve_flow = curtailed.filter(like="reserve_flow_").sum(axis=1)
    assert (reserve_flow > 0).all()
    # the allowance α is in force during the event and decays over its recovery (issue 25:
    # α·min(1, c/(R+1)) with c the recovery periods left)
    window = frame.loc[frame["il_event_window"], "il_allowance_k"]
    assert (window.loc[curtailed.index] == 1.0).all()
    after = window.drop(curtailed.index)
    assert (after > 0).all() and (after <= 1.0).all() and after.is_monotonic_decreasing
    # the raised setpoints use the allowance, and stay inside it (issue 25: event discomfort
    # is measured against the normal band, the part within α reported apart)
    assert run.summary["discomfort_event_beyond_allowance_kelvin_hours"] < 0.05


@pytest.mark.parametrize("name", BASELINE_PRESETS)
def test_a_baseline_run_resumed_from_its_checkpoint_is_identical(name: str, tmp_path: Path) -> None:
    cfg = preset(name, start="2014-03-03", days=1.5)  # the learned state crosses a day
    whole = run_simulation(cfg, tmp_path / "whole", progress=False).frame
    run_simulation(
        cfg, tmp_path / "split", progress=False, checkpoint_every=24, stop_after_steps=50
    )
    second = run_simulation(cfg, tmp_path / "split", progress=False, checkpoint_every=24)
    assert second.resumed_from_step == 50
    pd.testing.assert_frame_equal(whole, second.frame)


def test_occupancy_seed_draws_the_occupants_alone() -> None:
    def setup_with(**realisation: object) -> Setup:
        return prepare(
            preset(
                "rmpc",
                start="2014-03-03",
                days=0.5,
                realisation={"occupancy": "stochastic", "mode": "zero", **realisation},
            )
        )

    default, other = setup_with(), setup_with(occupancy_seed=3)
    same = setup_with(occupancy_seed=preset("rmpc").seed)
    gains = list(np.atleast_1d(default.exogenous.channel_index("internal_gain")))
    d_default, d_other = default.exogenous.disturbances, other.exogenous.disturbances
    # unset = the scenario's seed; another seed moves the occupants and nothing else
    np.testing.assert_array_equal(same.exogenous.disturbances, d_default)
    assert not np.allclose(d_other[:, gains], d_default[:, gains])
    rest = [i for i in range(d_default.shape[1]) if i not in gains]
    np.testing.assert_array_equal(d_other[:, rest], d_default[:, rest])
    np.testing.assert_array_equal(
        other.exogenous.reserve_price_sgd_per_mwh, default.exogenous.reserve_price_sgd_per_mwh
    )


def test_the_scenario_picks_the_power_model_of_its_plant_or_the_design_curves() -> None:
    building = load_building(resolve_building("office5"))
    assert set(building.power_models) == {"rc", "energyplus"}  # office5 ships both
    metered = prepare(preset("rmpc", start="2014-03-03", days=0.25))
    assert metered.building.metered_power == building.power_models["rc"]
    design = prepare(preset("rmpc", start="2014-03-03", days=0.25, power_model="design"))
    assert design.building.metered_power is None
