r"""Output feedback: a Kalman filter on the MPC's own affine model, with offset-free states.

A building measures its zone air temperatures, not its wall and slab nodes. This module
estimates every node from the zone air temperatures (docs/explanation/estimation.md).

Model
-----
The filter runs on the discrete affine model the MPC plans with, augmented with one
disturbance state ``s`` per zone (a random walk, [K per step]) that enters the zone air
node like an unmodelled heat gain::

    x_{k+1} = A_k x_k + B_k u_k + E_k d̂_k + g_k + Cᵀ s_k + E_k w_k + q_k
    s_{k+1} = s_k + q^s_k
    y_k     = C x_k + v_k,          |v_k| ≤ a  (uniform: variance (2a)²/12 = a²/3)

with ``u`` the applied flow, ``d̂`` the forecast disturbance (known inputs together with the
affine term ``g``), ``w`` the forecast error in the box ``|w| ≤ σ`` (variance σ²/3 for a
uniform draw), ``q`` and ``q^s`` white process noise of standard deviations
``process_noise_node_k`` and ``process_noise_offset_k`` (the tuned covariances; see
``scripts/tune_kalman.py`` and docs/explanation/estimation.md). With the augmented state
``z = (x, s)``, ``F_k = [[A_k, Cᵀ], [0, I]]`` and ``H = [C, 0]`` the filter is the textbook
time-varying Kalman filter (predict with ``F_k``, update with ``H``); the MPC then plans
from ``x̂`` and adds ``Cᵀ ŝ`` to its affine term (offset-free MPC).

Error bound
-----------
Let ``e = z − ẑ`` after the update. With the model error split as ``Cᵀ s_k + r_k``
(``|s_{k+1} − s_k| ≤ Δs̄``, ``|r_k| ≤ r̄``; both zero on the linear model) and a gain L::

    e_{k+1} = M e_k + (I − L H) ξ_k − L v_{k+1},   M = (I − L H) F,
    ξ_k = (E w_k + r_k, s_{k+1} − s_k),  |ξ_k| ≤ ξ̄ = (|E| σ + r̄, Δs̄),  |v| ≤ a,

so once the initial error has died out ``|e| ≤ ē = Σ_l |M^l (I − L H)| ξ̄ + |M^l L| a``
(:func:`steady_state_error_bound`, for the steady-state gain :func:`steady_state_gain`).
A per-step recursion ``ē_{k+1} = |M| ē_k + …`` is not usable: on office5 ρ(|M|) ≈ 1.01 > 1
although ρ(M) ≈ 0.98, so it diverges. A plan from ``(x̂, ŝ)`` that keeps ``ŝ`` constant is
off the true outputs by ``H F^k e``: the extra comfort margin is ``|H F^k| ē``
(:func:`estimation_margins`), added to δ_k.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from hvacflex.blas import one_blas_thread
from hvacflex.errors import ConfigError

FloatArray = NDArray[np.float64]

DEFAULT_MEASUREMENT_NOISE_K = 0.1
"""Half-width a of the uniform zone-air sensor error [K] (BEMS sensors: ~0.1–0.2 K)."""

DEFAULT_PROCESS_NOISE_NODE_K = 0.2
"""Standard deviation of the per-step node process noise [K] (tuned:
docs/explanation/estimation.md)."""

DEFAULT_PROCESS_NOISE_OFFSET_K = 0.1
"""Standard deviation of the per-step random walk of the zone offset states [K]
(tuned: docs/explanation/estimation.md)."""

DEFAULT_INITIAL_STD_K = 1.0
"""Prior standard deviation of every node and offset at the first measurement [K]."""


@dataclass(frozen=True)
class KalmanConfig:
    """Tuning of :func:`kalman_update` / :func:`kalman_predict`.

    Attributes
    ----------
    measurement_noise_k : half-width a ≥ 0 of the uniform sensor error [K].
    process_noise_node_k : std of the node process noise per step [K].
    process_noise_offset_k : std of the offset random walk per step [K].
    initial_std_k : prior std of nodes and offsets [K].
    offset_rate_bound_k : Δs̄, bound on the change of the true zone offset per step [K]
        (the bound only; 0 on the linear model).
    model_residual_bound_k : r̄, bound on the part of the model error per node that the
        offset does not represent [K per step] (the bound only; 0 on the linear model).
    """

    measurement_noise_k: float = DEFAULT_MEASUREMENT_NOISE_K
    process_noise_node_k: float = DEFAULT_PROCESS_NOISE_NODE_K
    process_noise_offset_k: float = DEFAULT_PROCESS_NOISE_OFFSET_K
    initial_std_k: float = DEFAULT_INITIAL_STD_K
    offset_rate_bound_k: float = 0.0
    model_residual_bound_k: float = 0.0

    def __post_init__(self) -> None:
        for name in (
            "measurement_noise_k",
            "process_noise_node_k",
            "process_noise_offset_k",
            "offset_rate_bound_k",
            "model_residual_bound_k",
        ):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise ConfigError("must be finite and ≥ 0", field=f"estimation.{name}", value=value)
        if not (np.isfinite(self.initial_std_k) and self.initial_std_k > 0.0):
            raise ConfigError(
                "must be finite and > 0", field="estimation.initial_std_k", value=self.initial_std_k
            )

    @property
    def measurement_variance_k2(self) -> float:
        """Variance of the uniform sensor error, (2a)²/12 [K²] (floored at 1e-8 K²)."""
        return max(self.measurement_noise_k**2 / 3.0, 1e-8)


class StepModel(Protocol):
    """One step of the affine model ``x+ = a x + b u + e d + g`` with outputs ``y = c x``.

    Shapes: a (n,n), b (n,m), e (n,nd), g (n,), c (m,n) zone selection.
    (:class:`hvacflex.building.discretize.LinearModel` and
    :class:`hvacflex.control.trajectory.StepMatrices` have these fields.)
    """

    @property
    def a(self) -> FloatArray: ...
    @property
    def b(self) -> FloatArray: ...
    @property
    def e(self) -> FloatArray: ...
    @property
    def g(self) -> FloatArray: ...
    @property
    def c(self) -> FloatArray: ...


@dataclass(frozen=True)
class EstimatorState:
    """Estimate after the last update (or prediction) and what the error bound needs.

    Attributes
    ----------
    x_degc : (n,) node temperature estimate x̂ [°C].
    offset_k : (m,) zone offset estimate ŝ [K per step].
    covariance : (n+m, n+m) covariance of (x, s) [K²].
    """

    x_degc: FloatArray
    offset_k: FloatArray
    covariance: FloatArray

    @property
    def n(self) -> int:
        return int(self.x_degc.shape[0])

    @property
    def m(self) -> int:
        return int(self.offset_k.shape[0])


def augmented_matrices(model: StepModel) -> tuple[FloatArray, FloatArray]:
    """``F = [[A, Cᵀ], [0, I]]`` (n+m, n+m) and ``H = [C, 0]`` (m, n+m)."""
    a, c = np.asarray(model.a, dtype=np.float64), np.asarray(model.c, dtype=np.float64)
    m, n = c.shape
    f = np.zeros((n + m, n + m))
    f[:n, :n] = a
    f[:n, n:] = c.T
    f[n:, n:] = np.eye(m)
    h = np.hstack([c, np.zeros((m, m))])
    return f, h


def initial_state(y_degc: ArrayLike, model: StepModel, config: KalmanConfig) -> EstimatorState:
    """Prior before the first measurement ``y_degc`` (m,) [°C]: every node at the mean
    measured zone temperature, offsets 0, covariance ``initial_std_k² I``."""
    y = np.asarray(y_degc, dtype=np.float64)
    c = np.asarray(model.c, dtype=np.float64)
    m, n = c.shape
    return EstimatorState(
        x_degc=np.full(n, float(y.mean())),
        offset_k=np.zeros(m),
        covariance=np.eye(n + m) * config.initial_std_k**2,
    )


def process_covariance(model: StepModel, d_sigma: ArrayLike, config: KalmanConfig) -> FloatArray:
    """Q (n+m, n+m): ``E diag(σ²/3) Eᵀ + q_x² I`` on the nodes, ``q_s² I`` on the offsets.

    ``d_sigma`` (nd,) is the box half-width of this step's forecast error.
    """
    e = np.asarray(model.e, dtype=np.float64)
    n, m = e.shape[0], np.asarray(model.c).shape[0]
    sigma = np.asarray(d_sigma, dtype=np.float64)
    q = np.zeros((n + m, n + m))
    q[:n, :n] = (e * (sigma**2 / 3.0)) @ e.T + np.eye(n) * config.process_noise_node_k**2
    q[n:, n:] = np.eye(m) * config.process_noise_offset_k**2
    return q


def kalman_gain(covariance: FloatArray, h: FloatArray, config: KalmanConfig) -> FloatArray:
    """L = P Hᵀ (H P Hᵀ + R)⁻¹ (n+m, m) for the prior covariance P."""
    s = h @ covariance @ h.T + np.eye(h.shape[0]) * config.measurement_variance_k2
    gain: FloatArray = np.asarray(np.linalg.solve(s, h @ covariance).T, dtype=np.float64)
    return gain


def kalman_update(
    state: EstimatorState,
    y_degc: ArrayLike,
    model: StepModel,
    config: KalmanConfig,
    *,
    gain: FloatArray | None = None,
) -> EstimatorState:
    """Measurement update with the zone-air temperatures ``y_degc`` (m,) [°C] (Joseph form).

    ``gain`` (n+m, m) replaces the Kalman gain (e.g. the steady-state gain L∞, for which
    :func:`steady_state_error_bound` holds); default: the time-varying Kalman gain.
    """
    _, h = augmented_matrices(model)
    n = state.n
    if gain is None:
        gain = kalman_gain(state.covariance, h, config)
    z = np.concatenate([state.x_degc, state.offset_k])
    z_new = z + gain @ (np.asarray(y_degc, dtype=np.float64) - h @ z)
    i_lh = np.eye(z.size) - gain @ h
    p_new = i_lh @ state.covariance @ i_lh.T + gain @ gain.T * config.measurement_variance_k2
    return EstimatorState(x_degc=z_new[:n], offset_k=z_new[n:], covariance=0.5 * (p_new + p_new.T))


def kalman_predict(
    state: EstimatorState,
    model: StepModel,
    flow_kg_s: ArrayLike,
    d_forecast: ArrayLike,
    d_sigma: ArrayLike,
    config: KalmanConfig,
) -> EstimatorState:
    """Time update over one step with the applied flow (m,) [kg/s], the forecast
    disturbance (nd,) and its box half-width σ (nd,) → prior for the next step."""
    f, _ = augmented_matrices(model)
    n = state.n
    drive = (
        np.asarray(model.b, dtype=np.float64) @ np.asarray(flow_kg_s, dtype=np.float64)
        + np.asarray(model.e, dtype=np.float64) @ np.asarray(d_forecast, dtype=np.float64)
        + np.asarray(model.g, dtype=np.float64)
    )
    z = np.concatenate([state.x_degc, state.offset_k])
    z_new = f @ z
    z_new[:n] += drive
    p_new = f @ state.covariance @ f.T + process_covariance(model, d_sigma, config)
    return EstimatorState(x_degc=z_new[:n], offset_k=z_new[n:], covariance=0.5 * (p_new + p_new.T))


def kalman_step(
    state: EstimatorState,
    model: StepModel,
    flow_kg_s: ArrayLike,
    d_forecast: ArrayLike,
    d_sigma: ArrayLike,
    y_degc: ArrayLike,
    config: KalmanConfig,
) -> EstimatorState:
    """Predict over the last step (``model``, applied flow, forecast d̂, σ) and update with
    the new measurement ``y_degc`` (m,) [°C]."""
    prior = kalman_predict(state, model, flow_kg_s, d_forecast, d_sigma, config)
    return kalman_update(prior, y_degc, model, config)


def steady_state_gain(model: StepModel, d_sigma: ArrayLike, config: KalmanConfig) -> FloatArray:
    """The gain L∞ (n+m, m) the filter converges to on a time-invariant model with a
    constant σ (nd,): from the discrete algebraic Riccati equation of (F, H, Q, R), solved on
    one BLAS thread (:func:`hvacflex.blas.one_blas_thread`: on office15 it rounds differently
    with two)."""
    f, h = augmented_matrices(model)
    q = process_covariance(model, d_sigma, config)
    r = np.eye(h.shape[0]) * config.measurement_variance_k2
    with one_blas_thread():
        p_prior = scipy.linalg.solve_discrete_are(f.T, h.T, q, r)
    return kalman_gain(p_prior, h, config)


def noise_bound(model: StepModel, d_sigma: ArrayLike, config: KalmanConfig) -> FloatArray:
    """ξ̄ (n+m,): bound on the step's unknown drive, ``(|E| σ + r̄, Δs̄)`` [K]."""
    e = np.abs(np.asarray(model.e, dtype=np.float64))
    m = np.asarray(model.c).shape[0]
    nodes = e @ np.asarray(d_sigma, dtype=np.float64) + config.model_residual_bound_k
    return np.concatenate([nodes, np.full(m, config.offset_rate_bound_k)])


