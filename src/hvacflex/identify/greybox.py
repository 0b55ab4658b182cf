"""The grey-box RC model that ``hvacflex identify fit`` fits, on arrays.

Per zone ``i`` an air node ``Ta_i`` and one mass node ``Tm_i`` (state ``x = [Ta (m), Tm (m)]``
[°C]); inputs per 30-min period ``u = [To, G, occ, 1, I (4), Q (m), Tb (nb)]`` (outdoor
temperature [°C], global horizontal irradiance [kW/m²], occupied share [–], a constant, the
irradiance on vertical planes facing north, east, south and west [kW/m²], delivered sensible
cooling per zone [kW], measured temperatures of unconditioned zones [°C]), held over the
period:

    C_a,i dTa_i/dt = UA_o,i (To − Ta_i) + UA_am,i (Tm_i − Ta_i) + Σ_j UA_ij (Ta_j − Ta_i)
                     + Σ_b UA_ib (Tb_b − Ta_i) + S_a,i G + Σ_o S_o,i I_o + P_occ,i occ
                     + P_0,i − Q_i
    C_m,i dTm_i/dt = UA_am,i (Ta_i − Tm_i) + UA_mo,i (To − Tm_i) + S_m,i G

with ``C`` [kJ/K], ``UA`` [kW/K], ``S`` [m²] (kW per kW/m²), ``P`` [kW]. The measured zone
temperature of period ``k`` is the mean over the period, so the output is that mean:
``y_k = C̄ x_k + D̄ u_k`` (exact for held inputs, from one matrix exponential), and
``x_{k+1} = A x_k + B u_k`` (zero-order hold). A steady-state Kalman filter (noise levels
:data:`PROCESS_STD_AIR_K`, :data:`PROCESS_STD_MASS_K`, :data:`MEASUREMENT_STD_K`) estimates the
state from the measured temperatures; the mass nodes are never measured.

**Where in the period the cooling comes** (``cooling_change_share`` γ of :func:`discretize`,
0 by default): a plant's local loop acts on a setpoint change at once — a packaged DX coil
pulls its zone to a lowered setpoint within minutes, then cycles — so a change of the
delivered cooling from one period to the next comes early in the period, not spread over it.
With γ > 0 the cooling within period ``k`` is ``Q_k + γ ΔQ_k (1/β − 1)`` over its first share
β (:data:`CHANGE_HOLD_SHARE`) and ``Q_k − γ ΔQ_k`` over the rest (``ΔQ_k = Q_k − Q_{k−1}``;
the period's energy is ``Q_k Δt`` either way), still linear in the inputs:

    x_{k+1} = A x_k + B u_k + B_Δ ΔQ_k,    y_k = C̄ x_k + D̄ u_k + D_Δ ΔQ_k.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from hvacflex.building.identified import WALL_ORIENTATIONS
from hvacflex.constants import PERIOD_S

FloatArray = npt.NDArray[np.float64]

_WEATHER_AND_SCHEDULE = ("outdoor_temp_degc", "ghi_kw_per_m2", "occupied", "constant")
EXOGENOUS_INPUTS = (
    *_WEATHER_AND_SCHEDULE,
    *(f"wall_{name}_kw_per_m2" for name, _ in WALL_ORIENTATIONS),
)
"""The inputs before the per-zone cooling, in order."""
WALL_INPUTS = slice(len(_WEATHER_AND_SCHEDULE), len(EXOGENOUS_INPUTS))
"""Where the vertical irradiances sit among :data:`EXOGENOUS_INPUTS`."""
PROCESS_STD_AIR_K = 0.1
"""Kalman filter: process noise on an air node per step [K]."""
PROCESS_STD_MASS_K = 0.02
"""Kalman filter: process noise on a mass node per step [K]."""
MEASUREMENT_STD_K = 0.05
"""Kalman filter: zone temperature measurement noise [K]."""
ZONE_PARAMETERS = (
    ("c_air_kj_per_k", "log"),
    ("c_mass_kj_per_k", "log"),
    ("ua_out_kw_per_k", "log"),
    ("ua_air_mass_kw_per_k", "log"),
    ("ua_mass_out_kw_per_k", "log"),
    ("solar_air_m2", "linear"),
    ("solar_mass_m2", "linear"),
    *((f"solar_wall_{name}_m2", "linear") for name, _ in WALL_ORIENTATIONS),
    ("occupied_gain_kw", "linear"),
    ("base_gain_kw", "linear"),
)
"""Each zone's parameters and how the optimiser sees them (log: positive, searched in log)."""
COUPLING_PARAMETER = "ua_kw_per_k"
CHANGE_HOLD_SHARE = 1.0 / 3.0
"""β: the share of the period at its start in which a change of the cooling comes (module
docstring) [–]: the first 10 min, one time step of EnergyPlus's zone heat balance (the plant
``identify collect`` runs), within which its coil meets a new setpoint."""
RICCATI_MAX_ITERATIONS = 60
RICCATI_TOLERANCE = 1e-12
"""The doubling algorithm stops when ``P`` changes by less than this, relatively."""


