"""Building + forecast → :class:`~hvacflex.opt.RMPCProblem`: the one place that builds it.

:func:`build_problem` is pure: the same model, period inputs, contract and plan context give
the same problem (docs/explanation/model.md §3):

* dynamics ``x+ = A x + B u + E d + g`` from :func:`hvacflex.building.discretize.linearize`
  (or the step model of a re-linearisation), the filter's offset in the affine term,
* power ``P_k = p0_k + p_kᵀ u_k`` from :func:`hvacflex.building.hvac.affine_power_model` at the
  forecast outdoor temperature and humidity and the zone temperature T₀, outdoor air only
  where the damper is open (occupied steps and the pre-occupancy purge, as the plant; a building
  identified from data, or a designed building with a power model fitted to its plant's
  meter (``Building.metered_power``): that model,
  :func:`hvacflex.building.identified.metered_affine_power`, re-linearised along the
  previous plan's total flow; :func:`lp_power_rows` is the one function over arrays),
* comfort bounds for ``C x_{k+1}``, the temperature at the end of period k: the tighter of
  the bands of periods k and k + 1, so that the instant occupancy starts (and ends) is
  inside the occupied band, the upper bound of unoccupied period ends lowered by
  ``[controller] unoccupied_plan_margin_k`` and the lower bound raised by
  ``lower_plan_margin_k`` (:func:`~hvacflex.control.plan_band.controller_band`: the plan
  rides neither the night bound nor the lower bound) and tightened by the estimation and
  model-error margins,
* flow bounds from the building's air system (occupied: ventilation, else the minimum); where
  an identified building's coil is scheduled off (``[identified.idle_air]``), an idle zone's
  lower bound is the input its fan-only air delivers
  (:func:`hvacflex.control.idle_air.idle_flow_min_kg_s`), not its
  minimum flow at the coil's temperature,
* σ from the scenario's uncertainty box (zero for the nominal MPC),
* prices, the peak-power price φ and, in billing-period mode, the month's peak so far,
* while φ > 0, the committed cap on the morning pull-down: P_k ≤ the cap in force (the
  previous plan's peak or the month's billed peak, the larger) in the steps of
  :func:`pull_down_steps`, never below the step's least power (:func:`pull_down_power_max_kw`;
  not with ``robust = "feedback"``, whose LP has no power column),
* the interruptible-load contract of the scenario's ``[reserve]`` table: the event length D,
  the allowance α, the recovery R, the recovery steps c still running from an event that
  just ended, the reserve committed ahead and the offers' settlement baselines
  (``RMPCProblem.events``, ``commitments``, ``offer_baselines``); ``None`` for D keeps
  the whole-horizon model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from hvacflex.building.discretize import LinearModel
from hvacflex.building.hvac import affine_power_model, reserve_power_coeff
from hvacflex.building.identified import (
    IdentifiedPower,
    metered_affine_power,
    metered_reserve_coeff,
)
from hvacflex.building.model import Building
from hvacflex.config import ControllerConfig, ReserveConfig
from hvacflex.control.base import FloatArray, PeriodInputs
from hvacflex.control.estimation import StepModel, tightened_bounds
from hvacflex.control.idle_air import idle_flow_min_kg_s
from hvacflex.control.plan_band import controller_band
from hvacflex.control.plan_linearisation import plan_linearisation
from hvacflex.data.forecast import Forecast
from hvacflex.data.signals import effective_peak_price
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.errors import ConfigError
from hvacflex.opt import (
    ComfortKnee,
    FeedbackOptions,
    ILEventModel,
    OfferBaselines,
    PowerCap,
    ReserveCommitment,
    RMPCProblem,
    RMPCSolution,
)
from hvacflex.opt.robust import comfort_margins
from hvacflex.units import SECONDS_PER_HOUR


def model_error_margins(
    model: LinearModel, model_error_k: FloatArray, config: ControllerConfig
) -> FloatArray:
    """Comfort margin (N, m) [K] of a per-zone one-step model error ``|ε_z| ≤ model_error_k``
    (m,) [K per step] entering every step's zone temperature: the box margin of
    :func:`hvacflex.opt.robust.comfort_margins` with ``E = Cᵀ`` and σ = ε,
    ``Σ_{j<k} |C A^{k−1−j} Cᵀ| ε`` (docs/explanation/forecast.md)."""
    sigma = np.tile(model_error_k, (config.horizon_steps, 1))
    return comfort_margins(model.a, model.c.T, model.c, sigma)


PULL_DOWN_LEAD_STEPS = 8
"""Unoccupied steps before an occupied spell that count as its pull-down (4 h of 30 min)."""
PULL_DOWN_OCCUPIED_STEPS = 2
"""The spell's first occupied steps that count as its pull-down (1 h of 30 min)."""


