"""Receding-horizon closed-loop simulation against the nonlinear building plant.

Every 30 minutes (docs/model.md §4): forecast → controller (MPC solve or rule) → the first step
is applied to the exact nonlinear plant under the realised disturbance d̂ + w (w drawn in
the uncertainty box) → measure → repeat. When interruptible load is activated the plant runs
u − r: under the event model the locked plan of the event's first period for at most D
periods, under the whole-horizon model each period's fresh plan (:mod:`hvacflex.sim.events`).
The reserve capacity scheduled is paid whether activated or not; delivery is settled in
:mod:`hvacflex.kpi`.

Each row of the output (``results.parquet``, schema in ``docs/architecture.md``) describes one
period. Both counterfactual plant steps are computed each period (served: u, curtailed: u − r)
so the power with and without activation is known; the applied one is chosen by the
activation schedule.

A run checkpoints every ``checkpoint_every`` steps and on interruption (Ctrl-C): the plant
state, the step index, the sampler's and sensors' RNG states, the controller's state (LP
basis, previous plan, filter) and the rows so far. Started again with the same
configuration, it resumes from the checkpoint and ends with results identical to an
uninterrupted run.
"""

from __future__ import annotations

import json
import pickle
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd

from hvacflex import version
from hvacflex.building.discretize import LinearModel, linearize
from hvacflex.building.hvac import hvac_power_kw
from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.config import LINEARISATION_MARGIN_K, ScenarioConfig
from hvacflex.control.base import Action, Controller, FloatArray
from hvacflex.control.baselines import ThermostatController
from hvacflex.control.mpc import MPCController
from hvacflex.data.forecast import Exogenous, Forecaster, load_exogenous
from hvacflex.data.gains import ComfortBand
from hvacflex.data.market import RESERVE_PRICE_SCALE
from hvacflex.data.uncertainty import DisturbanceSampler, UncertaintyBox
from hvacflex.errors import ConfigError, HvacflexError
from hvacflex.paths import resolve_building
from hvacflex.sim.activation import activation_schedule
from hvacflex.sim.events import EventTracker, PeriodOutcome, Role
from hvacflex.sim.measurement import Sensors, kalman_config
from hvacflex.sim.progress import progress_bar
from hvacflex.sim.run_files import CHECKPOINT_FILE as CHECKPOINT_FILE
from hvacflex.sim.run_files import CONFIG_FILE as CONFIG_FILE
from hvacflex.sim.run_files import RESULTS_FILE as RESULTS_FILE
from hvacflex.sim.run_files import SUMMARY_FILE as SUMMARY_FILE
from hvacflex.sim.run_files import check_checkpoint_code as check_checkpoint_code
from hvacflex.sim.run_files import load_checkpoint as load_checkpoint
from hvacflex.sim.run_files import read_results as read_results
from hvacflex.sim.run_files import read_summary as read_summary
from hvacflex.sim.run_files import run_key as run_key
from hvacflex.sim.run_files import write_results as write_results
from hvacflex.version import atomic_write_bytes, atomic_write_text

DEFAULT_CHECKPOINT_EVERY = 336
"""Steps between checkpoints (one week of 30-min periods)."""

ProgressCallback = Callable[[int, int], None]
PowerFunction = Callable[[int, FloatArray, FloatArray, float, float], float]
"""(step, flow_kg_s (m,), mean zone temperature (m,) [°C], outdoor temp [°C], humidity
ratio [kg/kg]) → electric power [kW]."""


class Plant(Protocol):
    """Anything that advances the node temperatures over one period."""

    def step(
        self, x_degc: FloatArray, flow_kg_s: FloatArray, d: FloatArray, dt_s: float = ...
    ) -> FloatArray: ...


@dataclass(frozen=True)
class RunResult:
    """A finished closed-loop run.

    Attributes
    ----------
    out_dir : the run's folder (results, summary, config).
    frame : one row per period (schema in ``docs/architecture.md``).
    summary : KPIs (see :mod:`hvacflex.kpi`).
    resumed_from_step : the checkpoint step the run resumed from, or None.
    cached : True when the results were already there and nothing was simulated.
    """

    out_dir: Path
    frame: pd.DataFrame
    summary: dict[str, float]
    resumed_from_step: int | None = None
    cached: bool = False

    @property
    def results_path(self) -> Path:
        return self.out_dir / RESULTS_FILE

    @property
    def results(self) -> pd.DataFrame:
        """The results table, ``frame`` (one row per period; ``docs/architecture.md``)."""
        return self.frame


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
    """The controller the configuration asks for."""
    cfg = setup.config.controller
    hvac = setup.building.hvac
    if cfg.kind == "thermostat":
        return ThermostatController(setup.model, hvac, cfg.thermostat_setpoint_degc)
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


