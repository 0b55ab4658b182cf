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

What the controller measures
----------------------------
The full state is measured, so at step j + 1 the one-step innovation
``e_j = x_{j+1} − A x_j − B u_j − E d̂_j − g = E w_j`` is known. The gains act on
``η_j = R e_j`` (chosen so that ``η_j = K w_j``):

* ``structure`` "full", "memory", "time-invariant": if E has full column rank, ``η_j = w_j``
  (``R = E⁺``, ``K = I``). Otherwise ``w_j`` is *not* recoverable; the columns of E are then
  reduced to a maximal independent subset ``S`` (pivoted QR of the column-normalised E, rank
  tolerance :data:`RANK_TOLERANCE`) and ``η_j = w_{j,S} + T w_{j,¬S}`` with
  ``E_{¬S} = E_S T`` (``R = E_S⁺``, ``K = [I T]``): exactly what ``e_j`` reveals. (The default
  office5 E has rank 9 of 10: its four façade solar channels and the perimeter gains are
  linearly dependent.)
* ``structure`` "zone-local": input i reacts only to its own zone's temperature innovation
  ``η_{j,i} = (C e_j)_i`` (``R = C``, ``K = C E``, Θ diagonal); needs ``ny = m`` with output
  i the zone of input i.

Structures (``L`` is ``memory_steps``): "full" (every ``Θ_{k,j}``, j < k); "memory" (only
``k − j ≤ L``); "time-invariant" (``Θ_{k,j} = Θ_{k−j}`` for lags ``k − j ≤ L``, zero beyond;
``L ≥ N − 1`` is the unrestricted Toeplitz policy); "zone-local" (diagonal gains on the zone
innovations, and — to be tractable — time-invariant with lags ≤ L as well: time-varying
zone-local gains still leave ~N²/2 distinct response blocks, and the LP took minutes at
N = 48 on office5).
``zero_gains=True`` forces Θ = 0 (the open-loop RMPC, for verification).

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
nominal (w = 0) cost, exactly docs/model.md §3.

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
from scipy import linalg

from hvacflex.opt.lp import (
    LinearProgram,
    LPBuilder,
    PlanColumns,
    add_comfort_with_margins,
    add_committed_reserve,
    add_curtailed_dynamics,
    add_plan_variables,
    add_served_dynamics,
    set_plan_costs,
)
from hvacflex.opt.options import FeedbackOptions
from hvacflex.opt.problem import FloatArray, IntArray, RMPCProblem
from hvacflex.opt.robust import impulse_responses, margin_operator, robust_margins
from hvacflex.units import KWH_PER_MWH

#: Relative pivot below which a (column-normalised) column of E counts as dependent.
RANK_TOLERANCE = 1e-9
#: Entries of K = E_S⁺ E below this (relative to 1) are round-off and dropped.
K_ROUND_OFF = 1e-12

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


def innovation_basis(e_matrix: FloatArray) -> tuple[FloatArray, FloatArray, IntArray]:
    """Innovation η = R e = K w that the measured one-step innovation e = E w reveals.

    Parameters
    ----------
    e_matrix : (n, nd) disturbance matrix E

    Returns
    -------
    ``(R, K, S)``: R (r, n) recovers η from e; K (r, nd) with ``E = E_S K`` and ``K[:, S] = I``;
    S (r,) the independent channels (all of them when E has full column rank, then K = I).
    """
    norms = np.linalg.norm(e_matrix, axis=0)
    live = np.flatnonzero(norms > 0)
    if live.size == 0:
        return np.zeros((0, e_matrix.shape[0])), np.zeros((0, e_matrix.shape[1])), live
    normalised = e_matrix[:, live] / norms[live]
    _, upper, pivots = linalg.qr(normalised, mode="economic", pivoting=True)
    diagonal = np.abs(np.diag(upper))
    rank = int(np.sum(diagonal > RANK_TOLERANCE * diagonal[0]))
    selected = np.sort(live[pivots[:rank]]).astype(np.int64)
    e_selected = e_matrix[:, selected]
    k_matrix = np.asarray(np.linalg.lstsq(e_selected, e_matrix, rcond=None)[0], dtype=np.float64)
    k_matrix[np.abs(k_matrix) < K_ROUND_OFF] = 0.0
    k_matrix[:, selected] = np.eye(rank)
    recover = np.asarray(np.linalg.pinv(e_selected), dtype=np.float64)
    return recover, k_matrix, selected


@dataclass(frozen=True, eq=False)
class GainParameterisation:
    """Which gains exist and where they act (module docstring).

    Gain entry e is ``Θ_{t,j}[i, q]`` with ``t = entry_step[e]``, ``j = entry_source[e]``
    (for "time-invariant" t is the lag and j = 0). Application a says that ``U_{k,j}`` uses
    entry ``app_entry[a]`` at ``k = app_step[a]``, ``j = app_source[a]``.
    """

    structure: str
    recover: FloatArray  # (r, n): η_j = R e_j
    k_matrix: FloatArray  # (r, nd): η_j = K w_j
    shift_invariant: bool
    entry_step: IntArray
    entry_source: IntArray
    entry_input: IntArray
    entry_component: IntArray
    app_entry: IntArray
    app_step: IntArray
    app_source: IntArray

    @property
    def num_gains(self) -> int:
        """Number of gain variables nθ."""
        return int(self.entry_step.size)


