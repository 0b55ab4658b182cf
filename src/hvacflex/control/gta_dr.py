"""Rule-based baseline ``gta-dr``: how buildings bid interruptible load today.

A thermostat (:mod:`hvacflex.control.baselines`, with its optimal start) that

* **offers a fixed share** ``s`` (``[controller] reserve_share``) of its predicted HVAC load
  as IL reserve every period: ``reserve_kw = s × P(u₀)``, with ``P`` the plant's power model
  (:func:`hvacflex.control.demand_limit.predicted_power_kw`); and
* **raises its set-points by α** (``[reserve] event_allowance_k``) when activated: the
  curtailed flows are the thermostat's flows to ``T_set + α`` (clipped to the band's upper
  bound + α, at least the period's minimum flow and at most the served flow), so the
  reserve is a real flow reduction ``r = u − u_curtailed`` that the closed loop applies
  (``u − r``) during an activation.

The bid and the delivery are decided apart, as they are in practice: the setpoint raise cuts
the flow most in the event's first period (the zones float up to ``T_set + α``) and little
once they hold there, so what is delivered may fall short of the fixed-share offer (the
settlement counts it, :mod:`hvacflex.kpi`).

Under the event model (the preset uses the product's D, α, R) each decision carries the
:class:`~hvacflex.control.base.EventPlan` an activation starting now locks: over D + R
periods, the served path (thermostat to ``T_set`` on the linear model with the forecast
disturbances) and, for the first D periods, the curtailed path (thermostat to ``T_set + α``);
in the recovery periods ``r = 0``.
"""

from __future__ import annotations

import numpy as np

from hvacflex.building.discretize import LinearModel
from hvacflex.building.model import HvacSystem
from hvacflex.control.base import Action, EventPlan, FloatArray, PeriodInputs
from hvacflex.control.baselines import UNOCCUPIED_MARGIN_K, OptimalStart, ThermostatController
from hvacflex.control.demand_limit import predicted_power_kw
from hvacflex.data.forecast import Forecast

DEFAULT_RESERVE_SHARE = 0.2
"""Share of the predicted HVAC load offered as reserve (``s``; 20 %, a typical IL bid)."""


class GtaDrController(ThermostatController):
    """Fixed-share IL bid with a set-point raise on activation (module docstring).

    Parameters
    ----------
    model, hvac, setpoint_degc, optimal_start : as :class:`ThermostatController`.
    reserve_share : ``s``, the share of the predicted load offered (0 ≤ s ≤ 1).
    raise_k : α, the set-point raise during an activation [K].
    event_steps : D, the event length the plan covers [periods].
    recovery_steps : R, the recovery periods after it.
    """

    def __init__(
        self,
        model: LinearModel,
        hvac: HvacSystem,
        setpoint_degc: float,
        optimal_start: OptimalStart | None,
        *,
        reserve_share: float = DEFAULT_RESERVE_SHARE,
        raise_k: float,
        event_steps: int,
        recovery_steps: int,
        unoccupied_margin_k: float = UNOCCUPIED_MARGIN_K,
    ) -> None:
        super().__init__(
            model, hvac, setpoint_degc, optimal_start, unoccupied_margin_k=unoccupied_margin_k
        )
        if not 0.0 <= reserve_share <= 1.0:
            raise ValueError(f"reserve share must be in [0, 1], got {reserve_share}")
        self.reserve_share = reserve_share
        self.raise_k = raise_k
        self.event_steps = event_steps
        self.recovery_steps = recovery_steps

    def _targets(self, forecast: Forecast, steps: int) -> FloatArray:
        """(L, m) served set-points [°C]: period 0's rule target, then per period the occupied
        set-point (also while pre-cooling towards occupancy) or the unoccupied one."""
        targets = [self.target_degc(forecast)]
        for j in range(1, steps):
            lower, upper = forecast.comfort_lower_degc[j], forecast.comfort_upper_degc[j]
            if bool(forecast.occupied[j]) or self.precooling:
                targets.append(np.clip(np.full_like(upper, self.setpoint_degc), lower, upper))
            else:
                targets.append(np.maximum(upper - self.unoccupied_margin_k, lower))
        return np.asarray(targets)

    def event_plan(self, x_degc: FloatArray, forecast: Forecast) -> EventPlan:
        """The served and curtailed paths over D + R periods (module docstring)."""
        model, hvac = self.model, self.hvac
        steps = min(self.event_steps + self.recovery_steps, len(forecast.occupied))
        targets = self._targets(forecast, steps)
        m = model.c.shape[0]
        flow, reserve = np.zeros((steps, m)), np.zeros((steps, m))
        served_kw, reserve_kw = np.zeros(steps), np.zeros(steps)
        served_degc, curtailed_degc = np.zeros((steps, m)), np.zeros((steps, m))
        x_served, x_cut = np.asarray(x_degc, dtype=float), np.asarray(x_degc, dtype=float)
        damper = hvac.outdoor_air_open_at(forecast.occupied, model.dt_s)  # the plant's rule
        for j in range(steps):
            d = forecast.disturbances[j]
            occupied = bool(forecast.occupied[j])
            u = self.flows_for(x_served, d, targets[j], occupied)
            if j < self.event_steps:
                ceiling = forecast.comfort_upper_degc[j] + self.raise_k
                raised = np.minimum(targets[j] + self.raise_k, ceiling)
                cut = np.minimum(self.flows_for(x_cut, d, raised, occupied), u)
            else:
                cut = self.flows_for(x_cut, d, targets[j], occupied)
            next_served = model.step(x_served, u, d)
            next_cut = model.step(x_cut, cut, d)
            flow[j] = u
            reserve[j] = np.maximum(u - cut, 0.0) if j < self.event_steps else 0.0
            outdoor = float(forecast.outdoor_temp_degc[j])
            humidity = float(forecast.outdoor_humidity_ratio_kg_per_kg[j])
            served_kw[j] = predicted_power_kw(
                hvac,
                u,
                model.c @ x_served,
                model.c @ next_served,
                outdoor,
                humidity,
                damper_open=bool(damper[j]),
            )
            reserve_kw[j] = self.reserve_share * served_kw[j] if j < self.event_steps else 0.0
            served_degc[j] = model.c @ next_served
            curtailed_degc[j] = model.c @ next_cut
            x_served, x_cut = next_served, next_cut
        return EventPlan(flow, reserve, served_kw, reserve_kw, served_degc, curtailed_degc)

    def act(self, inputs: PeriodInputs) -> Action:
        x_degc, forecast = inputs.x_degc, inputs.forecast
        self.observe(x_degc, forecast)
        event = self.event_plan(x_degc, forecast)
        return Action(
            flow_kg_s=event.flow_kg_s[0],
            reserve_flow_kg_s=event.reserve_flow_kg_s[0],
            reserve_kw=float(event.reserve_kw[0]),
            planned_power_kw=float(event.served_power_kw[0]),
            status="rule",
            fallback=False,
            solve_time_s=0.0,
            planned_slack_max_k=0.0,
            delta_max_k=0.0,
            predicted_served_degc=event.predicted_served_degc[0],
            predicted_curtailed_degc=event.predicted_curtailed_degc[0],
            event_plan=event,
        )
