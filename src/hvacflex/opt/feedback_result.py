"""The solution of a feedback LP: gains tensor, output response, realised margins.

:func:`feedback_solution` turns the primal values of the LP of :mod:`hvacflex.opt.feedback`
into an :class:`~hvacflex.opt.solution.RMPCSolution`: the plan, the gains ``U_{k,j}`` and the
comfort margins the gains actually give, ``δ_k = Σ_j |Y_{k,j}| σ_j`` with
``Y_{k,j} = G_{k-1-j} + Σ_t H_{k-1-t} U_{t,j}`` (the coefficient of w_j in C x_k).

For shift-invariant gains ("time-invariant", "zone-local": ``U_{t,j} = U_{t-j}``) the
response depends on the lag only, ``Y_{k,j} = Ȳ_{k-1-j}``, and :func:`lag_output_response`
computes the N lag blocks with L small products instead of the (N·ny × N·m) by (N·m × N·nd)
product of :func:`output_response` (≈ 0.3 ms instead of ≈ 6 ms per step on office5).
"""

from __future__ import annotations

import numpy as np
from scipy import sparse

from hvacflex.opt.feedback import FeedbackColumns, FeedbackMaps
from hvacflex.opt.lp import PlanColumns
from hvacflex.opt.problem import FloatArray, RMPCProblem
from hvacflex.opt.solution import (
    RMPCSolution,
    SolveStatus,
    failed_solution,
    plan_from_values,
    plan_solution,
)

__all__ = [
    "feedback_solution",
    "gains_tensor",
    "lag_output_response",
    "output_response",
    "realised_margins",
]


def gains_tensor(
    maps: FeedbackMaps, theta: FloatArray, horizon: int, m: int, nd: int
) -> FloatArray:
    """(N, N, m, nd) gains ``U_{k,j}`` (coefficient of w_j in u_k [kg/s per unit of w])
    from the gain values Θ."""
    gains = maps.gains
    tensor = np.zeros((horizon, horizon, m, nd))
    if gains.num_gains:
        e_app = gains.app_entry
        np.add.at(
            tensor,
            (gains.app_step, gains.app_source, gains.entry_input[e_app]),
            theta[e_app][:, None] * gains.k_matrix[gains.entry_component[e_app]],
        )
    scaled: FloatArray = tensor * maps.scale  # coefficient on w = coefficient on w̃ · ‖E_l‖
    return scaled


def output_response(maps: FeedbackMaps, tensor: FloatArray) -> FloatArray:
    """(N, N, ny, nd) ``Y[k-1, j]``: coefficient of w_j in C x_k under the gains ``tensor``.

    ``tensor`` as from :func:`gains_tensor` (per unit of w); so is the result.
    """
    horizon = tensor.shape[0]
    ny, nd = maps.g_resp.shape[1:]
    lag = np.arange(horizon)[:, None] - np.arange(horizon)[None, :]  # (k-1) - j
    causal = (lag >= 0)[:, :, None, None]
    response = np.where(causal, maps.g_resp[np.clip(lag, 0, None)], 0.0)
    h_full = np.where(causal, maps.h_resp[np.clip(lag, 0, None)], 0.0)  # [k-1, t]
    # Σ_t H_{k-1-t} U_{t,j} with t ≤ k-1 (U_{t,j} = 0 for t ≤ j)
    m = tensor.shape[2]  # [(k, a), (t, b)] @ [(t, b), (j, l)], the gains sparse (lags ≤ L)
    h_rows = h_full.transpose(0, 2, 1, 3).reshape(horizon * ny, horizon * m)
    u_cols = (tensor / maps.scale).transpose(0, 2, 1, 3).reshape(horizon * m, horizon * nd)
    product = np.asarray((sparse.csc_matrix(u_cols).T @ h_rows.T).T)
    feedback_part = product.reshape(horizon, ny, horizon, nd).transpose(0, 2, 1, 3)
    response = response + feedback_part
    result: FloatArray = response.reshape(horizon, horizon, ny, nd) * maps.scale
    return result


