"""One building of a fleet as a long-lived, steppable controller + plant (a "building agent").

An agent wraps the single-building machinery unchanged: the RMPC problem is built by
:meth:`hvacflex.control.mpc.MPCController.problem`, the period is decided by the one
:class:`hvacflex.sim.step.ControlStep` and the plant stepped and recorded by
:class:`hvacflex.sim.closed_loop.ClosedLoop` (so each building's rows have the schema of a
single-building run). What the fleet adds is the coordination hook: each step the agent

1. :meth:`BuildingAgent.begin_step` builds the step's problem and reports its power range
   (N,) [kW] (all flows at their lower, resp. upper bounds),
2. :meth:`BuildingAgent.solve` solves it with a feeder price λ (N,) [SGD/MWh] added to the
   energy price (warm-started: one :class:`~hvacflex.opt.RMPCSolver` per building, kept
   across steps and iterations),
3. :meth:`BuildingAgent.finalize` fixes the plan, re-solving with per-period power caps
   (N,) [kW] (``RMPCProblem.power_max_kw``, a bound on the plan's power column) when the
   coordinator allocates them,
4. :meth:`BuildingAgent.advance` passes the fixed plan to the control step
   (``ClosedLoop.step(plan=...)``) and applies its first step to the plant.

A :class:`BuildingGroup` holds the agents of one worker and vectorises these calls over its
buildings; it is what runs as a Dask actor.
"""

from __future__ import annotations

import copy
import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.config import (
    DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR,
    DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR,
    LINEARISATION_MARGIN_K,
    ComfortConfig,
    ControllerConfig,
    DataConfig,
    Linearisation,
    ReserveConfig,
    ScenarioConfig,
)
from hvacflex.control.base import Action, FloatArray, PeriodInputs
from hvacflex.control.demand_limit import forecast_period_power_kw, predicted_power_kw
from hvacflex.control.estimation import StepModel
from hvacflex.control.mpc import MPCController
from hvacflex.control.offers import snapped_flows_kg_s
from hvacflex.control.plan_linearisation import planned_first_step
from hvacflex.control.prediction_error import predicted_state_degc
from hvacflex.data.gains import DEFAULT_OFFICE_SCHEDULE, OfficeSchedule
from hvacflex.fleet.centralised import objective_split
from hvacflex.fleet.envelope import building_envelope, hold_flows
from hvacflex.fleet.guard import PATH_END, comfort_floor_flow_kg_s, path_flow_kg_s
from hvacflex.fleet.schema import Fleet, FleetBuilding, fleet_from_dict
from hvacflex.opt import RMPCProblem, RMPCSolution, RMPCSolver, SolveStatus
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.events import Role
from hvacflex.sim.setup import Setup, prepare
from hvacflex.sim.step import ControlStep
from hvacflex.units import KWH_PER_MWH

CAP_TOLERANCE_KW = 1e-6
"""Applied power may exceed its cap by this much (solver round-off)."""


def power_bounds_kw(problem: RMPCProblem, u_max: FloatArray | None = None) -> FloatArray:
    """(N,) largest affine power P_k = p0_k + p_k·u_k over the flow box [u_min, u_max] [kW]."""
    p = problem.power_coeff_kw_per_kg_s
    upper = problem.u_max if u_max is None else u_max
    bound: FloatArray = (
        problem.power_offset_kw
        + np.sum(np.maximum(p, 0.0) * upper, axis=1)
        + np.sum(np.minimum(p, 0.0) * problem.u_min, axis=1)
    )
    return bound


HOLD_LEVEL_ITERATIONS = 4
"""Corrections of a hold's affine level by the plant's predicted power
(:meth:`BuildingAgent.advance_held`)."""
HOLD_LEVEL_TOLERANCE_KW = 0.01
"""A hold's predicted power meets its level within this [kW]."""

CAP_BISECTION_STEPS = 30
"""Bisection steps of the cap's flow scaling by the predicted power (θ to 1e-9)."""


def _largest_within(power_kw: Callable[[float], float], cap_kw: float, upper: float) -> float:
    """The largest θ in [0, ``upper``] with ``power_kw(θ) ≤ cap_kw`` for a power that rises
    with θ (0 where even θ = 0 is above it: every flow at its lower bound), by bisection.

    More flow draws more power in cooling (fan, coil, chiller), so the assumption holds for
    the cooling-only buildings fleets are made of; where it did not (a heating coil's power
    falls with flow) the θ returned would still meet the cap wherever it is not 0."""
    if power_kw(0.0) > cap_kw:
        return 0.0
    within, above = 0.0, upper
    for _ in range(CAP_BISECTION_STEPS):
        middle = 0.5 * (within + above)
        if power_kw(middle) <= cap_kw:
            within = middle
        else:
            above = middle
    return within


