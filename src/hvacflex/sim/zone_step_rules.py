"""What hvacflex does at EnergyPlus's zone time step, between two periods' actuations.

* The **setpoint rule** (:class:`SetpointRule`, under setpoint actuation): each zone's heating
  setpoint is min(the IDF's heating schedule, cooling − :data:`SETPOINT_DEADBAND_K`); the air
  loop's availability schedules are forced on (:data:`AVAILABILITY_ON`) at every zone time
  step in which some zone is warmer than its actuated cooling setpoint, or would be warmer
  than its comfort limit (``Actuation.limit_degc``) by more than
  :data:`ANTICIPATION_TOLERANCE_K` at the next step if it kept rising at its last step's rate
  (a sunny afternoon can lift a zone left to float by more than 1 K in a 15-min step);
  otherwise the IDF's schedules decide.
* The **peak guard's shed** (:func:`next_shed_level`, :func:`shed_toward_band`): integral
  action on the meter against the period's committed cap, moving the zones below their
  upper bound toward it.

:class:`hvacflex.sim.energyplus_plant.EnergyPlusPlant` applies both; the rules read the
latest variables only, so a replay of the same actuations gives the same values.
"""

from __future__ import annotations

import numpy as np

from hvacflex.sim.plant import FloatArray, PeakGuard

SETPOINT_DEADBAND_K = 1.0
"""The heating setpoint is kept at least this far below the actuated cooling setpoint [K]."""
ANTICIPATION_TOLERANCE_K = 0.1
"""The loop is started a zone time step early only when a zone, rising at its last step's
rate, would pass its comfort limit by more than this [K]."""
AVAILABILITY_ON = 1.0
"""Value of a forced-on availability schedule."""
GUARD_GAIN = 4.0
"""The peak guard's integral gain while the meter exceeds the cap: change of its shed level
per zone time step per unit relative excess (a 5 % excess sheds a fifth of the way)."""
GUARD_RELEASE_GAIN = 1.0
"""The gain below the cap: the shed is released more slowly than it was taken (a fast
release rebounds above the cap, the zones having drifted up meanwhile)."""


class SetpointRule:
    """The setpoint rule of one run (module docstring): the actuator values of a zone time
    step from the period's commanded ones.

    Parameters
    ----------
    zones : m, the zones actuated (the first m variables are their air temperatures, the
        actuators their m cooling setpoints, m heating setpoints, then the availability
        schedules).
    """

    def __init__(self, zones: int) -> None:
        self.zones = zones
        self.heating_vars: list[int | None] = []
        """Per zone, the variable index of the IDF's heating setpoint schedule (None: none)."""
        self.limit_degc: FloatArray | None = None
        """(m,) the period's comfort limits (``Actuation.limit_degc``) [°C], or None."""
        self.previous_zone_degc: FloatArray | None = None
        """(m,) the zones' air temperatures at the last zone time step [°C], or None."""

    def reset(self) -> None:
        """A new run: no limit, no previous step."""
        self.limit_degc, self.previous_zone_degc = None, None

    def apply(self, now: FloatArray, commanded: FloatArray) -> FloatArray:
        """(na,) the values to actuate: ``commanded`` (na,) with the heating setpoints below
        the cooling ones and the availability forced on where the module docstring says;
        ``now`` (nv,) the latest variables."""
        m = self.zones
        cooling = commanded[:m]
        applied = commanded.copy()
        for i, index in enumerate(self.heating_vars):
            limit = cooling[i] - SETPOINT_DEADBAND_K
            applied[m + i] = limit if index is None else min(now[index], limit)
        if np.isnan(cooling).any():
            applied[: 2 * m] = np.nan
        zone_degc = now[:m]
        needs_cooling = bool(np.any(zone_degc > cooling))
        if self.previous_zone_degc is not None and self.limit_degc is not None:
            rise = np.maximum(zone_degc - self.previous_zone_degc, 0.0)
            ahead = zone_degc + rise > self.limit_degc + ANTICIPATION_TOLERANCE_K
            needs_cooling = needs_cooling or bool(np.any(ahead))
        self.previous_zone_degc = np.array(zone_degc, dtype=np.float64)
        applied[2 * m :] = AVAILABILITY_ON if needs_cooling else np.nan
        return applied


def next_shed_level(level: float, power_kw: float, cap_kw: float) -> float:
    """The peak guard's shed level ∈ [0, 1] for the next zone time step, integral action on
    the meter: s' = clip(s + g (P − cap) / cap, 0, 1), g = :data:`GUARD_GAIN` over the cap and
    :data:`GUARD_RELEASE_GAIN` below it, with P [kW] the
    meter's power over the last step and ``cap_kw`` [kW] the committed cap (shed deeper while
    over the cap, released as the meter falls below it)."""
    excess = (power_kw - cap_kw) / cap_kw
    gain = GUARD_GAIN if excess > 0.0 else GUARD_RELEASE_GAIN
    return float(np.clip(level + gain * excess, 0.0, 1.0))


def shed_toward_band(
    commanded: FloatArray,
    zone_temp_degc: FloatArray,
    guard: PeakGuard,
    level: float,
    *,
    setpoint: bool,
) -> FloatArray:
    """(m,) the actuated values with the peak guard's shed at ``level`` ∈ [0, 1].

    Zones whose air is below their upper comfort bound ``guard.comfort_upper_degc`` are
    shed; the others keep their value. ``setpoint``: ``commanded`` are cooling setpoints
    [°C], raised the share ``level`` of the way up to the bound (never lowered: a setpoint at
    or above it stays); else flows [kg/s], moved the share ``level`` of the way down to
    ``guard.flow_floor_kg_s`` (never raised).

    Parameters
    ----------
    commanded : (m,) the period's actuated setpoints [°C] or flows [kg/s].
    zone_temp_degc : (m,) zone air temperatures now [°C].
    """
    upper = np.asarray(guard.comfort_upper_degc, dtype=np.float64)
    may_shed = np.asarray(zone_temp_degc, dtype=np.float64) < upper
    if setpoint:
        target = np.maximum(upper, commanded)
    else:
        target = np.minimum(np.asarray(guard.flow_floor_kg_s, dtype=np.float64), commanded)
    shed: FloatArray = np.where(may_shed, commanded + level * (target - commanded), commanded)
    return shed