def pull_down_steps(
    occupied: np.ndarray,
    horizon: int,
    lead_steps: int = PULL_DOWN_LEAD_STEPS,
    occupied_steps: int = PULL_DOWN_OCCUPIED_STEPS,
) -> np.ndarray:
    """(N,) bool: the steps of a morning pull-down, the ``lead_steps`` steps before each
    occupied spell that starts inside the plan (step 1 … N, the spell starting at N
    included where ``occupied`` covers it) and its first ``occupied_steps`` steps.

    Parameters
    ----------
    occupied : (≥ N,) bool, the forecast's occupied periods from now on.
    horizon : N.
    """
    occ = np.asarray(occupied, dtype=bool)[: horizon + 1]
    starts = np.flatnonzero(occ[1:] & ~occ[:-1]) + 1
    mask = np.zeros(horizon, dtype=bool)
    for start in starts:
        mask[max(start - lead_steps, 0) : min(start + occupied_steps, horizon)] = True
    return mask


def pull_down_power_max_kw(
    phi_sgd_per_kw: float,
    committed_kw: float,
    pull_down: np.ndarray,
    least_power_kw: FloatArray,
) -> float | FloatArray:
    """The plan's power cap [kW]: +inf (a scalar) where φ = 0 or no cap is in force
    (``committed_kw`` NaN or ≤ 0); else (N,) ``committed_kw`` in the ``pull_down`` steps,
    never below ``least_power_kw`` (N,) (the step's power at its least flows, so the LP stays
    feasible), +inf elsewhere."""
    if not (phi_sgd_per_kw > 0.0 and np.isfinite(committed_kw) and committed_kw > 0.0):
        return np.inf
    capped: FloatArray = np.where(
        np.asarray(pull_down, dtype=bool), np.maximum(committed_kw, least_power_kw), np.inf
    )
    return capped


def committed_cap_in_force_kw(previous: RMPCSolution | None, billed_peak_kw: float) -> float:
    """The committed cap a new plan starts under [kW]: the larger of the previous plan's
    peak (``RMPCSolution.peak_kw``) and the month's billed peak so far; NaN where neither is
    positive."""
    planned = float("nan") if previous is None else float(previous.peak_kw)
    candidates = [v for v in (planned, billed_peak_kw) if np.isfinite(v) and v > 0.0]
    return max(candidates) if candidates else float("nan")


@dataclass(frozen=True)
class PlanContract:
    """What a building's MPC plans under, fixed for a run.

    Attributes
    ----------
    building : the building (HVAC limits, reserve zones, its power model).
    model : its discrete linear model at the control step (the fixed one).
    config : controller settings (robust mode, reserve, φ, billing mode, horizon).
    reserve : the IL contract (event length, allowance, recovery, commitments).
    box : the forecast-error box (ignored when ``config.robust == "none"``).
    linearisation_temp_degc : T₀ of the power coefficients [°C].
    reserve_mask : (m,) bool, zones allowed to offer reserve.
    commit_ahead : g, periods ahead that reserve is committed (0: decided at the start).
    """

    building: Building
    model: LinearModel
    config: ControllerConfig
    reserve: ReserveConfig
    box: UncertaintyBox
    linearisation_temp_degc: float
    reserve_mask: np.ndarray
    commit_ahead: int

    @classmethod
    def of(
        cls,
        building: Building,
        model: LinearModel,
        config: ControllerConfig,
        box: UncertaintyBox,
        linearisation_temp_degc: float,
        reserve: ReserveConfig,
    ) -> PlanContract:
        """The contract of a building's MPC (mask and g from its settings)."""
        hvac = building.hvac
        mask = np.array(
            [config.reserve and zone in hvac.reserve_zones for zone in building.zone_names]
        )
        events = reserve.event_max_steps is not None
        commit = reserve.commit_ahead_periods if events and config.reserve else 0
        return cls(building, model, config, reserve, box, linearisation_temp_degc, mask, commit)

    @property
    def flow_max_kg_s(self) -> FloatArray:
        """(m,) largest supply flow per zone [kg/s]."""
        return np.asarray(self.building.hvac.flow_max_kg_s, dtype=float)

    @property
    def events(self) -> bool:
        """True under the event model (``[reserve] event_max_steps`` set)."""
        return self.reserve.event_max_steps is not None

    @property
    def outdoor_index(self) -> int:
        """The position of the outdoor temperature among the disturbance channels."""
        return next(i for i, ch in enumerate(self.model.channels) if ch.kind == "outdoor_temp")

    @property
    def visible_offers(self) -> bool:
        """The LP pays only offers the settlement baselines would see
        (``[reserve] plan_visible_offers`` under the event model with reserve)."""
        return self.events and self.config.reserve and self.reserve.plan_visible_offers


