"""Linearisation of the VAV term and zero-order-hold discretisation (paper eq. 3).

The zone air balance carries the bilinear supply-air term ṁ c_p (T_s − T_r). About a
reference flow ṁ₀ and zone temperature T₀ (docs/explanation/model.md §1; by default ṁ₀ = ṁ_min and
T₀ = the occupied lower comfort bound)::

    ṁ c_p (T_s − T_r) ≈ ṁ₀ c_p (T_s − T_r) + (ṁ − ṁ₀) c_p (T_s − T₀)

which is exact at ṁ = ṁ₀, and for ṁ ≥ ṁ₀ and T_r ≥ T₀ predicts no more cooling than the
true term. Per zone node r (capacitance C_r) the continuous model gets::

    A_c[r, r] −= ṁ₀ c_p / C_r        B_c[r, zone] = c_p (T_s − T₀) / C_r   (≤ 0 when T_s ≤ T₀)
    g_c[r]     = ṁ₀ c_p T₀ / C_r      (the constant: ṁ₀ c_p T_s − ṁ₀ c_p (T_s − T₀))

and the discrete model ``x+ = a x + b u + e d + g`` follows from one matrix exponential of
the augmented matrix [[A_c, B_c, E_c, g_c], [0, 0, 0, 0]]·Δt (inputs held over the step).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from hvacflex.blas import one_blas_thread
from hvacflex.building.channels import DisturbanceChannel
from hvacflex.building.identified import sensible_cooling_kw
from hvacflex.building.model import Building
from hvacflex.building.rc import ThermalNetwork, build_network, frozen_array
from hvacflex.constants import PERIOD_S
from hvacflex.errors import BuildingConfigError
from hvacflex.units import CP_AIR_J_PER_KG_K, W_PER_KW

FloatArray = NDArray[np.float64]

DEFAULT_LINEARISATION_TEMP_DEGC = 23.0
"""T₀: the occupied lower comfort bound [°C]."""


def affine_step(
    matrices: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
    x: ArrayLike,
    u: ArrayLike,
    d: ArrayLike,
) -> FloatArray:
    """x+ = A x + B u + E d + g (n,) [°C] of the one-step ``matrices`` (A, B, E, g) from the
    state (n,) [°C], the input (m,) [kg/s] and the disturbance (nd,)."""
    a, b, e, g = matrices
    out: FloatArray = (
        a @ np.asarray(x, dtype=np.float64)
        + b @ np.asarray(u, dtype=np.float64)
        + e @ np.asarray(d, dtype=np.float64)
        + g
    )
    return out


@dataclass(frozen=True)
class LinearModel:
    """Affine discrete-time model ``x+ = a x + b u + e d + g`` over one step of ``dt_s``.

    Attributes
    ----------
    a : (n,n) state matrix [-].
    b : (n,m) input matrix [K per kg/s]; u = zone supply-air flow [kg/s].
    e : (n,nd) disturbance matrix [K per channel unit].
    g : (n,) constant term [K].
    c : (m,n) zone-node selection (rows of the identity) [-].
    dt_s : step [s].
    node_names : (n,), zone_names : (m,), channels : (nd,) as in the network.
    flow_ref_kg_s : (m,) reference flow ṁ₀ of the linearisation [kg/s].
    linearisation_temp_degc : (m,) reference zone temperature T₀ [°C].
    supply_temp_degc : the supply-air temperature T_s the input u is delivered at [°C]
        (below every T₀).
    """

    a: FloatArray
    b: FloatArray
    e: FloatArray
    g: FloatArray
    c: FloatArray
    dt_s: float
    node_names: tuple[str, ...]
    zone_names: tuple[str, ...]
    channels: tuple[DisturbanceChannel, ...]
    flow_ref_kg_s: FloatArray
    linearisation_temp_degc: FloatArray
    supply_temp_degc: float

    def step(self, x: ArrayLike, u: ArrayLike, d: ArrayLike) -> FloatArray:
        """One step: (n,), (m,), (nd,) → (n,) [°C]."""
        return affine_step((self.a, self.b, self.e, self.g), x, u, d)

    def steady_state(self, u: ArrayLike, d: ArrayLike) -> FloatArray:
        """Fixed point x = (I − a)⁻¹ (b u + e d + g) for constant (m,) u and (nd,) d → (n,)."""
        rhs = self.b @ np.asarray(u, dtype=np.float64) + self.e @ np.asarray(d, dtype=np.float64)
        solution = np.linalg.solve(np.eye(self.a.shape[0]) - self.a, rhs + self.g)
        return np.asarray(solution, dtype=np.float64)


def delivered_flow_kg_s(
    model: LinearModel,
    flow_kg_s: ArrayLike,
    zone_temp_degc: ArrayLike,
    inlet_temp_degc: ArrayLike,
) -> FloatArray:
    """(m,) the model input [kg/s] whose linearised HVAC term delivers what was metered.

    The model's zone heat from the air system is ``c_p (T_s − T₀) u − ṁ₀ c_p (Ta − T₀)``
    (linearised about ṁ₀ and T₀, :func:`continuous_affine_model`); the air that came in
    delivered ``ṁ c_p (T_in − Ta)``. Equal when
    ``u = (ṁ (T_in − Ta) + ṁ₀ (Ta − T₀)) / (T_s − T₀)`` — the flow itself where the supply
    air was at the model's T_s, less (or below 0) where it was warmer (a coil off out of
    hours: fan-only air).

    Parameters
    ----------
    model : the linearised model (ṁ₀, T₀, T_s).
    flow_kg_s, zone_temp_degc, inlet_temp_degc : (m,) period means of the supply flow
        [kg/s], the zone air and the supply air temperatures [°C] (the inlet's is not read
        where no air flows: NaN there is taken as no delivery).
    """
    flow = np.asarray(flow_kg_s, dtype=np.float64)
    zone = np.asarray(zone_temp_degc, dtype=np.float64)
    inlet = np.asarray(inlet_temp_degc, dtype=np.float64)
    t0 = model.linearisation_temp_degc
    # no air: no inlet reading; the metered cooling in K·kg/s
    cooling = np.where(flow > 0.0, sensible_cooling_kw(flow, zone, inlet), 0.0)
    metered = cooling * W_PER_KW / CP_AIR_J_PER_KG_K
    out: FloatArray = (model.flow_ref_kg_s * (zone - t0) - metered) / (model.supply_temp_degc - t0)
    return out


def zoh(a_cont: ArrayLike, inputs_cont: ArrayLike, dt_s: float) -> tuple[FloatArray, FloatArray]:
    """Zero-order-hold discretisation through one matrix exponential.

    The exponential runs on one BLAS thread (:func:`hvacflex.blas.one_blas_thread`): its
    Padé solve rounds differently with one and two, and the model must not depend on the
    machine's threads.

    Parameters
    ----------
    a_cont : (n,n) continuous state matrix [1/s].
    inputs_cont : (n,p) continuous input matrix (all held inputs side by side).
    dt_s : step [s].

    Returns
    -------
    (a (n,n), inputs (n,p)) with a = e^{A Δt}, inputs = ∫₀^Δt e^{A τ} dτ · B.
    """
    a_c = np.asarray(a_cont, dtype=np.float64)
    b_c = np.asarray(inputs_cont, dtype=np.float64)
    n, p = b_c.shape
    augmented = np.zeros((n + p, n + p))
    augmented[:n, :n] = a_c
    augmented[:n, n:] = b_c
    with one_blas_thread():
        phi = scipy.linalg.expm(augmented * dt_s)
    return phi[:n, :n].copy(), phi[:n, n:].copy()


def continuous_affine_model(
    b: Building,
    network: ThermalNetwork,
    flow_ref_kg_s: ArrayLike,
    zone_temp_ref_degc: ArrayLike,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Continuous model ẋ = A x + B u + E d + g linearised about (ṁ₀, T₀).

    Parameters
    ----------
    b, network : the building and its network.
    flow_ref_kg_s : (m,) reference flows ṁ₀ [kg/s].
    zone_temp_ref_degc : (m,) or scalar reference zone temperatures T₀ [°C].

    Returns
    -------
    a (n,n) [1/s], b (n,m) [K/s per kg/s], e (n,nd), g (n,) [K/s].
    """
    m = len(b.zones)
    flow_ref = np.broadcast_to(np.asarray(flow_ref_kg_s, dtype=np.float64), (m,))
    temp_ref = np.broadcast_to(np.asarray(zone_temp_ref_degc, dtype=np.float64), (m,))
    zones = network.zone_node_index
    cap = network.capacitance_j_per_k[zones]
    n = network.n_nodes
    a = network.a_cont.copy()
    a[zones, zones] -= flow_ref * CP_AIR_J_PER_KG_K / cap
    b_c = np.zeros((n, m))
    b_c[zones, np.arange(m)] = CP_AIR_J_PER_KG_K * (b.hvac.supply_temp_degc - temp_ref) / cap
    g = np.zeros(n)
    g[zones] = flow_ref * CP_AIR_J_PER_KG_K * temp_ref / cap
    return a, b_c, network.e_cont.copy(), g


