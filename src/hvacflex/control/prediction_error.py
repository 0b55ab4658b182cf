"""One-step prediction error of the controller's model against the plant.

    e_{k+1} = C (A_k x_k + B_k u_k + E_k d_k + g_k) − C x_{k+1}          [K]

with x the TRUE plant state, u the input the plant ran (u − r under IL activation) and d the
REALISED disturbance, so that e measures the model (its linearisation), not the forecast or
the state estimate. (A_k, B_k, E_k, g_k) is the model the controller planned step k with
(re-linearised each step for ``linearisation = "trajectory"``); the offset estimate of the
Kalman filter is not part of it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hvacflex.building.discretize import affine_step
from hvacflex.control.estimation import StepModel

FloatArray = NDArray[np.float64]


def predicted_state_degc(
    model: StepModel, x_degc: ArrayLike, flow_kg_s: ArrayLike, d: ArrayLike
) -> FloatArray:
    """x_{k+1} = A x_k + B u_k + E d_k + g (n,) [°C] of the one-step ``model`` from the state
    (n,) [°C], the flow (m,) [kg/s] and the disturbance (nd,)."""
    return affine_step((model.a, model.b, model.e, model.g), x_degc, flow_kg_s, d)


def one_step_prediction_error(
    model: StepModel,
    x_degc: ArrayLike,
    flow_kg_s: ArrayLike,
    d_realised: ArrayLike,
    x_next_degc: ArrayLike,
) -> FloatArray:
    """e_{k+1} (m,) [K] from the true state x_k (n,), the applied flow (m,) [kg/s], the
    realised disturbance (nd,) and the true next state x_{k+1} (n,)."""
    predicted = predicted_state_degc(model, x_degc, flow_kg_s, d_realised)
    out: FloatArray = model.c @ (predicted - np.asarray(x_next_degc, dtype=np.float64))
    return out


def prediction_error_rms_k(errors_k: ArrayLike) -> float:
    """Root mean square over steps and zones of the errors (T, m) [K]; NaN rows (steps
    without a model) are left out; NaN if none is left."""
    values = np.asarray(errors_k, dtype=np.float64)
    values = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(values**2))) if values.size else float("nan")


def prediction_error_max_k(errors_k: ArrayLike) -> float:
    """Largest |e| over steps and zones [K] (NaN entries left out; NaN if none is left)."""
    values = np.asarray(errors_k, dtype=np.float64)
    values = values[np.isfinite(values)]
    return float(np.max(np.abs(values))) if values.size else float("nan")