@dataclass(frozen=True)
class PlanContext:
    """What a period's problem takes from the controller's own state.

    Attributes
    ----------
    x_degc : (n,) the state the plan starts from [°C] (measured, or the filter's estimate).
    offset_k : (m,) the filter's offset estimate, added to the zones' affine term [K per
        step]; None: none.
    extra_margin_k : (N, m) comfort margin on top of δ (estimation, model error) [K].
    previous_plan : the last optimal plan (where the reserve's coil and fan terms are
        taken), or None.
    offer_baselines : the settlement baselines the offers are paid against, or None.
    meter_ratio : ρ the offers are scaled by (1: not scaled).
    plan_is_fresh : ``previous_plan`` was made one period ago and run (no fallback or locked
        IL period since): ``linearisation = "plan"`` linearises along it, else at T₀.
    """

    x_degc: FloatArray
    offset_k: FloatArray | None = None
    extra_margin_k: FloatArray | None = None
    previous_plan: RMPCSolution | None = None
    offer_baselines: OfferBaselines | None = None
    meter_ratio: float = 1.0
    plan_is_fresh: bool = True


def build_problem(
    model: StepModel, inputs: PeriodInputs, contract: PlanContract, context: PlanContext
) -> RMPCProblem:
    """The RMPC problem of the period starting now (see the module docstring).

    ``model`` gives the dynamics (a, b, e, g): the contract's fixed model, or the first
    step of a re-linearisation; the zone map C is always the fixed model's.
    """
    cfg, m = contract.config, contract.model
    affine = np.asarray(model.g, dtype=float)
    if context.offset_k is not None:
        affine = affine + m.c.T @ context.offset_k
    horizon = cfg.horizon_steps
    forecast = inputs.forecast
    d_hat = forecast.disturbances[:horizon]
    if d_hat.shape[0] < horizon:
        raise ConfigError(
            f"the forecast covers {d_hat.shape[0]} periods, fewer than the horizon",
            field="controller.horizon_steps",
            value=horizon,
            hint="load the data for steps + horizon_steps periods (load_exogenous)",
        )
    sigma = np.zeros_like(d_hat) if cfg.robust == "none" else contract.box.sigma(d_hat, m.channels)
    u_min = contract.building.hvac.flow_min_at(forecast.occupied[:horizon])
    if cfg.fan_only_air:  # an idle zone's fan-only input where the coil is scheduled off
        zone_temp = m.c @ np.asarray(context.x_degc, dtype=float)
        index = forecast.index[:horizon]
        u_min = idle_flow_min_kg_s(u_min, contract.building, contract.model, index, zone_temp)
    y_min, y_max = controller_band(forecast, horizon, cfg)
    if context.extra_margin_k is not None:
        y_min, y_max = tightened_bounds(y_min, y_max, context.extra_margin_k)
    along = None
    if cfg.linearisation == "plan" and context.plan_is_fresh:
        along = plan_linearisation(m, context.previous_plan, context.x_degc, horizon)
    if along is not None and along.affine_shift is not None:
        affine = affine + along.affine_shift
    p0, p, reserve_coeff = _power_coefficients(
        contract,
        context,
        forecast,
        d_hat,
        u_min,
        y_min,
        None if along is None else along.zone_temps_degc,
    )
    if inputs.meter_offset_kw is not None:  # levelled to the meter
        p0 = p0 + np.asarray(inputs.meter_offset_kw, dtype=float)[:horizon]
    reserve_price = forecast.reserve_price_sgd_per_mwh[:horizon]
    if not cfg.reserve:
        reserve_price = np.zeros_like(reserve_price)
    floor = inputs.peak_floor_kw if cfg.billing_mode == "billing-period" else 0.0
    phi = effective_peak_price(forecast, cfg.peak_price_sgd_per_kw)
    power_max: float | FloatArray = np.inf
    if cfg.robust != "feedback":
        power_max = pull_down_power_max_kw(
            phi,
            committed_cap_in_force_kw(context.previous_plan, inputs.peak_floor_kw),
            pull_down_steps(forecast.occupied, horizon),
            p0 + (p * u_min).sum(axis=1),
        )
    return RMPCProblem(
        a_matrix=model.a,
        b_matrix=model.b,
        e_matrix=model.e,
        c_matrix=m.c,
        affine_term=affine,
        x0=np.asarray(context.x_degc, dtype=float),
        d_forecast=d_hat,
        d_sigma=sigma,
        energy_price_sgd_per_mwh=forecast.energy_price_sgd_per_mwh[:horizon],
        reserve_price_sgd_per_mwh=reserve_price,
        peak_price_sgd_per_kw=phi,
        peak_floor_kw=floor,
        power_cap=(PowerCap(power_max_kw=power_max) if np.isfinite(power_max).any() else None),
        power_offset_kw=p0,
        power_coeff_kw_per_kg_s=p,
        step_linearisation=None if along is None else along.block,
        reserve_power_coeff_kw_per_kg_s=(
            context.meter_ratio * np.minimum(reserve_coeff, p) if contract.events else None
        ),
        u_min=u_min,
        u_max=contract.flow_max_kg_s,
        y_min=y_min,
        y_max=y_max,
        reserve_mask=contract.reserve_mask,
        comfort_penalty_sgd_per_kelvin_hour=cfg.comfort_penalty_sgd_per_kelvin_hour,
        comfort_knee=_comfort_knee(cfg),
        dt_h=m.dt_s / SECONDS_PER_HOUR,
        robust=cfg.robust,
        feedback=_feedback_options(cfg),
        commitments=_commitment(contract, inputs.committed_reserve_kg_s, u_min),
        offer_baselines=context.offer_baselines,
        events=_event_model(contract.reserve, horizon, inputs.allowance_carry_steps),
    )


