"""Rule-based baseline: a thermostat that drives each zone to its set-point.

The thermostat has no horizon, no prices and offers no reserve. Each period it picks the
zone flows whose one-step prediction on the linear model lands the zone temperatures on the
set-point (occupied) or just inside the upper unoccupied bound, clipped to the flow limits:

    C (A x + B u + E d̂₀ + g) = T_set   →   u = clip((C B)⁻¹ (T_set − C (A x + E d̂₀ + g)))

This is an ideal discrete-time thermostat (a dead-beat P rule), used as the paper-independent
reference and as the MPC's fallback when an optimisation fails.

**Optimal start** (:class:`OptimalStart`, preset ``thermostat-25.5``): the thermostat starts
cooling to the occupied set-point ``lead_steps`` periods before occupancy, and learns the lead
from the previous occupied day (the rule of ASHRAE Guideline 36 §5.1.9's optimal start, made
adaptive): at the start of the first occupied period of a day,

* the band was **missed** (some zone above the occupied upper bound by more than
  :data:`REACHED_TOLERANCE_K`): start one period earlier next time;
* the band was reached and every zone was already inside it one period before occupancy
  (the last pre-cooling period was not needed): start one period later next time;
* otherwise keep the lead;

always within [:data:`OPTIMAL_START_FLOOR_STEPS`, :data:`OPTIMAL_START_CEILING_STEPS`],
starting from :data:`OPTIMAL_START_INITIAL_STEPS`. So the lead settles on the latest start
that still reaches the band at occupancy.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from hvacflex.building.discretize import LinearModel
from hvacflex.building.model import HvacSystem
from hvacflex.control.base import Action, Controller, FloatArray, PeriodInputs
from hvacflex.data.forecast import Forecast

UNOCCUPIED_MARGIN_K = 1.0
"""Unoccupied set-point sits this far inside the upper unoccupied comfort bound [K]."""

REACHED_TOLERANCE_K = 0.05
"""A zone counts as inside the occupied band at occupancy up to this much above it [K]."""

OPTIMAL_START_INITIAL_STEPS = 2
"""Pre-cooling lead before the first learned day [30-min periods]."""

OPTIMAL_START_FLOOR_STEPS = 0
"""Shortest pre-cooling lead [periods] (0: start cooling at occupancy)."""

OPTIMAL_START_CEILING_STEPS = 8
"""Longest pre-cooling lead [periods] (4 h: a night-time pull-down is not a start)."""


class OptimalStart:
    """The learned pre-cooling lead of an optimal start (rule in the module docstring).

    Parameters
    ----------
    initial_steps, floor_steps, ceiling_steps : the lead to begin with and its limits
        [30-min periods].
    """

    def __init__(
        self,
        initial_steps: int = OPTIMAL_START_INITIAL_STEPS,
        floor_steps: int = OPTIMAL_START_FLOOR_STEPS,
        ceiling_steps: int = OPTIMAL_START_CEILING_STEPS,
    ) -> None:
        if not floor_steps <= initial_steps <= ceiling_steps:
            raise ValueError(
                f"optimal start needs floor ≤ initial ≤ ceiling, got "
                f"{floor_steps}, {initial_steps}, {ceiling_steps}"
            )
        self.floor_steps = floor_steps
        self.ceiling_steps = ceiling_steps
        self.lead_steps = initial_steps
        """Periods before occupancy at which pre-cooling starts."""
        self._was_occupied: bool | None = None
        self._early_in_band: bool | None = None

    def observe(self, forecast: Forecast, zone_temp_degc: FloatArray) -> bool:
        """Learn from the zone temperatures (m,) [°C] at the start of the forecast's first
        period and say whether this period pre-cools (unoccupied, occupancy within the lead).
        Call once per decided period."""
        occupied = np.asarray(forecast.occupied, dtype=bool)
        now = bool(occupied[0])
        if now and self._was_occupied is False:
            upper = forecast.comfort_upper_degc[0]
            if bool(np.any(zone_temp_degc > upper + REACHED_TOLERANCE_K)):
                self.lead_steps = min(self.lead_steps + 1, self.ceiling_steps)
            elif self._early_in_band:
                self.lead_steps = max(self.lead_steps - 1, self.floor_steps)
        if not now and occupied.size > 1 and bool(occupied[1]):
            upper_next = forecast.comfort_upper_degc[1]
            self._early_in_band = bool(np.all(zone_temp_degc <= upper_next + REACHED_TOLERANCE_K))
        self._was_occupied = now
        return not now and bool(np.any(occupied[1 : self.lead_steps + 1]))

    def get_state(self) -> dict[str, Any]:
        return {
            "lead_steps": self.lead_steps,
            "was_occupied": self._was_occupied,
            "early_in_band": self._early_in_band,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        self.lead_steps = int(state["lead_steps"])
        was, early = state["was_occupied"], state["early_in_band"]
        self._was_occupied = None if was is None else bool(was)
        self._early_in_band = None if early is None else bool(early)


def first_occupied_band(forecast: Forecast) -> tuple[FloatArray, FloatArray]:
    """The comfort band (lower, upper), each (m,) [°C], of the forecast's first occupied
    period (period 0's band when none is occupied)."""
    occupied = np.flatnonzero(np.asarray(forecast.occupied, dtype=bool))
    j = int(occupied[0]) if occupied.size else 0
    return forecast.comfort_lower_degc[j], forecast.comfort_upper_degc[j]


def unplanned_action(
    model: LinearModel,
    x_degc: FloatArray,
    flow_kg_s: FloatArray,
    d_now: FloatArray,
    *,
    status: str,
    fallback: bool,
    solve_time_s: float,
    plan_margin_k: float,
) -> Action:
    """An action without an optimal plan (a rule, or an MPC fallback): no reserve, no planned
    power, and the one-step prediction ``C (A x + B u + E d̂₀ + g)`` of the zone temperatures
    [°C] on ``model`` for both the served and the curtailed case.

    ``plan_margin_k`` fills ``planned_slack_max_k`` and ``delta_max_k`` (0 for a rule, which
    plans no slack and no margin; NaN for a fallback, whose plan failed).
    """
    predicted = model.c @ model.step(x_degc, flow_kg_s, d_now)
    return Action(
        flow_kg_s=flow_kg_s,
        reserve_flow_kg_s=np.zeros_like(flow_kg_s),
        reserve_kw=0.0,
        planned_power_kw=float("nan"),
        status=status,
        fallback=fallback,
        solve_time_s=solve_time_s,
        planned_slack_max_k=plan_margin_k,
        delta_max_k=plan_margin_k,
        predicted_served_degc=predicted,
        predicted_curtailed_degc=predicted,
    )


def rule_action(
    model: LinearModel, x_degc: FloatArray, flow_kg_s: FloatArray, d_now: FloatArray
) -> Action:
    """The action of a rule-based controller: :func:`unplanned_action` of the flows (m,)
    [kg/s] from the state ``x_degc`` (n,) [°C] under the disturbances ``d_now`` (nd,), with
    status ``"rule"``, no fallback, no solve time and no slack or margin."""
    return unplanned_action(
        model,
        x_degc,
        flow_kg_s,
        d_now,
        status="rule",
        fallback=False,
        solve_time_s=0.0,
        plan_margin_k=0.0,
    )


class ThermostatController(Controller):
    """Dead-beat thermostat on the linear model (see the module docstring).

    Parameters
    ----------
    model : the building's discrete linear model.
    hvac : flow limits (minimum, ventilation flow while occupied, maximum).
    setpoint_degc : occupied set-point [°C].
    optimal_start : pre-cool to the set-point before occupancy with this learner (None: the
        set-point applies from the first occupied period).
    unoccupied_margin_k : the night float's set-point below the unoccupied upper comfort
        bound [K] (``[controller] unoccupied_margin_k``).
    """

    def __init__(
        self,
        model: LinearModel,
        hvac: HvacSystem,
        setpoint_degc: float = 24.0,
        optimal_start: OptimalStart | None = None,
        *,
        unoccupied_margin_k: float = UNOCCUPIED_MARGIN_K,
    ) -> None:
        if unoccupied_margin_k < 0.0:
            raise ValueError(f"unoccupied margin must be ≥ 0 K, got {unoccupied_margin_k}")
        self.unoccupied_margin_k = unoccupied_margin_k
        self._model = model
        self._hvac = hvac
        self._flow_max = np.asarray(hvac.flow_max_kg_s, dtype=float)
        self._setpoint_degc = setpoint_degc
        self._cb_inv = np.linalg.pinv(model.c @ model.b)
        self.optimal_start = optimal_start
        self._precool = False

    @property
    def model(self) -> LinearModel:
        """The linear model the rule predicts with."""
        return self._model

    @property
    def hvac(self) -> HvacSystem:
        return self._hvac

    @property
    def setpoint_degc(self) -> float:
        """The occupied set-point [°C]."""
        return self._setpoint_degc

    @property
    def precooling(self) -> bool:
        """True when the last observed period pre-cools before occupancy (optimal start)."""
        return self._precool

    def observe(self, x_degc: FloatArray, forecast: Forecast) -> None:
        """Advance the optimal start by one decided period (no-op without one)."""
        if self.optimal_start is not None:
            zone_temp = self._model.c @ x_degc
            self._precool = self.optimal_start.observe(forecast, zone_temp)

    def flows_for(
        self, x_degc: FloatArray, d_now: FloatArray, target_degc: FloatArray, occupied: bool
    ) -> FloatArray:
        """Zone flows (m,) [kg/s] that bring the zones to ``target_degc`` (m,) in one step."""
        m = self._model
        free = m.c @ (m.a @ x_degc + m.e @ d_now + m.g)
        low = self._hvac.flow_min_at([occupied])[0]
        flow: FloatArray = np.clip(self._cb_inv @ (target_degc - free), low, self._flow_max)
        return flow

    def target_degc(self, forecast: Forecast) -> FloatArray:
        """Set-point per zone for the current period [°C]."""
        upper = forecast.comfort_upper_degc[0]
        lower = forecast.comfort_lower_degc[0]
        target: FloatArray
        if bool(forecast.occupied[0]):
            target = np.clip(np.full_like(upper, self._setpoint_degc), lower, upper)
        elif self._precool:
            occupied_lower, occupied_upper = first_occupied_band(forecast)
            target = np.clip(
                np.full_like(upper, self._setpoint_degc), occupied_lower, occupied_upper
            )
        else:
            target = np.maximum(upper - self.unoccupied_margin_k, lower)
        return target

    def flows_now(self, x_degc: FloatArray, forecast: Forecast) -> FloatArray:
        """Zone flows (m,) [kg/s] for the period starting now (forecast period 0)."""
        occupied = bool(forecast.occupied[0])
        return self.flows_for(
            x_degc, forecast.disturbances[0], self.target_degc(forecast), occupied
        )

    def act(self, inputs: PeriodInputs) -> Action:
        x_degc, forecast = inputs.x_degc, inputs.forecast
        self.observe(x_degc, forecast)
        return rule_action(
            self._model, x_degc, self.flows_now(x_degc, forecast), forecast.disturbances[0]
        )

    def get_state(self) -> dict[str, Any]:
        start = None if self.optimal_start is None else self.optimal_start.get_state()
        return {"optimal_start": start, "precool": self._precool}

    def set_state(self, state: dict[str, Any]) -> None:
        if self.optimal_start is not None and state.get("optimal_start") is not None:
            self.optimal_start.set_state(state["optimal_start"])
        self._precool = bool(state.get("precool", False))


class PlantBaselineController(Controller):
    """The plant's own control, no action from hvacflex (the ``plant-baseline`` preset): every
    period is released to the plant (:attr:`Action.released`), which on EnergyPlus runs the
    IDF's own schedules and thermostats. The recorded flow is zero (the plant reports what it
    supplied) and the predictions are the linear model's free response, so the results have
    the schema of every other run.
    """

    def __init__(self, model: LinearModel) -> None:
        self._model = model

    def act(self, inputs: PeriodInputs) -> Action:
        flow = np.zeros(self._model.b.shape[1])
        action = rule_action(self._model, inputs.x_degc, flow, inputs.forecast.disturbances[0])
        return replace(action, released=True)

    def get_state(self) -> dict[str, Any]:
        return {}

    def set_state(self, state: dict[str, Any]) -> None:
        return None
