"""Rule-based baseline: a thermostat that drives each zone to its set-point.

The thermostat has no horizon, no prices and offers no reserve. Each period it picks the
zone flows whose one-step prediction on the linear model lands the zone temperatures on the
set-point (occupied) or just inside the upper unoccupied bound, clipped to the flow limits:

    C (A x + B u + E d̂₀ + g) = T_set   →   u = clip((C B)⁻¹ (T_set − C (A x + E d̂₀ + g)))

This is an ideal discrete-time thermostat (a dead-beat P rule), used as the paper-independent
reference and as the MPC's fallback when an optimisation fails.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hvacflex.building.discretize import LinearModel
from hvacflex.building.model import HvacSystem
from hvacflex.control.base import Action, Controller, FloatArray
from hvacflex.data.forecast import Forecast

UNOCCUPIED_MARGIN_K = 1.0
"""Unoccupied set-point sits this far inside the upper unoccupied comfort bound [K]."""


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


class ThermostatController(Controller):
    """Dead-beat thermostat on the linear model (see the module docstring).

    Parameters
    ----------
    model : the building's discrete linear model.
    hvac : flow limits (minimum, ventilation flow while occupied, maximum).
    setpoint_degc : occupied set-point [°C].
    """

    def __init__(self, model: LinearModel, hvac: HvacSystem, setpoint_degc: float = 24.0) -> None:
        self._model = model
        self._hvac = hvac
        self._flow_max = np.asarray(hvac.flow_max_kg_s, dtype=float)
        self._setpoint_degc = setpoint_degc
        self._cb_inv = np.linalg.pinv(model.c @ model.b)

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
        else:
            target = np.maximum(upper - UNOCCUPIED_MARGIN_K, lower)
        return target

    def flows_now(self, x_degc: FloatArray, forecast: Forecast) -> FloatArray:
        """Zone flows (m,) [kg/s] for the period starting now (forecast period 0)."""
        occupied = bool(forecast.occupied[0])
        return self.flows_for(
            x_degc, forecast.disturbances[0], self.target_degc(forecast), occupied
        )

    def act(
        self,
        x_degc: FloatArray,
        forecast: Forecast,
        *,
        peak_floor_kw: float,
        allowance_carry_steps: int = 0,
        measured_zone_temp_degc: FloatArray | None = None,
        plan: Any = None,
    ) -> Action:
        return unplanned_action(
            self._model,
            x_degc,
            self.flows_now(x_degc, forecast),
            forecast.disturbances[0],
            status="rule",
            fallback=False,
            solve_time_s=0.0,
            plan_margin_k=0.0,
        )

    def get_state(self) -> dict[str, Any]:
        return {}

    def set_state(self, state: dict[str, Any]) -> None:
        return None
