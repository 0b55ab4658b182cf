"""An identified building's fan-only air in the plan: the coil scheduled off.

An air system may run its fans while its cooling coil is scheduled off (5ZoneAirCooled: out
of its weekday 06:00–20:00 and all weekend), or while a zone's own cycling coil idles (the
reference small office's packaged units: the fans run on ``HVACOperationSchd``, working days
06:00–22:00). ``hvacflex identify fit`` learns those hours, the fan-only air's temperature
and, for units per zone, its flow (``[identified.idle_air]``,
:class:`hvacflex.building.identified.IdentifiedIdleAir`); the MPC then

* plans an idle zone's input in those hours as what its fan-only air delivers
  (:func:`idle_flow_min_kg_s`: the step's lower flow bound), not as its minimum flow at the
  coil's temperature — without it the plan counted every night's minimum flow as the coil's
  cooling and predicted the zones 1.2–1.8 K colder than EnergyPlus;
* knows that, with one air system, one zone calling for cooling starts the coil for all
  (the setpoint actuation forces the coil's availability on), so the period's idle zones
  then receive the coil's air at their minimum flow (:func:`coil_started_flows_kg_s`: the
  flows the controller reports it applies; the plan itself is not re-solved). With a unit
  per zone (``fan_only_flow_kg_s`` recorded, :func:`shares_one_coil` False) an idle zone
  keeps its fan-only air whatever the others do, and when one zone calls outside the fans'
  hours the actuation's forcing starts every unit's fan, so the idle zones then receive
  their fan-only air (:func:`fans_started_flows_kg_s`; likewise reported, not re-solved).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from hvacflex.building.discretize import LinearModel, delivered_flow_kg_s
from hvacflex.building.model import Building
from hvacflex.control.base import FloatArray
from hvacflex.data.weather_forecast import period_of_day

CALLING_FLOW_KG_S = 1e-3
"""A zone planned more than this above its minimum flow calls for cooling [kg/s] (the
setpoint actuation sends it a setpoint below its temperature, which starts the coil)."""


def coil_started_flows_kg_s(
    flow_kg_s: FloatArray, u_min: FloatArray, flow_min_kg_s: FloatArray
) -> FloatArray:
    """(m,) a fan-only period's flows [kg/s] as the air system runs them: where the plan
    leaves some zones at their fan-only bound (``u_min`` (m,) below the minimum flow
    ``flow_min_kg_s`` (m,), :func:`idle_flow_min_kg_s`) and another zone calls for cooling,
    the coil starts for every zone (one air system), so each idle zone receives the coil's
    air at its minimum flow; ``flow_kg_s`` (m,) itself otherwise."""
    fan_only = u_min < flow_min_kg_s - CALLING_FLOW_KG_S
    calling = flow_kg_s > flow_min_kg_s + CALLING_FLOW_KG_S
    if not fan_only.any() or not calling.any():
        return flow_kg_s
    out: FloatArray = np.where(fan_only & ~calling, np.maximum(flow_kg_s, flow_min_kg_s), flow_kg_s)
    return out


def shares_one_coil(building: Building) -> bool:
    """Whether a zone's call starts the coil for every zone of ``building`` (one air system,
    :func:`coil_started_flows_kg_s`): an identified building whose ``[identified.idle_air]``
    has no per-zone fan-only flow; False without the table (nothing is fan-only)."""
    rc = building.identified
    return rc is not None and rc.idle_air is not None and rc.idle_air.fan_only_flow_kg_s is None


def idle_flow_min_kg_s(
    u_min: FloatArray,
    building: Building,
    model: LinearModel,
    index: pd.DatetimeIndex,
    zone_temp_degc: FloatArray,
) -> FloatArray:
    """(N, m) the steps' lower flow bounds [kg/s] with an identified building's fan-only air.

    Where ``[identified.idle_air]`` says the coil is scheduled off (the step's weekday and
    period of the day, ``index`` (N,) its starts), an idle zone receives air only
    ``fan_only_difference_k`` below the zone, not the coil's, at its minimum flow ``ṁ_min``
    (or at its ``fan_only_flow_kg_s``, a unit per zone): its bound is the model input that
    delivers ``ṁ_min c_p ΔT`` at the zone's present temperature
    (:func:`~hvacflex.building.discretize.delivered_flow_kg_s`, as the observer takes the
    plant's report), never above ``u_min``. So the plan does not count an idle night's
    minimum flow as the coil's cooling; more than the bound is the coil's air (the
    setpoint actuation then starts the coil). ``u_min`` (N, m), ``building`` and its linear
    ``model`` (ṁ₀, T₀, T_s), ``zone_temp_degc`` (m,) [°C]; ``u_min`` itself without the
    table."""
    fan_input = fan_only_input_kg_s(building, model, zone_temp_degc)
    rc = building.identified
    if fan_input is None or rc is None or rc.idle_air is None:
        return u_min
    starts = pd.DatetimeIndex(index)
    fan_only = rc.idle_air.fan_only_at(starts.day_of_week, period_of_day(starts))
    if not fan_only.any():
        return u_min
    out: FloatArray = np.where(fan_only[:, None], np.minimum(u_min, fan_input[None, :]), u_min)
    return out


def fan_only_input_kg_s(
    building: Building, model: LinearModel, zone_temp_degc: FloatArray
) -> FloatArray | None:
    """(m,) the model input [kg/s] that each zone's fan-only air delivers at the zones'
    present temperatures ``zone_temp_degc`` (m,) [°C]: ``ṁ c_p ΔT`` with ``ṁ`` the zone's
    ``fan_only_flow_kg_s`` (a unit per zone) or its minimum flow, ``ΔT`` its
    ``fan_only_difference_k`` (:func:`~hvacflex.building.discretize.delivered_flow_kg_s`, as
    the observer takes the plant's report); None without ``[identified.idle_air]``."""
    rc = building.identified
    if rc is None or rc.idle_air is None:
        return None
    idle = rc.idle_air
    flows = (
        building.hvac.flow_min_kg_s if idle.fan_only_flow_kg_s is None else idle.fan_only_flow_kg_s
    )
    inlet = zone_temp_degc - np.asarray(idle.fan_only_difference_k, dtype=float)
    out: FloatArray = delivered_flow_kg_s(
        model, np.asarray(flows, dtype=float), zone_temp_degc, inlet
    )
    return out


def fans_started_flows_kg_s(
    flow_kg_s: FloatArray, fan_input_kg_s: FloatArray, flow_min_kg_s: FloatArray
) -> FloatArray:
    """(m,) a period's inputs [kg/s] as units per zone run them: when some zone calls for
    cooling (planned above its minimum ``flow_min_kg_s`` (m,)), the setpoint actuation forces
    every unit's availability on (one rule for the plant's air loops), so each zone that does
    not call receives its fan-only air (``fan_input_kg_s`` (m,), :func:`fan_only_input_kg_s`)
    — at night too, outside the fans' own hours; ``flow_kg_s`` (m,) itself when none calls."""
    calling = flow_kg_s > flow_min_kg_s + CALLING_FLOW_KG_S
    if not calling.any():
        return flow_kg_s
    out: FloatArray = np.where(calling, flow_kg_s, np.minimum(flow_kg_s, fan_input_kg_s))
    return out