@dataclass(frozen=True)
class GreyBoxParameters:
    """Physical parameters of the grey-box model (module docstring).

    Attributes
    ----------
    zone : (m, len(ZONE_PARAMETERS)) per-zone values in :data:`ZONE_PARAMETERS` order.
    couplings : (p, 2) zone index pairs (i < j) that exchange heat.
    coupling_ua_kw_per_k : (p,) their conductances [kW/K].
    boundaries : nb, the measured boundary temperatures (unconditioned zones) among the
        inputs, after the cooling: ``u = [To, G, occ, 1, I (4), Q (m), Tb (nb)]``.
    boundary_couplings : (q, 2) (zone index, boundary index) pairs that exchange heat.
    boundary_ua_kw_per_k : (q,) their conductances [kW/K].
    """

    zone: FloatArray
    couplings: npt.NDArray[np.int64]
    coupling_ua_kw_per_k: FloatArray
    boundaries: int = 0
    boundary_couplings: npt.NDArray[np.int64] = field(
        default_factory=lambda: np.zeros((0, 2), dtype=np.int64)
    )
    boundary_ua_kw_per_k: FloatArray = field(default_factory=lambda: np.zeros(0))

    @property
    def zones(self) -> int:
        return int(self.zone.shape[0])

    def value(self, name: str) -> FloatArray:
        """(m,) one per-zone parameter by name."""
        names = [n for n, _ in ZONE_PARAMETERS]
        return self.zone[:, names.index(name)]