MAX_BOUND_TERMS = 20000
"""Cap on the number of terms of the series in :func:`steady_state_error_bound`."""


def steady_state_error_bound(
    model: StepModel,
    gain: FloatArray,
    d_sigma: ArrayLike,
    config: KalmanConfig,
    *,
    tolerance: float = 1e-9,
) -> FloatArray:
    """ē (n+m,) [K]: componentwise bound on the estimation error of the filter with the
    constant gain L (n+m, m), once the initial error has died out.

    ``ē = Σ_{l≥0} |M^l (I − L H)| ξ̄ + |M^l L| a`` with ``M = (I − L H) F``; the series is
    summed until ``‖M^l‖_∞ < tolerance`` (it converges because M is stable; the remainder is
    then below ``tolerance · (‖ξ̄‖_∞ + a) / (1 − ρ)``, negligible).

    Raises
    ------
    ConfigError
        if M is not stable (the series does not converge).
    """
    f, h = augmented_matrices(model)
    n_aug = f.shape[0]
    i_lh = np.eye(n_aug) - gain @ h
    transition = i_lh @ f
    radius = float(np.max(np.abs(np.linalg.eigvals(transition))))
    if radius >= 1.0:
        raise ConfigError(
            "the estimation error dynamics are not stable; no bound exists",
            field="estimation",
            value=radius,
            hint="check the model and the covariances",
        )
    xi = noise_bound(model, d_sigma, config)
    total = np.zeros(n_aug)
    power = np.eye(n_aug)
    for _ in range(MAX_BOUND_TERMS):
        total += (
            np.abs(power @ i_lh) @ xi
            + np.abs(power @ gain).sum(axis=1) * config.measurement_noise_k
        )
        power = power @ transition
        if np.max(np.abs(power).sum(axis=1)) < tolerance:
            break
    return total


