"""Receding-horizon closed-loop simulation against a building plant.

Every 30 minutes (docs/explanation/model.md §4): forecast → :class:`hvacflex.sim.step.ControlStep`
(controller, IL events) → the decision is applied to the plant (:class:`hvacflex.sim.plant.
Plant`; by default hvacflex's exact nonlinear RC network) under the realised disturbance
d + w (the data, :attr:`Setup.exogenous`, plus w drawn in the uncertainty box or the
realisation's own) → measure → repeat. The forecast the controller sees may differ from the
data (docs/explanation/forecast.md); the results' ``d_<channel>`` is that forecast of the period and
``w_<channel>`` its realised error. When interruptible load is
activated the plant runs u − r: under the event model the locked plan of the event's first
period for at most D periods, under the whole-horizon model each period's fresh plan
(:mod:`hvacflex.sim.events`).
The reserve capacity scheduled is paid whether activated or not; delivery is settled against
metered power (:mod:`hvacflex.settlement`, the ``il_baseline_power_kw``, ``il_delivered_kw``
and ``il_shortfall_kw`` columns of :meth:`ClosedLoop.frame`) and summed in :mod:`hvacflex.kpi`.

Each row of the output (``results.parquet``, schema in ``docs/reference/results.md``)
describes one period. On a plant that can snapshot its state both counterfactual plant steps are
computed each period (served: u, curtailed: u − r) so the power with and without activation is
known; the applied one is chosen by the activation schedule. On one that cannot (an external
emulator) only the applied step is run and the counterfactual columns are NaN.

A loop's state (:meth:`ClosedLoop.get_state`) is what a run's checkpoint holds;
:func:`hvacflex.sim.run.run_simulation` runs a scenario to its folder (checkpoints, resume,
re-use of finished results).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
import pandas as pd

from hvacflex import results, state, version
from hvacflex.building.discretize import delivered_flow_kg_s
from hvacflex.building.identified import initial_node_temps_degc
from hvacflex.config import ScenarioConfig
from hvacflex.control.base import Action, Controller, FloatArray, PeriodInputs, WarmRestart
from hvacflex.control.plan_band import band_at_period_ends
from hvacflex.data.forecast import Exogenous, Forecast
from hvacflex.data.signals import OperatorSignals, effective_peak_price
from hvacflex.data.uncertainty import DisturbanceSampler
from hvacflex.errors import ConfigError, HvacflexError
from hvacflex.settlement import SETTLEMENT_COLUMNS, settlement_columns
from hvacflex.sim.history import PeriodHistory, period_inputs
from hvacflex.sim.measurement import Sensors
from hvacflex.sim.plant import (
    Actuation,
    Disturbance,
    Observation,
    PeakGuard,
    Plant,
    reads_meter_in_period,
)
from hvacflex.sim.plants import scenario_plant
from hvacflex.sim.run_files import (
    run_key,
)
from hvacflex.sim.setup import Setup, make_controller
from hvacflex.sim.step import ControlStep, Decision

SETPOINT_IDLE_FLOW_KG_S = 1e-3
"""A zone whose planned flow is within this of its minimum is left to float (setpoint
actuation)."""


class _Recorder:
    """Preallocated per-step columns (cheap to fill, to checkpoint and to turn into a frame);
    the columns are those of the results schema (:func:`hvacflex.results.step_columns`)."""

    FLAG_COLUMNS: tuple[str, ...] = results.FLAG_COLUMNS

    def __init__(self, steps: int, zones: tuple[str, ...], channels: tuple[str, ...]) -> None:
        self.float_columns = results.step_columns(zones, channels)
        self.column_index = {name: i for i, name in enumerate(self.float_columns)}
        self.zone_index = {
            kind: np.array([self.column_index[kind.name(zone)] for zone in zones])
            for kind in results.ZONE_COLUMNS
        }
        """Per-zone column kind → (m,) positions of its zones' columns."""
        self.values = np.full((steps, len(self.float_columns)), np.nan)
        self.flags = {name: np.zeros(steps, dtype=bool) for name in self.FLAG_COLUMNS}
        self.status = np.empty(steps, dtype=object)

    def frame(self, index: pd.DatetimeIndex, steps_done: int) -> pd.DataFrame:
        frame = pd.DataFrame(
            self.values[:steps_done], index=index[:steps_done], columns=self.float_columns
        )
        for name, flags in self.flags.items():
            frame[name] = flags[:steps_done]
        frame[results.STATUS_COLUMN] = pd.Series(
            self.status[:steps_done], index=frame.index, dtype="string"
        )
        frame.index.name = results.INDEX_NAME
        return frame