def _comfort_knee(cfg: ControllerConfig) -> ComfortKnee | None:
    """The comfort knee block of the controller's δ and ρ₂ (None without a knee)."""
    if cfg.comfort_knee_k is None:
        return None
    return ComfortKnee(
        knee_kelvin=cfg.comfort_knee_k,
        penalty_beyond_sgd_per_kelvin_hour=cfg.comfort_penalty_beyond_knee_sgd_per_kelvin_hour,
    )


def _feedback_options(cfg: ControllerConfig) -> FeedbackOptions | None:
    """The affine-feedback policy's structure (None unless ``robust = "feedback"``)."""
    if cfg.robust != "feedback":
        return None
    return FeedbackOptions(structure=cfg.feedback.structure, memory_steps=cfg.feedback.memory_steps)


def _commitment(
    contract: PlanContract, committed_kg_s: FloatArray | None, u_min: FloatArray
) -> ReserveCommitment | None:
    """The (g, m) committed reserve flows of the first g steps, clipped into the room
    [0, u_max − u_min] of each step and the reserve mask (None: no commitments)."""
    g = contract.commit_ahead
    if not g:
        return None
    zones = len(contract.building.zone_names)
    held = np.zeros((g, zones)) if committed_kg_s is None else committed_kg_s
    committed = np.asarray(held, dtype=float).reshape(-1, zones)[:g]
    room = np.maximum(contract.flow_max_kg_s - u_min[: committed.shape[0]], 0.0)
    fixed: FloatArray = np.where(contract.reserve_mask, np.clip(committed, 0.0, room), 0.0)
    return ReserveCommitment(reserve_kg_s=fixed)