def gain_parameterisation(problem: RMPCProblem, options: FeedbackOptions) -> GainParameterisation:
    """The gain entries and their applications for ``problem``'s sizes and ``options``."""
    horizon, m = problem.horizon, problem.m
    e_scaled = problem.e_matrix / channel_scale(problem.e_matrix)
    if options.structure == "zone-local":
        recover = problem.c_matrix.copy()
        k_matrix = problem.c_matrix @ e_scaled
    else:
        recover, k_matrix, _ = innovation_basis(e_scaled)
    r = k_matrix.shape[0]
    shift_invariant = options.structure in ("time-invariant", "zone-local")
    if shift_invariant:
        steps = np.arange(1, min(horizon, options.memory_steps + 1))
        sources = np.zeros(steps.size, dtype=np.int64)
    else:
        steps, sources = np.tril_indices(horizon, -1)  # t > j
        if options.structure == "memory":
            keep = steps - sources <= options.memory_steps
            steps, sources = steps[keep], sources[keep]
    if options.zero_gains or r == 0:
        steps, sources = steps[:0], sources[:0]
    if options.structure == "zone-local":
        inputs = np.tile(np.arange(m), steps.size)
        components = inputs.copy()
        per_pair = m
    else:
        inputs = np.tile(np.repeat(np.arange(m), r), steps.size)
        components = np.tile(np.arange(r), steps.size * m)
        per_pair = m * r
    entry_step = np.repeat(steps, per_pair).astype(np.int64)
    entry_source = np.repeat(sources, per_pair).astype(np.int64)
    entry_index = np.arange(entry_step.size, dtype=np.int64)
    if shift_invariant:
        # entry with lag t acts on U_{j+t, j} for j = 0 .. N-1-t
        counts = horizon - entry_step
        app_entry = np.repeat(entry_index, counts)
        app_source = _ranges(counts)
        app_step = entry_step[app_entry] + app_source
    else:
        app_entry, app_step, app_source = entry_index, entry_step, entry_source
    return GainParameterisation(
        structure=options.structure,
        recover=recover,
        k_matrix=k_matrix,
        shift_invariant=shift_invariant,
        entry_step=entry_step,
        entry_source=entry_source,
        entry_input=inputs.astype(np.int64),
        entry_component=components.astype(np.int64),
        app_entry=app_entry,
        app_step=app_step,
        app_source=app_source,
    )


def channel_scale(e_matrix: FloatArray) -> FloatArray:
    """(nd,) column norms of E (1 for zero columns): the LP works with ``w̃ = ‖E_l‖ w_l``.

    Disturbance units differ by orders of magnitude (K, W/m², W); in these units every
    channel moves the state by O(1) K per unit, which keeps the LP well scaled.
    """
    norms = np.linalg.norm(e_matrix, axis=0)
    scale: FloatArray = np.where(norms > 0, norms, 1.0)
    return scale


def _ranges(counts: IntArray) -> IntArray:
    """Concatenation of ``arange(c)`` for every c in ``counts``."""
    total = int(counts.sum())
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    return np.arange(total, dtype=np.int64) - starts


# ---------------------------------------------------------------------- structure maps


@dataclass(frozen=True, eq=False)
class FeedbackMaps:
    """Index maps and responses that depend only on the problem's structure and options.

    A *key* is a pair (k, j), k − j ≥ 2, whose output response ``Y_{k,j}`` depends on the
    gains (module docstring); a *group* is a gain row ``U_{t,j}[i, :]`` (entries sharing
    (t, j, i)), applied at ``(uapp_step, uapp_source)``.
    """

    gains: GainParameterisation
    scale: FloatArray  # (nd,) channel norms: w̃ = ‖E_l‖ w_l
    g_resp: FloatArray  # (N, ny, nd) G_l = C A^l E, per unit of w̃
    h_resp: FloatArray  # (N, ny, m) H_l = C A^l B
    key_of: IntArray  # (N+1, N) key of (k, j) or −1
    key_k: IntArray  # (n_key,)
    key_j: IntArray
    entry_group: IntArray  # (nθ,) group of each gain entry
    group_input: IntArray  # (n_u,) input i of each group
    uapp_group: IntArray  # applications of the groups
    uapp_step: IntArray
    uapp_source: IntArray
    y_rhs: FloatArray  # (n_key, ny, nd) G_{k-1-j}
    delta_k: IntArray  # pairs (k, j) with a key, for the δ rows
    delta_j: IntArray
    delta_key: IntArray
    const_operator: FloatArray  # (N·ny, N·nd): δ's part from pairs without a key

    @property
    def num_groups(self) -> int:
        """Number of gain rows n_u."""
        return int(self.group_input.size)


