"""Rule-based baseline ``trim-respond``: ASHRAE Guideline 36-style trim and respond.

Guideline 36 resets VAV set-points by *trim and respond* (T&R): every time step the
set-point is trimmed a little in the energy-saving direction, and it responds to the
**requests** of the zones in the opposite direction, limited per step. Here at the 30-min
control step:

**Zone airflow** (each zone's cooling loop): the flow is ``u = u_low + f (u_max − u_low)``
with ``u_low`` the ventilation flow while occupied (or pre-cooling), else the minimum flow,
and the loop fraction ``f ∈ [0, 1]``. A zone above its set-point sends one cooling request
per :data:`REQUEST_STEP_K` above it (at most :data:`MAX_ZONE_REQUESTS`); each period

    f ← clip(f − TRIM_FRACTION + RESPOND_FRACTION × requests, 0, 1).

The set-point is ``[controller] thermostat_setpoint_degc`` while occupied (clipped to the
band) and while pre-cooling before occupancy (the learned optimal start of
:class:`hvacflex.control.baselines.OptimalStart`, Guideline 36 §5.1.9's cool-down mode);
otherwise the unoccupied set-back ``upper − unoccupied_margin_k`` (``[controller]``).

**Supply-air temperature** (the air handler's T&R): a zone whose loop is above
:data:`SAT_REQUEST_FRACTION` sends a supply-air request; each period

    SAT ← clip(SAT + SAT_TRIM_K − min(SAT_RESPOND_K × (requests − ignored), SAT_MAX_RESPOND_K),
               SAT_MIN_DEGC, SAT_MAX_DEGC)

(``ignored`` = :data:`SAT_IGNORED_REQUESTS`), starting at the building's design supply
temperature. The supply temperature goes to the plant as ``Action.supply_temp_degc`` only
where the plant accepts one (``reset_supply_temp``: EnergyPlus with flow actuation). The RC
plant keeps the supply temperature fixed at the design value, so there the controller is
**airflow-only** (``supply_temp_degc = None``, the SAT loop is not run).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from hvacflex.building.discretize import LinearModel
from hvacflex.building.model import HvacSystem
from hvacflex.control.base import Action, Controller, FloatArray, PeriodInputs
from hvacflex.control.baselines import (
    UNOCCUPIED_MARGIN_K,
    OptimalStart,
    first_occupied_band,
    rule_action,
)
from hvacflex.data.forecast import Forecast

REQUEST_STEP_K = 0.5
"""A zone sends one cooling request per this much above its set-point [K]."""

MAX_ZONE_REQUESTS = 3
"""Most cooling requests one zone sends in a period."""

TRIM_FRACTION = 0.1
"""Loop fraction trimmed every period (of the flow range u_max − u_low)."""

RESPOND_FRACTION = 0.15
"""Loop fraction added per cooling request."""

SAT_REQUEST_FRACTION = 0.95
"""A zone whose loop fraction exceeds this sends a supply-air temperature request."""

SAT_MIN_DEGC = 12.0
"""Lowest supply-air temperature set-point [°C] (Guideline 36's 55 °F, rounded down)."""

SAT_MAX_DEGC = 18.0
"""Highest supply-air temperature set-point [°C] (Guideline 36's 65 °F, rounded)."""

SAT_TRIM_K = 0.5
"""Supply-air temperature raise every period [K]."""

SAT_RESPOND_K = 0.5
"""Supply-air temperature drop per request beyond the ignored ones [K]."""

SAT_MAX_RESPOND_K = 1.5
"""Largest supply-air temperature drop in a period [K]."""

SAT_IGNORED_REQUESTS = 1
"""Requests ignored before the supply-air temperature responds."""


class TrimRespondController(Controller):
    """Zone-airflow and supply-air temperature trim and respond (module docstring).

    Parameters
    ----------
    model : the building's linear model (its zone selection ``c`` reads the zone
        temperatures from the state; its one-step prediction fills the action's).
    hvac : flow limits and design supply temperature.
    setpoint_degc : occupied zone cooling set-point [°C].
    optimal_start : the cool-down learner (None: no pre-cooling).
    reset_supply_temp : run the supply-air T&R and hand its set-point to the plant.
    """

    def __init__(
        self,
        model: LinearModel,
        hvac: HvacSystem,
        setpoint_degc: float,
        optimal_start: OptimalStart | None = None,
        *,
        reset_supply_temp: bool = False,
        unoccupied_margin_k: float = UNOCCUPIED_MARGIN_K,
    ) -> None:
        self.unoccupied_margin_k = unoccupied_margin_k
        """The night set-back below the unoccupied upper comfort bound [K]."""
        self._model = model
        self._hvac = hvac
        self._flow_max = np.asarray(hvac.flow_max_kg_s, dtype=float)
        self.setpoint_degc = setpoint_degc
        self.optimal_start = optimal_start
        self.reset_supply_temp = reset_supply_temp
        self.loop_fraction = np.zeros(len(self._flow_max))
        """(m,) each zone's loop fraction f."""
        self.supply_temp_degc = float(hvac.supply_temp_degc)
        """The supply-air temperature set-point [°C]."""

    def zone_setpoint_degc(self, forecast: Forecast, precool: bool) -> FloatArray:
        """(m,) zone cooling set-points of the current period [°C]."""
        lower, upper = forecast.comfort_lower_degc[0], forecast.comfort_upper_degc[0]
        if bool(forecast.occupied[0]) or precool:
            if precool:
                lower, upper = first_occupied_band(forecast)
            occupied: FloatArray = np.clip(np.full_like(upper, self.setpoint_degc), lower, upper)
            return occupied
        setback: FloatArray = np.maximum(upper - self.unoccupied_margin_k, lower)
        return setback

    def update(self, zone_temp_degc: FloatArray, setpoint_degc: FloatArray) -> None:
        """One T&R step of the zone loops and (``reset_supply_temp``) the supply air."""
        excess_k = np.asarray(zone_temp_degc - setpoint_degc, dtype=float)
        requests = np.clip(np.ceil(excess_k / REQUEST_STEP_K), 0, MAX_ZONE_REQUESTS)
        self.loop_fraction = np.clip(
            self.loop_fraction - TRIM_FRACTION + RESPOND_FRACTION * requests, 0.0, 1.0
        )
        if self.reset_supply_temp:
            sat_requests = int(np.sum(self.loop_fraction > SAT_REQUEST_FRACTION))
            drop_k = min(
                SAT_RESPOND_K * max(sat_requests - SAT_IGNORED_REQUESTS, 0), SAT_MAX_RESPOND_K
            )
            self.supply_temp_degc = float(
                np.clip(self.supply_temp_degc + SAT_TRIM_K - drop_k, SAT_MIN_DEGC, SAT_MAX_DEGC)
            )

    def act(self, inputs: PeriodInputs) -> Action:
        x_degc, forecast = inputs.x_degc, inputs.forecast
        zone_temp = self._model.c @ x_degc
        precool = False
        if self.optimal_start is not None:
            precool = self.optimal_start.observe(forecast, zone_temp)
        self.update(zone_temp, self.zone_setpoint_degc(forecast, precool))
        low = self._hvac.flow_min_at([bool(forecast.occupied[0]) or precool])[0]
        flow = low + self.loop_fraction * np.maximum(self._flow_max - low, 0.0)
        action = rule_action(self._model, x_degc, flow, forecast.disturbances[0])
        if not self.reset_supply_temp:
            return action
        return replace(action, supply_temp_degc=self.supply_temp_degc)

    def get_state(self) -> dict[str, Any]:
        start = None if self.optimal_start is None else self.optimal_start.get_state()
        return {
            "loop_fraction": self.loop_fraction.copy(),
            "supply_temp_degc": self.supply_temp_degc,
            "optimal_start": start,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        self.loop_fraction = np.asarray(state["loop_fraction"], dtype=float).copy()
        self.supply_temp_degc = float(state["supply_temp_degc"])
        if self.optimal_start is not None and state["optimal_start"] is not None:
            self.optimal_start.set_state(state["optimal_start"])
