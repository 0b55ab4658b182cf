"""Rule-based baseline ``demand-limit``: a thermostat that raises its set-points to hold a
peak target.

The controller is the dead-beat thermostat of :mod:`hvacflex.control.baselines` (with its
optimal start). Each period it predicts the HVAC power of the thermostat's flows with the
plant's power model (:func:`hvacflex.building.hvac.hvac_power_kw` at the mean of the zone
temperatures now and at the predicted period end, the forecast outdoor air; latent gains
left out). When that power exceeds the **peak target**, it raises every zone's set-point in
steps of :data:`SETPOINT_STEP_K`, up to the comfort band's upper bound less
:data:`UPPER_MARGIN_K` (the last candidate), and takes the smallest raise whose predicted power
is within the target (the largest raise when none is).

**How the target is set**: ``target = max(f × P_ref, P_month)``, where

* ``P_ref`` is the largest predicted power of the unlimited thermostat (the set-point
  without a raise) on the previous day that had one — yesterday's unmanaged peak;
* ``f`` is ``[controller] demand_limit_fraction`` (default 0.9: shave 10 % of it);
* ``P_month`` is the peak already billed in this billing period (``peak_floor_kw``, metered
  by the closed loop): power below it costs no demand charge, so it is never limited.

Before the first day has passed there is no ``P_ref`` and no limit (a plain thermostat).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from hvacflex.building.discretize import LinearModel
from hvacflex.building.hvac import hvac_power_kw
from hvacflex.building.model import HvacSystem
from hvacflex.control.base import Action, FloatArray, PeriodInputs
from hvacflex.control.baselines import (
    UNOCCUPIED_MARGIN_K,
    OptimalStart,
    ThermostatController,
    rule_action,
)
from hvacflex.data.forecast import Forecast

SETPOINT_STEP_K = 0.25
"""Set-point raise increment the limiter tries [K]."""

UPPER_MARGIN_K = 0.1
"""The raised set-point stays this far below the comfort band's upper bound [K]."""

DEFAULT_DEMAND_LIMIT_FRACTION = 0.9
"""Peak target as a share of yesterday's unmanaged peak (``f`` of the module docstring)."""


def predicted_power_kw(
    hvac: HvacSystem,
    flow_kg_s: FloatArray,
    zone_start_degc: FloatArray,
    zone_end_degc: FloatArray,
    outdoor_temp_degc: float,
    outdoor_humidity_ratio_kg_per_kg: float,
    latent_gain_w: float = 0.0,
    damper_open: bool = True,
) -> float:
    """HVAC power [kW] of flows (m,) [kg/s] over a period whose zone temperatures (m,) [°C]
    go from ``zone_start_degc`` to ``zone_end_degc`` (the plant's model at the mean zone
    temperature; the occupants' latent gain [W], all zones, left out by default; outdoor air
    only if ``damper_open``, the plant's schedule
    :meth:`~hvacflex.building.model.HvacSystem.outdoor_air_open_at`)."""
    mean = 0.5 * (np.asarray(zone_start_degc) + np.asarray(zone_end_degc))
    return float(
        hvac_power_kw(
            hvac,
            flow_kg_s,
            mean,
            outdoor_temp_degc,
            outdoor_humidity_ratio_kg_per_kg,
            latent_gain_w=latent_gain_w,
            damper_open=damper_open,
        )
    )


def forecast_period_power_kw(
    model: LinearModel,
    hvac: HvacSystem,
    x_degc: FloatArray,
    flow_kg_s: FloatArray,
    forecast: Forecast,
    *,
    latent: bool = False,
) -> float:
    """HVAC power [kW] of flows (m,) [kg/s] over the period starting now: the linear model
    stepped from ``x_degc`` (n,) [°C] under the forecast's first disturbances, then
    :func:`predicted_power_kw` with its outdoor air (the damper open as the plant's schedule
    has it in the period: occupied or the purge before occupancy) and, if ``latent``, the
    occupants' latent gain."""
    end = model.c @ model.step(x_degc, flow_kg_s, forecast.disturbances[0])
    gain = forecast.occupant_latent_w
    damper = hvac.outdoor_air_open_at(forecast.occupied, model.dt_s)
    return predicted_power_kw(
        hvac,
        flow_kg_s,
        model.c @ x_degc,
        end,
        float(forecast.outdoor_temp_degc[0]),
        float(forecast.outdoor_humidity_ratio_kg_per_kg[0]),
        latent_gain_w=float(gain[0]) if latent and gain.size else 0.0,
        damper_open=bool(damper[0]),
    )


