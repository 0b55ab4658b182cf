"""The fleet's guard on the metered power of the period about to be applied.

The feeder limit in force F [kW] is on the fleet's meter, not on each building's: a building
may draw more than its share of F when others draw less than theirs. The coordination's
plans meet (1 − ``feeder_margin``) × F on the LP's affine power (a secant; the margin is
headroom for the power model's error, which the guard leaves to the plants); what the
plants draw is closer to the power the plant's power model predicts for the plans'
first-period flows (:meth:`hvacflex.fleet.agent.FleetController.predicted_power_kw`), which
may lie above or below it. Before the period is applied, every building therefore reports (its
:meth:`~hvacflex.fleet.agent.BuildingAgent.guard_view`)

* P_b, the predicted power of the flows its plan applies,
* P_b^free, the predicted power once every zone's flow is cut only as far as comfort allows
  (each zone down to the flow that brings it to its upper band at the period's end on the
  controller's linear model, :func:`comfort_floor_flow_kg_s`, never below its lower bound),
* P_b^min, the predicted power with every flow at its lower bound,
* its room ρ_b [K]: how far its warmest zone ends the period below its upper band at the
  plan's flows,

and :func:`guard_caps_kw` gives each building a cap on its predicted power with
Σ_b cap_b = max(F, Σ_b P_b^min):

1. Σ_b P_b ≤ F: nothing is cut; each cap is P_b plus an equal share of the headroom (a
   building whose applied action differs from the one it reported, a fallback, is held to
   it, so the fleet stays within F).
2. Otherwise the excess E = Σ_b P_b − F is shed **first where comfort allows**: from the
   comfort-free parts P_b − P_b^free, the building furthest below its upper band (largest
   ρ_b) first; what is left is shared over the buildings in proportion to
   P_b^free − P_b^min (every zone then gives up part of the flow it needs; spread evenly,
   no zone is cut to its minimum while another keeps its comfort flow).

A building meets its cap along the same comfort-aware path (:func:`path_flow_kg_s`): its
flows first move from the plan's down to the comfort floor, then from the floor to the
lower bounds; the applied flows are the least cut on that path whose predicted power meets
the cap.
"""

from __future__ import annotations

import numpy as np

from hvacflex.control.base import FloatArray

PATH_END = 2.0
"""The path parameter of the plan's flows (:func:`path_flow_kg_s`): s ∈ [0, 2], 0 = every
flow at its lower bound, 1 = the comfort floor, 2 = the plan's flows."""


def comfort_floor_flow_kg_s(
    end_temp_degc: FloatArray,
    gain_k_per_kg_s: FloatArray,
    upper_degc: FloatArray,
    flow_kg_s: FloatArray,
    low_kg_s: FloatArray,
) -> FloatArray:
    """(m,) each zone's least flow [kg/s] that still ends the period at or below its upper
    band, the other zones at ``flow_kg_s``, within [``low_kg_s``, ``flow_kg_s``].

    Parameters
    ----------
    end_temp_degc : (m,) the zones' air temperatures at the period's end at ``flow_kg_s``
        on the linear model [°C].
    gain_k_per_kg_s : (m,) each zone's own end temperature per kg/s of its flow, the
        diagonal of C·B [K per kg/s]; < 0 (more air cools).
    upper_degc : (m,) the upper band at the period's end [°C].
    flow_kg_s, low_kg_s : (m,) the plan's flows and their lower bounds [kg/s].

    Returns
    -------
    (m,) flows [kg/s]; a zone already above its band (or whose flow does not cool it) keeps
    the plan's flow.
    """
    gain = np.asarray(gain_k_per_kg_s, dtype=float)
    room = np.asarray(upper_degc, dtype=float) - np.asarray(end_temp_degc, dtype=float)
    cut = np.where(gain < 0.0, room / np.where(gain < 0.0, -gain, 1.0), 0.0)
    floor = np.asarray(flow_kg_s, dtype=float) - np.maximum(cut, 0.0)
    clipped: FloatArray = np.clip(floor, low_kg_s, flow_kg_s)
    return clipped


def path_flow_kg_s(
    s: float, low_kg_s: FloatArray, floor_kg_s: FloatArray, flow_kg_s: FloatArray
) -> FloatArray:
    """(m,) the flows [kg/s] at ``s`` ∈ [0, :data:`PATH_END`] on the guard's path: from the
    plan's flows ``flow_kg_s`` (s = 2) down to the comfort floor ``floor_kg_s`` (s = 1),
    then down to the lower bounds ``low_kg_s`` (s = 0), linearly in each part. Every flow
    falls as s falls (low ≤ floor ≤ flow), so the power the flows draw does too."""
    if s >= 1.0:
        return floor_kg_s + (s - 1.0) * (flow_kg_s - floor_kg_s)
    return low_kg_s + s * (floor_kg_s - low_kg_s)


def guard_caps_kw(
    power_kw: FloatArray,
    free_power_kw: FloatArray,
    min_power_kw: FloatArray,
    room_k: FloatArray,
    limit_kw: float,
) -> FloatArray:
    """(B,) each building's cap on its predicted power in the period [kW] (module
    docstring): Σ = ``limit_kw`` where the buildings' minima fit under it.

    Parameters
    ----------
    power_kw : (B,) P_b, the predicted power of the plans' flows [kW].
    free_power_kw : (B,) P_b^free, at the comfort floor [kW] (≤ P_b).
    min_power_kw : (B,) P_b^min, every flow at its lower bound [kW] (≤ P_b^free).
    room_k : (B,) ρ_b, the warmest zone's distance below its upper band at the period's
        end [K] (−inf: a building whose power is fixed, e.g. locked to an event plan).
    limit_kw : the feeder limit in force in the period [kW] (not lowered by
        ``feeder_margin``: that is the plans' headroom); inf: no cap (all inf).
    """
    power = np.asarray(power_kw, dtype=float)
    if not np.isfinite(limit_kw) or power.size == 0:
        return np.full(power.shape, np.inf)
    excess = float(power.sum()) - limit_kw
    if excess <= 0.0:
        return power - excess / power.size
    free = np.clip(power - np.asarray(free_power_kw, dtype=float), 0.0, None)
    shed = np.zeros_like(power)
    left = excess
    for b in np.argsort(-np.asarray(room_k, dtype=float), kind="stable"):
        shed[b] = min(float(free[b]), left)
        left -= shed[b]
        if left <= 0.0:
            break
    if left > 0.0:
        rest = np.clip(
            np.minimum(power, free_power_kw) - np.asarray(min_power_kw, dtype=float), 0.0, None
        )
        total = float(rest.sum())
        if total > 0.0:
            shed += min(1.0, left / total) * rest
    caps: FloatArray = power - shed
    return caps
