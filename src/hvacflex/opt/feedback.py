r"""Affine disturbance-feedback (closed-loop) robust MPC: ``robust="feedback"``.

The open-loop RMPC of :mod:`hvacflex.opt.lp` plans one input sequence for every
disturbance in the box, so its comfort margin ``δ_k`` grows along the horizon. Here the plan
is a *policy* that reacts to the forecast errors it will have measured:

.. math::

    u_k(w) = v_k + \sum_{j<k} U_{k,j}\, w_j, \qquad U_{k,j} = \Theta_{k,j} K,

with ``v_k`` the nominal flows, ``w_j`` the box error of step j (``|w_j| ≤ σ_j``) and
``Θ_{k,j}`` the gains on an *innovation* ``η_j = K w_j`` that the controller can compute from
the measured state (below). The reserve flows ``r_k`` stay fixed (not adaptive). This is the
disturbance-feedback form of Löfberg/Goulart: convex in (v, Θ), where state feedback is not.

What the controller measures, and which gains exist (the structures "full", "memory",
"time-invariant", "zone-local"), is :mod:`hvacflex.opt.feedback_maps`'s: it turns a problem
and its :class:`~hvacflex.opt.options.FeedbackOptions` into the gains' parameterisation and
the index maps this LP is built from.

Robust counterpart
------------------
Because r is fixed, the served x and the curtailed z have the *same* response to w:

.. math::

    C x_k(w) = C x_k(0) + \sum_{j<k} Y_{k,j} w_j,\quad
    Y_{k,j} = G_{k-1-j} + \Psi_{k,j} K,\quad
    \Psi_{k,j} = \sum_{t=j+1}^{k-1} H_{k-1-t}\,\Theta_{t,j},

with ``G_l = C A^l E`` and ``H_l = C A^l B``. Each row is robust when its nominal value plus
``Σ_j |coefficient on w_j|·σ_j`` meets the bound; the absolute values are auxiliary variables
(``Y = Y⁺ − Y⁻``, ``Y^± ≥ 0``; exact at the optimum, as in the dual form of eq. 12–13):

* comfort, both trajectories: ``C x_k ± δ_k`` within the band (± slack), with
  ``δ_k = Σ_j (Y⁺+Y⁻)_{k,j} σ_j`` (the lag-1 term ``|C E| σ_{k−1}`` is constant);
* input limits: ``v_k + μ_k ≤ u_max`` and ``v_k − r_k − μ_k ≥ u_min`` with
  ``μ_{k,i} = Σ_j Σ_l |U_{k,j}[i,l]| σ_{j,l}`` (``U = U⁺ − U⁻``, one pair per gain row);
* peak: ``P_k(w) = p0_k + p_kᵀ u_k(w)``, so ``φ_k (P_k + Σ_j (Q⁺+Q⁻)_{k,j} σ_j) ≤ β`` with
  ``Q_{k,j} = p_kᵀ U_{k,j}`` (only for steps with ``φ_k > 0``).

Two trajectories still cover every partial IL activation pattern (same argument as the open
loop: the activation terms have one sign and do not depend on w). The objective is the
nominal (w = 0) cost, exactly docs/explanation/model.md §3.

LP layout
---------
Columns: x (N·n), z (N·n), v (N·m), r (N·m_r), ε (N·ny), β, δ (N·ny), μ (N·m), Θ (nθ),
U⁺, U⁻ (gain rows·nd), Ψ (keys·ny·r), Y⁺, Y⁻ (keys·ny·nd), Q⁺, Q⁻. A *key* is a pair (k, j) with
``k − j ≥ 2`` whose ``Y_{k,j}`` depends on the gains; for "time-invariant" ``Y_{k,j}`` depends
on k − j only, so there are N − 1 keys instead of ~N²/2 — this is what makes that structure
fast. The LP is built over :class:`hvacflex.opt.lp.LPBuilder` (sharing the plan variables,
dynamics, comfort rows and plan costs with the open-loop LP) by the ``add_…`` functions below,
and solved by :class:`hvacflex.opt.feedback_solve.FeedbackSolver`, warm-started from the
previous step's basis rotated by one step; the solution (gains tensor, realised margins) is
read by :mod:`hvacflex.opt.feedback_result`. The structural coefficients (gains, Ψ and Y rows)
depend only on the problem's structure and are assembled once (:func:`build_feedback_lp` with
``constants``); σ and p enter as *varying* coefficients in fixed positions (zeros kept), so
the sparsity pattern is fixed for a given φ support (φ = 0 everywhere or not).
Blocks indexed by the step k are ``time_indexed`` (for the warm start's rotation); the gains,
Ψ and Y^± are indexed by the lag; Q^± rotate within each lag (:func:`pair_shift`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from hvacflex.opt.feedback_maps import (
    FeedbackMaps,
    GainParameterisation,
    feedback_maps,
    flat_ranges,
    gain_parameterisation,
    innovation_basis,
)
from hvacflex.opt.lp import (
    LinearProgram,
    LPBuilder,
    PlanColumns,
    add_comfort_knee,
    add_comfort_with_margins,
    add_committed_reserve,
    add_curtailed_dynamics,
    add_plan_variables,
    add_served_dynamics,
    set_plan_costs,
)
from hvacflex.opt.problem import FloatArray, IntArray, RMPCProblem
from hvacflex.opt.robust import robust_margins
from hvacflex.units import KWH_PER_MWH

__all__ = [
    "FeedbackColumns",
    "FeedbackLPSize",
    "FeedbackMaps",
    "GainParameterisation",
    "build_feedback_lp",
    "feedback_maps",
    "gain_parameterisation",
    "innovation_basis",
    "pair_shift",
]


def _no_columns() -> IntArray:  # default of the Q columns: none
    return np.zeros((0,), dtype=np.int64)


@dataclass(frozen=True, eq=False)
class FeedbackColumns:
    """Columns of the feedback LP beyond the plan (index arrays shaped like the quantity);
    Q^± (pairs, nd) only if φ > 0, one step later pair e starts from pair ``q_shift[e]``."""

    delta: IntArray  # (N, ny) comfort margins δ
    mu: IntArray  # (N, m) input margins μ
    theta: IntArray  # (nθ,) gains Θ
    upos: IntArray  # (n_u, nd) U⁺
    uneg: IntArray  # (n_u, nd) U⁻
    psi: IntArray  # (n_key, ny, r) Ψ
    ypos: IntArray  # (n_key, ny, nd) Y⁺
    yneg: IntArray  # (n_key, ny, nd) Y⁻
    qpos: IntArray = field(default_factory=_no_columns)
    qneg: IntArray = field(default_factory=_no_columns)
    q_shift: IntArray = field(default_factory=_no_columns)


def add_feedback_variables(lp: LPBuilder, p: RMPCProblem, maps: FeedbackMaps) -> FeedbackColumns:
    """Margins δ, μ ≥ 0, gains Θ (free), |U| = U⁺ + U⁻, Ψ (free) and |Y| = Y⁺ + Y⁻."""
    horizon, ny, nd = p.horizon, p.ny, p.nd
    n_key, r = maps.key_k.size, maps.gains.k_matrix.shape[0]
    delta = lp.add_columns((horizon, ny), lower=0.0, time_indexed=True)
    mu = lp.add_columns((horizon, p.m), lower=0.0, time_indexed=True)
    theta = lp.add_columns((maps.gains.num_gains,))
    upos = lp.add_columns((maps.num_groups, nd), lower=0.0)
    uneg = lp.add_columns((maps.num_groups, nd), lower=0.0)
    psi = lp.add_columns((n_key, ny, r))
    ypos = lp.add_columns((n_key, ny, nd), lower=0.0)
    yneg = lp.add_columns((n_key, ny, nd), lower=0.0)
    return FeedbackColumns(delta, mu, theta, upos, uneg, psi, ypos, yneg)


def add_robust_flow_bounds(
    lp: LPBuilder, p: RMPCProblem, v: PlanColumns, f: FeedbackColumns
) -> None:
    """v_k + μ_k ≤ u_max and v_k − r_k − μ_k ≥ u_min for every input (2·N·m rows)."""
    up = lp.add_rows((p.horizon, p.m), upper=p.u_max, time_indexed=True)
    down = lp.add_rows((p.horizon, p.m), lower=p.u_min, time_indexed=True)
    lp.add_coefficients(down[:, v.reserve_inputs], v.r, -1.0)
    for rows, sign in ((up, 1.0), (down, -1.0)):
        lp.add_coefficients(rows, v.u, 1.0)
        lp.add_coefficients(rows, f.mu, sign)


def add_robust_peak(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> IntArray:
    """φ_k p_k·v_k − β ≤ −φ_k p0_k (N rows; φ p varies); the gains' part is added by
    :func:`add_peak_response`. Returns the rows (N,)."""
    phi = p.phi
    rows = lp.add_rows((p.horizon,), upper=-phi * p.power_offset_kw, time_indexed=True)
    lp.add_varying_coefficients(rows[:, None], v.u, phi[:, None] * p.power_coeff_kw_per_kg_s)
    lp.add_coefficients(rows, np.array(v.beta), -1.0)
    return rows


def add_comfort_margin_definition(
    lp: LPBuilder, f: FeedbackColumns, maps: FeedbackMaps, sigma: FloatArray
) -> None:
    """δ_k − Σ_j (Y⁺ + Y⁻)_{k,j} σ̃_j = Σ_{unkeyed j} |G_{k-1-j}| σ̃_j (N·ny rows; σ varies)."""
    delta_const = robust_margins(maps.const_operator, sigma)
    rows = lp.add_rows(f.delta.shape, lower=delta_const, upper=delta_const, time_indexed=True)
    lp.add_coefficients(rows, f.delta, 1.0)
    if maps.delta_key.size:
        kk, jj, key = maps.delta_k, maps.delta_j, maps.delta_key
        pair_rows = rows[kk - 1][:, :, None]  # (pairs, ny, 1)
        values = -sigma[jj][:, None, :]  # (pairs, 1, nd)
        lp.add_varying_coefficients(pair_rows, f.ypos[key], values)
        lp.add_varying_coefficients(pair_rows, f.yneg[key], values)


def add_input_margin_definition(
    lp: LPBuilder, f: FeedbackColumns, maps: FeedbackMaps, sigma: FloatArray
) -> None:
    """μ_{k,i} − Σ_j Σ_l (U⁺ + U⁻)_{k,j}[i,l] σ̃_{j,l} = 0 (N·m rows; σ varies)."""
    rows = lp.add_rows(f.mu.shape, lower=0.0, upper=0.0, time_indexed=True)
    lp.add_coefficients(rows, f.mu, 1.0)
    if maps.gains.num_gains:
        group = maps.uapp_group
        rows_mu = rows[maps.uapp_step, maps.group_input[group]][:, None]
        weight = -sigma[maps.uapp_source]  # (apps, nd)
        lp.add_varying_coefficients(rows_mu, f.upos[group], weight)
        lp.add_varying_coefficients(rows_mu, f.uneg[group], weight)


def add_gain_rows(lp: LPBuilder, f: FeedbackColumns, maps: FeedbackMaps) -> None:
    """U⁺ − U⁻ − Σ_q Θ_{t,j}[i, q] K[q, :] = 0 per gain row (n_u·nd rows)."""
    rows = lp.add_rows(f.upos.shape, lower=0.0, upper=0.0)
    if maps.gains.num_gains:
        gains = maps.gains
        lp.add_coefficients(rows, f.upos, 1.0)
        lp.add_coefficients(rows, f.uneg, -1.0)
        lp.add_coefficients(
            rows[maps.entry_group], f.theta[:, None], -gains.k_matrix[gains.entry_component]
        )


def add_psi_rows(lp: LPBuilder, f: FeedbackColumns, maps: FeedbackMaps) -> None:
    """Ψ_{k,j} − Σ_t H_{k-1-t} Θ_{t,j} = 0 per key (n_key·ny·r rows)."""
    rows = lp.add_rows(f.psi.shape, lower=0.0, upper=0.0)
    if not (maps.gains.num_gains and lp.records_constants):
        return  # the coefficients are constant and expensive: skip them on a rebuild
    gains, ny = maps.gains, f.psi.shape[1]
    # Ψ_{k,j}[i', q] = Σ_t H_{k-1-t}[i', i] Θ_{t,j}[i, q] for entries (t, j, i, q)
    counts = maps.h_resp.shape[0] - gains.entry_step  # k = t+1 .. N
    entry = np.repeat(np.arange(gains.num_gains), counts)
    k_out = gains.entry_step[entry] + 1 + flat_ranges(counts)
    key = maps.key_of[k_out, gains.entry_source[entry]]
    has_key = key >= 0
    entry, k_out, key = entry[has_key], k_out[has_key], key[has_key]
    lag = k_out - 1 - gains.entry_step[entry]
    h_values = maps.h_resp[lag, :, gains.entry_input[entry]]  # (apps, ny)
    lp.add_coefficients(
        rows[key[:, None], np.arange(ny)[None, :], gains.entry_component[entry][:, None]],
        f.theta[entry][:, None],
        -h_values,
    )
    lp.add_coefficients(rows, f.psi, 1.0)


def add_output_response_rows(lp: LPBuilder, f: FeedbackColumns, maps: FeedbackMaps) -> None:
    """Y⁺ − Y⁻ − Ψ K = G_{k-1-j} per key (n_key·ny·nd rows)."""
    rows = lp.add_rows(f.ypos.shape, lower=maps.y_rhs, upper=maps.y_rhs)
    if not maps.gains.num_gains:
        return
    k_matrix = maps.gains.k_matrix
    lp.add_coefficients(rows, f.ypos, 1.0)
    lp.add_coefficients(rows, f.yneg, -1.0)
    q_index, l_index = np.nonzero(k_matrix)
    lp.add_coefficients(
        rows[:, :, l_index], f.psi[:, :, q_index], -k_matrix[q_index, l_index][None, None, :]
    )


def add_peak_response(
    lp: LPBuilder,
    p: RMPCProblem,
    f: FeedbackColumns,
    maps: FeedbackMaps,
    peak_rows: IntArray,
    sigma: FloatArray,
) -> FeedbackColumns:
    """The peak rows' robust part ``φ_k Σ_j (Q⁺ + Q⁻)_{k,j} σ̃_j`` with
    ``Q⁺ − Q⁻ = Q_{k,j} = p_kᵀ U_{k,j}`` for steps with φ_k > 0 (columns and rows after all
    others: their number follows φ's support). Returns ``f`` with the Q columns."""
    gains, horizon, phi = maps.gains, p.horizon, p.phi
    if not (gains.num_gains and (phi > 0).any()):
        return f
    app = np.flatnonzero(phi[gains.app_step] > 0)
    pair_id = gains.app_step[app] * horizon + gains.app_source[app]
    pairs, pair_index = np.unique(pair_id, return_inverse=True)
    pair_k, pair_j = pairs // horizon, pairs % horizon
    shift = pair_shift(pair_k, pair_j)
    col_qpos = lp.add_columns((pairs.size, p.nd), lower=0.0)
    col_qneg = lp.add_columns((pairs.size, p.nd), lower=0.0)
    row_shift = (shift[:, None] * p.nd + np.arange(p.nd)[None, :]).ravel()
    row_q = lp.add_rows((pairs.size, p.nd), lower=0.0, upper=0.0, time_permutation=row_shift)
    lp.add_varying_coefficients(row_q, col_qpos, 1.0)
    lp.add_varying_coefficients(row_q, col_qneg, -1.0)
    e_app = gains.app_entry[app]
    k_rows = gains.k_matrix[gains.entry_component[e_app]]  # (apps, nd)
    p_app = p.power_coeff_kw_per_kg_s[gains.app_step[app], gains.entry_input[e_app]]
    lp.add_varying_coefficients(
        row_q[pair_index], f.theta[e_app][:, None], -p_app[:, None] * k_rows
    )
    weight = phi[pair_k][:, None] * sigma[pair_j]  # (pairs, nd)
    lp.add_varying_coefficients(peak_rows[pair_k][:, None], col_qpos, weight)
    lp.add_varying_coefficients(peak_rows[pair_k][:, None], col_qneg, weight)
    return replace(f, qpos=col_qpos, qneg=col_qneg, q_shift=shift)


def pair_shift(pair_k: IntArray, pair_j: IntArray) -> IntArray:
    """(pairs,) time shift of the pairs (k, j): one step later pair e starts from the pair
    (k + 1, j + 1) of the same lag k − j, the last of each lag from the first (a rotation
    within each lag, like the time-indexed blocks' roll)."""
    lag = pair_k - pair_j
    order = np.lexsort((pair_j, lag))
    sorted_lag, position = lag[order], np.arange(order.size)
    last = np.searchsorted(sorted_lag, sorted_lag, side="right") - 1
    following = np.where(position < last, position + 1, np.searchsorted(sorted_lag, sorted_lag))
    shift = np.empty_like(order)
    shift[order] = order[following]
    return shift.astype(np.int64)


def set_feedback_objective(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """Nominal energy cost Δt·c_k·p_k·v_k on v plus the shared plan costs [SGD]."""
    set_plan_costs(lp, p, v)
    lp.set_cost(
        v.u, p.dt_h * p.energy_price_sgd_per_mwh[:, None] * p.power_coeff_kw_per_kg_s / KWH_PER_MWH
    )


def build_feedback_lp(
    p: RMPCProblem, maps: FeedbackMaps, *, constants: bool = True
) -> tuple[LinearProgram, PlanColumns, FeedbackColumns]:
    """The feedback LP of ``p`` (module docstring); ``constants=False`` skips the structural
    coefficients (take them from a first build of the same structure)."""
    sigma = p.d_sigma * maps.scale  # σ̃ of w̃
    lp = LPBuilder(constants=constants)
    v = add_plan_variables(lp, p, power_column=False)
    add_committed_reserve(lp, p, v)
    f = add_feedback_variables(lp, p, maps)
    add_served_dynamics(lp, p, v)
    add_curtailed_dynamics(lp, p, v)
    add_comfort_with_margins(lp, p, v, np.zeros((p.horizon, p.ny)), margin_cols=f.delta)
    add_comfort_knee(lp, p, v)
    add_robust_flow_bounds(lp, p, v, f)
    peak_rows = add_robust_peak(lp, p, v)
    add_comfort_margin_definition(lp, f, maps, sigma)
    add_input_margin_definition(lp, f, maps, sigma)
    add_gain_rows(lp, f, maps)
    add_psi_rows(lp, f, maps)
    add_output_response_rows(lp, f, maps)
    f = add_peak_response(lp, p, f, maps, peak_rows, sigma)
    set_feedback_objective(lp, p, v)
    return lp.finish(), v, f


@dataclass(frozen=True)
class FeedbackLPSize:
    """Size of one assembled feedback LP."""

    num_cols: int
    num_rows: int
    num_nonzeros: int
    num_gains: int