class FleetController(MPCController):
    """The building's MPC, driven by the fleet coordinator.

    One warm-started solver: the first solve of a step starts from the previous step's
    basis rotated by one step, the step's re-solves at other prices or caps
    (``same_step``) from the basis HiGHS holds. :meth:`act` applies the coordinator's plan
    (passed in as ``plan``) through :meth:`MPCController.act` (its fallbacks included) and
    then enforces the step's power cap on whatever it returns: flows above the cap are
    scaled towards the lower bounds until both the LP's affine power and the power the plant's
    model predicts for the period (:func:`hvacflex.control.demand_limit.forecast_period_power_kw`
    from the state now and the forecast, the occupants' latent gain included) meet it. The
    affine power is a secant: at small and changing flows (outdoor air, the part-load
    chiller) it lies below the plant's power, which is what the feeder meters.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.cap_now_kw = np.inf
        self.power_now: tuple[float, FloatArray, FloatArray] | None = None
        """The step's first period as the LP sees it: (P₀ [kW], p (m,) [kW per kg/s], q (m,)
        the reserve capacity per kg/s of reserve flow [kW per kg/s]); None before a step."""
        self.guard_cap_kw: float | None = None
        """The fleet guard's cap on the period's predicted power [kW]
        (:func:`hvacflex.fleet.guard.guard_caps_kw`; inf: none); None: no fleet guard this
        period, the predicted power is held to the building's own cap ``cap_now_kw``."""
        self.upper_now_degc: FloatArray | None = None
        """(m,) the upper band at the end of the step's first period [°C]; None before a
        step is finalised."""
        self.model_now: StepModel = self.model
        """The model the step's first period is planned with (the fixed model; under
        ``linearisation = "plan"`` B diag(s_0), :func:`planned_first_step`), set when the
        step is finalised: what the comfort floor steps with."""
        self.held_flow_kg_s: FloatArray | None = None
        """(m,) flows [kg/s] a hold of the envelope fixes for this period (applied as they
        are, no reserve offered; :meth:`BuildingAgent.advance_held`); None: not held."""

    @staticmethod
    def fleet_inputs(inputs: PeriodInputs) -> PeriodInputs:
        """``inputs`` without the building's own settlement baselines: the controller's
        all-or-nothing check (which drops the offer of every building whose plan is not
        below its last metered power) is replaced by the coordinator's, which cuts each
        staged offer to the part the building's meter would show, the curtailed power read
        by the plant's power model (:func:`hvacflex.fleet.aggregation.visible_offers_kw`)."""
        return dataclasses.replace(inputs, baseline_power_kw=None, baseline_ahead_kw=None)

    def first_offer_kw(
        self, problem: RMPCProblem, plan: RMPCSolution, inputs: PeriodInputs
    ) -> tuple[float, float]:
        """(the offer q₀·r₀ [kW], the curtailed power [kW]) of ``plan``'s first period, its
        flows snapped onto the physical limits as :meth:`act` snaps them. The curtailed
        power is what the plant's power model predicts for the curtailed flows u₀ − r₀
        (:meth:`predicted_power_kw`, from ``inputs``), the meter's scale: the LP's affine
        p₀·r₀ is a secant and over-states what shedding r₀ takes off the meter (the RC
        plants shed 0.81 × p₀·r₀ over 50 buildings' office hours, the power model's
        prediction 1.01 ×; docs/guide/fleet.md, "The aggregator's offer")."""
        flows, reserves = snapped_flows_kg_s(problem, plan, 1, self.contract.flow_max_kg_s)
        reserve = reserves[0]
        curtailed = self.predicted_power_kw(inputs, flows[0] - reserve)
        return float(problem.reserve_kw_per_kg_s[0] @ reserve), curtailed

    def solver(self, problem: RMPCProblem) -> RMPCSolver:
        """The building's solver (built on first use, from a restored basis if any)."""
        return self.solver_slot.rmpc_solver(problem)

    def predicted_power_kw(self, inputs: PeriodInputs, flow_kg_s: FloatArray) -> float:
        """The HVAC power [kW] the flows (m,) [kg/s] draw over the period starting now, by
        the plant's power model at the period's mean zone temperatures (the linear model
        stepped from ``inputs.x_degc``) and the forecast's outdoor air and latent gain."""
        return forecast_period_power_kw(
            self.model,
            self.building.hvac,
            inputs.x_degc,
            flow_kg_s,
            inputs.forecast,
            latent=True,
        )

    def hold_power_kw(self, inputs: PeriodInputs, flows_kg_s: FloatArray) -> float:
        """The mean HVAC power [kW] the plant's power model predicts for the flows (h, m)
        [kg/s] of the h periods from now: the linear model stepped from ``inputs.x_degc``
        under the forecast, each period's power at its mean zone temperatures, outdoor air
        and occupants' latent gain (:func:`predicted_power_kw`)."""
        forecast, model = inputs.forecast, self.model
        gain = forecast.occupant_latent_w
        x, total = np.asarray(inputs.x_degc, dtype=float), 0.0
        for j, flow in enumerate(flows_kg_s):
            end = model.step(x, flow, forecast.disturbances[j])
            total += predicted_power_kw(
                self.building.hvac,
                flow,
                model.c @ x,
                model.c @ end,
                float(forecast.outdoor_temp_degc[j]),
                float(forecast.outdoor_humidity_ratio_kg_per_kg[j]),
                latent_gain_w=float(gain[j]) if gain.size else 0.0,
            )
            x = end
        return total / len(flows_kg_s)

    def flow_floor_kg_s(self, inputs: PeriodInputs) -> FloatArray:
        """(m,) the flows' lower bounds in the period starting now [kg/s]."""
        floor: FloatArray = self.building.hvac.flow_min_at(inputs.forecast.occupied[:1])[0]
        return floor

    def comfort_floor(
        self, inputs: PeriodInputs, flow_kg_s: FloatArray, low_kg_s: FloatArray
    ) -> tuple[FloatArray, float]:
        """(the comfort floor (m,) [kg/s] of the flows ``flow_kg_s`` (m,): each zone's flow
        cut only as far as it still ends the period at or below its upper band on the
        linear model, :func:`hvacflex.fleet.guard.comfort_floor_flow_kg_s`; the room [K]
        of the warmest zone below its band at ``flow_kg_s``). Without a band (no step
        finalised yet) the floor is ``low_kg_s`` and the room inf."""
        upper = self.upper_now_degc
        if upper is None:
            return np.asarray(low_kg_s, dtype=float), np.inf
        model = self.model_now
        d0 = inputs.forecast.disturbances[0]
        end = model.c @ predicted_state_degc(model, inputs.x_degc, flow_kg_s, d0)
        gain = np.diag(model.c @ model.b)
        floor = comfort_floor_flow_kg_s(end, gain, upper, flow_kg_s, low_kg_s)
        return floor, float(np.min(upper - end))

    def act(self, inputs: PeriodInputs) -> Action:
        action = super().act(self.fleet_inputs(inputs))
        if inputs.locked is not None:
            if self.held_flow_kg_s is not None:  # the event plan wins: say so
                return dataclasses.replace(action, status=f"{action.status}+hold-ignored")
            return action
        if self.held_flow_kg_s is not None:
            return self._with_hold(action)
        if np.isnan(self.cap_now_kw):
            raise ValueError("the coordinator gave this building a NaN power cap")
        guard = self.cap_now_kw if self.guard_cap_kw is None else self.guard_cap_kw
        if self.power_now is None or (self.cap_now_kw == np.inf and guard == np.inf):
            return action
        p0, p, q = self.power_now
        low = self.flow_floor_kg_s(inputs)
        high = action.flow_kg_s
        floor, _ = self.comfort_floor(inputs, high, low)

        def flows(s: float) -> FloatArray:
            return path_flow_kg_s(s, low, floor, high)

        def predicted(s: float) -> float:
            return self.predicted_power_kw(inputs, flows(s))

        s = PATH_END  # the affine power's least cut on the path, then the predicted power's
        if p0 + float(p @ high) > self.cap_now_kw + CAP_TOLERANCE_KW:
            cap = self.cap_now_kw + CAP_TOLERANCE_KW
            s = _largest_within(lambda t: p0 + float(p @ flows(t)), cap, PATH_END)
        if predicted(s) > guard + CAP_TOLERANCE_KW:
            s = _largest_within(predicted, guard + CAP_TOLERANCE_KW, s)
        elif s == PATH_END:  # both within their caps: the action as decided
            return action
        flow = flows(s)
        reserve = np.clip(action.reserve_flow_kg_s, 0.0, flow - low)
        return dataclasses.replace(
            action,
            flow_kg_s=flow,
            reserve_flow_kg_s=reserve,
            reserve_kw=min(action.reserve_kw, float(q @ reserve)),  # priced at q, as offered
            planned_power_kw=p0 + float(p @ flow),
            fallback=True,
            status=f"{action.status}+capped",
        )

    def _with_hold(self, action: Action) -> Action:
        """``action`` with the hold's flows (no reserve offered) and their affine power."""
        assert self.held_flow_kg_s is not None and self.power_now is not None
        p0, p, _ = self.power_now
        flow = self.held_flow_kg_s
        return dataclasses.replace(
            action,
            flow_kg_s=flow,
            reserve_flow_kg_s=np.zeros_like(flow),
            reserve_kw=0.0,
            planned_power_kw=p0 + float(p @ flow),
            status=f"{action.status}+held",
        )