def _event_model(
    reserve: ReserveConfig, horizon: int, allowance_carry_steps: int
) -> ILEventModel | None:
    """The problem's IL event model from the IL contract (None: whole horizon)."""
    if reserve.event_max_steps is None:
        return None
    return ILEventModel(
        max_steps=min(reserve.event_max_steps, horizon),
        allowance_kelvin=reserve.event_allowance_k,
        recovery_steps=reserve.event_recovery_steps,
        carry_steps=min(allowance_carry_steps, horizon),
    )


def lp_power_rows(
    building: Building,
    outdoor_degc: FloatArray,
    humidity_kg_per_kg: FloatArray,
    latent_gain_w: FloatArray,
    occupied: npt.ArrayLike,
    damper_open: npt.ArrayLike,
    linearisation_temp_degc: float,
    flow_min_kg_s: FloatArray,
    *,
    zone_temp_degc: FloatArray | None = None,
    reference_flow_kg_s: FloatArray | None = None,
    total_flow_max_kg_s: float = 0.0,
) -> tuple[FloatArray, FloatArray]:
    """The LP's power rows ``P_k = p0_k + p_kᵀ u_k``: p0 (N,) [kW], p (N, m) [kW per kg/s]
    over N periods, on arrays (the MPC's forecast, or the data of a whole period).

    A power model fitted to the meter (an identified building's, or a designed building's
    ``metered_power``): :func:`hvacflex.building.identified.metered_affine_power`, its tangent
    along ``reference_flow_kg_s`` ((N,) total flow [kg/s]; None: Σ ``flow_min_kg_s``) with the
    running load's secant over [0, ``total_flow_max_kg_s``] where the reference is off, at the
    outdoor humidity ``humidity_kg_per_kg`` (its occupied outdoor air's moisture term);
    otherwise :func:`hvacflex.building.hvac.affine_power_model` at the outdoor air
    ``outdoor_degc`` (N,) [°C] and ``humidity_kg_per_kg`` (N,), the occupants' latent gain
    ``latent_gain_w`` ((N,) [W], or empty: none), the damper schedule ``damper_open`` (N,)
    over the step's flow range [``flow_min_kg_s`` (N, m), u_max] [kg/s]; both at the zone
    temperature ``linearisation_temp_degc`` [°C], the design curves at each step's own
    ``zone_temp_degc`` ((N, m) [°C]) where it is given. ``occupied`` (N,) bool.
    """
    meter_fit = _meter_fit(building)
    if meter_fit is not None:
        fitted, supply_temp_degc = meter_fit
        low = np.asarray(flow_min_kg_s, dtype=np.float64).sum(axis=1)
        return metered_affine_power(
            fitted or IdentifiedPower(0.0, 0.0, 0.0),  # an identified file without a meter
            supply_temp_degc,
            len(building.zone_names),
            outdoor_degc,
            linearisation_temp_degc,
            np.asarray(occupied).astype(np.float64),
            low if reference_flow_kg_s is None else reference_flow_kg_s,
            total_flow_max_kg_s,
            humidity_kg_per_kg,
        )
    latent = np.asarray(latent_gain_w, dtype=np.float64)
    return affine_power_model(
        building.hvac,
        outdoor_degc,
        humidity_kg_per_kg,
        linearisation_temp_degc if zone_temp_degc is None else zone_temp_degc,
        latent_gain_w=latent if latent.size == len(outdoor_degc) else 0.0,
        flow_min_kg_s=flow_min_kg_s,
        damper_open=damper_open,
    )


