"""The building-level MPC: building + forecast + measured state → RMPC problem → action.

This is the only place that turns a building and its forecast into an
:class:`~hvacflex.opt.RMPCProblem` (docs/model.md §3):

* dynamics ``x+ = A x + B u + E d + g`` from :func:`hvacflex.building.discretize.linearize`,
* power ``P_k = p0_k + p_kᵀ u_k`` from :func:`hvacflex.building.hvac.affine_power_model` at the
  forecast outdoor temperature and humidity and the zone temperature T₀ (a building
  identified from data: its fitted power model,
  :func:`hvacflex.building.identified.identified_affine_power`),
* comfort bounds for ``C x_{k+1}``, the temperature at the end of period k: the tighter of
  the bands of periods k and k + 1, so that the instant occupancy starts (and ends) is
  inside the occupied band,
* σ from the scenario's uncertainty box (zero for the nominal MPC),
* prices, the peak-power price φ and, in billing-period mode, the month's peak so far,
* the interruptible-load contract of the scenario's ``[reserve]`` table: the event length D,
  the allowance α, the recovery R, and the recovery steps c still running from an event that
  just ended (``RMPCProblem.il_*``); ``None`` for D keeps the whole-horizon model.

One warm-started solver is kept across steps. When a solve does not return an optimal plan,
the controller falls back to the previous plan shifted by one step, else to the thermostat,
offers no reserve, and says so in the :class:`~hvacflex.control.base.Action`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from hvacflex.building.discretize import LinearModel
from hvacflex.building.hvac import affine_power_model, reserve_power_coeff
from hvacflex.building.identified import identified_affine_power
from hvacflex.building.model import Building
from hvacflex.building.rc import build_network
from hvacflex.config import ControllerConfig, Linearisation, ReserveConfig
from hvacflex.control.base import (
    Action,
    Controller,
    EventPlan,
    FloatArray,
    PeriodInputs,
    ReserveOffer,
)
from hvacflex.control.baselines import ThermostatController, unplanned_action
from hvacflex.control.estimation import (
    AppliedStep,
    KalmanConfig,
    KalmanEstimator,
    StepModel,
    tightened_bounds,
)
from hvacflex.control.trajectory import relinearised_first_step
from hvacflex.data.forecast import Forecast
from hvacflex.data.signals import effective_peak_price
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.errors import ConfigError, ProblemError
from hvacflex.opt import (
    FeedbackOptions,
    OfferBaselines,
    RMPCProblem,
    RMPCSolution,
    SolverBasis,
    SolveStatus,
    WarmSolver,
    make_solver,
)
from hvacflex.opt.problem import BoolArray
from hvacflex.opt.robust import comfort_margins
from hvacflex.units import SECONDS_PER_HOUR


def comfort_bounds_at_period_ends(
    forecast: Forecast, horizon: int
) -> tuple[FloatArray, FloatArray]:
    """(N, m) comfort bounds on the temperatures x_1 … x_N at the ends of periods 0 … N−1.

    The end of period k is the start of period k + 1: the bound is the tighter of the two
    periods' bands. The forecast must cover ``horizon + 1`` periods; with exactly
    ``horizon`` the last period's band is used alone.
    """
    lower, upper = forecast.comfort_lower_degc, forecast.comfort_upper_degc
    nxt = slice(1, horizon + 1)
    lower_next = np.vstack([lower[nxt], lower[horizon - 1 : horizon]])[:horizon]
    upper_next = np.vstack([upper[nxt], upper[horizon - 1 : horizon]])[:horizon]
    return (
        np.maximum(lower[:horizon], lower_next),
        np.minimum(upper[:horizon], upper_next),
    )


RESERVE_FLOW_TOLERANCE_KG_S = 1e-6
"""Reserve flows below this are zero up to the solver's tolerance and are not offered."""

FLOW_SNAP_TOLERANCE_KG_S = 1e-9
"""A planned flow this close to a limit is the limit (the LP's round-off; a flow of 1e-13
kg/s above an unoccupied zero would start the fan)."""

BASELINE_TOLERANCE_KW = 1e-6
"""An offer that exceeds what the baseline would see by no more than this is kept [kW]."""


