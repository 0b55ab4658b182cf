r"""Robust comfort margins δ for box-bounded disturbance errors, and the explicit dual form.

The predicted disturbance is ``d̂_j + w_j`` with an unknown error ``|w_j| ≤ σ_j`` (elementwise,
``σ_j ≥ 0``, shape (nd,) per step). Through the linear dynamics ``x_{j+1} = A x_j + … + E w_j``
the error moves the comfort output at step ``k`` (``k = 1..N``) by

.. math::

    C x_k(w) - C x_k(0) = \sum_{j<k} C A^{k-1-j} E\, w_j = \sum_{j<k} G_{k-1-j} w_j,
    \qquad G_l = C A^l E \quad (ny \times nd),

the *impulse responses* of the disturbance-to-output map. The worst case over the box of one
output row ``i`` is

.. math::

    \max_{|w_j| \le \sigma_j} \sum_{j<k} (G_{k-1-j})_{i,:} w_j
    = \sum_{j<k} |G_{k-1-j}|_{i,:}\, \sigma_j \;=:\; \delta_{k,i},

which is the optimum of the paper's per-row dual (eq. 12–13; docs/explanation/model.md §3): minimise
``σᵀ(λ₁ + λ₂)`` subject to ``λ₁ − λ₂ = h``, ``λ₁, λ₂ ≥ 0`` with ``h`` that row of the
disturbance-to-output map. Tightening each comfort row by ``δ`` ("tightening" form) therefore
gives the same LP optimum as carrying the λ's explicitly ("dual" form, offered for
verification: :func:`dual_row_entries` lists the rows' ``h``).

Cost: the |G_l| are computed once per (A, E, C, N) and laid out as a block lower-triangular
Toeplitz matrix ``T`` of shape (N·ny, N·nd), so ``δ = T σ`` is one matrix–vector product,
O(N²·ny·nd) per step when σ changes.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def impulse_responses(
    a_matrix: FloatArray, e_matrix: FloatArray, c_matrix: FloatArray, horizon: int
) -> FloatArray:
    """Signed impulse responses ``G_l = C A^l E`` of the disturbance-to-output map.

    Parameters
    ----------
    a_matrix : (n, n) state matrix [-]
    e_matrix : (n, nd) disturbance matrix [K per disturbance unit]
    c_matrix : (ny, n) output matrix [-]
    horizon : N, number of responses (l = 0..N-1)

    Returns
    -------
    (N, ny, nd) array; entry ``[l]`` is the effect of a unit disturbance error at step ``j``
    on the outputs at step ``j + 1 + l`` [K per disturbance unit].
    """
    ny, nd = c_matrix.shape[0], e_matrix.shape[1]
    responses = np.empty((horizon, ny, nd))
    propagated = e_matrix.copy()  # A^l E
    for lag in range(horizon):
        responses[lag] = c_matrix @ propagated
        propagated = a_matrix @ propagated
    return responses


def margin_operator(responses: FloatArray) -> FloatArray:
    """Block lower-triangular Toeplitz matrix ``T`` with ``δ.ravel() = T @ σ.ravel()``.

    Parameters
    ----------
    responses : (N, ny, nd) impulse responses ``G_l`` (signed; their absolute value is used)

    Returns
    -------
    (N·ny, N·nd) array; block ``(k, j)`` (output step ``k+1``, disturbance step ``j``) is
    ``|G_{k-j}|`` for ``j ≤ k`` and zero otherwise.
    """
    horizon, ny, nd = responses.shape
    magnitude = np.abs(responses)
    lag = np.arange(horizon)[:, None] - np.arange(horizon)[None, :]  # (k, j) -> k - j
    blocks = np.where(
        (lag >= 0)[:, :, None, None], magnitude[np.clip(lag, 0, None)], 0.0
    )  # (N, N, ny, nd)
    return np.ascontiguousarray(blocks.transpose(0, 2, 1, 3).reshape(horizon * ny, horizon * nd))


def robust_margins(operator: FloatArray, d_sigma: FloatArray) -> FloatArray:
    """Worst-case output deviation δ for box half-widths σ.

    Parameters
    ----------
    operator : (N·ny, N·nd) from :func:`margin_operator`
    d_sigma : (N', nd) box half-widths ``σ_j ≥ 0`` [disturbance units] for N' ≤ N steps
        (a shorter σ uses the operator's leading block, which is the operator for N')

    Returns
    -------
    (N', ny) margins ``δ_k`` for outputs at steps k = 1..N' [K]:
    ``δ_k = Σ_{j<k} |C A^{k-1-j} E| σ_j``.
    """
    horizon, nd = d_sigma.shape
    rows = horizon * (operator.shape[0] * nd // operator.shape[1])
    if rows != operator.shape[0]:
        operator = operator[:rows, : horizon * nd]
    margins: FloatArray = (operator @ d_sigma.ravel()).reshape(horizon, -1)
    return margins


def comfort_margins(
    a_matrix: FloatArray, e_matrix: FloatArray, c_matrix: FloatArray, d_sigma: FloatArray
) -> FloatArray:
    """One-shot δ (N, ny) [K] for σ of shape (N, nd); see :func:`robust_margins`."""
    responses = impulse_responses(a_matrix, e_matrix, c_matrix, d_sigma.shape[0])
    return robust_margins(margin_operator(responses), d_sigma)


def dual_row_entries(
    responses: FloatArray,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], FloatArray]:
    """Entries of every robust row's disturbance map, for the explicit dual form.

    The output row ``(k, i)`` (step ``k = 1..N``, output ``i``) is affected by ``w_{j,l}``
    for every ``j < k`` and disturbance ``l`` with coefficient ``h = (G_{k-1-j})_{i,l}``.
    The dual form gives each such entry of each robust row its own pair λ₁, λ₂ ≥ 0 with
    ``λ₁ − λ₂ = h`` and adds ``σ_{j,l} (λ₁ + λ₂)`` to the row.

    Parameters
    ----------
    responses : (N, ny, nd) signed impulse responses from :func:`impulse_responses`

    Returns
    -------
    ``(step, output, dist_step, channel, h)``: five flat arrays of equal length
    ``ny·nd·N(N+1)/2``; ``step`` is 0-based (output at step ``step + 1``).
    """
    horizon, ny, nd = responses.shape
    step, dist_step = np.tril_indices(horizon)  # dist_step <= step
    count = step.size
    step_full = np.repeat(step, ny * nd)
    dist_full = np.repeat(dist_step, ny * nd)
    output = np.tile(np.repeat(np.arange(ny), nd), count)
    channel = np.tile(np.arange(nd), count * ny)
    values = responses[step_full - dist_full, output, channel]
    return step_full, output, dist_full, channel, values