def lag_output_response(maps: FeedbackMaps, tensor: FloatArray) -> FloatArray:
    """(N, ny, nd) ``Ȳ_g``: the coefficient of w_j in C x_{j+g+1}, for gains ``tensor``
    that are shift-invariant (``U_{t,j} = U_{t-j}``, as :func:`gains_tensor` gives for the
    "time-invariant" and "zone-local" structures); ``Y[k-1, j] = Ȳ_{k-1-j}`` for k − 1 ≥ j
    (:func:`output_response`).

    ``Ȳ_g = G_g + Σ_{s=1}^{g} H_{g-s} U_s``; ``tensor`` (N, N, m, nd) per unit of w, and so is
    the result. Only the first column of ``tensor`` (``U_{s,0}``) is read.
    """
    horizon = tensor.shape[0]
    lags = tensor[:, 0] / maps.scale  # (N, m, nd) U_s per unit of w̃; U_0 = 0
    response = maps.g_resp.copy()
    for s in np.flatnonzero(np.any(lags[1:] != 0.0, axis=(1, 2))) + 1:
        response[s:] += np.einsum("gai,il->gal", maps.h_resp[: horizon - s], lags[s])
    result: FloatArray = response * maps.scale
    return result


def realised_margins(maps: FeedbackMaps, tensor: FloatArray, sigma: FloatArray) -> FloatArray:
    """(N, ny) margins ``δ[k-1] = Σ_j Σ_l |Y[k-1, j, :, l]| σ_{j,l}`` the gains ``tensor``
    (N, N, m, nd) give against the box ``sigma`` (N, nd) [K]."""
    horizon = tensor.shape[0]
    if maps.gains.shift_invariant:
        lag = np.arange(horizon)[:, None] - np.arange(horizon)[None, :]  # [k-1, j]
        # σ seen at lag g from row k-1: σ_{k-1-g}, zero before the horizon
        shifted = np.where((lag >= 0)[:, :, None], sigma[np.clip(lag, 0, None)], 0.0)
        absolute = np.abs(lag_output_response(maps, tensor))  # (g, ny, nd)
        delta: FloatArray = np.einsum("gal,kgl->ka", absolute, shifted, optimize=True)
        return delta
    ny, nd = maps.g_resp.shape[1:]
    full = np.abs(output_response(maps, tensor)).reshape(horizon, horizon, ny, nd)
    general: FloatArray = np.einsum("kjal,jl->ka", full, sigma, optimize=True)
    return general


def feedback_solution(
    problem: RMPCProblem,
    maps: FeedbackMaps,
    columns: tuple[PlanColumns, FeedbackColumns],
    *,
    status: SolveStatus,
    values: FloatArray,
    message: str,
    start: float,
    highs_time_s: float,
    simplex_iterations: int = 0,
    warm_start: bool = False,
) -> RMPCSolution:
    """The :class:`RMPCSolution` of a feedback LP's primal ``values`` (NaN unless optimal);
    ``message`` says what was solved (size, structure) and HiGHS's verdict."""
    horizon, m, ny, nd = problem.horizon, problem.m, problem.ny, problem.nd
    if not status.ok:
        return failed_solution(
            problem,
            status=status,
            message=f"{status.value}: {message}; no plan returned",
            delta=np.full((horizon, ny), np.nan),
            start=start,
            highs_time_s=highs_time_s,
            simplex_iterations=simplex_iterations,
            warm_start=warm_start,
        )
    plan_cols, feedback_cols = columns
    tensor = gains_tensor(maps, values[feedback_cols.theta], horizon, m, nd)
    delta = realised_margins(maps, tensor, problem.d_sigma)
    return plan_solution(
        problem,
        status=status,
        message=f"optimal: {message}",
        plan=plan_from_values(problem, plan_cols, values),
        delta=delta,
        start=start,
        highs_time_s=highs_time_s,
        simplex_iterations=simplex_iterations,
        warm_start=warm_start,
        feedback_gains=tensor,
    )