class Control(Protocol):
    """What decides a period for the closed loop: a :class:`ControlStep`, or a stand-in with
    the same calls (the service replay's, which asks the service)."""

    @property
    def takes_measurements(self) -> bool: ...

    def decide(
        self, k: int, inputs: PeriodInputs, *, activated: Callable[[int], bool]
    ) -> Decision: ...

    def restart_warm(self) -> None: ...

    def get_state(self) -> dict[str, Any]: ...

    def set_state(self, state: dict[str, Any]) -> None: ...


@dataclass(frozen=True)
class _PlantPeriod:
    """One period on the plant: the applied step and both counterfactuals."""

    applied: Observation
    served_power_kw: float
    curtailed_power_kw: float
    x_next_degc: FloatArray
    input_kg_s: FloatArray
    """(m,) the air system's input over the period as the model takes it [kg/s]
    (:meth:`ClosedLoop._delivered_input`)."""


def committed_peak_kw(phi_sgd_per_kw: float, action: Action, billed_peak_kw: float) -> float:
    """The cap in force in a period [kW] while the peak is priced (φ > 0): the larger of the
    fresh plan's peak (``action.plan.peak_kw``, max_k P_k) and the month's billed peak so far
    ``billed_peak_kw`` (the metered periods before it); the billed peak alone without a fresh
    plan; NaN where φ = 0 or neither is positive."""
    if not phi_sgd_per_kw > 0.0:
        return float("nan")
    planned = float(getattr(action.plan, "peak_kw", float("nan")))
    candidates = [v for v in (planned, billed_peak_kw) if np.isfinite(v) and v > 0.0]
    return max(candidates) if candidates else float("nan")


def peak_guard_enabled(config: ScenarioConfig, plant: Plant) -> bool:
    """Whether the in-period peak guard runs on ``plant`` (``[controller] peak_guard``:
    ``auto`` where the plant reads its meter within a period, ``on`` required, ``off``).

    Raises
    ------
    ConfigError : ``on`` with a plant that cannot read its meter within a period (exit 2,
        before the run).
    """
    mode = config.controller.peak_guard
    reads = reads_meter_in_period(plant)
    if mode == "on" and not reads:
        raise ConfigError(
            f"the peak guard needs a plant that reads its meter within a period; the "
            f"{config.plant.kind} plant reads it once a period",
            field="controller.peak_guard",
            value=mode,
            hint="set peak_guard = 'auto' or 'off', or run on the RC or EnergyPlus plant",
        )
    return mode != "off" and reads


def band_at_period_end_degc(exo: Exogenous, k: int) -> tuple[FloatArray, FloatArray]:
    """(m,) lower and (m,) upper comfort bound [°C] at the end of period ``k``: the tighter of
    the bands of periods k and k + 1, as the plan's
    (:func:`~hvacflex.control.plan_band.band_at_period_ends`). The peak guard sheds
    toward its upper bound and the setpoint actuation clips to it
    (:func:`setpoint_actuation_degc`): in the period before occupancy starts, neither works
    toward the night band the plan has already left."""
    lower, upper = exo.comfort_lower_degc[k : k + 2], exo.comfort_upper_degc[k : k + 2]
    lower_end, upper_end = band_at_period_ends(lower, upper, 1)
    return np.asarray(lower_end[0], dtype=np.float64), np.asarray(upper_end[0], dtype=np.float64)


