"""prepare(): the one set-up path of every run."""

from __future__ import annotations

import dataclasses

import numpy as np

from hvacflex.building.io import load_building
from hvacflex.config import preset
from hvacflex.control.baselines import ThermostatController
from hvacflex.control.mpc import MPCController
from hvacflex.paths import resolve_building
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