def _power_coefficients(
    contract: PlanContract,
    context: PlanContext,
    forecast: Forecast,
    d_hat: FloatArray,
    u_min: FloatArray,
    y_min: FloatArray,
    zone_temps_degc: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The LP's power rows ``P_k = p0_k + p_kᵀ u_k`` ((N,), (N, m)) and the reserve's
    power per kg/s (N, m), from the building's power model at the forecast (outdoor air,
    its humidity, the occupants' latent gain) over the step's flow range [u_min, u_max];
    the design curves' coil at ``zone_temps_degc`` ((N, m) [°C], ``linearisation = "plan"``)
    where given, else at T₀."""
    horizon = d_hat.shape[0]
    building, outdoor = contract.building, d_hat[:, contract.outdoor_index]
    humidity = forecast.outdoor_humidity_ratio_kg_per_kg[:horizon]
    # the plant's damper schedule, purge included where the forecast shows the next spell
    damper = building.hvac.outdoor_air_open_at(forecast.occupied, contract.model.dt_s)[:horizon]
    reference = _total_flow_reference_kg_s(context.previous_plan, u_min)
    p0, p = lp_power_rows(
        building,
        outdoor,
        humidity,
        forecast.occupant_latent_w[:horizon],
        forecast.occupied[:horizon],
        damper,
        contract.linearisation_temp_degc,
        u_min,
        zone_temp_degc=zone_temps_degc,
        reference_flow_kg_s=reference,
        total_flow_max_kg_s=float(contract.flow_max_kg_s.sum()),
    )
    meter_fit = _meter_fit(building)
    if meter_fit is not None:
        fitted, supply_temp_degc = meter_fit
        if fitted is None:  # an identified file without a meter
            return p0, p, p
        reserve = metered_reserve_coeff(
            fitted,
            supply_temp_degc,
            outdoor,
            _return_air_estimate_degc(contract.model, context, y_min),
            _curtailed_flow_estimate_kg_s(context.previous_plan, u_min),
            reference,
        )
        return p0, p, reserve
    reserve_coeff = reserve_power_coeff(
        building.hvac,
        outdoor,
        humidity,
        _return_air_estimate_degc(contract.model, context, y_min),
        _curtailed_flow_estimate_kg_s(context.previous_plan, u_min),
        damper_open=damper,
    )
    return p0, p, reserve_coeff


def _meter_fit(building: Building) -> tuple[IdentifiedPower | None, float] | None:
    """The power model fitted to the building's meter and the supply temperature [°C] it
    goes with: an identified building's (None for a file without a meter), or a designed
    building's ``metered_power``; None for a building planned on its design curves."""
    if building.identified is not None:
        return building.identified.power, building.identified.supply_temp_degc
    if building.metered_power is not None:
        return building.metered_power, building.hvac.supply_temp_degc
    return None


def _total_flow_reference_kg_s(plan: RMPCSolution | None, u_min: FloatArray) -> FloatArray:
    """(N,) total supply flow [kg/s] along which a metered power model is re-linearised: the
    previous plan's Σu one step on (its last step repeated), never below the step's Σ u_min;
    Σ u_min alone without a previous plan."""
    low: FloatArray = np.asarray(u_min, dtype=float).sum(axis=1)
    if plan is None or plan.u.shape[0] != low.size:
        return low
    planned = plan.u.sum(axis=1)
    shifted = np.concatenate([planned[1:], planned[-1:]])
    reference: FloatArray = np.maximum(shifted, low)
    return reference


def _return_air_estimate_degc(
    model: LinearModel, context: PlanContext, y_min: FloatArray
) -> FloatArray:
    """(N, m) zone (return-air) temperatures at which the coil term of the reserve's
    power is taken [°C]: the previous plan's served zone temperatures at the start of
    each step, one step on (now: the measured state), never below the plan's lower bound
    ``y_min`` (its margins included: the plan holds them). Curtailment only warms the zones,
    so the curtailed return air is warmer and its coil power per kg/s larger: a lower bound
    while the plan holds."""
    c = model.c
    plan = context.previous_plan
    horizon = y_min.shape[0]
    now = c @ np.asarray(context.x_degc, dtype=float)
    if plan is None or plan.x_served.shape[0] != horizon + 1:
        start = np.broadcast_to(now, y_min.shape)
    else:
        served = plan.x_served[1:] @ c.T  # start of the new steps 0 … N − 1
        start = np.concatenate([now[None], served[1:]])
    estimate: FloatArray = np.maximum(start, y_min)
    return estimate


def _curtailed_flow_estimate_kg_s(plan: RMPCSolution | None, u_min: FloatArray) -> FloatArray:
    """(N,) total flow after curtailment at which the fan's tangent bounds the reserve's
    power [kg/s]: the previous plan's Σ(u − r), one step on (its last step repeated), never
    below the step's Σ u_min; Σ u_min alone without a previous plan."""
    low: FloatArray = np.asarray(u_min, dtype=float).sum(axis=1)
    if plan is None or plan.u.shape[0] != low.size:
        return low
    curtailed = (plan.u - plan.r).sum(axis=1)
    shifted = np.concatenate([curtailed[1:], curtailed[-1:]])
    estimate: FloatArray = np.maximum(shifted, low)
    return estimate
