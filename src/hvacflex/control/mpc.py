"""The building-level MPC: period inputs → RMPC problem → plan → action.

The controller is made of parts, each in its own module:

* :func:`hvacflex.control.problem_builder.build_problem`, the one place that turns a
  building and its forecast into an :class:`~hvacflex.opt.RMPCProblem` (pure: model, period
  inputs, the run's :class:`~hvacflex.control.problem_builder.PlanContract` and the plan
  context);
* :class:`hvacflex.control.offers.OfferSizer`, the reserve offers sized to what the
  settlement would see, the offer committed ahead and the event plan;
* :class:`hvacflex.control.warm_solver.SolverSlot`, the warm solver and its basis;
* :class:`hvacflex.control.estimation.KalmanEstimator`, the filter of output feedback, and
  the re-linearisation about the previous plan (:mod:`hvacflex.control.trajectory`).

What :class:`MPCController` itself keeps is the plan's history: the last optimal plan, how
many periods ago it was made and how many fallbacks since. When a solve does not return an
optimal plan, the controller falls back to the previous plan's step for this period, else
to the thermostat, offers no reserve, and says so in the
:class:`~hvacflex.control.base.Action`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from hvacflex.building.discretize import LinearModel
from hvacflex.building.model import Building
from hvacflex.building.rc import build_network
from hvacflex.config import ControllerConfig, Linearisation, ReserveConfig
from hvacflex.control.base import Action, Controller, FloatArray, PeriodInputs
from hvacflex.control.baselines import ThermostatController, unplanned_action
from hvacflex.control.estimation import AppliedStep, KalmanConfig, KalmanEstimator, StepModel
from hvacflex.control.idle_air import (
    coil_started_flows_kg_s,
    fan_only_input_kg_s,
    fans_started_flows_kg_s,
    shares_one_coil,
)
from hvacflex.control.offers import OfferSizer, offer_steps, seen_steps, snapped_flows_kg_s
from hvacflex.control.plan_linearisation import planned_first_step
from hvacflex.control.problem_builder import (
    PlanContext,
    PlanContract,
    build_problem,
    model_error_margins,
)
from hvacflex.control.trajectory import relinearised_first_step
from hvacflex.control.warm_solver import SolverSlot
from hvacflex.data.forecast import Forecast
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.errors import ConfigError
from hvacflex.opt import RMPCProblem, RMPCSolution, SolveStatus


class MPCController(Controller):
    """Nominal or robust MPC for one building (see the module docstring).

    Parameters
    ----------
    building : the building (HVAC limits, reserve zones).
    model : its discrete linear model at the control step.
    config : controller settings (robust mode, reserve, φ, billing mode, ρ, horizon).
    box : the forecast-error box; ignored when ``config.robust == "none"``.
    linearisation_temp_degc : T₀ used for the power coefficients [°C].
    reserve : the IL contract (event length, allowance, recovery); default: whole horizon.
    estimation : Kalman filter settings for output feedback (``[estimation] mode =
        "kalman"``): :meth:`act` then needs the measured zone temperatures and plans from the
        estimate, with the offset estimate in the affine term and the estimation margin
        (docs/explanation/estimation.md) added to δ when the MPC is robust; None = full state.
    linearisation : ``"fixed"`` (``model`` throughout), ``"trajectory"`` (re-linearised
        each step about the previous plan shifted by one step) or ``"plan"`` (every step of
        the horizon at the previous plan's zone temperature over it; the config's, which
        builds the problem), docs/explanation/estimation.md §3.
    model_error_k : (m,) calibrated one-step model error per zone [K per step]
        (:func:`hvacflex.data.calibration.calibrate_box`); its margin
        (:func:`~hvacflex.control.problem_builder.model_error_margins`) tightens the comfort
        band on top of δ when the MPC is robust; None = no model-error term.
    """

    def __init__(
        self,
        building: Building,
        model: LinearModel,
        config: ControllerConfig,
        box: UncertaintyBox,
        linearisation_temp_degc: float,
        reserve: ReserveConfig | None = None,
        *,
        estimation: KalmanConfig | None = None,
        linearisation: Linearisation = "fixed",
        model_error_k: FloatArray | None = None,
    ) -> None:
        reserve = reserve if reserve is not None else ReserveConfig()
        if config.linearisation == "plan" and config.robust == "feedback":
            raise ConfigError(
                "linearisation = 'plan' is not available with robust = 'feedback'",
                field="controller.linearisation",
                value=config.linearisation,
                hint="use linearisation = 'fixed' or 'trajectory' with feedback",
            )
        self.contract = PlanContract.of(
            building, model, config, box, linearisation_temp_degc, reserve
        )
        """What every period's problem is built under."""
        self.commits_ahead = self.contract.commit_ahead
        self.takes_measurements = estimation is not None
        self._thermostat = ThermostatController(
            model, building.hvac, config.thermostat_setpoint_degc
        )
        self._network = build_network(building) if linearisation == "trajectory" else None
        self.solver_slot = SolverSlot(
            config.time_limit_s, rebuilt_each_model=linearisation != "fixed"
        )
        """The warm solver and its basis (:mod:`hvacflex.control.warm_solver`)."""
        self._estimator = KalmanEstimator(estimation) if estimation is not None else None
        self._model_error_margin_k = (
            None
            if model_error_k is None or config.robust == "none"
            else model_error_margins(model, np.asarray(model_error_k, dtype=float), config)
        )
        self._observers: list[Callable[[RMPCProblem], None]] = []
        # the plan's history (what get_state stores)
        self._previous_plan: RMPCSolution | None = None
        self._plan_seen_kw: FloatArray | None = None
        """What the last optimal plan's baselines could see (:meth:`OfferSizer.seen_kw`)."""
        self._periods_since_plan = 0
        """Periods begun since the last optimal plan was made (decided or held)."""
        self._plan_age = 0
        """Fallbacks since the last optimal plan (0: the plan is this period's own)."""
        self._step_model: StepModel = model
        self._solver_model: StepModel = model
        self._held = False

    @property
    def model(self) -> LinearModel:
        """The building's fixed discrete model."""
        return self.contract.model

    @property
    def building(self) -> Building:
        return self.contract.building

    @property
    def last_plan(self) -> RMPCSolution | None:
        """The last optimal plan over the horizon (None before the first)."""
        return self._previous_plan

    @property
    def reserve_mask(self) -> np.ndarray:
        """(m,) bool: zones allowed to offer reserve."""
        return self.contract.reserve_mask

    def observe_problems(self, callback: Callable[[RMPCProblem], None]) -> None:
        """Call ``callback`` with the problem of every later :meth:`act`
        (:mod:`hvacflex.sim.recording`)."""
        self._observers.append(callback)

    # -- one period ---------------------------------------------------------------------
    def act(self, inputs: PeriodInputs) -> Action:
        """Decide the period's action from the plant state ``inputs.x_degc`` (n,) (full
        state) or, with a filter, from the measured zone temperatures (m,) [°C] alone;
        ``inputs.plan``: an ``RMPCSolution`` of this period's problem decided elsewhere (the
        fleet coordinator's), applied as if the solver had returned it; ``inputs.locked``:
        a locked IL event period, returned as it is once the filter has measured."""
        self._take_previous_flow(inputs.previous_flow_kg_s)
        self._periods_since_plan += 1
        if inputs.locked is not None:
            return self._hold(inputs)
        x_degc, offset = self._estimate(inputs)
        previous = self._previous_plan
        step_model: StepModel = self.model
        if self._network is not None and previous is not None and self._plan_fresh:
            step_model = relinearised_first_step(
                self.building,
                self._network,
                self.model.c,
                previous.u,
                previous.x_served,
                self.model.c @ x_degc,
                self.model.dt_s,
            )
        sigma, sizer = self._box_and_sizer(inputs)
        problem = self._problem(inputs, step_model, x_degc, offset, sigma, sizer)
        for observe in self._observers:
            observe(problem)
        if step_model is not self._solver_model:
            self.solver_slot.new_model(problem)
        self._solver_model = step_model
        action = self._decide(problem, x_degc, inputs, sizer)
        step_model = planned_first_step(problem, step_model)
        self._step_model, self._held = step_model, False
        if self._estimator is not None:
            flow, d0 = action.flow_kg_s, inputs.forecast.disturbances[0]
            self._estimator.applied(AppliedStep(step_model, flow, d0, sigma[0]))
        return replace(action, step_model=step_model)

    def problem_for(self, inputs: PeriodInputs) -> RMPCProblem:
        """The problem :meth:`act` would build for ``inputs`` now, without deciding (a
        fleet's building plans it with the coordinator; full state, fixed model)."""
        sigma, sizer = self._box_and_sizer(inputs)
        x = np.asarray(inputs.x_degc, dtype=float)
        return self._problem(inputs, self.model, x, None, sigma, sizer, shift=1)

    @property
    def _plan_fresh(self) -> bool:
        """The last optimal plan is this period's predecessor's own, and the plant ran it
        (no fallback, no locked IL period since)."""
        return self._previous_plan is not None and self._plan_age == 0 and not self._held

    def _box_and_sizer(self, inputs: PeriodInputs) -> tuple[FloatArray, OfferSizer]:
        """The box's σ (N, nd) over the horizon and the period's offer sizer (with the
        power the last plan planned for now, where that plan is fresh)."""
        previous, fresh = self._previous_plan, self._plan_fresh
        horizon = self.contract.config.horizon_steps
        sigma = self.contract.box.sigma(inputs.forecast.disturbances[:horizon], self.model.channels)
        planned_now = float(previous.power_kw[0]) if previous is not None and fresh else None
        return sigma, OfferSizer.of(self.contract, inputs, planned_now)

    def _problem(
        self,
        inputs: PeriodInputs,
        step_model: StepModel,
        x_degc: FloatArray,
        offset_k: FloatArray | None,
        sigma: FloatArray,
        sizer: OfferSizer,
        shift: int = 0,
    ) -> RMPCProblem:
        """The period's problem: the plan context from the controller's state (margins,
        previous plan, the offers' baselines) and :func:`build_problem`. ``shift``: periods
        still to begin before the problem's (0 in :meth:`act`, which has begun it)."""
        contract, horizon = self.contract, self.contract.config.horizon_steps
        extra = None
        if self._estimator is not None and contract.config.robust != "none":
            extra = self._estimator.margins(step_model, sigma.max(axis=0), horizon)
        if self._model_error_margin_k is not None:
            model_margin = self._model_error_margin_k
            extra = model_margin if extra is None else extra + model_margin
        baselines = None
        if contract.visible_offers:
            paid = seen_steps(self._plan_seen_kw, self._periods_since_plan + shift, horizon)
            baselines = sizer.baselines(horizon, paid)
        fresh = self._periods_since_plan + shift == 1 and self._plan_fresh
        context = PlanContext(
            x_degc, offset_k, extra, self._previous_plan, baselines, sizer.scale, fresh
        )
        return build_problem(step_model, inputs, contract, context)

    def _take_previous_flow(self, flow_kg_s: FloatArray | None) -> None:
        """The input of the filter's last step as the plant ran it (u − r under IL
        activation) or as the air delivered it; no-op without a filter."""
        estimator = self._estimator
        if flow_kg_s is not None and estimator is not None and estimator.last is not None:
            flow = np.asarray(flow_kg_s, dtype=float)
            estimator.applied(replace(estimator.last, flow_kg_s=flow))

    def _estimate(self, inputs: PeriodInputs) -> tuple[FloatArray, FloatArray | None]:
        """The state the plan starts from (n,) [°C] and the filter's offset (m,) [K per
        step]: the plant's state, or with a filter the estimate from the zone readings."""
        if self._estimator is None:
            return inputs.x_degc, None
        if inputs.measured_zone_temp_degc is None:
            raise ConfigError(
                "the Kalman filter needs the measured zone temperatures",
                field="estimation.mode",
                value="kalman",
                hint="pass measured_zone_temp_degc (the closed loop does so)",
            )
        estimate = self._estimator.estimate(inputs.measured_zone_temp_degc, self.model)
        return estimate.x_degc, estimate.offset_k

    def _hold(self, inputs: PeriodInputs) -> Action:
        """A period the plant runs a locked IL-event plan: the filter still takes the
        measurement and predicts over the period with the locked flow, with the fixed model
        (the last plan is stale: the next :meth:`act` does not re-linearise about it)."""
        locked = inputs.locked
        assert locked is not None
        self._step_model, self._held = self.model, True
        measured = inputs.measured_zone_temp_degc
        if self._estimator is not None and measured is not None:
            forecast = inputs.forecast
            self._estimator.estimate(measured, self.model)
            sigma = self.contract.box.sigma(forecast.disturbances[:1], self.model.channels)[0]
            flow = locked.applied_flow_kg_s(curtailed=True)
            step = AppliedStep(self.model, flow, forecast.disturbances[0], sigma)
            self._estimator.applied(step)
        return replace(locked, step_model=self.model)

    def _air_system_flows(
        self,
        flow: FloatArray,
        problem: RMPCProblem,
        zone_temp_degc: FloatArray,
        inputs: PeriodInputs,
    ) -> FloatArray:
        """(m,) the period's planned flows as the identified building's air system runs them
        (:mod:`hvacflex.control.idle_air`): one coil started by a call for every zone, or
        every unit's fan forced on by a call; ``flow`` (m,) itself without fan-only air."""
        flow_min = self.building.hvac.flow_min_at(inputs.forecast.occupied[:1])[0]
        if shares_one_coil(self.building):
            return coil_started_flows_kg_s(flow, problem.u_min[0], flow_min)
        fan_input = fan_only_input_kg_s(self.building, self.contract.model, zone_temp_degc)
        if fan_input is None:
            return flow
        return fans_started_flows_kg_s(flow, fan_input, flow_min)

    def _decide(
        self, problem: RMPCProblem, x_degc: FloatArray, inputs: PeriodInputs, sizer: OfferSizer
    ) -> Action:
        plan = inputs.plan
        solution = plan if plan is not None else self.solver_slot.solve(problem)
        if solution.status is not SolveStatus.OPTIMAL:
            return self._fallback(x_degc, inputs.forecast, solution)
        self._previous_plan, self._plan_age = solution, 0
        self._plan_seen_kw = sizer.seen_kw(problem, solution)
        self._periods_since_plan = 0
        c = self.model.c
        # the LP's solution satisfies its bounds to the solver tolerance (~1e-9): snap the
        # flows of every step an offer is sized for onto the physical limits, once
        steps = offer_steps(self.contract)
        flows, reserves = snapped_flows_kg_s(problem, solution, steps, self.contract.flow_max_kg_s)
        visible_kw = sizer.visible_offers_kw(problem, solution.power_kw, reserves)
        flow, reserve = flows[0], reserves[0]
        if self.contract.config.fan_only_air:
            flow = self._air_system_flows(flow, problem, c @ x_degc, inputs)
        offer_kw = float(problem.reserve_kw_per_kg_s[0] @ reserve)
        if not self.commits_ahead:  # decided now: offer only what the baseline sees
            offer_kw = float(visible_kw[0])
            reserve = reserve if offer_kw > 0.0 else np.zeros_like(reserve)
        return Action(
            flow_kg_s=flow,
            reserve_flow_kg_s=reserve,
            reserve_kw=offer_kw,
            planned_power_kw=float(solution.power_kw[0]),
            status=solution.status.value,
            fallback=False,
            solve_time_s=solution.solve_time_s,
            planned_slack_max_k=float(np.max(solution.slack, initial=0.0)),
            delta_max_k=float(np.max(solution.delta, initial=0.0)),
            predicted_served_degc=c @ solution.x_served[1],
            predicted_curtailed_degc=c @ solution.x_curtailed[1],
            event_plan=sizer.event_plan(problem, solution, flows, reserves, visible_kw),
            predicted_event_worst_degc=np.asarray(solution.y_event_worst[0], dtype=float),
            offer_ahead=sizer.offer_ahead(reserves, visible_kw),
            offer_meter_ratio=sizer.meter_ratio,
            plan=solution,
        )

    def _fallback(self, x_degc: FloatArray, forecast: Forecast, failed: RMPCSolution) -> Action:
        """The last plan's step for this period if it reaches this far (shifted by every
        period begun since it was made, held IL-event periods included), else the
        thermostat."""
        self._plan_age += 1
        plan = self._previous_plan
        shift = self._periods_since_plan
        if plan is not None and shift < plan.u.shape[0]:
            low = self.building.hvac.flow_min_at(forecast.occupied[:1])[0]
            flow = np.clip(plan.u[shift], low, self.contract.flow_max_kg_s)
        else:
            flow = self._thermostat.flows_now(x_degc, forecast)
        return unplanned_action(
            self.model,
            x_degc,
            flow,
            forecast.disturbances[0],
            status=failed.status.value,
            fallback=True,
            solve_time_s=failed.solve_time_s,
            plan_margin_k=float("nan"),
        )

    # -- state --------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        return {
            "basis": self.solver_slot.basis(),
            "previous_plan": self._previous_plan,
            "plan_seen_kw": self._plan_seen_kw,
            "periods_since_plan": self._periods_since_plan,
            "plan_age": self._plan_age,
            "estimator": self._estimator.get_state() if self._estimator is not None else None,
            "step_model": self._step_model,
            "held": self._held,
        }

    def restart_warm(self) -> None:
        """Drop the solver (HiGHS's factorisation and internal state) and keep its basis to
        warm-start a new one at the next solve, as a controller restored by
        :meth:`set_state` starts."""
        self.solver_slot.restart()

    def set_state(self, state: dict[str, Any]) -> None:
        self.solver_slot.restore(state["basis"])
        self._previous_plan = state["previous_plan"]
        self._plan_seen_kw = state.get("plan_seen_kw")
        self._plan_age = state["plan_age"]
        self._periods_since_plan = int(state.get("periods_since_plan", self._plan_age))
        if self._estimator is not None and state.get("estimator") is not None:
            self._estimator.set_state(state["estimator"])
        self._step_model = state.get("step_model", self.model)
        self._held = bool(state.get("held", False))
        self._solver_model = self._step_model if self._network is not None else self.model