def estimation_margins(model: StepModel, error_bound_k: ArrayLike, horizon: int) -> FloatArray:
    """Extra comfort margin (N, m) [K] for a plan from the estimate: row k−1 is ``|H F^k| ē``.

    A plan that starts from ``(x̂, ŝ)`` and keeps the offset ``ŝ`` constant predicts the
    outputs ``H F^k ẑ + …``; the true outputs (same inputs, same disturbances) differ by
    ``H F^k e`` with ``|e| ≤ ē``, hence by at most ``|H F^k| ē`` componentwise.
    """
    f, h = augmented_matrices(model)
    bound = np.asarray(error_bound_k, dtype=np.float64)
    out = np.empty((horizon, h.shape[0]))
    row = h.copy()
    for k in range(horizon):
        row = row @ f
        out[k] = np.abs(row) @ bound
    return out


def tightened_bounds(
    y_min: ArrayLike, y_max: ArrayLike, extra_k: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Comfort bounds (N, m) tightened by the estimation margin (N, m) [°C, K].

    Where the two tightened bounds would cross (margin above half the band) both are set to
    the band's midpoint: the plan aims at the middle and the comfort slack pays for the rest
    (the worst-case guarantee is then lost on those steps, which the planned slack shows).
    """
    lo = np.asarray(y_min, dtype=np.float64) + np.asarray(extra_k, dtype=np.float64)
    hi = np.asarray(y_max, dtype=np.float64) - np.asarray(extra_k, dtype=np.float64)
    mid = 0.5 * (np.asarray(y_min, dtype=np.float64) + np.asarray(y_max, dtype=np.float64))
    cross = lo > hi
    return np.where(cross, mid, lo), np.where(cross, mid, hi)


def measure_zone_temps(
    rng: np.random.Generator, x_degc: ArrayLike, c_matrix: ArrayLike, measurement_noise_k: float
) -> FloatArray:
    """Zone-air sensor readings (m,) [°C]: ``C x`` plus uniform noise in ±a."""
    y = np.asarray(c_matrix, dtype=np.float64) @ np.asarray(x_degc, dtype=np.float64)
    noise = rng.uniform(-measurement_noise_k, measurement_noise_k, y.shape)
    out: FloatArray = y + noise
    return out


@dataclass(frozen=True)
class AppliedStep:
    """What the filter's next prediction needs about the step just decided: the model the
    plan used, the flow (m,) [kg/s], the forecast d̂ (nd,) and its box σ (nd,)."""

    model: StepModel
    flow_kg_s: FloatArray
    d_forecast: FloatArray
    d_sigma: FloatArray


class KalmanEstimator:
    """The filter as the MPC uses it: one call per step with the new measurement.

    Parameters
    ----------
    config : tuning and bounds.
    """

    def __init__(self, config: KalmanConfig) -> None:
        self.config = config
        self.state: EstimatorState | None = None
        self.last: AppliedStep | None = None

    def estimate(self, y_degc: ArrayLike, model: StepModel) -> EstimatorState:
        """Update with the zone-air measurement (m,) [°C] (predicting over the last applied
        step first) and return the estimate."""
        cfg = self.config
        if self.state is None or self.last is None:
            prior = self.state if self.state is not None else initial_state(y_degc, model, cfg)
            self.state = kalman_update(prior, y_degc, model, cfg)
        else:
            last = self.last
            self.state = kalman_step(
                self.state, last.model, last.flow_kg_s, last.d_forecast, last.d_sigma, y_degc, cfg
            )
        return self.state

    def applied(self, step: AppliedStep) -> None:
        """Record the step just decided (used by the next :meth:`estimate`)."""
        self.last = step

    def margins(self, model: StepModel, d_sigma: ArrayLike, horizon: int) -> FloatArray:
        """Extra comfort margin (N, m) [K]: ``|H F^k| ē`` for the steady-state gain of
        ``model`` and the largest σ (nd,) of the horizon."""
        gain = steady_state_gain(model, d_sigma, self.config)
        bound = steady_state_error_bound(model, gain, d_sigma, self.config)
        return estimation_margins(model, bound, horizon)

    def get_state(self) -> dict[str, object]:
        return {"state": self.state, "last": self.last}

    def set_state(self, state: dict[str, object]) -> None:
        saved, last = state["state"], state["last"]
        self.state = saved if isinstance(saved, EstimatorState) else None
        self.last = last if isinstance(last, AppliedStep) else None