@dataclass(frozen=True)
class FleetSettings:
    """What every agent of a run shares: the period, the controller settings and the data."""

    start: str
    days: float
    seed: int
    robust: str
    horizon_steps: int
    reserve: bool
    peak_price_sgd_per_kw: float
    billing_mode: str
    comfort_penalty_sgd_per_kelvin_hour: float = DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR
    """ρ of every building's MPC [SGD per K·h] (the fleet file's key)."""
    comfort_knee_k: float | None = None
    """δ [K] and ρ₂ [SGD per K·h] of every building's comfort knee (the fleet file's keys)."""
    comfort_penalty_beyond_knee_sgd_per_kelvin_hour: float = (
        DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR
    )
    linearisation_margin_k: float = LINEARISATION_MARGIN_K
    """T₀ of every building's model is its occupied upper comfort bound less this [K] (the
    fleet file's key)."""
    linearisation: Linearisation = "fixed"
    """Every building's model at T₀ or each step at its previous plan's zone temperatures
    (the fleet file's key)."""
    lower_plan_margin_k: float = ControllerConfig.lower_plan_margin_k
    """Every building's plan stays this far above its lower comfort bound [K] (the fleet
    file's key)."""
    unoccupied_plan_margin_k: float = ControllerConfig.unoccupied_plan_margin_k
    """Every building's plan stays this far below its unoccupied upper bound [K] (the
    scenario's default; not a fleet-file key: ``fleet bound`` sets it to 0)."""
    il_events: ReserveConfig = field(default_factory=ReserveConfig)
    """The IL contract (event model D, α, R) every building plans for."""
    data: DataConfig = field(default_factory=DataConfig)
    """The fleet file's ``[data]``: the weather and market data (one market) every building
    sees, paths resolved."""

    @staticmethod
    def of(fleet: Fleet, start: str, days: float) -> FleetSettings:
        s = fleet.spec
        return FleetSettings(
            start=start,
            days=days,
            seed=s.seed,
            robust=s.robust,
            horizon_steps=s.horizon_steps,
            reserve=s.reserve.enabled,
            peak_price_sgd_per_kw=s.ppp.peak_price_sgd_per_kw,
            billing_mode=s.ppp.billing_mode,
            comfort_penalty_sgd_per_kelvin_hour=s.comfort_penalty_sgd_per_kelvin_hour,
            comfort_knee_k=s.comfort_knee_k,
            comfort_penalty_beyond_knee_sgd_per_kelvin_hour=(
                s.comfort_penalty_beyond_knee_sgd_per_kelvin_hour
            ),
            linearisation_margin_k=s.linearisation_margin_k,
            linearisation=s.linearisation,
            lower_plan_margin_k=s.lower_plan_margin_k,
            il_events=s.reserve.config(),
            data=fleet.data,
        )