class _Recorder:
    """Preallocated per-step columns (cheap to fill, to checkpoint and to turn into a frame)."""

    FLAG_COLUMNS: tuple[str, ...] = (
        "il_activated",
        "il_curtailed",
        "il_beyond_model",
        "il_event_window",
        "fallback",
    )

    def __init__(self, steps: int, zones: tuple[str, ...], channels: tuple[str, ...]) -> None:
        self.float_columns = [
            "energy_price_sgd_per_mwh",
            "reserve_price_sgd_per_mwh",
            "peak_price_sgd_per_kw",
            "power_kw",
            "power_served_kw",
            "power_curtailed_kw",
            "planned_power_kw",
            "reserve_kw",
            "solve_time_s",
            "planned_slack_max_k",
            "delta_max_k",
            "il_allowance_k",
            "il_reference_power_kw",
            "il_penalty_price_sgd_per_mwh",
        ]
        for zone in zones:
            self.float_columns += [
                f"flow_{zone}_kg_s",
                f"reserve_flow_{zone}_kg_s",
                f"temp_{zone}_degc",
                f"temp_end_{zone}_degc",
                f"temp_served_{zone}_degc",
                f"temp_curtailed_{zone}_degc",
                f"event_worst_{zone}_degc",
                f"comfort_lower_{zone}_degc",
                f"comfort_upper_{zone}_degc",
                f"prediction_error_{zone}_k",
            ]
        self.float_columns += [f"d_{c}" for c in channels] + [f"w_{c}" for c in channels]
        self.column_index = {name: i for i, name in enumerate(self.float_columns)}
        self.values = np.full((steps, len(self.float_columns)), np.nan)
        self.flags = {name: np.zeros(steps, dtype=bool) for name in self.FLAG_COLUMNS}
        self.status = np.empty(steps, dtype=object)

    def frame(self, index: pd.DatetimeIndex, steps_done: int) -> pd.DataFrame:
        frame = pd.DataFrame(
            self.values[:steps_done], index=index[:steps_done], columns=self.float_columns
        )
        for name, flags in self.flags.items():
            frame[name] = flags[:steps_done]
        frame["solve_status"] = pd.Series(
            self.status[:steps_done], index=frame.index, dtype="string"
        )
        frame.index.name = "time"
        return frame