def _discretise(
    a_c: FloatArray, b_c: FloatArray, e_c: FloatArray, g_c: FloatArray, dt_s: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    m, nd = b_c.shape[1], e_c.shape[1]
    a_d, held = zoh(a_c, np.hstack([b_c, e_c, g_c[:, None]]), dt_s)
    return a_d, held[:, :m], held[:, m : m + nd], held[:, m + nd]


def _check_dt(b: Building, dt_s: float) -> None:
    if not dt_s > 0:
        raise BuildingConfigError(
            "time step must be > 0 s", source=b.source_path, field="dt_s", value=dt_s
        )


def linearize(
    b: Building,
    dt_s: float = PERIOD_S,
    linearisation_temp_degc: float = DEFAULT_LINEARISATION_TEMP_DEGC,
    *,
    network: ThermalNetwork | None = None,
) -> LinearModel:
    """Affine discrete model about ṁ₀ = ṁ_min and T₀ (docs/explanation/model.md §1).

    Parameters
    ----------
    b : the building.
    dt_s : step [s] (default 1800).
    linearisation_temp_degc : T₀ [°C], the occupied lower comfort bound; must exceed the
        supply temperature so that b ≤ 0 (supply air cools).
    network : the building's network, if already built.

    Returns
    -------
    :class:`LinearModel`.
    """
    _check_dt(b, dt_s)
    if linearisation_temp_degc <= b.hvac.supply_temp_degc:
        raise BuildingConfigError(
            "the linearisation temperature must be above the supply-air temperature "
            f"{b.hvac.supply_temp_degc:g} °C",
            source=b.source_path,
            field="linearisation_temp_degc",
            value=linearisation_temp_degc,
            hint="use the occupied lower comfort bound, e.g. 23 °C",
        )
    net = network if network is not None else build_network(b)
    m = len(b.zones)
    flow_ref = np.asarray(b.hvac.flow_min_kg_s, dtype=np.float64)
    temp_ref = np.full(m, float(linearisation_temp_degc))
    a_d, b_d, e_d, g_d = _discretise(*continuous_affine_model(b, net, flow_ref, temp_ref), dt_s)
    return LinearModel(
        **_model_fields(b, net, dt_s, (a_d, b_d, e_d, g_d)),
        flow_ref_kg_s=frozen_array(flow_ref),
        linearisation_temp_degc=frozen_array(temp_ref),
        supply_temp_degc=float(b.hvac.supply_temp_degc),
    )


def _model_fields(
    b: Building,
    net: ThermalNetwork,
    dt_s: float,
    matrices: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
) -> dict[str, Any]:
    """The fields of :class:`LinearModel` that do not name the reference point, from the
    discrete (a, b, e, g), read-only."""
    a_d, b_d, e_d, g_d = (frozen_array(matrix) for matrix in matrices)
    return {
        "a": a_d,
        "b": b_d,
        "e": e_d,
        "g": g_d,
        "c": frozen_array(zone_selection(net)),
        "dt_s": float(dt_s),
        "node_names": net.node_names,
        "zone_names": b.zone_names,
        "channels": net.channels,
    }


def zone_selection(network: ThermalNetwork) -> FloatArray:
    """(m,n) matrix selecting the zone air nodes from the state."""
    c = np.zeros((len(network.zone_node_index), network.n_nodes))
    c[np.arange(len(network.zone_node_index)), network.zone_node_index] = 1.0
    return c