def _schedule(hours: tuple[int, int]) -> OfficeSchedule:
    """The default office schedule shifted so that occupancy starts at ``hours[0]``."""
    shift = hours[0] - DEFAULT_OFFICE_SCHEDULE.occupied_hours[0]
    base = DEFAULT_OFFICE_SCHEDULE
    rolled = {
        name: tuple(np.roll(np.asarray(getattr(base, name)), shift).tolist())
        for name in ("people_workday", "lighting_workday", "equipment_workday")
    }
    return dataclasses.replace(
        base,
        occupied_hours=hours,
        people_workday=rolled["people_workday"],
        lighting_workday=rolled["lighting_workday"],
        equipment_workday=rolled["equipment_workday"],
    )


def building_setup(entry: FleetBuilding, index: int, settings: FleetSettings) -> Setup:
    """The single-building :class:`Setup` of one fleet building (its own seed), made by the
    one set-up path :func:`hvacflex.sim.setup.prepare`. Its activation schedule starts
    all False: the fleet run sets each period's entry when the fleet's IL is activated
    (:meth:`BuildingAgent.advance`)."""
    controller = ControllerConfig(
        robust=settings.robust,  # type: ignore[arg-type]
        reserve=settings.reserve,
        peak_price_sgd_per_kw=settings.peak_price_sgd_per_kw,
        billing_mode=settings.billing_mode,  # type: ignore[arg-type]
        horizon_steps=settings.horizon_steps,
        linearisation_temp_degc=max(  # inside the band (a margin of its width, rounded)
            entry.comfort_occupied_degc[1] - settings.linearisation_margin_k,
            entry.comfort_occupied_degc[0],
        ),
        linearisation=settings.linearisation,
        lower_plan_margin_k=settings.lower_plan_margin_k,
        unoccupied_plan_margin_k=settings.unoccupied_plan_margin_k,
        comfort_penalty_sgd_per_kelvin_hour=settings.comfort_penalty_sgd_per_kelvin_hour,
        comfort_knee_k=settings.comfort_knee_k,
        comfort_penalty_beyond_knee_sgd_per_kelvin_hour=(
            settings.comfort_penalty_beyond_knee_sgd_per_kelvin_hour
        ),
    )
    comfort = ComfortConfig(
        occupied_degc=entry.comfort_occupied_degc, unoccupied_degc=entry.comfort_unoccupied_degc
    )
    config = ScenarioConfig(
        name=entry.name,
        start=settings.start,
        days=settings.days,
        seed=settings.seed + index,
        initial_temp_degc=entry.initial_temp_degc,
        controller=controller,
        reserve=settings.il_events,
        comfort=comfort,
        data=settings.data,
    )
    return prepare(
        config,
        entry.building,
        schedule=_schedule(entry.occupied_hours),
        market_seed=settings.seed,  # one market: every building sees the same reserve price
    )


@dataclass
class StepSolve:
    """One building's answer to a price: plan power (N,) [kW], its cost without the feeder
    price [SGD], its Lagrangian objective (with it) [SGD], and whether it is optimal."""

    power_kw: FloatArray
    cost_sgd: float
    lagrangian_sgd: float
    ok: bool