def model_error_margins(
    model: LinearModel, model_error_k: FloatArray, config: ControllerConfig
) -> FloatArray:
    """Comfort margin (N, m) [K] of a per-zone one-step model error ``|ε_z| ≤ model_error_k``
    (m,) [K per step] entering every step's zone temperature: the box margin of
    :func:`hvacflex.opt.robust.comfort_margins` with ``E = Cᵀ`` and σ = ε,
    ``Σ_{j<k} |C A^{k−1−j} Cᵀ| ε`` (docs/forecast.md)."""
    sigma = np.tile(model_error_k, (config.horizon_steps, 1))
    return comfort_margins(model.a, model.c.T, model.c, sigma)


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
        (docs/estimation.md) added to δ when the MPC is robust; None = full state.
    linearisation : ``"fixed"`` (``model`` throughout) or ``"trajectory"`` (re-linearised
        each step about the previous plan shifted by one step, docs/estimation.md §3).
    model_error_k : (m,) calibrated one-step model error per zone [K per step]
        (:func:`hvacflex.data.calibration.calibrate_box`); its margin
        (:func:`model_error_margins`) tightens the comfort band on top of δ when the MPC is
        robust; None = no model-error term.
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
        self._building = building
        self._reserve = reserve if reserve is not None else ReserveConfig()
        self._model = model
        self._config = config
        self._box = box
        self._temp_ref_degc = linearisation_temp_degc
        hvac = building.hvac
        self._flow_max = np.asarray(hvac.flow_max_kg_s, dtype=float)
        self._mask = np.array(
            [config.reserve and zone in hvac.reserve_zones for zone in building.zone_names]
        )
        self._outdoor_index = next(
            i for i, ch in enumerate(model.channels) if ch.kind == "outdoor_temp"
        )
        self._thermostat = ThermostatController(model, hvac, config.thermostat_setpoint_degc)
        self._solver: WarmSolver | None = None
        self._pending_basis: SolverBasis | None = None
        self._previous_plan: RMPCSolution | None = None
        self._baseline_kw: float | None = None
        self._baseline_ahead_kw: FloatArray | None = None
        self._meter_ratio = math.nan
        """ρ told by the control step (NaN: never told, offers on the model's own scale)."""
        self._commit_ahead = (
            self._reserve.commit_ahead_periods
            if self._reserve.event_max_steps is not None and config.reserve
            else 0
        )
        self._committed_kg_s = np.zeros((0, len(building.zone_names)))
        self._previous_planned_kw: float | None = None
        self._plan_seen_kw: FloatArray | None = None
        """What the last optimal plan's baselines could see (:meth:`_seen_kw`)."""
        self._periods_since_plan = 0
        """Periods begun since the last optimal plan was made (decided or held)."""
        self._plan_age = 0
        """Fallbacks since the last optimal plan (0: the plan is this period's own)."""
        self._estimator = KalmanEstimator(estimation) if estimation is not None else None
        self._network = build_network(building) if linearisation == "trajectory" else None
        self._step_model: StepModel = model
        self._solver_model: StepModel = model
        self._held = False
        self.takes_measurements = estimation is not None
        self._observers: list[Callable[[RMPCProblem], None]] = []
        self._model_error_margin_k = (
            None
            if model_error_k is None or config.robust == "none"
            else model_error_margins(model, np.asarray(model_error_k, dtype=float), config)
        )

    @property
    def last_plan(self) -> RMPCSolution | None:
        """The last optimal plan over the horizon (None before the first)."""
        return self._previous_plan

    def observe_problems(self, callback: Callable[[RMPCProblem], None]) -> bool:
        """Call ``callback`` with the problem of every later :meth:`act`."""
        self._observers.append(callback)
        return True

    @property
    def step_model(self) -> StepModel:
        """The model (a, b, e, g, c) the last decision was planned with (its first step)."""
        return self._step_model

    def note_applied_flow(self, flow_kg_s: FloatArray) -> None:
        """The flow the plant actually ran this period (u − r under IL activation), or where
        the plant reads its supply air the cooling the air delivered as a flow
        (:meth:`hvacflex.sim.step.ControlStep.note_delivered_flow`), for the filter's next
        prediction; no-op without a filter."""
        if self._estimator is not None and self._estimator.last is not None:
            last = self._estimator.last
            self._estimator.applied(replace(last, flow_kg_s=np.asarray(flow_kg_s, dtype=float)))

    def hold(
        self,
        forecast: Forecast,
        flow_kg_s: FloatArray,
        measured_zone_temp_degc: FloatArray | None = None,
    ) -> None:
        """A period the plant runs a locked IL-event plan (flow (m,) [kg/s]) without asking
        :meth:`act`: the filter still takes the measurement (m,) [°C] and predicts over the
        period, with the fixed model (the last plan is stale: the next :meth:`act` does not
        re-linearise about it)."""
        self._step_model, self._held = self._model, True
        self._periods_since_plan += 1
        if self._estimator is None or measured_zone_temp_degc is None:
            return
        self._estimator.estimate(measured_zone_temp_degc, self._model)
        sigma = self._box.sigma(forecast.disturbances[:1], self._model.channels)[0]
        flow = np.asarray(flow_kg_s, dtype=float)
        self._estimator.applied(AppliedStep(self._model, flow, forecast.disturbances[0], sigma))

    @property
    def commits_ahead(self) -> int:
        """g (``[reserve] commit_ahead_periods``) under the event model with reserve offered,
        else 0 (the whole-horizon model decides each period's offer at its start)."""
        return self._commit_ahead

    def note_commitments(self, reserve_flow_kg_s: FloatArray) -> None:
        self._committed_kg_s = np.array(reserve_flow_kg_s, dtype=float).reshape(
            -1, len(self._flow_max)
        )

    def _fixed_reserve_kg_s(self, u_min: FloatArray) -> FloatArray | None:
        """(g, m) committed reserve flows of the first g steps, clipped into the room
        [0, u_max − u_min] of each step and the reserve mask (None: no commitments)."""
        if not self._commit_ahead:
            return None
        committed = self._committed_kg_s[: self._commit_ahead]
        room = np.maximum(self._flow_max - u_min[: committed.shape[0]], 0.0)
        fixed: FloatArray = np.where(self._mask, np.clip(committed, 0.0, room), 0.0)
        return fixed

    @property
    def reserve_mask(self) -> np.ndarray:
        """(m,) bool: zones allowed to offer reserve."""
        return self._mask

    def problem(
        self,
        x_degc: FloatArray,
        forecast: Forecast,
        peak_floor_kw: float,
        allowance_carry_steps: int = 0,
        *,
        step_model: StepModel | None = None,
        offset_k: FloatArray | None = None,
        extra_margin_k: FloatArray | None = None,
    ) -> RMPCProblem:
        """The RMPC problem for the period starting now.

        ``allowance_carry_steps``: see :class:`hvacflex.control.base.PeriodInputs` (ignored
        under the whole-horizon model). ``step_model`` replaces the dynamics (a, b, e, g) of
        the fixed model (trajectory linearisation); ``offset_k`` (m,) [K per step] is added to
        the zone nodes' affine term (the filter's offset estimate); ``extra_margin_k`` (N, m)
        [K] tightens the comfort bounds on top of δ (the estimation margin).
        """
        cfg, m = self._config, self._model
        dyn = step_model if step_model is not None else m
        affine = np.asarray(dyn.g, dtype=float)
        if offset_k is not None:
            affine = affine + m.c.T @ offset_k
        horizon = cfg.horizon_steps
        d_hat = forecast.disturbances[:horizon]
        if d_hat.shape[0] < horizon:
            raise ConfigError(
                f"the forecast covers {d_hat.shape[0]} periods, fewer than the horizon",
                field="controller.horizon_steps",
                value=horizon,
                hint="load the data for steps + horizon_steps periods (load_exogenous)",
            )
        if cfg.robust == "none":
            sigma = np.zeros_like(d_hat)
        else:
            sigma = self._box.sigma(d_hat, m.channels)
        u_min = self._building.hvac.flow_min_at(forecast.occupied[:horizon])
        y_min, y_max = comfort_bounds_at_period_ends(forecast, horizon)
        if extra_margin_k is not None:
            y_min, y_max = tightened_bounds(y_min, y_max, extra_margin_k)
        p0, p, reserve_coeff = self._power_coefficients(x_degc, forecast, d_hat, u_min, y_min)
        reserve_price = forecast.reserve_price_sgd_per_mwh[:horizon]
        if not cfg.reserve:
            reserve_price = np.zeros_like(reserve_price)
        floor = peak_floor_kw if cfg.billing_mode == "billing-period" else 0.0
        events = self._reserve.event_max_steps is not None
        return RMPCProblem(
            a_matrix=dyn.a,
            b_matrix=dyn.b,
            e_matrix=dyn.e,
            c_matrix=m.c,
            affine_term=affine,
            x0=np.asarray(x_degc, dtype=float),
            d_forecast=d_hat,
            d_sigma=sigma,
            energy_price_sgd_per_mwh=forecast.energy_price_sgd_per_mwh[:horizon],
            reserve_price_sgd_per_mwh=reserve_price,
            peak_price_sgd_per_kw=effective_peak_price(forecast, cfg.peak_price_sgd_per_kw),
            peak_floor_kw=floor,
            power_offset_kw=p0,
            power_coeff_kw_per_kg_s=p,
            reserve_power_coeff_kw_per_kg_s=(
                self._offer_scale * np.minimum(reserve_coeff, p) if events else None
            ),
            u_min=u_min,
            u_max=self._flow_max,
            y_min=y_min,
            y_max=y_max,
            reserve_mask=self._mask,
            comfort_penalty_sgd_per_kelvin_hour=cfg.comfort_penalty_sgd_per_kelvin_hour,
            dt_h=m.dt_s / SECONDS_PER_HOUR,
            robust=cfg.robust,
            feedback=(
                FeedbackOptions(
                    structure=cfg.feedback.structure, memory_steps=cfg.feedback.memory_steps
                )
                if cfg.robust == "feedback"
                else None
            ),
            reserve_fixed_kg_s=self._fixed_reserve_kg_s(u_min),
            offer_baselines=(
                self._offer_baselines(horizon, self._seen_steps(horizon))
                if events and cfg.reserve and self._reserve.plan_visible_offers
                else None
            ),
            **self._event_fields(horizon, allowance_carry_steps),
        )

    def _offer_baselines(
        self, horizon: int, offer_steps: BoolArray | None = None
    ) -> OfferBaselines:
        """The settlement baselines of the horizon's offers (event model), as the driver told
        them (:meth:`note_baseline_power`): its similar-days baseline where it has one, else
        the plan's own powers P̂_{s−1} and, for the starts s = 0, :meth:`_baseline_now`. The
        LP pays only what they see at ``offer_steps`` (``[reserve] plan_visible_offers``)
        and :meth:`_visible_offers_kw` sizes the offers to them."""
        reserve = self._reserve
        assert reserve.event_max_steps is not None
        fixed = np.full(horizon, np.nan)
        on_plan = np.zeros(horizon, dtype=bool)
        planned = np.ones(horizon, dtype=bool)
        ahead = self._baseline_ahead_kw
        known = 0 if ahead is None else min(len(ahead), horizon)
        if ahead is not None:
            similar = np.isfinite(ahead[:known])
            fixed[:known][similar] = ahead[:known][similar]
            planned[:known][similar] = False
        now = self._baseline_now()
        if now is not None:
            kind, value = now
            starts_now = np.arange(horizon) < reserve.event_max_steps
            starts_now &= planned  # a similar-days baseline replaces the pre-event ones
            fixed[starts_now] = value
            on_plan[starts_now] = kind == "planned"
        return OfferBaselines(
            meter_ratio=self._offer_scale,
            fixed_baseline_kw=fixed,
            fixed_on_plan_scale=on_plan,
            planned_baselines=planned,
            offer_steps=offer_steps,
            tolerance_kw=BASELINE_TOLERANCE_KW,
        )

    def _seen_steps(self, horizon: int) -> BoolArray | None:
        """(N,) bool: the steps at which the last plan could have shown an offer — shedding
        all it could (u − u_min) would have reached every baseline (:meth:`_seen_kw` ≥ 0,
        moved to this step, its last step repeated); None (every step) without such a plan.
        The others — an air handler off before, a start-up steeper than any shed — are not
        paid at all, rather than charged for a rise no offer could show."""
        seen = self._plan_seen_kw
        if seen is None:
            return None
        shift = self._periods_since_plan
        moved = np.concatenate([seen[shift:], np.repeat(seen[-1:], min(shift, seen.size))])
        steps: BoolArray = moved[:horizon] >= 0.0
        return steps

    def _power_coefficients(
        self,
        x_degc: FloatArray,
        forecast: Forecast,
        d_hat: FloatArray,
        u_min: FloatArray,
        y_min: FloatArray,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The LP's power rows ``P_k = p0_k + p_kᵀ u_k`` ((N,), (N, m)) and the reserve's
        power per kg/s (N, m), from the building's power model at the forecast (outdoor air,
        its humidity, the occupants' latent gain) over the step's flow range [u_min, u_max]."""
        horizon = d_hat.shape[0]
        identified = self._building.identified
        if identified is not None:  # the power model fitted to the building's meter
            p0, p = identified_affine_power(
                identified,
                d_hat[:, self._outdoor_index],
                self._temp_ref_degc,
                forecast.occupied[:horizon].astype(np.float64),
            )
            return p0, p, p
        latent = forecast.occupant_latent_w[:horizon]
        p0, p = affine_power_model(
            self._building.hvac,
            d_hat[:, self._outdoor_index],
            forecast.outdoor_humidity_ratio_kg_per_kg[:horizon],
            self._temp_ref_degc,
            latent_gain_w=latent if latent.size == horizon else 0.0,
            flow_min_kg_s=u_min,
        )
        reserve_coeff = reserve_power_coeff(
            self._building.hvac,
            d_hat[:, self._outdoor_index],
            forecast.outdoor_humidity_ratio_kg_per_kg[:horizon],
            self._return_air_estimate_degc(x_degc, y_min),
            self._curtailed_flow_estimate_kg_s(u_min),
        )
        return p0, p, reserve_coeff

    def _event_fields(self, horizon: int, allowance_carry_steps: int) -> dict[str, Any]:
        """The ``il_*`` fields of the problem from the IL contract (none: whole horizon)."""
        reserve = self._reserve
        if reserve.event_max_steps is None:
            return {"il_event_max_steps": None}
        return {
            "il_event_max_steps": min(reserve.event_max_steps, horizon),
            "il_event_allowance_kelvin": reserve.event_allowance_k,
            "il_event_recovery_steps": reserve.event_recovery_steps,
            "il_allowance_carry_steps": min(allowance_carry_steps, horizon),
        }

    def _return_air_estimate_degc(self, x_degc: FloatArray, y_min: FloatArray) -> FloatArray:
        """(N, m) zone (return-air) temperatures at which the coil term of the reserve's
        power is taken [°C]: the previous plan's served zone temperatures at the start of
        each step, one step on (now: the measured state), never below the lower comfort
        bound. Curtailment only warms the zones, so the curtailed return air is warmer and
        its coil power per kg/s larger: a lower bound while the plan holds."""
        c = self._model.c
        plan = self._previous_plan
        horizon = y_min.shape[0]
        if plan is None or plan.x_served.shape[0] != horizon + 1:
            start = np.broadcast_to(c @ np.asarray(x_degc, dtype=float), y_min.shape)
        else:
            served = plan.x_served[1:] @ c.T  # start of the new steps 0 … N − 1
            start = np.concatenate([(c @ np.asarray(x_degc, dtype=float))[None], served[1:]])
        estimate: FloatArray = np.maximum(start, y_min)
        return estimate

    def _curtailed_flow_estimate_kg_s(self, u_min: FloatArray) -> FloatArray:
        """(N,) total flow after curtailment at which the fan's tangent bounds the reserve's
        power [kg/s]: the previous plan's Σ(u − r), one step on (its last step repeated), never
        below the step's Σ u_min; Σ u_min alone without a previous plan."""
        low: FloatArray = np.asarray(u_min, dtype=float).sum(axis=1)
        plan = self._previous_plan
        if plan is None or plan.u.shape[0] != low.size:
            return low
        curtailed = (plan.u - plan.r).sum(axis=1)
        shifted = np.concatenate([curtailed[1:], curtailed[-1:]])
        estimate: FloatArray = np.maximum(shifted, low)
        return estimate

    def act(self, inputs: PeriodInputs) -> Action:
        """Decide the period's action from the plant state ``inputs.x_degc`` (n,) (full
        state) or, with a filter, from the measured zone temperatures (m,) [°C] alone;
        ``inputs.plan``: an ``RMPCSolution`` of this period's problem decided elsewhere (the
        fleet coordinator's), applied as if the solver had returned it."""
        x_degc, forecast = inputs.x_degc, inputs.forecast
        measured_zone_temp_degc = inputs.measured_zone_temp_degc
        self._periods_since_plan += 1
        offset = extra = None
        if self._estimator is not None:
            if measured_zone_temp_degc is None:
                raise ConfigError(
                    "the Kalman filter needs the measured zone temperatures",
                    field="estimation.mode",
                    value="kalman",
                    hint="pass measured_zone_temp_degc (the closed loop does so)",
                )
            estimate = self._estimator.estimate(measured_zone_temp_degc, self._model)
            x_degc, offset = estimate.x_degc, estimate.offset_k
        step_model: StepModel = self._model
        previous = self._previous_plan
        fresh = previous is not None and self._plan_age == 0 and not self._held
        self._previous_planned_kw = (
            float(previous.power_kw[0]) if previous is not None and fresh else None
        )
        if self._network is not None and previous is not None and fresh:
            step_model = relinearised_first_step(
                self._building,
                self._network,
                self._model.c,
                previous.u,
                previous.x_served,
                self._model.c @ x_degc,
                self._model.dt_s,
            )
        horizon = self._config.horizon_steps
        sigma = self._box.sigma(forecast.disturbances[:horizon], self._model.channels)
        if self._estimator is not None and self._config.robust != "none":
            extra = self._estimator.margins(step_model, sigma.max(axis=0), horizon)
        if self._model_error_margin_k is not None:
            model_margin = self._model_error_margin_k
            extra = model_margin if extra is None else extra + model_margin
        problem = self.problem(
            x_degc,
            forecast,
            inputs.peak_floor_kw,
            inputs.allowance_carry_steps,
            step_model=step_model,
            offset_k=offset,
            extra_margin_k=extra,
        )
        for observe in self._observers:
            observe(problem)
        if self._solver is not None and step_model is not self._solver_model:
            self._carry_basis_to(problem)
        self._solver_model = step_model
        action = self._decide(problem, x_degc, forecast, inputs.plan)
        self._step_model, self._held = step_model, False
        if self._estimator is not None:
            self._estimator.applied(
                AppliedStep(step_model, action.flow_kg_s, forecast.disturbances[0], sigma[0])
            )
        return action

    def _carry_basis_to(self, problem: RMPCProblem) -> None:
        """A new model is a new LP structure: start a new solver from the old one's basis
        (same columns and rows, so the basis stays valid and is rotated as usual)."""
        assert self._solver is not None
        basis = self._solver.get_basis()
        self._solver = None
        self._pending_basis = (
            None if basis is None else replace(basis, fingerprint=problem.structure.fingerprint())
        )

    def _decide(
        self,
        problem: RMPCProblem,
        x_degc: FloatArray,
        forecast: Forecast,
        plan: RMPCSolution | None = None,
    ) -> Action:
        if self._solver is None:
            self._solver = make_solver(problem, time_limit_s=self._config.time_limit_s)
            pending = self._pending_basis
            if pending is not None and self._network is not None:
                # trajectory linearisation: every step is a new structure of the same layout
                pending = replace(pending, fingerprint=problem.structure.fingerprint())
            if pending is not None:
                try:
                    self._solver.set_basis(pending)
                except ProblemError:  # another row count (e.g. lazy event rows): cold start
                    pass
                self._pending_basis = None
        solution = plan if plan is not None else self._solver.solve(problem)
        if solution.status is SolveStatus.OPTIMAL:
            self._previous_plan, self._plan_age = solution, 0
            self._plan_seen_kw = self._seen_kw(problem, solution)
            self._periods_since_plan = 0
            c = self._model.c
            # the LP's solution satisfies its bounds to the solver tolerance (~1e-9): snap
            # the flows of every step an offer is sized for onto the physical limits, once
            flows, reserves = self._snapped_reserve_kg_s(problem, solution, self._offer_steps)
            visible_kw = self._visible_offers_kw(problem, solution.power_kw, reserves)
            flow, reserve = flows[0], reserves[0]
            offer_kw = float(problem.reserve_kw_per_kg_s[0] @ reserve)
            if not self._commit_ahead:  # decided now: offer only what the baseline sees
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
                event_plan=self._event_plan(problem, solution, flows, reserves, visible_kw),
                predicted_event_worst_degc=np.asarray(solution.y_event_worst[0], dtype=float),
                offer_ahead=self._offer_ahead(reserves, visible_kw),
                offer_meter_ratio=self._meter_ratio,
            )
        return self._fallback(x_degc, forecast, solution)

    def _seen_kw(self, problem: RMPCProblem, solution: RMPCSolution) -> FloatArray | None:
        """(N,) how far below every baseline of the problem's offer baselines the plan's
        power would fall if each step shed all it could, u − u_min on the reserve zones
        [kW]: negative where no offer could be seen (None without offer baselines)."""
        baselines = problem.offer_baselines
        max_steps = self._reserve.event_max_steps
        if baselines is None or max_steps is None:
            return None
        room = np.where(self._mask, np.maximum(solution.u - problem.u_min, 0.0), 0.0)
        return baselines.seen_kw(
            solution.power_kw,
            np.einsum("km,km->k", problem.power_coeff_kw_per_kg_s, room),
            np.full(problem.horizon, np.inf),
            min(max_steps, problem.horizon),
        )

    def _snapped_reserve_kg_s(
        self, problem: RMPCProblem, solution: RMPCSolution, steps: int
    ) -> tuple[FloatArray, FloatArray]:
        """(steps, m) each: the plan's u and r of the first ``steps`` steps snapped onto the
        physical limits (u_min ≤ u − r, u ≤ u_max; u within ``FLOW_SNAP_TOLERANCE_KG_S`` of a
        limit is the limit; r below the solver tolerance is 0)."""
        low = np.asarray(problem.u_min, dtype=float)[:steps]
        high = np.broadcast_to(self._flow_max, low.shape)
        flow = np.clip(solution.u[:steps], low, high)
        flow = np.where(flow - low < FLOW_SNAP_TOLERANCE_KG_S, low, flow)
        flow = np.where(high - flow < FLOW_SNAP_TOLERANCE_KG_S, high, flow)
        reserve = np.clip(solution.r[:steps], 0.0, flow - low)
        reserve[reserve < RESERVE_FLOW_TOLERANCE_KG_S] = 0.0
        return flow, reserve

    @property
    def _offer_steps(self) -> int:
        """J: the plan's steps 0 … J − 1 an offer may be sized for — now (g = 0), the
        committed one g and, under the event model, the event plan's D + R."""
        events = self._reserve.event_max_steps
        event_steps = 1 if events is None else events + self._reserve.event_recovery_steps
        return min(max(self._commit_ahead + 1, event_steps), self._config.horizon_steps)

    def _offer_ahead(self, reserves: FloatArray, visible_kw: FloatArray) -> ReserveOffer | None:
        """The offer committed now for the period g steps ahead: the plan's snapped r_g
        (``reserves`` (J, m)), sized to what the baseline would see (``visible_kw`` (J,),
        :meth:`_visible_offers_kw`); None without commitments."""
        g = self._commit_ahead
        if not g:
            return None
        offer_kw = float(visible_kw[g])
        flow = reserves[g] if offer_kw > 0.0 else np.zeros_like(reserves[g])
        return ReserveOffer(flow_kg_s=flow, reserve_kw=offer_kw, meter_ratio=self._meter_ratio)

    def note_baseline_power(
        self, baseline_power_kw: float | None, ahead_kw: FloatArray | None = None
    ) -> None:
        self._baseline_kw = baseline_power_kw
        self._baseline_ahead_kw = None if ahead_kw is None else np.asarray(ahead_kw, dtype=float)

    def note_meter_response(self, ratio: float) -> None:
        self._meter_ratio = float(ratio)

    @property
    def _offer_scale(self) -> float:
        """ρ, or 1 where the control step told none."""
        return 1.0 if math.isnan(self._meter_ratio) else self._meter_ratio

    def _baseline_now(self) -> tuple[str, float] | None:
        """The baseline of an activation starting now: ``("planned", P̂)``, the plan made for
        the period before, where that is known and at least the metered B (the affine model
        runs above the metered power: the fan secant, so the plan's own power is the
        baseline on the scale of the curtailed power it is compared with); else
        ``("metered", B)`` (−inf where B is NaN, the run's first period: nothing is seen);
        None: unknown to the driver (that start is skipped)."""
        baseline = self._baseline_kw
        if baseline is None:
            return None
        if not np.isfinite(baseline):
            return ("metered", -np.inf)
        previous = self._previous_planned_kw
        if previous is not None and previous >= baseline:
            return ("planned", previous)
        return ("metered", baseline)

    def _visible_offers_kw(
        self, problem: RMPCProblem, served_kw: FloatArray, reserve_flow_kg_s: FloatArray
    ) -> FloatArray:
        """(J,) the capacity offered for each step j < J with reserve flows r_j
        (``reserve_flow_kg_s`` (J, m)) [kg/s]: q_j·r_j, but no more than the settlement
        baselines would see of it [kW], at least 0.

        An activation covering step j starts at some s ∈ [j − D + 1, j] (s ≥ 0) and is settled
        against the power of the period before s (``pre-event``): the plan's served power
        P̂_{s−1} for s ≥ 1, and :meth:`_baseline_now` for s = 0 (skipped where unknown).
        Under ``similar-days`` the baseline of step j is the driver's (the metered power of
        earlier similar days, whenever the activation starts), and the pre-event ones apply
        only where it has none (no similar day yet, as in the settlement). The curtailed
        power must show the offer below every such baseline
        (:meth:`~hvacflex.opt.problem.OfferBaselines.seen_kw` of :meth:`_offer_baselines`):
        a period whose air handler was off before, a rising morning load, show less. ρ ∈
        [0, 1] is the meter's response to the plan's power (:meth:`note_meter_response`;
        the problem's q carries it too): a change of the plan's power shows as ρ times it
        on the meter, so the gap to a baseline of the plan's own is ρ·(P̂_{s−1} − P̂_j), and
        to a metered baseline B (its level against the plan's level, as without ρ) B − P̂_j.
        ``served_kw`` (N,) is the plan's P̂ [kW]. The whole-horizon model (the paper's)
        offers q_j·r_j unchecked."""
        served = np.asarray(served_kw, dtype=float)
        steps = reserve_flow_kg_s.shape[0]
        offer_kw = np.einsum("km,km->k", problem.reserve_kw_per_kg_s[:steps], reserve_flow_kg_s)
        max_steps = self._reserve.event_max_steps
        if max_steps is None:
            visible: FloatArray = np.maximum(offer_kw, 0.0)
            return visible
        horizon = problem.horizon
        shed_kw = np.zeros(horizon)
        shed_kw[:steps] = np.einsum(
            "km,km->k", problem.power_coeff_kw_per_kg_s[:steps], reserve_flow_kg_s
        )
        offers_kw = np.zeros(horizon)
        offers_kw[:steps] = offer_kw
        seen = self._offer_baselines(horizon).seen_kw(
            served, shed_kw, offers_kw, min(max_steps, horizon)
        )
        visible = np.maximum(seen[:steps], 0.0)
        return visible

    def _event_plan(
        self,
        problem: RMPCProblem,
        solution: RMPCSolution,
        flows: FloatArray,
        reserves: FloatArray,
        visible_kw: FloatArray,
    ) -> EventPlan | None:
        """The first D + R steps of an optimal plan, for an IL event starting now, from its
        snapped flows and reserve flows (J, m) and their visible offers (J,)
        (:meth:`_visible_offers_kw`). ``None`` under the whole-horizon model (an activation
        then curtails each period's fresh plan).
        """
        reserve = self._reserve
        if reserve.event_max_steps is None:
            return None
        steps = min(reserve.event_max_steps + reserve.event_recovery_steps, solution.u.shape[0])
        flow, flow_reserve = flows[:steps], reserves[:steps].copy()
        reserve_coeff = np.asarray(problem.reserve_kw_per_kg_s, dtype=float)[:steps]
        offer_kw = np.einsum("km,km->k", reserve_coeff, flow_reserve)
        # committed steps (< g) were offered before; the others are offered from this plan
        end = steps if self._commit_ahead else min(reserve.event_max_steps, steps)
        checked = slice(self._commit_ahead, end)
        offer_kw[checked] = visible_kw[checked]
        flow_reserve[checked][visible_kw[checked] <= 0.0] = 0.0
        coeff = np.asarray(problem.power_coeff_kw_per_kg_s, dtype=float)[:steps]
        offset = np.asarray(problem.power_offset_kw, dtype=float)[:steps]
        c = self._model.c
        return EventPlan(
            flow_kg_s=flow,
            reserve_flow_kg_s=flow_reserve,
            served_power_kw=offset + np.einsum("km,km->k", coeff, flow),
            reserve_kw=offer_kw,
            predicted_served_degc=solution.x_served[1 : steps + 1] @ c.T,
            predicted_curtailed_degc=solution.x_curtailed[1 : steps + 1] @ c.T,
            meter_ratio=self._meter_ratio,
        )

    def _fallback(self, x_degc: FloatArray, forecast: Forecast, failed: RMPCSolution) -> Action:
        """The last plan's step for this period if it reaches this far (shifted by every
        period begun since it was made, held IL-event periods included), else the
        thermostat."""
        self._plan_age += 1
        plan = self._previous_plan
        shift = self._periods_since_plan
        if plan is not None and shift < plan.u.shape[0]:
            low = self._building.hvac.flow_min_at(forecast.occupied[:1])[0]
            flow = np.clip(plan.u[shift], low, self._flow_max)
        else:
            flow = self._thermostat.flows_now(x_degc, forecast)
        return unplanned_action(
            self._model,
            x_degc,
            flow,
            forecast.disturbances[0],
            status=failed.status.value,
            fallback=True,
            solve_time_s=failed.solve_time_s,
            plan_margin_k=float("nan"),
        )

    def get_state(self) -> dict[str, Any]:
        return {
            "basis": self._solver.get_basis() if self._solver is not None else self._pending_basis,
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
        if self._solver is not None:
            basis = self._solver.get_basis()
            self._solver = None
            self._pending_basis = basis

    def set_state(self, state: dict[str, Any]) -> None:
        basis = state["basis"]
        if self._solver is not None and basis is not None:
            self._solver.set_basis(basis)
        else:
            self._pending_basis = basis
        self._previous_plan = state["previous_plan"]
        self._plan_seen_kw = state.get("plan_seen_kw")
        self._plan_age = state["plan_age"]
        self._periods_since_plan = int(state.get("periods_since_plan", self._plan_age))
        if self._estimator is not None and state.get("estimator") is not None:
            self._estimator.set_state(state["estimator"])
        self._step_model = state.get("step_model", self._model)
        self._held = bool(state.get("held", False))
        self._solver_model = self._step_model if self._network is not None else self._model
