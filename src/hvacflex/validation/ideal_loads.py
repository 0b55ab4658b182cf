"""Ideal-loads and free-float simulation of an RC network (no HVAC power model).

The continuous network ``C dx/dt = K x + F d + P q`` (``rc.py``; ``q`` the heat into the zone
air nodes [W], ``P`` the zone-node selection) is discretised exactly by zero-order hold at a
step ``dt_s`` with ``d`` and ``q`` held over the step::

    x_{k+1} = a x_k + e d_k + p q_k

Free float: ``q = 0``. Ideal loads (an ideal, 100 % convective air system with unlimited
capacity, non-proportional, as in Standard 140): each step first computes the free-floating
end state ``x_ff = a x_k + e d_k``; every zone whose end temperature leaves
``[heating_setpoint, cooling_setpoint]`` gets the constant heat input that puts its end
temperature exactly on the violated bound. The zone rows of ``p`` couple the zones, so the
heat inputs of the active zones solve one small linear system
``p[z, active] q_active = bound − x_ff[z]``; a zone pushed out of its band by a neighbour's
input joins the active set and the system is solved again (exact for a linear network).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hvacflex.building.discretize import zoh
from hvacflex.building.rc import ThermalNetwork

FloatArray = NDArray[np.float64]

SETPOINT_TOLERANCE_K = 1e-9
"""A zone counts as out of its band when it leaves it by more than this [K]."""


@dataclass(frozen=True)
class ZoneLoadsResult:
    """Outcome of :func:`simulate_zone_loads` over K steps of ``dt_s``.

    Attributes
    ----------
    zone_temp_degc : (K + 1, m) zone air temperatures at the step boundaries, the initial
        state first [°C].
    heating_w : (K, m) heat supplied to each zone in each step (mean power) [W], ≥ 0.
    cooling_w : (K, m) heat removed from each zone in each step [W], ≥ 0.
    final_state_degc : (n,) all node temperatures after the last step [°C].
    dt_s : step [s].
    """

    zone_temp_degc: FloatArray
    heating_w: FloatArray
    cooling_w: FloatArray
    final_state_degc: FloatArray
    dt_s: float

    def step_mean_zone_temp_degc(self) -> FloatArray:
        """(K, m) mean zone temperature over each step (trapezoid of its end points) [°C]."""
        t = self.zone_temp_degc
        mean: FloatArray = 0.5 * (t[1:] + t[:-1])
        return mean


@dataclass(frozen=True)
class DiscreteNetwork:
    """``x+ = a x + e d + p q`` of a network over ``dt_s`` (see the module docstring).

    Attributes
    ----------
    a : (n,n) [-];  e : (n,nd) [K per channel unit];  p : (n,m) [K per W into each zone air
    node];  zone_node_index : (m,);  dt_s : [s].
    """

    a: FloatArray
    e: FloatArray
    p: FloatArray
    zone_node_index: NDArray[np.intp]
    dt_s: float


def discretize_network(net: ThermalNetwork, dt_s: float) -> DiscreteNetwork:
    """Exact ZOH discretisation of a network with zone heat inputs.

    Parameters
    ----------
    net : the continuous network (``build_network``).
    dt_s : step [s].
    """
    n = net.n_nodes
    zones = net.zone_node_index
    heat_cont = np.zeros((n, len(zones)))
    heat_cont[zones, np.arange(len(zones))] = 1.0 / net.capacitance_j_per_k[zones]
    a, inputs = zoh(net.a_cont, np.hstack([net.e_cont, heat_cont]), dt_s)
    nd = net.e_cont.shape[1]
    return DiscreteNetwork(a, inputs[:, :nd], inputs[:, nd:], zones, dt_s)


def simulate_zone_loads(
    net: ThermalNetwork,
    disturbances: ArrayLike,
    dt_s: float,
    *,
    heating_setpoint_degc: float | None = None,
    cooling_setpoint_degc: float | None = None,
    initial_state_degc: ArrayLike | None = None,
) -> ZoneLoadsResult:
    """Ideal loads (with set-points) or free float (without) over a disturbance series.

    Parameters
    ----------
    net : the building's network.
    disturbances : (K, nd) disturbance vector per step, held over the step, in the
        network's channel order (``channels.py``).
    dt_s : step [s].
    heating_setpoint_degc : heat every zone whose air would end a step below it; ``None``:
        no heating.
    cooling_setpoint_degc : cool every zone whose air would end a step above it; ``None``:
        no cooling. Both ``None`` is free float.
    initial_state_degc : (n,) node temperatures at the start; default: the steady state
        for the mean disturbance (clipped into the set-point band at the zones).

    Returns
    -------
    :class:`ZoneLoadsResult`.
    """
    d = np.asarray(disturbances, dtype=np.float64)
    if d.ndim != 2 or d.shape[1] != len(net.channels):
        raise ValueError(f"disturbances must have shape (K, {len(net.channels)}), got {d.shape}")
    if (
        heating_setpoint_degc is not None
        and cooling_setpoint_degc is not None
        and heating_setpoint_degc > cooling_setpoint_degc
    ):
        raise ValueError(
            f"heating set-point {heating_setpoint_degc} °C above cooling set-point "
            f"{cooling_setpoint_degc} °C"
        )
    model = discretize_network(net, dt_s)
    zones = model.zone_node_index
    m = len(zones)
    low = -np.inf if heating_setpoint_degc is None else heating_setpoint_degc
    high = np.inf if cooling_setpoint_degc is None else cooling_setpoint_degc
    if initial_state_degc is None:
        x = net.steady_state_degc(d.mean(axis=0))
    else:
        x = np.array(initial_state_degc, dtype=np.float64)
    forced = d @ model.e.T  # (K, n)
    p_zone = model.p[zones]  # (m, m)
    steps = d.shape[0]
    temps = np.empty((steps + 1, m))
    temps[0] = x[zones]
    heat = np.zeros((steps, m))
    controlled = heating_setpoint_degc is not None or cooling_setpoint_degc is not None
    for k in range(steps):
        x = model.a @ x + forced[k]
        if controlled:
            q = _zone_heat_w(x[zones], p_zone, low, high)
            if q is not None:
                x = x + model.p @ q
                heat[k] = q
        temps[k + 1] = x[zones]
    return ZoneLoadsResult(
        zone_temp_degc=temps,
        heating_w=np.maximum(heat, 0.0),
        cooling_w=np.maximum(-heat, 0.0),
        final_state_degc=x,
        dt_s=dt_s,
    )


def _zone_heat_w(
    free_zone_degc: FloatArray, p_zone: FloatArray, low: float, high: float
) -> FloatArray | None:
    """Zone heat inputs that put every out-of-band zone on its violated bound (``None``: all
    zones are in band without HVAC)."""
    out = (free_zone_degc < low - SETPOINT_TOLERANCE_K) | (
        free_zone_degc > high + SETPOINT_TOLERANCE_K
    )
    if not out.any():
        return None
    m = len(free_zone_degc)
    active = out.copy()
    target = np.clip(free_zone_degc, low, high)
    q = np.zeros(m)
    for _ in range(m):
        idx = np.flatnonzero(active)
        q = np.zeros(m)
        q[idx] = np.linalg.solve(p_zone[np.ix_(idx, idx)], target[idx] - free_zone_degc[idx])
        result = free_zone_degc + p_zone @ q
        newly = ~active & (
            (result < low - SETPOINT_TOLERANCE_K) | (result > high + SETPOINT_TOLERANCE_K)
        )
        if not newly.any():
            break
        active |= newly
        target[newly] = np.clip(result[newly], low, high)
    return q