def setpoint_actuation_degc(
    planned_degc: FloatArray,
    idle: npt.NDArray[np.bool_],
    lower_degc: FloatArray,
    upper_degc: FloatArray,
) -> FloatArray:
    """(m,) the zones' setpoints [°C] under setpoint actuation: the planned end-of-period
    temperatures (m,) [°C] (NaN: none planned, the upper bound) clipped to the band
    ``lower_degc`` … ``upper_degc`` (m,) [°C]; a zone ``idle`` (m,) (left at its minimum flow)
    gets the upper bound, so the plant's loop does not cool it towards a temperature the plan
    expects it to drift to."""
    planned = np.where(np.isnan(planned_degc), upper_degc, planned_degc)  # NaN: none planned
    setpoint = np.clip(planned, lower_degc, upper_degc)
    return np.asarray(np.where(idle, upper_degc, setpoint), dtype=np.float64)


class ClosedLoop:
    """A closed-loop run that can be advanced, checkpointed and resumed.

    Most users call :func:`run_simulation`; this class is the stepping engine behind it.

    Parameters
    ----------
    setup : the run's parts (:func:`hvacflex.sim.setup.prepare`).
    controller : the controller (default: the one the configuration asks for).
    plant : the plant (default: the scenario's, :func:`hvacflex.sim.plants.scenario_plant`).
    control : what decides each period (default: a :class:`ControlStep` of ``controller``).
    signals : operator signals laid over every forecast (prices, φ).
    """

    def __init__(
        self,
        setup: Setup,
        controller: Controller | None = None,
        *,
        plant: Plant | None = None,
        control: Control | None = None,
        signals: OperatorSignals | None = None,
    ) -> None:
        self.setup = setup
        cfg = setup.config
        if control is None:
            chosen = controller if controller is not None else make_controller(setup)
            control = ControlStep(cfg, chosen, len(setup.zone_names))
        self.control: Control = control
        self.plant: Plant = plant if plant is not None else scenario_plant(setup)
        self.actuation = self.plant.actuations[0]
        """How the plant is driven: ``"flow"`` (the plan's flows) or ``"setpoint"``."""
        self.signals = signals if signals is not None else OperatorSignals()
        self.steps = cfg.steps
        self.k = 0
        self._zone_rows = setup.model.c.argmax(axis=1)
        identified = setup.building.identified
        nodes = setup.model.node_names
        self._boundary_rows = np.array(
            [nodes.index(b.name) for b in identified.boundaries] if identified else [], dtype=int
        )
        """(nb,) the model's boundary nodes (an identified model's plenums), node order."""
        hvac = setup.building.hvac
        occupancy = (np.array([False]), np.array([True]))
        self._flow_min_kg_s = tuple(hvac.flow_min_at(occupied)[0] for occupied in occupancy)
        """(m,) lowest flow [kg/s] when unoccupied and when occupied."""
        self._damper_open = hvac.outdoor_air_open_at(setup.exogenous.occupied, cfg.dt_s)
        """(T,) bool: the outdoor-air damper open (occupied or purge), the plant's schedule."""
        self._guard_on = peak_guard_enabled(cfg, self.plant)  # checked before the run
        self._period_guard: PeakGuard | None = None  # the guard of the period being stepped
        self.x = np.full(len(setup.model.node_names), cfg.initial_temp_degc)
        if setup.building.identified is not None:  # hidden nodes at their estimated values
            self.x = initial_node_temps_degc(setup.building.identified, cfg.initial_temp_degc)
        self.x = self._state_after(self.plant.reset(cfg.initial_temp_degc), None, None)
        self.sampler = DisturbanceSampler(
            cfg.realisation.mode, seed=cfg.seed, ar1_coefficient=cfg.realisation.ar1_coefficient
        )
        self.history = PeriodHistory.empty(setup.exogenous.index, self.steps)
        """The metered periods so far (:mod:`hvacflex.sim.history`)."""
        channel_names = tuple(ch.name for ch in setup.model.channels)
        self.recorder = _Recorder(self.steps, setup.zone_names, channel_names)
        self._outdoor = next(
            i for i, ch in enumerate(setup.model.channels) if ch.kind == "outdoor_temp"
        )
        self.timing_s = {"controller": 0.0, "plant": 0.0, "record": 0.0}
        self.sensors = Sensors(cfg, setup.model.c, self.control.takes_measurements)

    @property
    def controller(self) -> Controller | None:
        """The controller the control step drives (None for a stand-in control)."""
        return self.control.controller if isinstance(self.control, ControlStep) else None

    @property
    def resumable_anywhere(self) -> bool:
        """True when a checkpoint written at any period resumes bit for bit: the control
        keeps no live solver state (a rule-based controller); an MPC resumes bit for bit
        from its restart points only (:func:`run_simulation`)."""
        controller = self.controller
        return controller is not None and not isinstance(controller, WarmRestart)

    def _activated(self, j: int) -> bool:
        return bool(self.setup.activation[j])

    # -- one period -------------------------------------------------------------------
    def inputs(self, plan: Any = None) -> PeriodInputs:
        """The driver's inputs of period ``k`` (:func:`hvacflex.sim.history.period_inputs`);
        the sensors are read here (their noise draws advance)."""
        return period_inputs(
            self.k,
            self.history,
            self.setup.forecaster,
            self.signals,
            self.setup.config,
            x_degc=self.x,
            measured_zone_temp_degc=self.sensors.read(self.x),
            plan=plan,
        )

    def step(self, plan: Any = None) -> None:
        """Simulate period ``k`` and advance; ``plan``: this period's plan decided elsewhere
        (a fleet coordinator's), applied as the controller's."""
        setup, k = self.setup, self.k
        exo = setup.exogenous
        t0 = time.perf_counter()
        inputs = self.inputs(plan)
        forecast = inputs.forecast
        decision = self.control.decide(k, inputs, activated=self._activated)
        t1 = time.perf_counter()

        # the plant sees the data plus a draw in the sampling box; the results record the
        # controller's forecast of the period and its error (0 + draw under perfect foresight)
        d_data = exo.disturbances[k]
        d_hat = np.asarray(forecast.disturbances[0], dtype=float)
        sigma = setup.sampling_box.sigma(d_data[None, :], setup.model.channels)[0]
        w_box = self.sampler.sample(sigma)
        d_real = d_data + w_box
        w = (d_data - d_hat) + w_box
        disturbance = Disturbance(
            d_real,
            float(d_real[self._outdoor]),
            float(exo.outdoor_humidity_ratio_kg_per_kg[k]),
            latent_gain_w=float(exo.occupant_latent_w[k]),
            damper_open=bool(self._damper_open[k]),
        )
        cap_kw = committed_peak_kw(
            effective_peak_price(forecast, setup.config.controller.peak_price_sgd_per_kw),
            decision.action,
            self.history.peak_floor_kw(k),
        )
        self._period_guard = None
        if self._guard_on and np.isfinite(cap_kw) and not decision.action.released:
            self._period_guard = PeakGuard(
                cap_kw,
                band_at_period_end_degc(exo, k)[1] + decision.allowance_k,
                self._flow_min_kg_s[int(exo.occupied[k])],
                setup.config.controller.peak_guard_substeps,
            )
        period = self._plant_period(decision, disturbance)
        self._period_guard = None
        delivered = None
        if period.applied.supply_temp_degc is not None and period.applied.node_temp_degc is None:
            # the filter predicts with what the air delivered, as the observer does
            delivered = period.input_kg_s
        step_model = decision.action.step_model
        # graded with the decided input, not the delivered one: the error between plan and
        # plant, which a box calibrated from it must cover (docs/explanation/estimation.md section
        # 4)
        error_k = self.sensors.prediction_error_k(
            setup.model if step_model is None else step_model,
            self.x,
            decision.applied_flow_kg_s,
            d_real,
            period.x_next_degc,
        )
        t2 = time.perf_counter()

        power = period.applied.power_kw
        self._record(k, decision, forecast, d_hat, w, period)
        self.recorder.values[k, self.recorder.column_index["committed_peak_kw"]] = cap_kw
        self.recorder.flags["peak_guard_active"][k] = period.applied.peak_guard_active
        self.recorder.values[k, self.recorder.zone_index[results.PREDICTION_ERROR]] = error_k
        self._record_event(k, decision)
        self.history.record(k, power, self._activated(k), delivered)
        self.x = period.x_next_degc
        self.k += 1
        t3 = time.perf_counter()
        self.timing_s["controller"] += t1 - t0
        self.timing_s["plant"] += t2 - t1
        self.timing_s["record"] += t3 - t2

    def _plant_period(self, decision: Decision, disturbance: Disturbance) -> _PlantPeriod:
        """Run the period on the plant: the served and the curtailed step where the plant can
        snapshot (the applied one is kept), the applied step alone where it cannot."""
        plant, dt_s = self.plant, self.setup.config.dt_s
        action = decision.action
        curtailed = decision.outcome.curtailed
        served_act = self._actuation(decision, curtailed=False)
        offered = bool(np.any(action.reserve_flow_kg_s > 0))
        if not plant.can_snapshot:
            applied_act = self._actuation(decision, curtailed=curtailed)
            applied = plant.step(applied_act, disturbance, dt_s)
            nan = float("nan")
            served_kw = applied.power_kw if not curtailed else nan
            curtailed_kw = applied.power_kw if curtailed or not offered else nan
            flow = self._delivered_input(applied)
            x_next = self._state_after(applied, disturbance, flow)
            return _PlantPeriod(applied, served_kw, curtailed_kw, x_next, flow)
        before = plant.get_state()
        served = plant.step(served_act, disturbance, dt_s)
        if offered:
            after_served = plant.get_state()
            plant.set_state(before)
            cut = plant.step(self._actuation(decision, curtailed=True), disturbance, dt_s)
            if not curtailed:
                plant.set_state(after_served)
        else:  # no reserve offered: activation changes nothing
            cut = served
        applied = cut if curtailed else served
        flow = self._delivered_input(applied)
        x_next = self._state_after(applied, disturbance, flow)
        return _PlantPeriod(applied, served.power_kw, cut.power_kw, x_next, flow)

    def _actuation(self, decision: Decision, *, curtailed: bool) -> Actuation:
        """What the plant is told: the flows (u, or u − r when curtailed) with the action's
        supply-air temperature (None: the plant's own), or under setpoint actuation each zone's
        planned end-of-period temperature (served, or curtailed; the limit itself with ``[plant]
        curtailed_setpoint = "limit"``) clipped to the band at the period's end, its upper bound
        raised by the allowance α in force to the limit, as a supervisory MPC hands setpoints to
        a BMS (:func:`band_at_period_end_degc`, :func:`setpoint_actuation_degc`)."""
        action = decision.action
        if action.released:  # the plant's own control: no setpoint from hvacflex
            return Actuation(setpoint_degc=np.full(action.flow_kg_s.shape, np.nan))
        flow = action.applied_flow_kg_s(curtailed=curtailed)
        if self.actuation == "flow":
            return Actuation(
                flow_kg_s=np.maximum(flow, 0.0),  # a fan-only idle input is below 0 (no air)
                supply_temp_degc=action.supply_temp_degc,
                peak_guard=self._period_guard,
            )
        k, exo = self.k, self.setup.exogenous
        planned = action.predicted_curtailed_degc if curtailed else action.predicted_served_degc
        lower, upper = band_at_period_end_degc(exo, k)
        idle = flow <= self._flow_min_kg_s[int(exo.occupied[k])] + SETPOINT_IDLE_FLOW_KG_S
        limit = upper + decision.allowance_k
        if curtailed and self.setup.config.plant.curtailed_setpoint == "limit":
            planned = np.asarray(limit, dtype=np.float64)  # the deepest shed the contract allows
        return Actuation(
            setpoint_degc=setpoint_actuation_degc(planned, idle, lower, limit),
            peak_guard=self._period_guard,
            limit_degc=np.asarray(limit, dtype=np.float64),
        )

    def _state_after(
        self,
        observation: Observation,
        disturbance: Disturbance | None,
        flow_kg_s: FloatArray | None,
    ) -> FloatArray:
        """The node temperatures (n,) [°C] after the period: the plant's own where it shows
        them; else the controller's model predicts the other nodes from the state before,
        the air system's input the plant reports (the delivered cooling where it reads the
        supply air temperature, else the flows) and the realised disturbance, and the zone readings
        replace its zone nodes, the plant's boundary readings (a plenum) its boundary nodes
        (an open-loop observer of the hidden wall and mass temperatures). ``flow_kg_s``: that
        input (m,) [kg/s] (:meth:`_delivered_input`), None at the reset."""
        if observation.node_temp_degc is not None:
            return np.asarray(observation.node_temp_degc, dtype=float)
        model = self.setup.model
        x = self.x.copy()
        if disturbance is not None and flow_kg_s is not None:
            x = model.a @ x + model.b @ flow_kg_s + model.e @ disturbance.d + model.g
        x[self._zone_rows] = observation.zone_temp_degc
        if observation.boundary_temp_degc is not None and self._boundary_rows.size:
            x[self._boundary_rows] = observation.boundary_temp_degc
        return np.asarray(x, dtype=float)

    def _delivered_input(self, observation: Observation) -> FloatArray:
        """(m,) the air system's input over the period as the model takes it [kg/s]: the
        cooling the air delivered (``delivered_flow_kg_s``) where the plant reads the supply
        air temperature, else the metered flows."""
        flow = np.asarray(observation.supply_flow_kg_s, dtype=float)
        if observation.supply_temp_degc is None:
            return flow
        return delivered_flow_kg_s(
            self.setup.model,
            flow,
            observation.zone_mean_temp_degc,
            observation.supply_temp_degc,
        )

    def _record_event(self, k: int, decision: Decision) -> None:
        rec, col = self.recorder, self.recorder.column_index
        outcome = decision.outcome
        rec.flags["il_activated"][k] = self._activated(k)
        rec.flags["il_curtailed"][k] = outcome.curtailed
        rec.flags["il_beyond_model"][k] = outcome.beyond_model
        rec.flags["il_event_window"][k] = outcome.event_window
        rec.values[k, col["il_allowance_k"]] = outcome.allowance_k
        rec.values[k, col["il_reference_power_kw"]] = outcome.reference_power_kw
        reserve = self.setup.config.reserve
        rec.values[k, col["il_penalty_price_sgd_per_mwh"]] = (
            reserve.non_delivery_penalty_sgd_per_mwh
        )
        forfeited = self.setup.exogenous.reserve_price_sgd_per_mwh[k]
        forfeit = reserve.non_delivery_forfeits_reserve_payment
        rec.values[k, col["il_forfeited_price_sgd_per_mwh"]] = forfeited if forfeit else 0.0

    def _record(
        self,
        k: int,
        decision: Decision,
        forecast: Forecast,
        d_hat: FloatArray,
        w: FloatArray,
        period: _PlantPeriod,
    ) -> None:
        rec, col = self.recorder, self.recorder.column_index
        row = rec.values[k]
        exo = self.setup.exogenous
        action = decision.action
        phi = effective_peak_price(forecast, self.setup.config.controller.peak_price_sgd_per_kw)
        for name in results.EXOGENOUS_COLUMNS:
            row[col[name]] = getattr(exo, name)[k]
        row[col["peak_price_sgd_per_kw"]] = phi
        row[col["power_kw"]] = period.applied.power_kw
        row[col["facility_power_kw"]] = period.applied.facility_power_kw
        row[col["power_served_kw"]] = period.served_power_kw
        row[col["power_curtailed_kw"]] = period.curtailed_power_kw
        row[col["planned_power_kw"]] = action.planned_power_kw
        row[col["reserve_kw"]] = action.reserve_kw
        row[col["offer_meter_ratio"]] = action.offer_meter_ratio
        row[col["solve_time_s"]] = action.solve_time_s
        row[col["planned_slack_max_k"]] = action.planned_slack_max_k
        row[col["delta_max_k"]] = action.delta_max_k
        zone = rec.zone_index
        row[zone[results.FLOW]] = action.flow_kg_s
        row[zone[results.RESERVE_FLOW]] = action.reserve_flow_kg_s
        row[zone[results.TEMP]] = self.x[self._zone_rows]
        row[zone[results.TEMP_END]] = period.x_next_degc[self._zone_rows]
        row[zone[results.TEMP_SERVED]] = action.predicted_served_degc
        row[zone[results.TEMP_CURTAILED]] = action.predicted_curtailed_degc
        if action.predicted_event_worst_degc is not None:
            row[zone[results.EVENT_WORST]] = action.predicted_event_worst_degc
        row[zone[results.COMFORT_LOWER]] = exo.comfort_lower_degc[k]
        row[zone[results.COMFORT_UPPER]] = exo.comfort_upper_degc[k]
        first_d = col[results.FORECAST_DISTURBANCE.name(self.setup.model.channels[0].name)]
        nd = len(d_hat)
        row[first_d : first_d + nd] = d_hat
        row[first_d + nd : first_d + 2 * nd] = w
        rec.flags["fallback"][k] = action.fallback
        rec.flags["model_extrapolation"][k] = self._extrapolating(action, d_hat)
        rec.status[k] = action.status

    def _extrapolating(self, action: Action, d_hat: FloatArray) -> bool:
        """Whether the period was planned outside an identified model's validity range: a
        zone's planned end temperature or the forecast outdoor temperature beyond what its
        training data saw (False without a range)."""
        identified = self.setup.building.identified
        validity = None if identified is None else identified.validity
        if validity is None or not np.isfinite(action.predicted_served_degc).all():
            return False
        outdoor = float(d_hat[self._outdoor])
        return bool(validity.outside(action.predicted_served_degc[None, :], outdoor)[0])

    # -- checkpoints ------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        """The run's state as data (:mod:`hvacflex.state`)."""
        rec = self.recorder
        return {
            "config_hash": run_key(self.setup.config),
            "code_version": version.code_version(),
            "k": self.k,
            "x": self.x.copy(),
            "plant": self.plant.get_state(),
            "history": self.history.get_state(),
            "sampler": self.sampler.get_state(),
            "sensors": self.sensors.get_state(),
            "control": self.control.get_state(),
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
        self.k, self.x = k, np.asarray(state["x"], dtype=float).copy()
        self.plant.set_state(state["plant"])  # an emulator replays its recorded actuations
        self.history.set_state(state["history"])
        self.sampler.set_state(state["sampler"])
        self.sensors.set_state(state["sensors"])
        self.control.set_state(state["control"])
        rec = self.recorder
        rec.values[:k] = state["values"]
        for name, flags in state["flags"].items():
            rec.flags[name][:k] = flags
        rec.status[:k] = state["status"]

    def save_checkpoint(self, path: Path) -> None:
        """Write the state atomically (a crash mid-write leaves the previous checkpoint), and
        continue from it as a resumed run would (the controller restarts its solver warm
        from the stored basis), so a run resumed from any checkpoint ends with the results of
        the uninterrupted run, bit for bit."""
        state.save(path, self.get_state())
        self.control.restart_warm()

    def frame(self) -> pd.DataFrame:
        """The results so far, settled against metered power (:mod:`hvacflex.settlement`:
        the settlement columns are a function of the whole series, so they are computed
        here, not per step)."""
        frame = self.recorder.frame(self.setup.exogenous.index, self.k)
        settled = settlement_columns(frame, self.setup.config.reserve.il_baseline)
        for name in SETTLEMENT_COLUMNS:
            frame[name] = settled[name].to_numpy()
        return frame
