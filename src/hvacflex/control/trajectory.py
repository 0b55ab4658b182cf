r"""Linearisation of the VAV term along the previous plan (``[controller] linearisation``).

The fixed model linearises the bilinear supply-air term once, about (ṁ_min, T₀)
(:func:`hvacflex.building.discretize.linearize`). Its one-step error against the plant grows
with |ṁ − ṁ₀|·|T_r − T₀| (docs/explanation/estimation.md). Here each step k of the horizon is
linearised about the previous plan shifted by one step, (ṁ_k, T_k) = (u_{k+1}, mean zone temperature
of period k+1) of the last plan, which gives the time-varying model

    x_{k+1} = A_k x_k + B_k u_k + E_k d_k + g_k       (:func:`linearize_along`)

exact where the new plan repeats the old one. Its robust margin is the worst case of the
box error through the products of the A_k (:func:`time_varying_margins`)::

    δ_k = Σ_{j<k} |C Φ(k, j+1) E_j| σ_j,    Φ(k, j+1) = A_{k−1} ⋯ A_{j+1}  (Φ(j+1, j+1) = I).

The MPC uses the first step's operating point for the whole horizon
(:func:`first_step_operating_point`; see ``MPCController`` and docs/explanation/estimation.md for
why).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hvacflex.building.discretize import continuous_affine_model, zoh
from hvacflex.building.model import Building
from hvacflex.building.rc import ThermalNetwork
from hvacflex.errors import InputError

FloatArray = NDArray[np.float64]

MIN_SUPPLY_DIFFERENCE_K = 1.0
"""Reference zone temperatures are kept at least this far above the supply air [K], so that
B_k ≤ 0 (supply air cools), which the two-trajectory reserve argument needs."""


@dataclass(frozen=True)
class TrajectoryModel:
    """``x_{k+1} = a[k] x_k + b[k] u_k + e[k] d_k + g[k]``, k = 0..K−1; outputs ``y = c x``.

    Shapes: a (K,n,n), b (K,n,m), e (K,n,nd), g (K,n), c (m,n); flow_ref_kg_s (K,m) and
    temp_ref_degc (K,m) the operating points [kg/s, °C].
    """

    a: FloatArray
    b: FloatArray
    e: FloatArray
    g: FloatArray
    c: FloatArray
    flow_ref_kg_s: FloatArray
    temp_ref_degc: FloatArray

    def __len__(self) -> int:
        return int(self.a.shape[0])


@dataclass(frozen=True)
class StepMatrices:
    """One step of :class:`TrajectoryModel`: a (n,n), b (n,m), e (n,nd), g (n,), c (m,n)."""

    a: FloatArray
    b: FloatArray
    e: FloatArray
    g: FloatArray
    c: FloatArray


def linearize_along(
    building: Building,
    network: ThermalNetwork,
    c_matrix: FloatArray,
    flow_ref_kg_s: ArrayLike,
    temp_ref_degc: ArrayLike,
    dt_s: float,
) -> TrajectoryModel:
    """The time-varying model about operating points (ṁ_k, T_k).

    Parameters
    ----------
    building, network : the building and its RC network.
    c_matrix : (m,n) zone-node selection.
    flow_ref_kg_s : (K,m) reference flows ṁ_k [kg/s], ≥ 0.
    temp_ref_degc : (K,m) reference zone temperatures T_k [°C]; raised to at least the supply
        temperature + :data:`MIN_SUPPLY_DIFFERENCE_K`.
    dt_s : step [s].

    Returns
    -------
    :class:`TrajectoryModel`; step k is exact at ṁ = ṁ_k for any zone temperature and at
    T_r = T_k for any flow (the error is (ṁ − ṁ_k) c_p (T_k − T_r) per zone).
    """
    flows = np.atleast_2d(np.asarray(flow_ref_kg_s, dtype=np.float64))
    temps = np.atleast_2d(np.asarray(temp_ref_degc, dtype=np.float64))
    m = len(building.zones)
    if flows.shape != temps.shape or flows.shape[1] != m:
        raise InputError(
            f"reference flows and temperatures must both have shape (K, {m})",
            source="linearize_along",
            field="flow_ref_kg_s",
            value=(flows.shape, temps.shape),
        )
    if not (np.all(np.isfinite(flows)) and np.all(flows >= 0) and np.all(np.isfinite(temps))):
        raise InputError(
            "reference flows must be finite and ≥ 0, temperatures finite",
            source="linearize_along",
            field="flow_ref_kg_s",
        )
    temps = np.maximum(temps, building.hvac.supply_temp_degc + MIN_SUPPLY_DIFFERENCE_K)
    steps = []
    for flow, temp in zip(flows, temps, strict=True):
        a_c, b_c, e_c, g_c = continuous_affine_model(building, network, flow, temp)
        nb, nd = b_c.shape[1], e_c.shape[1]
        a_d, held = zoh(a_c, np.hstack([b_c, e_c, g_c[:, None]]), dt_s)
        steps.append((a_d, held[:, :nb], held[:, nb : nb + nd], held[:, nb + nd]))
    a_s, b_s, e_s, g_s = (np.stack([s[i] for s in steps]) for i in range(4))
    return TrajectoryModel(
        a=a_s,
        b=b_s,
        e=e_s,
        g=g_s,
        c=np.asarray(c_matrix, dtype=np.float64),
        flow_ref_kg_s=flows,
        temp_ref_degc=temps,
    )


def step_matrices(model: TrajectoryModel, k: int) -> StepMatrices:
    """Step ``k`` of a trajectory model as a one-step model."""
    return StepMatrices(a=model.a[k], b=model.b[k], e=model.e[k], g=model.g[k], c=model.c)


def shifted_operating_points(
    planned_flow_kg_s: ArrayLike,
    planned_zone_temp_degc: ArrayLike,
    current_zone_temp_degc: ArrayLike,
    horizon: int,
) -> tuple[FloatArray, FloatArray]:
    """Operating points for the new horizon from the previous plan shifted by one step.

    Parameters
    ----------
    planned_flow_kg_s : (N,m) the previous plan's flows u_0..u_{N−1} [kg/s].
    planned_zone_temp_degc : (N+1,m) its zone temperatures C x_0..C x_N [°C].
    current_zone_temp_degc : (m,) zone temperature now (measured or estimated) [°C].
    horizon : N' of the new plan.

    Returns
    -------
    (flow_ref (N',m), temp_ref (N',m)): step k of the new plan is period k+1 of the old one
    (flow u_{k+1} clipped at 0, the mean of C x_{k+1} and C x_{k+2}); the first temperature
    uses the current one in place of C x_1, and beyond the old plan the last values are
    repeated.
    """
    flows = np.asarray(planned_flow_kg_s, dtype=np.float64)
    temps = np.asarray(planned_zone_temp_degc, dtype=np.float64).copy()
    temps[1] = np.asarray(current_zone_temp_degc, dtype=np.float64)
    shift_u = np.clip(np.arange(horizon) + 1, 0, flows.shape[0] - 1)
    start = np.clip(np.arange(horizon) + 1, 0, temps.shape[0] - 1)
    end = np.clip(np.arange(horizon) + 2, 0, temps.shape[0] - 1)
    # an LP's flows meet u ≥ 0 only to its tolerance: clip the round-off
    return np.maximum(flows[shift_u], 0.0), 0.5 * (temps[start] + temps[end])


def time_varying_margins(
    a_seq: ArrayLike, e_seq: ArrayLike, c_matrix: ArrayLike, d_sigma: ArrayLike
) -> FloatArray:
    """δ (N, ny) [K] for the time-varying model: ``δ_k = Σ_{j<k} |C Φ(k, j+1) E_j| σ_j``.

    Parameters
    ----------
    a_seq : (N,n,n) A_0..A_{N−1}.
    e_seq : (N,n,nd) E_0..E_{N−1}.
    c_matrix : (ny,n).
    d_sigma : (N,nd) box half-widths σ_j.

    Returns
    -------
    (N, ny): row k−1 bounds the output deviation at step k = 1..N. With constant A and E it
    equals :func:`hvacflex.opt.robust.comfort_margins`.
    """
    a = np.asarray(a_seq, dtype=np.float64)
    e = np.asarray(e_seq, dtype=np.float64)
    c = np.asarray(c_matrix, dtype=np.float64)
    sigma = np.asarray(d_sigma, dtype=np.float64)
    horizon = sigma.shape[0]
    out = np.zeros((horizon, c.shape[0]))
    for j in range(horizon):
        row = c.copy()  # C Φ(k, j+1), starting at k = j+1
        for k in range(j + 1, horizon + 1):
            out[k - 1] += np.abs(row @ e[j]) @ sigma[j]
            if k < horizon:
                row = row @ a[k]
    return out


def relinearised_first_step(
    building: Building,
    network: ThermalNetwork,
    c_matrix: FloatArray,
    planned_flow_kg_s: ArrayLike,
    planned_states_degc: ArrayLike,
    zone_temp_now_degc: ArrayLike,
    dt_s: float,
) -> StepMatrices:
    """The model for the new plan: linearised about the previous plan's step 1 (shifted by
    one step; see :func:`shifted_operating_points`), used for the whole horizon.

    Parameters
    ----------
    planned_flow_kg_s : (N,m) the previous plan's flows [kg/s].
    planned_states_degc : (N+1,n) its (served) node trajectory [°C].
    zone_temp_now_degc : (m,) zone temperature now (measured or estimated) [°C].
    """
    c = np.asarray(c_matrix, dtype=np.float64)
    zone_temps = np.asarray(planned_states_degc, dtype=np.float64) @ c.T
    flow_ref, temp_ref = shifted_operating_points(
        planned_flow_kg_s, zone_temps, zone_temp_now_degc, 1
    )
    return step_matrices(linearize_along(building, network, c, flow_ref, temp_ref, dt_s), 0)