def _symmetric_parts(p: GreyBoxParameters) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``a = diag(1/C) k`` and ``b = diag(1/C) h`` with ``k`` symmetric.

    Returns
    -------
    k : (2m, 2m) conductance matrix [kW/K]; h : (2m, 8 + m + nb) input gains [kW per input unit];
    capacitance : (2m,) [kJ/K].
    """
    m = p.zones
    c_air, c_mass = p.value("c_air_kj_per_k"), p.value("c_mass_kj_per_k")
    ua_o, ua_am = p.value("ua_out_kw_per_k"), p.value("ua_air_mass_kw_per_k")
    ua_mo = p.value("ua_mass_out_kw_per_k")
    conductance = np.zeros((2 * m, 2 * m))
    air, mass = np.arange(m), np.arange(m, 2 * m)
    conductance[air, mass] = conductance[mass, air] = ua_am
    for (i, j), ua in zip(p.couplings, p.coupling_ua_kw_per_k, strict=True):
        conductance[i, j] = conductance[j, i] = ua
    to_outdoor = np.concatenate([ua_o, ua_mo])
    capacitance = np.concatenate([c_air, c_mass])
    to_boundary = np.zeros(2 * m)
    h = np.zeros((2 * m, len(EXOGENOUS_INPUTS) + m + p.boundaries))
    for (i, b), ua in zip(p.boundary_couplings, p.boundary_ua_kw_per_k, strict=True):
        to_boundary[i] += ua
        h[i, len(EXOGENOUS_INPUTS) + m + b] += ua
    k = conductance - np.diag(conductance.sum(axis=1) + to_outdoor + to_boundary)
    h[:, 0] = to_outdoor
    h[air, 1] = p.value("solar_air_m2")
    h[mass, 1] = p.value("solar_mass_m2")
    for column, (name, _) in enumerate(WALL_ORIENTATIONS, start=WALL_INPUTS.start):
        h[air, column] = p.value(f"solar_wall_{name}_m2")
    h[air, 2] = p.value("occupied_gain_kw")
    h[air, 3] = p.value("base_gain_kw")
    h[air, len(EXOGENOUS_INPUTS) + air] = -1.0
    return k, h, capacitance


def continuous_matrices(p: GreyBoxParameters) -> tuple[FloatArray, FloatArray]:
    """The continuous model ``dx/dt = a x + b u``.

    Returns
    -------
    a : (2m, 2m) [1/s]; b : (2m, 8 + m + nb) [K/s per input unit].
    """
    k, h, capacitance = _symmetric_parts(p)
    return k / capacitance[:, None], h / capacitance[:, None]


@dataclass(frozen=True)
class DiscreteModel:
    """The model on the 30-min grid.

    Attributes
    ----------
    a : (n, n), b : (n, nu): ``x_{k+1} = a x_k + b u_k``.
    c_mean : (m, n), d_mean : (m, nu): the period-mean zone temperature ``y_k``.
    gain : (n, m) the steady-state Kalman predictor gain.
    b_change : (n, m), d_change : (m, m): ``B_Δ`` and ``D_Δ``, the effect of the cooling's
        change ``ΔQ_k`` [kW] coming early in the period (module docstring; zero for γ = 0).
    """

    a: FloatArray
    b: FloatArray
    c_mean: FloatArray
    d_mean: FloatArray
    gain: FloatArray
    b_change: FloatArray
    d_change: FloatArray


def _filter_gain(
    model_a: FloatArray, c: FloatArray, noise: FloatArray, r: FloatArray
) -> FloatArray:
    """Steady-state Kalman predictor gain ``a P cᵀ (c P cᵀ + r)⁻¹``, with ``P`` from the
    filter's Riccati equation solved by the structure-preserving doubling algorithm (a few
    10×10 products; ``scipy.linalg.solve_discrete_are`` is the same ``P`` but ~50× slower)."""
    a_k, g_k, h_k = model_a.T.copy(), c.T @ np.linalg.solve(r, c), noise.copy()
    eye = np.eye(a_k.shape[0])
    for _ in range(RICCATI_MAX_ITERATIONS):
        w = np.linalg.solve(eye + g_k @ h_k, np.hstack([a_k, g_k]))
        w_a, w_g = w[:, : a_k.shape[0]], w[:, a_k.shape[0] :]
        h_next = h_k + a_k.T @ h_k @ w_a
        g_k, a_k = g_k + a_k @ w_g @ a_k.T, a_k @ w_a
        converged = np.abs(h_next - h_k).max() <= RICCATI_TOLERANCE * np.abs(h_next).max()
        h_k = h_next
        if converged:
            break
    cov = h_k
    return model_a @ cov @ c.T @ np.linalg.inv(c @ cov @ c.T + r)


def discretize(
    p: GreyBoxParameters, dt_s: float = PERIOD_S, cooling_change_share: float = 0.0
) -> DiscreteModel:
    """Zero-order-hold discretisation, the period-mean output and the Kalman gain;
    ``cooling_change_share`` γ [–], 0…1: how much of the cooling's change comes in the
    period's first share β (module docstring; 0: the plain zero-order hold).

    ``a = diag(1/C) k`` is similar to the symmetric ``C^(-1/2) k C^(-1/2)``, so every function
    of it comes from one symmetric eigendecomposition (real, negative eigenvalues λ):
    ``e^(a dt)``, ``∫e^(as)ds = V diag((e^(λdt) − 1)/λ) V⁻¹`` and the period mean
    ``(1/dt)∫∫e^(ar)dr ds = V diag((e^(λdt) − 1 − λdt)/(λ² dt)) V⁻¹``.
    """
    k, h, capacitance = _symmetric_parts(p)
    root = np.sqrt(capacitance)
    eigenvalues, w = np.linalg.eigh(k / root[:, None] / root[None, :])
    v, v_inv = w / root[:, None], w.T * root[None, :]
    x = eigenvalues * dt_s
    phi1 = np.expm1(x) / eigenvalues
    phi2 = (np.expm1(x) - x) / (eigenvalues**2 * dt_s)
    b_c = h / capacitance[:, None]
    m = p.zones
    a = (v * np.exp(x)) @ v_inv
    b = (v * phi1) @ v_inv @ b_c
    c_mean = ((v * (phi1 / dt_s)) @ v_inv)[:m]
    d_mean = ((v * phi2) @ v_inv @ b_c)[:m]
    n = a.shape[0]
    noise = np.diag(np.r_[np.full(m, PROCESS_STD_AIR_K), np.full(n - m, PROCESS_STD_MASS_K)] ** 2)
    r = np.eye(m) * MEASUREMENT_STD_K**2
    gain = _filter_gain(a, c_mean, noise, r)
    b_change, d_change = np.zeros((n, m)), np.zeros((m, m))
    share = cooling_change_share
    if share != 0.0:  # the parameter fit's plain hold skips it
        early_end, early_mean = _early_input(eigenvalues, dt_s, CHANGE_HOLD_SHARE)
        b_cooling = b_c[:, cooling_columns(m)]
        b_change = share * (v * (early_end / CHANGE_HOLD_SHARE - phi1)) @ v_inv @ b_cooling
        d_change = share * ((v * (early_mean / CHANGE_HOLD_SHARE - phi2)) @ v_inv @ b_cooling)[:m]
    return DiscreteModel(
        a=a, b=b, c_mean=c_mean, d_mean=d_mean, gain=gain, b_change=b_change, d_change=d_change
    )


def cooling_columns(zones: int) -> slice:
    """The columns of the zones' cooling Q [kW] in the fit's inputs ``u`` (after
    :data:`EXOGENOUS_INPUTS`, one per zone)."""
    return slice(len(EXOGENOUS_INPUTS), len(EXOGENOUS_INPUTS) + zones)


def _early_input(
    eigenvalues: FloatArray, dt_s: float, share: float
) -> tuple[FloatArray, FloatArray]:
    """Per eigenvalue λ, the period-end state and the period-mean state [s] from a unit input
    held over the period's first ``share`` only, from zero: ``e^(λ(1−β)dt) (e^(λβdt) − 1)/λ``
    and ``[(e^(λβdt) − 1 − λβdt)/λ² + (e^(λβdt) − 1)/λ · (e^(λ(1−β)dt) − 1)/λ] / dt``."""
    early, late = eigenvalues * share * dt_s, eigenvalues * (1.0 - share) * dt_s
    held = np.expm1(early) / eigenvalues
    end = np.exp(late) * held
    mean = ((np.expm1(early) - early) / eigenvalues**2 + held * np.expm1(late) / eigenvalues) / dt_s
    return end, mean


def cooling_change_kw(u: FloatArray, zones: int) -> FloatArray:
    """(T, m) ``ΔQ_k = Q_k − Q_{k−1}`` [kW], the cooling's change from the period before
    (0 in the first period), from the inputs ``u`` (T, nu) of ``zones`` zones."""
    cooling = u[:, cooling_columns(zones)]
    change: FloatArray = np.zeros_like(cooling)
    change[1:] = np.diff(cooling, axis=0)
    return change


def filter_states(model: DiscreteModel, y: FloatArray, u: FloatArray) -> FloatArray:
    """One-step-ahead state estimates from the measured period means.

    Parameters
    ----------
    y : (T, m) measured period-mean zone temperatures [°C]; u : (T, nu) inputs.

    Returns
    -------
    (T, n) ``x̂_k`` from ``y_0 … y_{k−1}`` (``x̂_0``: every node at ``y_0``'s zone value); the
    cooling's change (:func:`cooling_change_kw`) enters through ``b_change`` and ``d_change``.
    """
    steps, n = y.shape[0], model.a.shape[0]
    closed = model.a - model.gain @ model.c_mean
    drive = u @ (model.b - model.gain @ model.d_mean).T + y @ model.gain.T
    drive += cooling_change_kw(u, y.shape[1]) @ (model.b_change - model.gain @ model.d_change).T
    states = np.empty((steps, n))
    x = np.concatenate([y[0], y[0]])
    for k in range(steps):
        states[k] = x
        x = closed @ x + drive[k]
    return states


def simulate_windows(
    model: DiscreteModel,
    x0: FloatArray,
    u: FloatArray,
    window: int,
    change: FloatArray | None = None,
) -> FloatArray:
    """Open-loop period-mean predictions of windows started from estimated states.

    Parameters
    ----------
    x0 : (W, n) the state at each window's start; u : (W, window, nu) the measured inputs;
    change : (W, window, m) the cooling's change ``ΔQ`` [kW] (:func:`cooling_change_kw`),
        default none.

    Returns
    -------
    (W, window, m) predicted period-mean zone temperatures [°C].
    """
    x = x0.copy()
    out = np.empty((x0.shape[0], window, model.c_mean.shape[0]))
    delta = np.zeros((*u.shape[:2], model.d_change.shape[1])) if change is None else change
    for k in range(window):
        out[:, k] = x @ model.c_mean.T + u[:, k] @ model.d_mean.T + delta[:, k] @ model.d_change.T
        x = x @ model.a.T + u[:, k] @ model.b.T + delta[:, k] @ model.b_change.T
    return out


def time_constants_s(p: GreyBoxParameters) -> FloatArray:
    """(n,) the continuous model's time constants −1/λ [s], ascending."""
    eigenvalues = np.linalg.eigvals(continuous_matrices(p)[0])
    return np.sort(-1.0 / eigenvalues.real)


@dataclass(frozen=True)
class FilterNoise:
    """Noise levels of the one-step predictor's Kalman filter (:func:`one_step_predictions`).

    Attributes
    ----------
    air_k, mass_k : process noise on an air and a mass node per step [K].
    gain_kw : process noise of each zone's unmeasured heat gain per step [kW] (0: no such
        state, the plain filter of :func:`filter_states`).
    gain_persistence : ``ρ`` of the gain's AR(1) ``d_{k+1} = ρ d_k + w`` [–], 0…1.
    measurement_k : measurement noise of a period-mean zone temperature [K].
    """

    air_k: float = PROCESS_STD_AIR_K
    mass_k: float = PROCESS_STD_MASS_K
    gain_kw: float = 0.0
    gain_persistence: float = 0.0
    measurement_k: float = MEASUREMENT_STD_K


def one_step_predictions(
    model: DiscreteModel, y: FloatArray, u: FloatArray, noise: FilterNoise
) -> FloatArray:
    """One-step-ahead predictions of the period means by a steady-state Kalman filter on the
    model augmented with an unmeasured heat gain ``d_i`` [kW] into each zone's air node
    (``d_{k+1} = ρ d_k + w``: the slowly varying part of the balance the inputs miss).

    Parameters
    ----------
    y : (T, m) measured period-mean zone temperatures [°C]; u : (T, nu) inputs.

    Returns
    -------
    (T, m) ``ŷ_k`` from ``y_0 … y_{k−1}`` and ``u_k`` [°C] (``ŷ_0``: every node at ``y_0``),
    the cooling's change ``u_k − u_{k−1}`` entering as in :func:`filter_states`.
    """
    m, n = y.shape[1], model.a.shape[0]
    cooling = cooling_columns(m)
    a = np.block(
        [
            [model.a, -model.b[:, cooling]],
            [np.zeros((m, n)), noise.gain_persistence * np.eye(m)],
        ]
    )
    c = np.hstack([model.c_mean, -model.d_mean[:, cooling]])
    q = np.r_[np.full(m, noise.air_k), np.full(n - m, noise.mass_k), np.full(m, noise.gain_kw)]
    gain = _filter_gain(a, c, np.diag(q**2), np.eye(m) * noise.measurement_k**2)
    b = np.vstack([model.b, np.zeros((m, u.shape[1]))])
    b_change = np.vstack([model.b_change, np.zeros((m, m))])
    change = cooling_change_kw(u, m)
    closed = a - gain @ c
    feed = u @ (b - gain @ model.d_mean).T + y @ gain.T
    feed += change @ (b_change - gain @ model.d_change).T
    out = np.empty_like(y)
    x = np.concatenate([y[0], y[0], np.zeros(m)])
    for k in range(y.shape[0]):
        out[k] = c @ x
        x = closed @ x + feed[k]
    result: FloatArray = out + u @ model.d_mean.T + change @ model.d_change.T
    return result