class DemandLimitController(ThermostatController):
    """Thermostat with set-point raises that hold a peak target (module docstring).

    Parameters
    ----------
    model, hvac, setpoint_degc, optimal_start : as :class:`ThermostatController`.
    fraction : ``f``, the target's share of yesterday's unmanaged peak (0 < f ≤ 1].
    """

    def __init__(
        self,
        model: LinearModel,
        hvac: HvacSystem,
        setpoint_degc: float,
        optimal_start: OptimalStart | None = None,
        fraction: float = DEFAULT_DEMAND_LIMIT_FRACTION,
        *,
        unoccupied_margin_k: float = UNOCCUPIED_MARGIN_K,
    ) -> None:
        super().__init__(
            model, hvac, setpoint_degc, optimal_start, unoccupied_margin_k=unoccupied_margin_k
        )
        if not 0.0 < fraction <= 1.0:
            raise ValueError(f"demand-limit fraction must be in (0, 1], got {fraction}")
        self.fraction = fraction
        self.reference_kw = math.nan
        """``P_ref``: yesterday's largest unmanaged predicted power [kW] (NaN: not known)."""
        self._day: str | None = None
        self._day_peak_kw = math.nan
        self.last_raise_k = 0.0
        """The set-point raise of the last decision [K]."""

    def target_kw(self, peak_floor_kw: float) -> float:
        """The peak target [kW] (inf before a day has passed)."""
        if math.isnan(self.reference_kw):
            return math.inf
        return max(self.fraction * self.reference_kw, peak_floor_kw)

    def _roll_day(self, forecast: Forecast) -> None:
        day = str(forecast.index[0].date())
        if self._day is not None and day != self._day and not math.isnan(self._day_peak_kw):
            self.reference_kw = self._day_peak_kw
            self._day_peak_kw = math.nan
        self._day = day

    def _power_kw(self, x_degc: FloatArray, flow: FloatArray, forecast: Forecast) -> float:
        return forecast_period_power_kw(self.model, self.hvac, x_degc, flow, forecast)

    def limited_flows(
        self, x_degc: FloatArray, forecast: Forecast, target_kw: float
    ) -> tuple[FloatArray, float]:
        """Zone flows (m,) [kg/s] and the set-point raise [K] that hold ``target_kw``."""
        base = self.target_degc(forecast)
        occupied = bool(forecast.occupied[0])
        d_now = forecast.disturbances[0]
        flow = self.flows_for(x_degc, d_now, base, occupied)
        if self._power_kw(x_degc, flow, forecast) <= target_kw:
            return flow, 0.0
        ceiling = forecast.comfort_upper_degc[0] - UPPER_MARGIN_K
        room_k = float(np.max(ceiling - base))
        raises = [*np.arange(SETPOINT_STEP_K, room_k - 1e-9, SETPOINT_STEP_K), room_k]
        raise_k = 0.0
        for raise_k in (float(r) for r in raises if r > 0):
            target = np.maximum(np.minimum(base + raise_k, ceiling), base)
            flow = self.flows_for(x_degc, d_now, target, occupied)
            if self._power_kw(x_degc, flow, forecast) <= target_kw:
                break
        return flow, raise_k

    def act(self, inputs: PeriodInputs) -> Action:
        x_degc, forecast = inputs.x_degc, inputs.forecast
        self.observe(x_degc, forecast)
        self._roll_day(forecast)
        unlimited = self._power_kw(x_degc, self.flows_now(x_degc, forecast), forecast)
        self._day_peak_kw = float(np.nanmax([self._day_peak_kw, unlimited]))
        flow, self.last_raise_k = self.limited_flows(
            x_degc, forecast, self.target_kw(inputs.peak_floor_kw)
        )
        return rule_action(self.model, x_degc, flow, forecast.disturbances[0])

    def get_state(self) -> dict[str, Any]:
        return super().get_state() | {
            "reference_kw": self.reference_kw,
            "day": self._day,
            "day_peak_kw": self._day_peak_kw,
            "last_raise_k": self.last_raise_k,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        super().set_state(state)
        self.reference_kw = float(state["reference_kw"])
        self._day = None if state["day"] is None else str(state["day"])
        self._day_peak_kw = float(state["day_peak_kw"])
        self.last_raise_k = float(state["last_raise_k"])
