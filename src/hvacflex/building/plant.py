"""The nonlinear (bilinear) plant the simulator runs: paper eq. (1) with the exact VAV term.

    C dx/dt = K x + F d + P diag(ṁ) c_p (T_s − P' x)

For flows ṁ and disturbances d held over a step the system is linear in x with constant
forcing, so one step is exact::

    A_ṁ = C⁻¹ (K − P diag(ṁ c_p) P'),   f = C⁻¹ (F d + P ṁ c_p T_s)
    x+ = e^{A_ṁ Δt} x + ∫₀^Δt e^{A_ṁ τ} dτ · f

``K − P diag(ṁ c_p) P'`` is symmetric, so ``A_ṁ`` is similar to the symmetric matrix
``S = C^{-1/2} (K − …) C^{-1/2}``; one symmetric eigendecomposition ``S = Q Λ Qᵀ`` gives both
matrices (``e^{λΔt}`` and ``(e^{λΔt} − 1)/λ`` on the diagonal). They are cached per flow vector
and step, so repeated flows (minimum or maximum flow, a fallback rule) cost two small
matrix–vector products.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hvacflex.building.model import Building
from hvacflex.building.rc import ThermalNetwork, build_network
from hvacflex.constants import PERIOD_S
from hvacflex.errors import InputError
from hvacflex.units import CP_AIR_J_PER_KG_K

FloatArray = NDArray[np.float64]

CACHE_SIZE = 512
"""Number of (flow, Δt) step matrices kept by :class:`NonlinearPlant`."""


class NonlinearPlant:
    """Exact bilinear building dynamics with zone supply-air flows as inputs.

    Parameters
    ----------
    building : the building.
    network : its RC network, if already built.

    Attributes
    ----------
    n, m, nd : numbers of nodes, zones and disturbance channels.
    network : the RC network (node names, channels, zone node indices).
    """

    def __init__(self, building: Building, network: ThermalNetwork | None = None) -> None:
        self.building = building
        self.network = network if network is not None else build_network(building)
        net = self.network
        self.n = net.n_nodes
        self.m = len(building.zones)
        self.nd = len(net.channels)
        self._zones = net.zone_node_index
        self._cap = np.asarray(net.capacitance_j_per_k)
        self._sqrt_cap = np.sqrt(self._cap)
        self._k = np.asarray(net.conductance_w_per_k)
        self._f = np.asarray(net.input_w)
        self._supply_temp_degc = building.hvac.supply_temp_degc
        self._cache: OrderedDict[tuple[bytes, float], tuple[FloatArray, FloatArray]] = OrderedDict()

    def initial_state(self, temp_degc: float | ArrayLike) -> FloatArray:
        """A state with every node at ``temp_degc`` (scalar, or (m,) per zone with each wall
        node at the mean) → (n,) [°C]."""
        temps = np.asarray(temp_degc, dtype=np.float64)
        x = np.full(self.n, float(temps.mean()))
        x[self._zones] = np.broadcast_to(temps, (self.m,))
        return x

    def _check(self, x: ArrayLike, flow_kg_s: ArrayLike, d: ArrayLike) -> tuple[FloatArray, ...]:
        x_a = np.asarray(x, dtype=np.float64)
        flow = np.asarray(flow_kg_s, dtype=np.float64)
        d_a = np.asarray(d, dtype=np.float64)
        for name, arr, size in (
            ("x_degc", x_a, self.n),
            ("flow_kg_s", flow, self.m),
            ("d", d_a, self.nd),
        ):
            if arr.shape != (size,):
                raise InputError(
                    f"expected shape ({size},)",
                    source="NonlinearPlant",
                    field=name,
                    value=arr.shape,
                )
        if np.any(flow < 0) or not np.all(np.isfinite(flow)):
            raise InputError(
                "supply-air flows must be finite and ≥ 0",
                source="NonlinearPlant",
                field="flow_kg_s",
                value=flow.tolist(),
            )
        return x_a, flow, d_a

    def derivative(self, x_degc: ArrayLike, flow_kg_s: ArrayLike, d: ArrayLike) -> FloatArray:
        """dx/dt [K/s] of the exact bilinear model; shapes (n,), (m,), (nd,) → (n,)."""
        x, flow, d_a = self._check(x_degc, flow_kg_s, d)
        heat = self._k @ x + self._f @ d_a
        heat[self._zones] += flow * CP_AIR_J_PER_KG_K * (self._supply_temp_degc - x[self._zones])
        out: FloatArray = heat / self._cap
        return out

    def _step_matrices(self, flow: FloatArray, dt_s: float) -> tuple[FloatArray, FloatArray]:
        key = (flow.tobytes(), float(dt_s))
        cached = self._cache.get(key)
        if cached is not None:
            self._cache.move_to_end(key)
            return cached
        k = self._k.copy()
        k[self._zones, self._zones] -= flow * CP_AIR_J_PER_KG_K
        s = k / np.outer(self._sqrt_cap, self._sqrt_cap)
        lam, q = np.linalg.eigh(s)
        exp = np.exp(lam * dt_s)
        # (e^{λΔt} − 1)/λ, → Δt as λ → 0 (λ < 0 for a network connected to the outside)
        small = np.abs(lam * dt_s) < 1e-12
        integral = np.where(small, dt_s, np.expm1(lam * dt_s) / np.where(small, 1.0, lam))
        left = q / self._sqrt_cap[:, None]  # C^{-1/2} Q
        right = q.T * self._sqrt_cap[None, :]  # Qᵀ C^{1/2}
        phi = (left * exp) @ right
        gamma = (left * integral) @ right
        # the forcing is C⁻¹ (F d + P ṁ c_p T_s): fold C⁻¹ into Γ
        gamma = gamma / self._cap[None, :]
        self._cache[key] = (phi, gamma)
        if len(self._cache) > CACHE_SIZE:
            self._cache.popitem(last=False)
        return phi, gamma

    def step(
        self,
        x_degc: ArrayLike,
        flow_kg_s: ArrayLike,
        d: ArrayLike,
        dt_s: float = PERIOD_S,
    ) -> FloatArray:
        """Advance the exact dynamics over one step with flows and disturbances held.

        Parameters
        ----------
        x_degc : (n,) node temperatures at the start [°C].
        flow_kg_s : (m,) zone supply-air flows held over the step [kg/s], ≥ 0.
        d : (nd,) disturbances held over the step (channel units).
        dt_s : step [s].

        Returns
        -------
        (n,) node temperatures at the end of the step [°C].
        """
        x, flow, d_a = self._check(x_degc, flow_kg_s, d)
        phi, gamma = self._step_matrices(flow, dt_s)
        forcing = self._f @ d_a
        forcing[self._zones] += flow * CP_AIR_J_PER_KG_K * self._supply_temp_degc
        out: FloatArray = phi @ x + gamma @ forcing
        return out