def _keys(gains: GainParameterisation, horizon: int) -> tuple[IntArray, IntArray, IntArray]:
    """(key_of (N+1, N), key_k, key_j): the pairs (k, j), k − j ≥ 2, whose Y has gains."""
    key_of = np.full((horizon + 1, horizon), -1, dtype=np.int64)
    if not gains.num_gains:
        empty = np.zeros(0, dtype=np.int64)
        return key_of, empty, empty
    if gains.shift_invariant:
        key_k, key_j = np.arange(2, horizon + 1), np.zeros(horizon - 1, dtype=np.int64)
    else:
        grid_k, grid_j = np.meshgrid(np.arange(horizon + 1), np.arange(horizon), indexing="ij")
        ok = (grid_k - grid_j >= 2) & np.isin(grid_j, np.unique(gains.entry_source))
        key_k, key_j = grid_k[ok], grid_j[ok]
    key_of[key_k, key_j] = np.arange(key_k.size)
    return key_of, key_k, key_j


def _groups(
    gains: GainParameterisation, horizon: int
) -> tuple[IntArray, IntArray, IntArray, IntArray, IntArray]:
    """(entry_group, group_input, uapp_group, uapp_step, uapp_source): the gain rows
    ``U_{t,j}[i, :] = Σ_q Θ_{t,j}[i, q] K[q, :]`` and where each applies."""
    groups = np.stack([gains.entry_step, gains.entry_source, gains.entry_input])
    unique, entry_group = np.unique(groups, axis=1, return_inverse=True)
    u_step, u_source, u_input = unique[0], unique[1], unique[2]
    if gains.shift_invariant:
        counts = horizon - u_step
        uapp_group = np.repeat(np.arange(u_step.size), counts)
        uapp_source = _ranges(counts)
        uapp_step = u_step[uapp_group] + uapp_source
    else:
        uapp_group = np.arange(u_step.size)
        uapp_step, uapp_source = u_step, u_source
    return entry_group.ravel(), u_input, uapp_group, uapp_step, uapp_source


def feedback_maps(problem: RMPCProblem, options: FeedbackOptions) -> FeedbackMaps:
    """The structural maps of ``problem``'s feedback LP (computed once per structure)."""
    horizon, ny, nd = problem.horizon, problem.ny, problem.nd
    gains = gain_parameterisation(problem, options)
    scale = channel_scale(problem.e_matrix)
    a, c = problem.a_matrix, problem.c_matrix
    g_resp = impulse_responses(a, problem.e_matrix / scale, c, horizon)
    h_resp = impulse_responses(a, problem.b_matrix, c, horizon)
    key_of, key_k, key_j = _keys(gains, horizon)
    y_rhs = g_resp[key_k - key_j - 1] if key_k.size else np.zeros((0, ny, nd))
    # pairs (k, j), k - j >= 2, for the δ rows and their key
    pairs_k, pairs_j = np.nonzero(np.tril(np.ones((horizon + 1, horizon), dtype=bool), -2))
    kk, jj = pairs_k.astype(np.int64), pairs_j.astype(np.int64)
    if key_k.size:
        pair_key = key_of[kk - jj, 0] if gains.shift_invariant else key_of[kk, jj]
        keep = pair_key >= 0
        delta_k, delta_j, delta_key = kk[keep], jj[keep], pair_key[keep]
    else:
        delta_k = delta_j = delta_key = np.zeros(0, dtype=np.int64)
    # δ's constant part: |G_{k-1-j}| σ_j summed over the pairs without a key (lag 1, and
    # every pair when there are no gains), as one (N·ny, N·nd) operator
    keyed = np.zeros((horizon, horizon), dtype=bool)  # [k-1, j]
    keyed[delta_k - 1, delta_j] = True
    operator = margin_operator(g_resp).reshape(horizon, ny, horizon, nd)
    operator = operator * ~keyed[:, None, :, None]
    entry_group, group_input, uapp_group, uapp_step, uapp_source = _groups(gains, horizon)
    return FeedbackMaps(
        gains=gains,
        scale=scale,
        g_resp=g_resp,
        h_resp=h_resp,
        key_of=key_of,
        key_k=key_k,
        key_j=key_j,
        entry_group=entry_group,
        group_input=group_input,
        uapp_group=uapp_group,
        uapp_step=uapp_step,
        uapp_source=uapp_source,
        y_rhs=y_rhs,
        delta_k=delta_k,
        delta_j=delta_j,
        delta_key=delta_key,
        const_operator=operator.reshape(horizon * ny, horizon * nd),
    )


# ---------------------------------------------------------------------- LP families


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
    k_out = gains.entry_step[entry] + 1 + _ranges(counts)
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
