r"""The affine disturbance-feedback policy's parameterisation: what the controller measures,
which gains exist, and the index maps the feedback LP (:mod:`hvacflex.opt.feedback`) is
built from.

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from hvacflex.opt.options import FeedbackOptions
from hvacflex.opt.problem import FloatArray, IntArray, RMPCProblem
from hvacflex.opt.robust import impulse_responses, margin_operator

#: Relative pivot below which a (column-normalised) column of E counts as dependent.
RANK_TOLERANCE = 1e-9
#: Entries of K = E_S⁺ E below this (relative to 1) are round-off and dropped.
K_ROUND_OFF = 1e-12

__all__ = [
    "FeedbackMaps",
    "GainParameterisation",
    "channel_scale",
    "feedback_maps",
    "flat_ranges",
    "gain_parameterisation",
    "innovation_basis",
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
        app_source = flat_ranges(counts)
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


def flat_ranges(counts: IntArray) -> IntArray:
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
        uapp_source = flat_ranges(counts)
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
