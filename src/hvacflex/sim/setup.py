"""One set-up path: a scenario's building, data, model, forecaster, box and controller.

:func:`prepare` is the only way a run is set up — by ``hvacflex simulate``, the service
(a building received as content) and each building agent of a fleet — so every driver of
:class:`hvacflex.sim.step.ControlStep` plans from the same parts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hvacflex.building.discretize import LinearModel, linearize
from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.config import LINEARISATION_MARGIN_K, ScenarioConfig
from hvacflex.control.base import Controller
from hvacflex.control.baselines import OptimalStart, ThermostatController
from hvacflex.control.demand_limit import DemandLimitController
from hvacflex.control.gta_dr import GtaDrController
from hvacflex.control.mpc import MPCController
from hvacflex.control.trim_respond import TrimRespondController
from hvacflex.data.forecast import Exogenous, Forecaster, load_exogenous
from hvacflex.data.gains import ComfortBand
from hvacflex.data.market import RESERVE_PRICE_SCALE
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.paths import resolve_building
from hvacflex.sim.activation import activation_schedule
from hvacflex.sim.measurement import kalman_config


@dataclass(frozen=True)
class Setup:
    """Everything a run needs, built from its configuration."""

    config: ScenarioConfig
    building: Building
    model: LinearModel
    plant: NonlinearPlant
    exogenous: Exogenous
    forecaster: Forecaster
    box: UncertaintyBox
    activation: np.ndarray
    linearisation_temp_degc: float

    @property
    def zone_names(self) -> tuple[str, ...]:
        return tuple(self.building.zone_names)


def prepare(config: ScenarioConfig, building: Building | None = None) -> Setup:
    """Load the building and data and build the linear model for ``config`` (``building``:
    a description received as content, e.g. by the service, instead of ``config.building``)."""
    if building is None:
        building = load_building(resolve_building(config.building))
    temp_ref = config.controller.linearisation_temp_degc
    if temp_ref is None:
        temp_ref = config.comfort.occupied_degc[1] - LINEARISATION_MARGIN_K
    model = linearize(building, dt_s=config.dt_s, linearisation_temp_degc=temp_ref)
    data = config.data
    scale = RESERVE_PRICE_SCALE if data.reserve_price_scale is None else data.reserve_price_scale
    exogenous = load_exogenous(
        model.channels,
        [zone.floor_area_m2 for zone in building.zones],
        building.gains,
        start=config.start_timestamp,
        steps=config.steps,
        horizon_steps=config.controller.horizon_steps,
        weather_file=data.weather_file,
        usep_source=data.usep_source,
        reserve_source=data.reserve_source,
        price_gap_fill=data.price_gap_fill,
        comfort=ComfortBand(config.comfort.occupied_degc, config.comfort.unoccupied_degc),
        seed=config.seed,
        reserve_scale_sgd_per_mwh=scale,
    )
    activation = activation_schedule(
        config.activation,
        exogenous.index[: config.steps],
        seed=config.seed,
        max_steps=config.activation_max_steps,
    )
    return assemble_setup(config, building, model, exogenous, activation, temp_ref)


def assemble_setup(
    config: ScenarioConfig,
    building: Building,
    model: LinearModel,
    exogenous: Exogenous,
    activation: np.ndarray,
    linearisation_temp_degc: float,
) -> Setup:
    """The :class:`Setup` of loaded parts: adds the plant, forecaster and uncertainty box.
    ``activation`` (steps,) bool: the IL activation schedule."""
    box = UncertaintyBox(
        relative=dict(config.uncertainty.relative), absolute=dict(config.uncertainty.absolute)
    )
    return Setup(
        config=config,
        building=building,
        model=model,
        plant=NonlinearPlant(building),
        exogenous=exogenous,
        forecaster=Forecaster(exogenous),
        box=box,
        activation=activation,
        linearisation_temp_degc=linearisation_temp_degc,
    )


def make_controller(setup: Setup) -> Controller:
    """The controller the configuration asks for (``[controller] kind``; the rule-based
    baselines are described in docs/baselines.md)."""
    cfg = setup.config.controller
    if cfg.kind != "mpc":
        return make_rule_controller(setup)
    return MPCController(
        setup.building,
        setup.model,
        cfg,
        setup.box,
        setup.linearisation_temp_degc,
        reserve=setup.config.reserve,
        estimation=kalman_config(setup.config),
        linearisation=cfg.linearisation,
    )


def make_rule_controller(setup: Setup) -> Controller:
    """The rule-based controller of ``[controller] kind`` (not ``"mpc"``)."""
    config = setup.config
    cfg, model, hvac = config.controller, setup.model, setup.building.hvac
    setpoint = cfg.thermostat_setpoint_degc
    start = OptimalStart() if cfg.optimal_start else None
    if cfg.kind == "trim-respond":
        plant = config.plant
        accepts_supply_temp = plant.kind != "rc" and plant.resolved_actuation == "flow"
        return TrimRespondController(
            model, hvac, setpoint, start, reset_supply_temp=accepts_supply_temp
        )
    if cfg.kind == "demand-limit":
        return DemandLimitController(model, hvac, setpoint, start, cfg.demand_limit_fraction)
    if cfg.kind == "gta-dr":
        reserve = config.reserve
        assert reserve.event_max_steps is not None  # the schema requires the event model
        return GtaDrController(
            model,
            hvac,
            setpoint,
            start,
            reserve_share=cfg.reserve_share if cfg.reserve else 0.0,
            raise_k=reserve.event_allowance_k,
            event_steps=reserve.event_max_steps,
            recovery_steps=reserve.event_recovery_steps,
        )
    return ThermostatController(model, hvac, setpoint, start)