class BuildingAgent:
    """One building's controller and plant across the whole run (see the module docstring)."""

    def __init__(self, entry: FleetBuilding, index: int, settings: FleetSettings) -> None:
        self.name = entry.name
        self.setup = building_setup(entry, index, settings)
        cfg = self.setup.config.controller
        self.controller = FleetController(
            self.setup.building,
            self.setup.model,
            cfg,
            self.setup.box,
            self.setup.linearisation_temp_degc,
            reserve=self.setup.config.reserve,
            linearisation=cfg.linearisation,
        )
        self.control = ControlStep(self.setup.config, self.controller, len(self.setup.zone_names))
        self.loop = ClosedLoop(self.setup, control=self.control)
        self._problem: RMPCProblem | None = None
        self._inputs: PeriodInputs | None = None
        """The current step's inputs (after :meth:`begin_step`)."""
        self._staged: RMPCSolution | None = None
        """The coordinator's plan of the step, applied by :meth:`advance`."""
        self._last: RMPCSolution | None = None
        self._last_price: FloatArray | None = None
        self._last_cap: FloatArray | float = np.inf
        self.locked_power_kw: float | None = None
        """This period's power fixed by a locked event plan [kW] (None: not locked)."""
        self._baseline_kw: float | None = None
        """The building's own settlement baseline of an activation starting this period
        [kW] (NaN: none; None: unknown, the first period); set by :meth:`begin_step`."""

    @property
    def problem(self) -> RMPCProblem:
        """The current step's problem (without feeder price or caps); after begin_step()."""
        assert self._problem is not None, "begin_step() first"
        return self._problem

    # -- coordination --------------------------------------------------------------
    def begin_step(self, continuing: bool = False) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Build this step's problem; (P_min (N,), P_max (N,), energy price (N,)).

        ``continuing``: an IL activation that started earlier goes on in this period. A
        building then locked to its event plan (:class:`hvacflex.sim.events.EventTracker`)
        will draw that plan's curtailed power whatever it is told, so its range in the
        first period is that power alone: P_min₀ = P_max₀ = p0₀ + p₀·(u − r)ⱼ [kW], and
        the coordinator gives it exactly that as its cap."""
        inputs = self.control.prepared(self.loop.inputs())
        self._inputs = inputs
        self._baseline_kw = inputs.baseline_power_kw
        problem = self.controller.problem_for(self.controller.fleet_inputs(inputs))
        self._problem, self._last, self._last_price = problem, None, None
        p_min = power_bounds_kw(problem, problem.u_min)
        p_max = power_bounds_kw(problem)
        locked = self._locked_flow_kg_s() if continuing else None
        if locked is not None:
            power = float(problem.power_offset_kw[0] + problem.power_coeff_kw_per_kg_s[0] @ locked)
            p_min[0] = p_max[0] = power
        self.locked_power_kw = None if locked is None else float(p_min[0])
        return p_min, p_max, problem.energy_price_sgd_per_mwh.copy()

    def _locked_flow_kg_s(self) -> FloatArray | None:
        """(m,) the curtailed flows u − r [kg/s] the building's event plan fixes for this
        period if an activation going on locks it, else None (probed on a copy of the
        event tracker: the real one advances when the period is decided)."""
        probe = copy.deepcopy(self.control.tracker)
        if probe.role(True) is not Role.EVENT_LOCKED:
            return None
        action = probe.locked_action()
        return action.applied_flow_kg_s(curtailed=True)

    def staged_offer_kw(self) -> tuple[float, float, float]:
        """What the building's meter would show of its staged offer: (the staged plan's
        first-period offer [kW], its curtailed power by the plant's power model [kW]
        (:meth:`FleetController.first_offer_kw`), its settlement baseline of an activation
        starting now [kW]) — the building's part of the fleet's bid
        (:func:`hvacflex.fleet.aggregation.visible_offers_kw`). The offer is 0 without an
        optimal plan; the baseline NaN where nothing is metered yet (the run's first
        period)."""
        staged, problem, inputs = self._staged, self._problem, self._inputs
        baseline = self._baseline_kw
        seen = float("nan") if self.loop.k == 0 or baseline is None else float(baseline)
        if (
            staged is None
            or problem is None
            or inputs is None
            or staged.status is not SolveStatus.OPTIMAL
        ):
            return 0.0, float("nan") if staged is None else float(staged.power_kw[0]), seen
        offer, curtailed = self.controller.first_offer_kw(problem, staged, inputs)
        return offer, curtailed, seen

    def staged_split_sgd(self) -> FloatArray:
        """(3,) the staged plan's cost [SGD]: energy + peak, reserve (−revenue) and comfort
        penalty (:func:`hvacflex.fleet.centralised.objective_split`); NaN without an
        optimal staged plan."""
        staged, problem = self._staged, self._problem
        if staged is None or problem is None or staged.status is not SolveStatus.OPTIMAL:
            return np.full(3, np.nan)
        return objective_split(problem, staged.u, staged.r, staged.slack, staged.peak_charge_sgd)

    def _solve(self, price_kw: FloatArray, cap_kw: FloatArray | None = None) -> StepSolve:
        base = self._problem
        assert base is not None, "begin_step() first"
        problem = base.with_price_and_cap(
            base.energy_price_sgd_per_mwh + price_kw, np.inf if cap_kw is None else cap_kw
        )
        solution = self.controller.solver(problem).solve(problem, same_step=self._last is not None)
        self._last, self._last_price = solution, price_kw.copy()
        self._last_cap = np.inf if cap_kw is None else np.asarray(cap_kw, dtype=float).copy()
        if solution.status is not SolveStatus.OPTIMAL:
            nan = np.full(base.horizon, np.nan)
            return StepSolve(nan, np.nan, np.nan, False)
        priced = base.dt_h * float(price_kw @ solution.power_kw) / KWH_PER_MWH
        return StepSolve(
            solution.power_kw.copy(), solution.objective_sgd - priced, solution.objective_sgd, True
        )

    def solve(self, price_sgd_per_mwh: FloatArray) -> StepSolve:
        """Solve the step's problem with the feeder price added to the energy price."""
        return self._solve(np.asarray(price_sgd_per_mwh, dtype=float))

    def finalize(self, price_sgd_per_mwh: FloatArray, cap_kw: FloatArray) -> StepSolve:
        """Fix the step's plan: re-solve inside the power caps (N,) [kW] (inf = none) unless
        the last solve at this price already respects them; stage it for :meth:`advance`."""
        base = self._problem
        assert base is not None
        price = np.asarray(price_sgd_per_mwh, dtype=float)
        cap = np.asarray(cap_kw, dtype=float)
        last = self._last
        reuse = (
            last is not None
            and last.status is SolveStatus.OPTIMAL
            and self._last_price is not None
            and np.array_equal(self._last_price, price)
            and bool(np.all(last.power_kw <= cap + CAP_TOLERANCE_KW))
            # optimal under the new caps only if they are no looser than the last solve's
            and bool(np.all(cap <= self._last_cap))
        )
        if reuse:
            assert last is not None
            priced = base.dt_h * float(price @ last.power_kw) / KWH_PER_MWH
            result = StepSolve(
                last.power_kw.copy(), last.objective_sgd - priced, last.objective_sgd, True
            )
        else:
            # caps below the minimum power cannot bind the LP (flows at their minimum): the
            # coordinator flags those periods; the cap row then sits at the minimum
            floor = power_bounds_kw(base, base.u_min)
            result = self._solve(price, np.maximum(cap, floor + CAP_TOLERANCE_KW))
        self._staged = self._last
        self.controller.cap_now_kw = float(cap[0])
        self.controller.upper_now_degc = np.array(base.y_max[0], dtype=float)
        self.controller.model_now = planned_first_step(base, self.controller.model)
        self.controller.power_now = (
            float(base.power_offset_kw[0]),
            base.power_coeff_kw_per_kg_s[0].copy(),
            base.reserve_kw_per_kg_s[0].copy(),
        )
        return result

    def cap_values(self) -> FloatArray:
        """(N,) marginal value of this building's caps at its last solve [SGD/kW] (zeros
        when it failed); what the coordinator reallocates caps by."""
        base = self._problem
        assert base is not None, "begin_step() first"
        last = self._last
        if last is None or last.status is not SolveStatus.OPTIMAL:
            return np.zeros(base.horizon)
        return self.controller.solver(base).power_cap_values_sgd_per_kw()

    def guard_view(self) -> tuple[float, float, float, float]:
        """The period about to be applied as the fleet's guard sees it (after
        :meth:`finalize`; :mod:`hvacflex.fleet.guard`): (P, the predicted power of the
        staged plan's first-period flows [kW]; P^free, of their comfort floor [kW];
        P^min, of the lower bounds [kW]; ρ, the warmest zone's room below its upper band
        at the period's end [K]). A building locked to its event plan reports its locked
        flows' power three times and ρ = −inf (it cannot shed); one without an optimal
        staged plan (it will fall back) its largest flows'."""
        inputs, problem, controller = self._inputs, self.problem, self.controller
        assert inputs is not None, "begin_step() first"
        low = controller.flow_floor_kg_s(inputs)
        if self.locked_power_kw is not None:
            locked = self._locked_flow_kg_s()
            if locked is not None:
                power = controller.predicted_power_kw(inputs, locked)
                return power, power, power, -np.inf
        staged = self._staged
        if staged is not None and staged.status is SolveStatus.OPTIMAL:
            flows = snapped_flows_kg_s(problem, staged, 1, controller.contract.flow_max_kg_s)
            flow = flows[0][0]
        else:
            flow = np.broadcast_to(controller.contract.flow_max_kg_s, low.shape).astype(float)
        floor, room = controller.comfort_floor(inputs, flow, low)
        return (
            controller.predicted_power_kw(inputs, flow),
            controller.predicted_power_kw(inputs, floor),
            controller.predicted_power_kw(inputs, low),
            room,
        )

    def advance(
        self, activated: bool = False, guard_cap_kw: float | None = None
    ) -> dict[str, float]:
        """Apply the staged plan's first step to the plant (curtailed when the fleet's IL
        is ``activated`` in this period), its predicted power held to the fleet guard's
        ``guard_cap_kw`` [kW] (None: to the building's own cap); the step's row values."""
        k = self.loop.k
        self.setup.activation[k] = activated
        plan, self._staged = self._staged, None
        self.controller.guard_cap_kw = guard_cap_kw
        try:
            self.loop.step(plan=plan)
        finally:
            self.controller.guard_cap_kw = None
        col = self.loop.recorder.column_index
        row = self.loop.recorder.values[k]
        return {
            "planned_power_kw": float(row[col["planned_power_kw"]]),
            "power_kw": float(row[col["power_kw"]]),
            "reserve_kw": float(row[col["reserve_kw"]]),
            "fallback": float(self.loop.recorder.flags["fallback"][k]),
        }

    def envelope(self, steps: tuple[int, ...]) -> FloatArray:
        """(D, 2) the least and the most power [kW] the building holds for each of ``steps``
        periods from now without leaving comfort, on the step's problem (after
        :meth:`begin_step`; :func:`hvacflex.fleet.envelope.building_envelope`): NaN for a
        duration no hold of which keeps comfort."""
        inputs = self._inputs
        assert inputs is not None, "begin_step() first"
        return building_envelope(
            self.problem, steps, lambda flows: self.controller.hold_power_kw(inputs, flows)
        )

    def advance_held(self, level_kw: float, steps_left: int) -> dict[str, float]:
        """Hold ``level_kw`` [kW] this period (after :meth:`begin_step`): the flows of the
        hold over the ``steps_left`` periods left of it, re-planned from the state now
        (:func:`hvacflex.fleet.envelope.hold_flows`) at the affine level whose flows the
        plant's power model (:meth:`FleetController.hold_power_kw`) predicts at
        ``level_kw`` (the affine level corrected by the difference, up to
        :data:`HOLD_LEVEL_ITERATIONS` times), applied to the plant as they are (no IL
        activation); the step's row values as :meth:`advance`.

        Raises RuntimeError when the hold's LP fails (no flows to hold); in a period an
        event plan locks, the plan is applied and the step's status reads ``+hold-ignored``
        instead of ``+held``."""
        problem, inputs = self.problem, self._inputs
        assert inputs is not None
        affine = level_kw
        for _ in range(HOLD_LEVEL_ITERATIONS):  # the affine level the plant's model meets
            flows = hold_flows(problem, affine, steps_left)
            if np.any(np.isnan(flows)):
                break
            predicted = self.controller.hold_power_kw(inputs, flows)
            if abs(predicted - level_kw) <= HOLD_LEVEL_TOLERANCE_KW:
                break
            affine += level_kw - predicted
        if np.any(np.isnan(flows)):
            raise RuntimeError(
                f"building {self.name}: the hold LP at {level_kw:.2f} kW over {steps_left} "
                f"period(s) from step {self.loop.k} failed; no flows to hold"
            )
        flow = np.clip(flows[0], problem.u_min[0], problem.u_max[0])
        self.controller.held_flow_kg_s = flow
        self.controller.cap_now_kw = np.inf
        self.controller.power_now = (
            float(problem.power_offset_kw[0]),
            problem.power_coeff_kw_per_kg_s[0].copy(),
            problem.reserve_kw_per_kg_s[0].copy(),
        )
        try:
            return self.advance(False)
        finally:
            self.controller.held_flow_kg_s = None

    # -- state -----------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        return self.loop.get_state()

    def set_state(self, state: dict[str, Any]) -> None:
        self.loop.set_state(state)

    def restart_warm(self) -> None:
        """Drop the solver and keep its basis, as :meth:`set_state` leaves it: after a
        checkpoint the run goes on as a run resumed from it does (a HiGHS handle restarted
        from a basis may settle on another of an LP's optimal vertices than one that kept
        its factorisation, and the coordination amplifies it)."""
        self.control.restart_warm()

    def frame(self) -> pd.DataFrame:
        return self.loop.frame()