class ClosedLoop:
    """A closed-loop run that can be advanced, checkpointed and resumed.

    Most users call :func:`run_simulation`; this class is the stepping engine behind it.
    """

    def __init__(
        self,
        setup: Setup,
        controller: Controller | None = None,
        *,
        plant: Plant | None = None,
        power_fn: PowerFunction | None = None,
    ) -> None:
        """``plant`` and ``power_fn`` replace the nonlinear plant and the exact HVAC power
        (e.g. by the controller's own linear model, to test the loop in isolation)."""
        self.setup = setup
        self.controller = controller if controller is not None else make_controller(setup)
        self.plant: Plant = plant if plant is not None else setup.plant
        self.power_fn: PowerFunction = power_fn if power_fn is not None else self._exact_power
        cfg = setup.config
        self.steps = cfg.steps
        self.k = 0
        self.x = np.full(len(setup.model.node_names), cfg.initial_temp_degc)
        self.sampler = DisturbanceSampler(
            cfg.realisation.mode, seed=cfg.seed, ar1_coefficient=cfg.realisation.ar1_coefficient
        )
        self.month_peak_kw = 0.0
        self.month = -1
        channel_names = tuple(ch.name for ch in setup.model.channels)
        self.recorder = _Recorder(self.steps, setup.zone_names, channel_names)
        self._zone_rows = setup.model.c.argmax(axis=1)
        self._outdoor = next(
            i for i, ch in enumerate(setup.model.channels) if ch.kind == "outdoor_temp"
        )
        self.timing_s = {"controller": 0.0, "plant": 0.0, "record": 0.0}
        self.sensors = Sensors(cfg, setup.model.c, self.controller)
        reserve = cfg.reserve
        events = reserve.event_max_steps is not None
        self.events = EventTracker(
            reserve.event_max_steps,
            reserve.event_recovery_steps if events else 0,
            reserve.event_allowance_k if events else 0.0,
        )

    # -- one period -------------------------------------------------------------------
    def step(self) -> None:
        """Simulate period ``k`` and advance."""
        setup, k = self.setup, self.k
        exo = setup.exogenous
        month = exo.index[k].month
        if month != self.month:
            self.month, self.month_peak_kw = month, 0.0
        t0 = time.perf_counter()
        # one period beyond the horizon: the band at the end of the last planned period
        forecast = setup.forecaster.forecast(k, setup.config.controller.horizon_steps + 1)
        activated = bool(setup.activation[k])
        role = self.events.role(activated)
        if role is Role.EVENT_LOCKED:
            action = self.events.locked_action()
            self.sensors.hold(self.x, forecast, action.flow_kg_s - action.reserve_flow_kg_s)
        else:
            action = self.sensors.act(
                self.controller,
                self.x,
                forecast,
                peak_floor_kw=self.month_peak_kw,
                allowance_carry_steps=self.events.carry_steps,
            )
        if role is Role.EVENT_START:
            self.events.lock(action.event_plan)
        outcome = self.events.finish(role, action)
        t1 = time.perf_counter()

        d_hat = exo.disturbances[k]
        sigma = setup.box.sigma(d_hat[None, :], setup.model.channels)[0]
        w = self.sampler.sample(sigma)
        d_real = d_hat + w
        t_out = d_real[self._outdoor]
        humidity = float(exo.outdoor_humidity_ratio_kg_per_kg[k])

        served_flow = action.flow_kg_s
        curtailed_flow = action.flow_kg_s - action.reserve_flow_kg_s
        x_served = self.plant.step(self.x, served_flow, d_real, setup.config.dt_s)
        zone_start = self.x[self._zone_rows]
        mean_served = 0.5 * (zone_start + x_served[self._zone_rows])
        power_served = self.power_fn(k, served_flow, mean_served, t_out, humidity)
        if np.any(action.reserve_flow_kg_s > 0):
            x_curtailed = self.plant.step(self.x, curtailed_flow, d_real, setup.config.dt_s)
            mean_curtailed = 0.5 * (zone_start + x_curtailed[self._zone_rows])
            power_curtailed = self.power_fn(k, curtailed_flow, mean_curtailed, t_out, humidity)
        else:  # no reserve offered: activation changes nothing
            x_curtailed, power_curtailed = x_served, power_served
        x_next = x_curtailed if outcome.curtailed else x_served
        power = power_curtailed if outcome.curtailed else power_served
        applied_flow = curtailed_flow if outcome.curtailed else served_flow
        self.sensors.applied(applied_flow)
        error_k = self.sensors.prediction_error_k(setup.model, self.x, applied_flow, d_real, x_next)
        t2 = time.perf_counter()

        self._record(k, action, forecast, d_hat, w, x_next, power, power_served, power_curtailed)
        row, col = self.recorder.values[k], self.recorder.column_index
        for z, zone in enumerate(setup.zone_names):
            row[col[f"prediction_error_{zone}_k"]] = error_k[z]
        self._record_event(k, activated, outcome)
        self.month_peak_kw = max(self.month_peak_kw, power)
        self.x = x_next
        self.k += 1
        t3 = time.perf_counter()
        self.timing_s["controller"] += t1 - t0
        self.timing_s["plant"] += t2 - t1
        self.timing_s["record"] += t3 - t2

    def _exact_power(
        self,
        k: int,
        flow: FloatArray,
        zone_mean_degc: FloatArray,
        outdoor_temp_degc: float,
        humidity: float,
    ) -> float:
        """Plant electric power [kW] at the period's mean zone temperature (exact model)."""
        return float(
            hvac_power_kw(
                self.setup.building.hvac, flow, zone_mean_degc, outdoor_temp_degc, humidity
            )
        )

    def _record_event(self, k: int, activated: bool, outcome: PeriodOutcome) -> None:
        rec, col = self.recorder, self.recorder.column_index
        rec.flags["il_activated"][k] = activated
        rec.flags["il_curtailed"][k] = outcome.curtailed
        rec.flags["il_beyond_model"][k] = outcome.beyond_model
        rec.flags["il_event_window"][k] = outcome.event_window
        rec.values[k, col["il_allowance_k"]] = outcome.allowance_k
        rec.values[k, col["il_reference_power_kw"]] = outcome.reference_power_kw
        penalty = self.setup.config.reserve.non_delivery_penalty_sgd_per_mwh
        rec.values[k, col["il_penalty_price_sgd_per_mwh"]] = penalty

    def _record(
        self,
        k: int,
        action: Action,
        forecast: Any,
        d_hat: FloatArray,
        w: FloatArray,
        x_next: FloatArray,
        power: float,
        power_served: float,
        power_curtailed: float,
    ) -> None:
        rec, col = self.recorder, self.recorder.column_index
        row = rec.values[k]
        exo = self.setup.exogenous
        row[col["energy_price_sgd_per_mwh"]] = exo.energy_price_sgd_per_mwh[k]
        row[col["reserve_price_sgd_per_mwh"]] = exo.reserve_price_sgd_per_mwh[k]
        row[col["peak_price_sgd_per_kw"]] = self.setup.config.controller.peak_price_sgd_per_kw
        row[col["power_kw"]] = power
        row[col["power_served_kw"]] = power_served
        row[col["power_curtailed_kw"]] = power_curtailed
        row[col["planned_power_kw"]] = action.planned_power_kw
        row[col["reserve_kw"]] = action.reserve_kw
        row[col["solve_time_s"]] = action.solve_time_s
        row[col["planned_slack_max_k"]] = action.planned_slack_max_k
        row[col["delta_max_k"]] = action.delta_max_k
        start = self.x[self._zone_rows]
        end = x_next[self._zone_rows]
        for z, zone in enumerate(self.setup.zone_names):
            row[col[f"flow_{zone}_kg_s"]] = action.flow_kg_s[z]
            row[col[f"reserve_flow_{zone}_kg_s"]] = action.reserve_flow_kg_s[z]
            row[col[f"temp_{zone}_degc"]] = start[z]
            row[col[f"temp_end_{zone}_degc"]] = end[z]
            row[col[f"temp_served_{zone}_degc"]] = action.predicted_served_degc[z]
            row[col[f"temp_curtailed_{zone}_degc"]] = action.predicted_curtailed_degc[z]
            if action.predicted_event_worst_degc is not None:
                row[col[f"event_worst_{zone}_degc"]] = action.predicted_event_worst_degc[z]
            row[col[f"comfort_lower_{zone}_degc"]] = exo.comfort_lower_degc[k, z]
            row[col[f"comfort_upper_{zone}_degc"]] = exo.comfort_upper_degc[k, z]
        first_d = col[f"d_{self.setup.model.channels[0].name}"]
        nd = len(d_hat)
        row[first_d : first_d + nd] = d_hat
        row[first_d + nd : first_d + 2 * nd] = w
        rec.flags["fallback"][k] = action.fallback
        rec.status[k] = action.status

    # -- checkpoints ------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        rec = self.recorder
        return {
            "config_hash": run_key(self.setup.config),
            "code_version": version.code_version(),
            "k": self.k,
            "x": self.x.copy(),
            "month": self.month,
            "month_peak_kw": self.month_peak_kw,
            "sampler": self.sampler.get_state(),
            "sensors": self.sensors.get_state(),
            "controller": self.controller.get_state(),
            "events": self.events.get_state(),
            "values": rec.values[: self.k].copy(),
            "flags": {name: flags[: self.k].copy() for name, flags in rec.flags.items()},
            "status": rec.status[: self.k].copy(),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        expected = run_key(self.setup.config)
        if state["config_hash"] != expected:
            raise HvacflexError(
                f"checkpoint of configuration {state['config_hash']} cannot resume a run of "
                f"configuration {expected}; start afresh or use the matching configuration"
            )
        k = state["k"]
        self.k, self.x = k, state["x"].copy()
        self.month, self.month_peak_kw = state["month"], state["month_peak_kw"]
        self.sampler.set_state(state["sampler"])
        self.sensors.set_state(state["sensors"])
        self.controller.set_state(state["controller"])
        rec = self.recorder
        rec.values[:k] = state["values"]
        self.events.set_state(state["events"])
        for name, flags in state["flags"].items():
            rec.flags[name][:k] = flags
        rec.status[:k] = state["status"]

    def save_checkpoint(self, path: Path) -> None:
        """Write the state atomically (a crash mid-write leaves the previous checkpoint)."""
        atomic_write_bytes(path, pickle.dumps(self.get_state(), protocol=pickle.HIGHEST_PROTOCOL))

    def frame(self) -> pd.DataFrame:
        return self.recorder.frame(self.setup.exogenous.index, self.k)


def run_simulation(
    config: ScenarioConfig,
    out_dir: str | Path,
    *,
    progress: bool = True,
    checkpoint_every: int = DEFAULT_CHECKPOINT_EVERY,
    resume: bool = True,
    stop_after_steps: int | None = None,
    on_step: ProgressCallback | None = None,
) -> RunResult:
    """Run (or resume, or re-use) a closed-loop simulation and write its results.

    Parameters
    ----------
    config : the scenario.
    out_dir : folder for ``results.parquet``, ``summary.json``, ``config.json`` and the
        checkpoint.
    progress : show a progress bar (steps/s, ETA).
    checkpoint_every : steps between checkpoints.
    resume : resume from a checkpoint of the same configuration, and re-use finished results
        of the same inputs (:func:`run_key`) and code (:func:`hvacflex.version.code_version`).
        A checkpoint of the same configuration written by other code is refused.
    stop_after_steps : stop (after checkpointing) once this many steps are done, as an
        interruption would; the run is then resumable. For tests and batch schedulers.
    on_step : called with (steps done, total steps) after each step.
    """
    from hvacflex.kpi import summary as kpi_summary

    if checkpoint_every < 1:
        raise ConfigError("must be ≥ 1 step", field="checkpoint_every", value=checkpoint_every)

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results_path = out / RESULTS_FILE
    checkpoint_path = out / CHECKPOINT_FILE
    config_hash = run_key(config)
    if resume and results_path.is_file():
        frame, stored = read_results(results_path)
        same_code = stored["version"] == version.code_version()
        if stored["run_key"] == config_hash and same_code and (out / SUMMARY_FILE).is_file():
            summary = read_summary(out / SUMMARY_FILE)
            return RunResult(out, frame, summary, cached=True)

    state: dict[str, Any] | None = None
    if resume and checkpoint_path.is_file():
        state = load_checkpoint(checkpoint_path)
        if state["config_hash"] == config_hash:
            check_checkpoint_code(state, checkpoint_path)
        else:  # a checkpoint of another configuration: this run starts afresh over it
            state = None
    loop = ClosedLoop(prepare(config))
    resumed_from: int | None = None
    if state is not None:
        loop.set_state(state)
        resumed_from = loop.k
    atomic_write_text(out / CONFIG_FILE, json.dumps(config.to_dict(), indent=2))

    last = loop.steps if stop_after_steps is None else min(loop.steps, stop_after_steps)
    try:
        with progress_bar(progress, config.name, loop.steps, loop.k) as advance:
            while loop.k < last:
                loop.step()
                advance()
                if on_step is not None:
                    on_step(loop.k, loop.steps)
                if loop.k % checkpoint_every == 0 and loop.k < loop.steps:
                    loop.save_checkpoint(checkpoint_path)
    except BaseException:
        loop.save_checkpoint(checkpoint_path)
        raise
    if loop.k < loop.steps:
        loop.save_checkpoint(checkpoint_path)
        frame = loop.frame()
        return RunResult(out, frame, kpi_summary(frame), resumed_from_step=resumed_from)

    frame = loop.frame()
    write_results(frame, results_path, config)
    summary = kpi_summary(frame)
    # timing_s covers only the steps simulated by this call (it is not checkpointed)
    steps_timed = loop.k - (resumed_from or 0)
    summary["steps_per_s"] = _steps_per_second(loop, steps_timed)
    for part, seconds in loop.timing_s.items():
        summary[f"time_{part}_ms_per_step"] = 1e3 * seconds / max(steps_timed, 1)
    atomic_write_text(out / SUMMARY_FILE, json.dumps(summary, indent=2))
    checkpoint_path.unlink(missing_ok=True)
    return RunResult(out, frame, summary, resumed_from_step=resumed_from)


def _steps_per_second(loop: ClosedLoop, steps_timed: int) -> float:
    """Steps per second of wall time over the ``steps_timed`` steps ``loop.timing_s`` covers."""
    total = sum(loop.timing_s.values())
    return steps_timed / total if total > 0 else float("nan")
