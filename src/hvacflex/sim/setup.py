"""One set-up path: a scenario's building, data, model, forecaster, box and controller.

:func:`prepare` is the only way a run is set up — by ``hvacflex simulate``, the service
(a building received as content) and each building agent of a fleet — so every driver of
:class:`hvacflex.sim.step.ControlStep` plans from the same parts.

What the plant sees and what the controller is told are built here (docs/explanation/forecast.md):
the data (``Setup.exogenous``: the weather file, and the gains of the schedule or, with
``[realisation] occupancy = "stochastic"``, of the stochastic occupancy model), and the
``Forecaster`` (the data, or with ``[forecast] weather = "statistical"`` a weather forecast
fitted on the days before the run, and always the schedule's gains). With ``[uncertainty]
calibrate`` the box is sized from a training period's errors (:func:`calibrated_box`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.building.discretize import LinearModel, linearize
from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.config import LINEARISATION_MARGIN_K, ScenarioConfig
from hvacflex.constants import PERIODS_PER_DAY
from hvacflex.control.base import Controller
from hvacflex.control.baselines import (
    OptimalStart,
    PlantBaselineController,
    ThermostatController,
)
from hvacflex.control.demand_limit import DemandLimitController
from hvacflex.control.gta_dr import GtaDrController
from hvacflex.control.mpc import MPCController
from hvacflex.control.trim_respond import TrimRespondController
from hvacflex.data.calibration import Calibration, calibrate_box, forecast_errors
from hvacflex.data.forecast import Exogenous, Forecaster, default_weather_file, load_exogenous
from hvacflex.data.gains import DEFAULT_OFFICE_SCHEDULE, ComfortBand, OfficeSchedule
from hvacflex.data.market import (
    RESERVE_PRICE_SCALE,
)
from hvacflex.data.occupancy import early_arrival_gain_disturbances, stochastic_gain_disturbances
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.data.weather_forecast import fit_weather_forecaster
from hvacflex.errors import ConfigError
from hvacflex.paths import resolve_building
from hvacflex.results import PREDICTION_ERROR, read_results
from hvacflex.sim.activation import activation_schedule
from hvacflex.sim.measurement import kalman_config
from hvacflex.sim.run_files import check_linearisation


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
    realisation_box: UncertaintyBox | None = None
    """The box the realised error w is drawn in; None: ``box``."""
    calibration: Calibration | None = None
    """The calibration behind ``box`` (``[uncertainty] calibrate``), or None."""

    @property
    def sampling_box(self) -> UncertaintyBox:
        """The box w is drawn in (``realisation_box``, else ``box``)."""
        return self.box if self.realisation_box is None else self.realisation_box

    @property
    def zone_names(self) -> tuple[str, ...]:
        return tuple(self.building.zone_names)


def prepare(
    config: ScenarioConfig,
    building: Building | None = None,
    *,
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
    market_seed: int | None = None,
) -> Setup:
    """Load the building and data and build the linear model for ``config``.

    Parameters
    ----------
    config : the scenario.
    building : a description received as content (the service, a fleet file) instead of
        ``config.building``.
    schedule : the occupancy schedule of the internal gains and comfort band (a fleet shifts
        each building's hours).
    market_seed : seed of the synthetic reserve prices (None: ``config.seed``); a fleet's
        buildings share one market.
    """
    if building is None:
        building = load_building(resolve_building(config.building))
    if config.controller.power_model == "metered":  # fitted to this plant's meter, if any
        building = building.with_power_model_for(config.plant.kind)
    check_linearisation(config, building=building)
    temp_ref = config.controller.linearisation_temp_degc
    if temp_ref is None:
        temp_ref = config.comfort.occupied_degc[1] - LINEARISATION_MARGIN_K
    model = linearize(building, dt_s=config.dt_s, linearisation_temp_degc=temp_ref)
    exogenous = _load_exogenous(
        config,
        building,
        model,
        config.start_timestamp,
        config.steps,
        schedule=schedule,
        market_seed=market_seed,
    )
    activation = activation_schedule(
        config.activation,
        exogenous.index[: config.steps],
        seed=config.seed,
        max_steps=config.activation_max_steps,
    )
    calibration = calibrated_box(config, building, model)
    return assemble_setup(
        config, building, model, exogenous, activation, temp_ref, calibration=calibration
    )


def _load_exogenous(
    config: ScenarioConfig,
    building: Building,
    model: LinearModel,
    start: pd.Timestamp,
    steps: int,
    *,
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
    market_seed: int | None = None,
) -> Exogenous:
    """The scenario's data (scheduled gains) over ``steps`` periods from ``start`` and the
    horizon after them (``schedule``, ``market_seed``: see :func:`prepare`)."""
    data = config.data
    scale = RESERVE_PRICE_SCALE if data.reserve_price_scale is None else data.reserve_price_scale
    return load_exogenous(
        model.channels,
        building.gain_floor_areas_m2,
        building.gains,
        start=start,
        steps=steps,
        horizon_steps=config.controller.horizon_steps,
        weather_file=data.weather_file,
        usep_source=data.usep_source,
        reserve_source=data.reserve_source,
        price_gap_fill=data.price_gap_fill,
        calendar=data.calendar,
        comfort=ComfortBand(config.comfort.occupied_degc, config.comfort.unoccupied_degc),
        seed=config.seed if market_seed is None else market_seed,
        schedule=schedule,
        reserve_scale_sgd_per_mwh=scale,
        reserve_correlation=data.reserve_price_correlation,
    )


def realised_exogenous(
    config: ScenarioConfig, building: Building, scheduled: Exogenous
) -> Exogenous:
    """What the plant sees: ``scheduled`` itself, or with ``[realisation] occupancy =
    "stochastic"`` its internal gains drawn by the occupancy model (seed: ``[realisation]
    occupancy_seed``, else the scenario's)."""
    if config.realisation.occupancy == "schedule":
        return scheduled
    seed = config.realisation.occupancy_seed
    disturbances = stochastic_gain_disturbances(
        scheduled.disturbances,
        scheduled.channels,
        scheduled.index,
        building.gain_floor_areas_m2,
        building.gains,
        seed=config.seed if seed is None else seed,
    )
    return replace(scheduled, disturbances=disturbances)


def make_forecaster(
    config: ScenarioConfig, truth: Exogenous, scheduled: Exogenous, building: Building
) -> Forecaster:
    """The controller's forecaster over the data ``truth``: its weather from the file or the
    statistical forecaster fitted on the ``[forecast] train_days`` days before the data, its
    gains those of ``scheduled`` — where the plant sees stochastic occupancy, with the
    mornings planned for the first arrival's 5 % quantile
    (:func:`hvacflex.data.occupancy.early_arrival_gain_disturbances`)."""
    weather = None
    if config.forecast.weather == "statistical":
        weather = fit_weather_forecaster(
            truth.channels,
            truth.index[0],
            train_days=config.forecast.train_days,
            weather_file=config.data.weather_file or default_weather_file(),
        )
    expected = None
    if truth is not scheduled:
        expected = early_arrival_gain_disturbances(
            scheduled.disturbances,
            scheduled.channels,
            scheduled.index,
            building.gain_floor_areas_m2,
            building.gains,
        )
    return Forecaster(truth, weather=weather, expected_disturbances=expected)


def calibrated_box(
    config: ScenarioConfig, building: Building, model: LinearModel
) -> Calibration | None:
    """The box of ``[uncertainty] calibrate``, or None: the scenario's forecaster and plant
    data rebuilt on the training days, the errors of every forecast made there (every lead
    of the horizon), and the model-error term from the ``prediction_errors`` results file."""
    spec = config.uncertainty.calibrate
    if spec is None:
        return None
    first, last = spec.train_days
    steps = ((last - first).days + 1) * PERIODS_PER_DAY
    scheduled = _load_exogenous(config, building, model, first, steps)
    truth = realised_exogenous(config, building, scheduled)
    forecaster = make_forecaster(config, truth, scheduled, building)
    horizon = config.controller.horizon_steps
    errors, forecasts = forecast_errors(forecaster, truth.disturbances, range(steps), horizon)
    prediction = None
    if spec.prediction_errors is not None:
        prediction = _training_prediction_errors(
            spec.prediction_errors, building.zone_names, first, last
        )
    return calibrate_box(
        errors, forecasts, model.channels, spec.quantile, prediction_error_k=prediction
    )


def _training_prediction_errors(
    path: str, zones: tuple[str, ...] | list[str], first: pd.Timestamp, last: pd.Timestamp
) -> dict[str, np.ndarray]:
    """zone → one-step prediction errors [K] of the results file's rows on the training days."""
    if not Path(path).is_file():
        raise ConfigError(
            "no such results file",
            field="uncertainty.calibrate.prediction_errors",
            value=path,
            hint="simulate the training days first and give that run's results.parquet "
            "(a path relative to the working directory)",
        )
    frame, _ = read_results(path)
    rows = frame[(frame.index >= first) & (frame.index < last + pd.Timedelta(days=1))]
    columns = [PREDICTION_ERROR.name(zone) for zone in zones]
    missing = [c for c in columns if c not in rows.columns]
    if rows.empty or missing:
        raise ConfigError(
            "the results file has no one-step prediction errors on the training days",
            source=path,
            field="uncertainty.calibrate.prediction_errors",
            value=missing or f"{first:%Y-%m-%d}..{last:%Y-%m-%d}",
            hint="simulate the training days with this building first and give that run's "
            "results.parquet",
        )
    return {zone: rows[c].to_numpy(dtype=float) for zone, c in zip(zones, columns, strict=True)}


def assemble_setup(
    config: ScenarioConfig,
    building: Building,
    model: LinearModel,
    exogenous: Exogenous,
    activation: np.ndarray,
    linearisation_temp_degc: float,
    *,
    calibration: Calibration | None = None,
) -> Setup:
    """The :class:`Setup` of loaded parts: adds the plant's data, the forecaster and the
    uncertainty boxes. ``exogenous``: the data with the scheduled gains; ``activation``
    (steps,) bool: the IL activation schedule; ``calibration``: a calibrated box replacing
    the scenario's ``relative``/``absolute``."""
    box = UncertaintyBox(
        relative=dict(config.uncertainty.relative), absolute=dict(config.uncertainty.absolute)
    )
    if calibration is not None:
        box = calibration.box
    realisation = config.realisation
    realisation_box = None
    if realisation.box_relative is not None or realisation.box_absolute is not None:
        realisation_box = UncertaintyBox(
            relative=dict(realisation.box_relative or {}),
            absolute=dict(realisation.box_absolute or {}),
        )
    truth = realised_exogenous(config, building, exogenous)
    return Setup(
        config=config,
        building=building,
        model=model,
        plant=NonlinearPlant(building),
        exogenous=truth,
        forecaster=make_forecaster(config, truth, exogenous, building),
        box=box,
        activation=activation,
        linearisation_temp_degc=linearisation_temp_degc,
        realisation_box=realisation_box,
        calibration=calibration,
    )


def make_controller(setup: Setup) -> Controller:
    """The controller the configuration asks for (``[controller] kind``; the rule-based
    baselines are described in docs/explanation/baselines.md)."""
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
        model_error_k=_model_error_k(setup),
    )


def _model_error_k(setup: Setup) -> np.ndarray | None:
    """(m,) calibrated one-step model error per zone [K per step], or None."""
    calibration = setup.calibration
    if calibration is None or not calibration.model_error_k:
        return None
    return np.array([calibration.model_error_k.get(z, 0.0) for z in setup.zone_names])


def make_rule_controller(setup: Setup) -> Controller:
    """The rule-based controller of ``[controller] kind`` (not ``"mpc"``)."""
    config = setup.config
    cfg, model, hvac = config.controller, setup.model, setup.building.hvac
    setpoint = cfg.thermostat_setpoint_degc
    start = OptimalStart() if cfg.optimal_start else None
    margin = cfg.unoccupied_margin_k
    if cfg.kind == "trim-respond":
        plant = config.plant
        accepts_supply_temp = plant.kind != "rc" and plant.resolved_actuation == "flow"
        return TrimRespondController(
            model,
            hvac,
            setpoint,
            start,
            reset_supply_temp=accepts_supply_temp,
            unoccupied_margin_k=margin,
        )
    if cfg.kind == "demand-limit":
        return DemandLimitController(
            model, hvac, setpoint, start, cfg.demand_limit_fraction, unoccupied_margin_k=margin
        )
    if cfg.kind == "plant":
        return PlantBaselineController(model)
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
            unoccupied_margin_k=margin,
        )
    return ThermostatController(model, hvac, setpoint, start, unoccupied_margin_k=margin)