class BuildingGroup:
    """The agents of one worker; every call is vectorised over its buildings (a Dask actor).

    Parameters
    ----------
    fleet_doc : the fleet document (parsed TOML); only ``indices`` are built here.
    indices : positions of this group's buildings in the fleet.
    settings : the run's shared settings.
    """

    def __init__(
        self, fleet_doc: dict[str, Any], indices: list[int], settings: FleetSettings
    ) -> None:
        tick, cpu = time.perf_counter(), time.process_time()
        fleet = fleet_from_dict(fleet_doc, source="fleet")
        self.indices = list(indices)
        self.agents = [BuildingAgent(fleet.buildings[i], i, settings) for i in self.indices]
        self.setup_s = (time.perf_counter() - tick, time.process_time() - cpu)
        """(wall, process CPU) time [s] this group took to build its agents."""

    def begin_step(self, continuing: bool = False) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(B, N) minimum and maximum power [kW] and (B, N) energy prices [SGD/MWh];
        ``continuing`` as :meth:`BuildingAgent.begin_step`."""
        parts = [agent.begin_step(continuing) for agent in self.agents]
        return (
            np.array([p[0] for p in parts]),
            np.array([p[1] for p in parts]),
            np.array([p[2] for p in parts]),
        )

    def solve(self, price_sgd_per_mwh: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(B, N) plan powers [kW], (B,) costs and Lagrangian objectives [SGD] at price (N,)."""
        return _stack([agent.solve(price_sgd_per_mwh) for agent in self.agents])

    def finalize(
        self, price_sgd_per_mwh: FloatArray, cap_kw: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Fix every plan inside its caps (B, N) [kW]; like :meth:`solve`."""
        return _stack([a.finalize(price_sgd_per_mwh, cap_kw[i]) for i, a in enumerate(self.agents)])

    def cap_values(self) -> FloatArray:
        """(B, N) marginal values of the caps at the last solves [SGD/kW]."""
        return np.array([agent.cap_values() for agent in self.agents])

    def finalize_with_values(
        self, price_sgd_per_mwh: FloatArray, cap_kw: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """:meth:`finalize`, and the cap values (B, N) [SGD/kW] after it (one round trip
        instead of two in the cap reallocation)."""
        power, cost, lagrangian = self.finalize(price_sgd_per_mwh, cap_kw)
        return power, cost, lagrangian, self.cap_values()

    def problems(self) -> list[RMPCProblem]:
        """The step's problems of this group's buildings (after :meth:`begin_step`)."""
        return [agent.problem for agent in self.agents]

    def staged_split_sgd(self) -> tuple[FloatArray]:
        """((B, 3) the staged plans' cost split [SGD], :meth:`BuildingAgent.staged_split_sgd`,)."""
        return (np.array([agent.staged_split_sgd() for agent in self.agents]),)

    def staged_offer_kw(
        self, envelope_steps: tuple[int, ...] = ()
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """(B,) the staged plans' first-period offers, their curtailed powers by the plant's
        power model and the buildings' settlement baselines now [kW]
        (:meth:`BuildingAgent.staged_offer_kw`), and (B, D, 2) every building's envelope
        [kW] for the D holds of ``envelope_steps`` periods (:meth:`BuildingAgent.envelope`;
        D = 0, none computed, for an empty tuple): the step's offers and envelope in one
        round trip."""
        envelope = (
            np.array([agent.envelope(envelope_steps) for agent in self.agents])
            if envelope_steps
            else np.empty((len(self.agents), 0, 2))
        )
        parts = np.array([agent.staged_offer_kw() for agent in self.agents], dtype=float)
        parts = parts.reshape(len(self.agents), 3)
        return parts[:, 0].copy(), parts[:, 1].copy(), parts[:, 2].copy(), envelope

    def guard_view(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """(B,) each of :meth:`BuildingAgent.guard_view`'s four values."""
        parts = np.array([agent.guard_view() for agent in self.agents]).reshape(-1, 4)
        return parts[:, 0], parts[:, 1], parts[:, 2], parts[:, 3]

    def advance(
        self, activated: bool = False, guard_cap_kw: FloatArray | None = None
    ) -> dict[str, FloatArray]:
        """Step every plant (curtailed where ``activated`` and a reserve is offered), each
        held to its fleet guard's cap (B,) [kW] (None: its own cap); (B,) arrays of the
        step's planned and realised power etc."""
        caps: list[float | None] = [None] * len(self.agents)
        if guard_cap_kw is not None:
            caps = [float(c) for c in guard_cap_kw]
        rows = [agent.advance(activated, cap) for agent, cap in zip(self.agents, caps, strict=True)]
        return {key: np.array([r[key] for r in rows]) for key in rows[0]}

    def envelope(self, steps: tuple[int, ...]) -> tuple[FloatArray]:
        """((B, D, 2) every building's envelope [kW], :meth:`BuildingAgent.envelope`,)."""
        return (np.array([agent.envelope(steps) for agent in self.agents]),)

    def advance_held(self, level_kw: FloatArray, steps_left: int) -> dict[str, FloatArray]:
        """:meth:`BuildingAgent.advance_held` at each building's level (B,) [kW]; like
        :meth:`advance`."""
        rows = [a.advance_held(float(level_kw[i]), steps_left) for i, a in enumerate(self.agents)]
        return {key: np.array([r[key] for r in rows]) for key in rows[0]}

    def get_state(self) -> list[dict[str, Any]]:
        return [agent.get_state() for agent in self.agents]

    def set_state(self, states: list[dict[str, Any]]) -> int:
        for agent, state in zip(self.agents, states, strict=True):
            agent.set_state(state)
        return len(states)

    def restart_warm(self) -> int:
        """:meth:`BuildingAgent.restart_warm` on every agent; how many."""
        for agent in self.agents:
            agent.restart_warm()
        return len(self.agents)

    def frames(self) -> list[pd.DataFrame]:
        return [agent.frame() for agent in self.agents]

    def ping(self) -> int:
        return len(self.agents)

    def timings(self) -> tuple[float, float, float]:
        """(set-up wall [s], set-up CPU [s], this process's CPU time so far [s]) (benchmarks)."""
        return self.setup_s[0], self.setup_s[1], time.process_time()


def _stack(parts: list[StepSolve]) -> tuple[FloatArray, FloatArray, FloatArray]:
    power = np.array([p.power_kw for p in parts])
    cost = np.array([p.cost_sgd if p.ok else np.nan for p in parts])
    lagrangian = np.array([p.lagrangian_sgd if p.ok else np.nan for p in parts])
    return power, cost, lagrangian
