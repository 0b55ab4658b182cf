r"""Affine disturbance-feedback (closed-loop) robust MPC: ``robust="feedback"`` (issue 9).

The open-loop RMPC of :mod:`hvacflex.opt.problem` plans one input sequence for every
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
nominal (w = 0) cost, exactly DESIGN §3.

LP layout
---------
Columns: x (N·n), z (N·n), v (N·m), r (N·m_r), ε (N·ny), β, δ (N·ny), μ (N·m), Θ (nθ),
U⁺, U⁻ (gain rows·nd), Ψ (keys·ny·r), Y⁺, Y⁻ (keys·ny·nd), Q⁺, Q⁻. A *key* is a pair (k, j) with
``k − j ≥ 2`` whose ``Y_{k,j}`` depends on the gains; for "time-invariant" ``Y_{k,j}`` depends
on k − j only, so there are N − 1 keys instead of ~N²/2 — this is what makes that structure
fast. The LP is assembled with scipy.sparse and solved cold by
:func:`hvacflex.opt.solve.solve_lp` each step (its size depends on σ's and φ's support).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, get_args

import numpy as np
from numpy.typing import NDArray
from scipy import linalg, sparse

from hvacflex.errors import ProblemError
from hvacflex.opt import robust as robust_mod
from hvacflex.opt.problem import KW_PER_MW, RMPCProblem, dynamics_rhs, fill_plan_columns
from hvacflex.opt.solve import (
    RMPCSolution,
    SolverBasis,
    SolveStatus,
    check_time_limit,
    failed_solution,
    plan_solution,
    solve_lp,
)

if TYPE_CHECKING:
    from collections.abc import Sequence

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

FeedbackStructure = Literal["full", "memory", "zone-local", "time-invariant"]
FEEDBACK_STRUCTURES: tuple[str, ...] = get_args(FeedbackStructure)

#: Relative pivot below which a (column-normalised) column of E counts as dependent.
RANK_TOLERANCE = 1e-9
#: Entries of K = E_S⁺ E below this (relative to 1) are round-off and dropped.
K_ROUND_OFF = 1e-12
#: HiGHS algorithm for the feedback LP ("simplex", "ipm" or "choose").
DEFAULT_LP_METHOD = "simplex"

_SOURCE = "RMPCProblem.feedback"

__all__ = [
    "FEEDBACK_STRUCTURES",
    "FeedbackOptions",
    "FeedbackSolver",
    "GainParameterisation",
    "check_feedback_problem",
    "innovation_basis",
    "solve_feedback",
]


@dataclass(frozen=True)
class FeedbackOptions:
    """Structure of the affine disturbance-feedback policy (``RMPCProblem.robust="feedback"``).

    Parameters
    ----------
    structure : "full", "memory", "zone-local" or "time-invariant" (module docstring)
    memory_steps : L ≥ 1, for "memory" and "time-invariant": innovations older than L steps
        get no gain (the gains' lag k − j is at most L)
    zero_gains : force all gains to zero (the open-loop RMPC; for verification)
    """

    structure: FeedbackStructure = "time-invariant"
    memory_steps: int = 4
    zero_gains: bool = False

    def __post_init__(self) -> None:
        if self.structure not in FEEDBACK_STRUCTURES:
            raise ProblemError(
                f"unknown feedback structure; expected one of {FEEDBACK_STRUCTURES}",
                source=_SOURCE,
                field="structure",
                value=self.structure,
            )
        if (
            isinstance(self.memory_steps, bool)
            or not isinstance(self.memory_steps, int)
            or self.memory_steps < 1
        ):
            raise ProblemError(
                "memory must be an integer ≥ 1 step",
                source=_SOURCE,
                field="memory_steps",
                value=self.memory_steps,
            )


def check_feedback_problem(problem: RMPCProblem) -> None:
    """Refuse a ``robust="feedback"`` problem its structure cannot serve (clear error)."""
    options = problem.feedback
    if options is not None and options.structure == "zone-local" and problem.ny != problem.m:
        raise ProblemError(
            f"zone-local feedback pairs input i with comfort output i, but ny = {problem.ny} "
            f"≠ m = {problem.m}",
            source=_SOURCE,
            field="structure",
            value=options.structure,
            hint="use structure 'time-invariant', 'memory' or 'full'",
        )


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


def _markov(
    a_matrix: FloatArray, right: FloatArray, c_matrix: FloatArray, horizon: int
) -> FloatArray:
    """(N, ny, ·) Markov parameters ``C A^l right`` for l = 0..N-1."""
    return robust_mod.impulse_responses(a_matrix, right, c_matrix, horizon)


# ---------------------------------------------------------------------- LP assembly


class _Triplets:
    """Accumulates (row, col, value) blocks of a sparse matrix."""

    def __init__(self) -> None:
        self.rows: list[IntArray] = []
        self.cols: list[IntArray] = []
        self.values: list[FloatArray] = []

    def add(self, rows: object, cols: object, values: object) -> None:
        r, c, v = np.broadcast_arrays(np.asarray(rows), np.asarray(cols), np.asarray(values))
        self.rows.append(r.ravel().astype(np.int64))
        self.cols.append(c.ravel().astype(np.int64))
        self.values.append(v.ravel().astype(np.float64))

    def extend(self, other: _Triplets) -> None:
        self.rows += other.rows
        self.cols += other.cols
        self.values += other.values

    def csr(self, shape: tuple[int, int]) -> sparse.csr_matrix:
        rows = np.concatenate(self.rows)
        cols = np.concatenate(self.cols)
        values = np.concatenate(self.values)
        keep = values != 0.0
        return sparse.csr_matrix((values[keep], (rows[keep], cols[keep])), shape=shape)


class _Counter:
    def __init__(self) -> None:
        self.size = 0

    def take(self, shape: Sequence[int]) -> IntArray:
        count = int(np.prod(shape)) if len(shape) else 1
        index = np.arange(self.size, self.size + count, dtype=np.int64).reshape(tuple(shape))
        self.size += count
        return index


@dataclass(frozen=True)
class FeedbackLPSize:
    """Size of one assembled feedback LP."""

    num_cols: int
    num_rows: int
    num_nonzeros: int
    num_gains: int


class FeedbackSolver:
    """Solver for ``robust="feedback"`` problems of one structure; mirrors :class:`RMPCSolver`.

    The structural part of the LP (gains, Ψ and Y rows, dynamics) is built once; each
    :meth:`solve` adds the σ-, p- and φ-dependent rows and solves the LP cold with HiGHS
    (:func:`hvacflex.opt.solve.solve_lp`). No simplex basis is kept: :meth:`get_basis`
    returns None.

    Parameters
    ----------
    problem : the first problem (``robust="feedback"``); fixes A, B, E, C, N, mask, options
    time_limit_s : wall-clock limit per solve [s]; None = no limit
    method : HiGHS algorithm, "simplex" (default), "ipm" or "choose"
    """

    def __init__(
        self,
        problem: RMPCProblem,
        *,
        time_limit_s: float | None = None,
        method: str = DEFAULT_LP_METHOD,
    ) -> None:
        if problem.robust != "feedback" or problem.feedback is None:
            raise ProblemError(
                "FeedbackSolver needs a problem with robust='feedback'",
                source="FeedbackSolver",
                field="robust",
                value=problem.robust,
                hint="use RMPCSolver for the open-loop modes",
            )
        check_time_limit(time_limit_s, source="FeedbackSolver")
        self._time_limit_s = time_limit_s
        self._method = method
        self._structure = problem.structure
        self._options: FeedbackOptions = problem.feedback
        self._gains = gain_parameterisation(problem, self._options)
        self._build_structure(problem)
        self.last_size: FeedbackLPSize | None = None

    # ------------------------------------------------------------------ structure
    def _build_structure(self, problem: RMPCProblem) -> None:
        horizon, n, m, nd, ny = problem.horizon, problem.n, problem.m, problem.nd, problem.ny
        gains = self._gains
        self._scale = channel_scale(problem.e_matrix)
        a, b, c = problem.a_matrix, problem.b_matrix, problem.c_matrix
        e = problem.e_matrix / self._scale  # unit columns: w̃ = ‖E_l‖ w_l
        ridx = np.flatnonzero(np.asarray(problem.reserve_mask, dtype=bool)).astype(np.int64)
        self._ridx = ridx
        self._g_resp = _markov(a, e, c, horizon)  # (N, ny, nd) G_l, per unit of w̃
        self._h_resp = _markov(a, b, c, horizon)  # (N, ny, m) H_l
        k_matrix = gains.k_matrix
        r = k_matrix.shape[0]
        n_gain = gains.num_gains
        # keys: pairs (k, j), k - j >= 2, whose Y depends on the gains
        key_of = np.full((horizon + 1, horizon), -1, dtype=np.int64)
        if n_gain:
            if gains.shift_invariant:
                key_k, key_j = np.arange(2, horizon + 1), np.zeros(horizon - 1, dtype=np.int64)
            else:
                grid_k, grid_j = np.meshgrid(
                    np.arange(horizon + 1), np.arange(horizon), indexing="ij"
                )
                sources = np.unique(gains.entry_source)
                ok = (grid_k - grid_j >= 2) & np.isin(grid_j, sources)
                key_k, key_j = grid_k[ok], grid_j[ok]
            key_of[key_k, key_j] = np.arange(key_k.size)
        else:
            key_k = key_j = np.zeros(0, dtype=np.int64)
        self._key_of, self._key_k, self._key_j = key_of, key_k, key_j
        n_key = key_k.size

        cols = _Counter()
        self._col_x = cols.take((horizon, n))
        self._col_z = cols.take((horizon, n)) if ridx.size else self._col_x
        self._col_v = cols.take((horizon, m))
        self._col_r = cols.take((horizon, ridx.size))
        self._col_eps = cols.take((horizon, ny))
        self._col_beta = int(cols.take((1,))[0])
        self._col_delta = cols.take((horizon, ny))
        self._col_mu = cols.take((horizon, m))
        self._col_theta = cols.take((n_gain,))
        # U_{t,j}[i, :] = Σ_q Θ_{t,j}[i, q] K[q, :] per group (t, j, i) of gain entries
        groups = np.stack([gains.entry_step, gains.entry_source, gains.entry_input])
        unique, self._entry_group = np.unique(groups, axis=1, return_inverse=True)
        self._entry_group = self._entry_group.ravel()
        u_step, u_source, self._u_input = unique[0], unique[1], unique[2]
        n_u = u_step.size
        if gains.shift_invariant:
            counts = horizon - u_step
            self._uapp_group = np.repeat(np.arange(n_u), counts)
            self._uapp_source = _ranges(counts)
            self._uapp_step = u_step[self._uapp_group] + self._uapp_source
        else:
            self._uapp_group = np.arange(n_u)
            self._uapp_step, self._uapp_source = u_step, u_source
        self._col_upos = cols.take((n_u, nd))
        self._col_uneg = cols.take((n_u, nd))
        self._col_psi = cols.take((n_key, ny, r))
        self._col_ypos = cols.take((n_key, ny, nd))
        self._col_yneg = cols.take((n_key, ny, nd))
        self._num_fixed_cols = cols.size

        rows = _Counter()
        self._row_dyn_x = rows.take((horizon, n))
        self._row_dyn_z = rows.take((horizon, n)) if ridx.size else np.zeros((0, n), np.int64)
        self._row_hi_x = rows.take((horizon, ny))
        self._row_lo_x = rows.take((horizon, ny))
        self._row_hi_z = rows.take((horizon, ny)) if ridx.size else np.zeros((0, ny), np.int64)
        self._row_lo_z = rows.take((horizon, ny)) if ridx.size else np.zeros((0, ny), np.int64)
        self._row_up = rows.take((horizon, m))
        self._row_down = rows.take((horizon, m))
        self._row_peak = rows.take((horizon,))
        self._row_delta = rows.take((horizon, ny))
        self._row_mu = rows.take((horizon, m))
        self._row_u = rows.take((n_u, nd))
        self._row_psi = rows.take((n_key, ny, r))
        self._row_y = rows.take((n_key, ny, nd))
        self._num_fixed_rows = rows.size

        fixed = _Triplets()
        eye = np.eye(n)
        trajectories = [(self._col_x, self._row_dyn_x, self._row_hi_x, self._row_lo_x)]
        if ridx.size:
            trajectories.append((self._col_z, self._row_dyn_z, self._row_hi_z, self._row_lo_z))
        for col_state, row_dyn, row_hi, row_lo in trajectories:
            fixed.add(row_dyn[:, :, None], col_state[:, None, :], eye[None])
            fixed.add(row_dyn[1:, :, None], col_state[:-1, None, :], -a[None])
            fixed.add(row_dyn[:, :, None], self._col_v[:, None, :], -b[None])
            for row, sign in ((row_hi, 1.0), (row_lo, -1.0)):
                fixed.add(row[:, :, None], col_state[:, None, :], c[None])
                fixed.add(row, self._col_delta, sign)
                fixed.add(row, self._col_eps, -sign)
        if ridx.size:
            fixed.add(self._row_dyn_z[:, :, None], self._col_r[:, None, :], b[:, ridx][None])
            fixed.add(self._row_down[:, ridx], self._col_r, -1.0)
        for row, sign in ((self._row_up, 1.0), (self._row_down, -1.0)):
            fixed.add(row, self._col_v, 1.0)
            fixed.add(row, self._col_mu, sign)
        fixed.add(self._row_peak, self._col_beta, -1.0)
        fixed.add(self._row_delta, self._col_delta, 1.0)
        fixed.add(self._row_mu, self._col_mu, 1.0)
        if n_gain:
            fixed.add(self._row_u, self._col_upos, 1.0)
            fixed.add(self._row_u, self._col_uneg, -1.0)
            fixed.add(
                self._row_u[self._entry_group],
                self._col_theta[:, None],
                -k_matrix[gains.entry_component],
            )
            # Ψ_{k,j}[i', q] = Σ_t H_{k-1-t}[i', i] Θ_{t,j}[i, q] for entries (t, j, i, q)
            counts = horizon - gains.entry_step  # k = t+1 .. N
            entry = np.repeat(np.arange(n_gain), counts)
            k_out = gains.entry_step[entry] + 1 + _ranges(counts)
            key = key_of[k_out, gains.entry_source[entry]]
            has_key = key >= 0
            entry, k_out, key = entry[has_key], k_out[has_key], key[has_key]
            lag = k_out - 1 - gains.entry_step[entry]
            h_values = self._h_resp[lag, :, gains.entry_input[entry]]  # (apps, ny)
            fixed.add(
                self._row_psi[
                    key[:, None], np.arange(ny)[None, :], gains.entry_component[entry][:, None]
                ],
                self._col_theta[entry][:, None],
                -h_values,
            )
            fixed.add(self._row_psi, self._col_psi, 1.0)
            # Y⁺ − Y⁻ − Ψ K = G_{k-1-j}
            fixed.add(self._row_y, self._col_ypos, 1.0)
            fixed.add(self._row_y, self._col_yneg, -1.0)
            q_index, l_index = np.nonzero(k_matrix)
            fixed.add(
                self._row_y[:, :, l_index],
                self._col_psi[:, :, q_index],
                -k_matrix[q_index, l_index][None, None, :],
            )
        self._fixed = fixed
        key_lag = key_k - key_j
        self._y_rhs = self._g_resp[key_lag - 1] if n_key else np.zeros((0, ny, nd))
        # pairs (k, j), k - j >= 2, for the δ rows and their key
        pairs_k, pairs_j = np.nonzero(np.tril(np.ones((horizon + 1, horizon), dtype=bool), -2))
        kk, jj = pairs_k.astype(np.int64), pairs_j.astype(np.int64)
        if n_key:
            pair_key = key_of[kk - jj, 0] if gains.shift_invariant else key_of[kk, jj]
            keep = pair_key >= 0
            self._delta_k, self._delta_j, self._delta_key = kk[keep], jj[keep], pair_key[keep]
        else:
            self._delta_k = self._delta_j = self._delta_key = np.zeros(0, dtype=np.int64)
        # δ's constant part: |G_{k-1-j}| σ_j summed over the pairs without a key (lag 1, and
        # every pair when there are no gains), as one (N·ny, N·nd) operator
        keyed = np.zeros((horizon, horizon), dtype=bool)  # [k-1, j]
        keyed[self._delta_k - 1, self._delta_j] = True
        operator = robust_mod.margin_operator(self._g_resp).reshape(horizon, ny, horizon, nd)
        operator = operator * ~keyed[:, None, :, None]
        self._const_operator = operator.reshape(horizon * ny, horizon * nd)

    # ------------------------------------------------------------------ per step
    def _assemble(
        self, problem: RMPCProblem
    ) -> tuple[FloatArray, sparse.csr_matrix, FloatArray, FloatArray, FloatArray, FloatArray]:
        horizon, nd = problem.horizon, problem.nd
        gains = self._gains
        ridx = self._ridx
        sigma = problem.d_sigma * self._scale  # σ̃ of w̃
        p = problem.power_coeff_kw_per_kg_s
        phi = problem.phi
        step = _Triplets()
        delta_const = robust_mod.robust_margins(self._const_operator, sigma)
        if self._delta_key.size:
            kk, jj, key = self._delta_k, self._delta_j, self._delta_key
            rows = self._row_delta[kk - 1][:, :, None]  # (pairs, ny, 1)
            values = -sigma[jj][:, None, :]  # (pairs, 1, nd)
            step.add(rows, self._col_ypos[key], values)
            step.add(rows, self._col_yneg[key], values)
        if gains.num_gains:
            # μ_{k,i} = Σ_j Σ_l |U_{k,j}[i,l]| σ̃_{j,l}
            group = self._uapp_group
            rows_mu = self._row_mu[self._uapp_step, self._u_input[group]][:, None]
            weight = -sigma[self._uapp_source]  # (apps, nd)
            step.add(rows_mu, self._col_upos[group], weight)
            step.add(rows_mu, self._col_uneg[group], weight)
        # peak rows, robust part: Q_{k,j,l} = Σ_i p_{k,i} U_{k,j}[i,l] for steps with φ_k > 0
        step.add(self._row_peak[:, None], self._col_v, phi[:, None] * p)
        cols = _Counter()
        cols.size = self._num_fixed_cols
        rows = _Counter()
        rows.size = self._num_fixed_rows
        if gains.num_gains and (phi > 0).any():
            use = phi[gains.app_step] > 0
            app = np.flatnonzero(use)
            pair_id = gains.app_step[app] * horizon + gains.app_source[app]
            pairs, pair_index = np.unique(pair_id, return_inverse=True)
            col_qpos = cols.take((pairs.size, nd))
            col_qneg = cols.take((pairs.size, nd))
            row_q = rows.take((pairs.size, nd))
            step.add(row_q, col_qpos, 1.0)
            step.add(row_q, col_qneg, -1.0)
            e_app = gains.app_entry[app]
            k_rows = gains.k_matrix[gains.entry_component[e_app]]  # (apps, nd)
            p_app = p[gains.app_step[app], gains.entry_input[e_app]]
            step.add(row_q[pair_index], self._col_theta[e_app][:, None], -p_app[:, None] * k_rows)
            pair_k, pair_j = pairs // horizon, pairs % horizon
            weight = phi[pair_k][:, None] * sigma[pair_j]  # (pairs, nd)
            step.add(self._row_peak[pair_k][:, None], col_qpos, weight)
            step.add(self._row_peak[pair_k][:, None], col_qneg, weight)
        num_cols, num_rows = cols.size, rows.size
        triplets = _Triplets()
        triplets.extend(self._fixed)
        triplets.extend(step)
        matrix = triplets.csr((num_rows, num_cols))

        inf = np.inf
        cost = np.zeros(num_cols)
        lower = np.full(num_cols, -inf)
        upper = np.full(num_cols, inf)
        fill_plan_columns(
            problem,
            cost,
            lower,
            upper,
            col_u=self._col_v,
            col_r=self._col_r,
            col_eps=self._col_eps,
            col_beta=self._col_beta,
            reserve_inputs=ridx,
        )
        cost[self._col_v] = problem.dt_h * problem.energy_price_sgd_per_mwh[:, None] * p / KW_PER_MW
        nonnegative = [self._col_delta, self._col_mu, self._col_upos, self._col_uneg]
        nonnegative += [self._col_ypos, self._col_yneg]
        for index in nonnegative:
            lower[index] = 0.0
        lower[self._num_fixed_cols :] = 0.0  # Q⁺, Q⁻

        row_lower = np.full(num_rows, -inf)
        row_upper = np.full(num_rows, inf)
        rhs = dynamics_rhs(problem)
        for row_dyn, row_hi, row_lo in (
            (self._row_dyn_x, self._row_hi_x, self._row_lo_x),
            (self._row_dyn_z, self._row_hi_z, self._row_lo_z),
        ):
            if row_dyn.size == 0:
                continue
            row_lower[row_dyn] = row_upper[row_dyn] = rhs
            row_upper[row_hi] = problem.y_max
            row_lower[row_lo] = problem.y_min
        row_upper[self._row_up] = problem.u_max
        row_lower[self._row_down] = problem.u_min
        row_upper[self._row_peak] = -phi * problem.power_offset_kw
        row_lower[self._row_delta] = row_upper[self._row_delta] = delta_const
        row_lower[self._row_mu] = row_upper[self._row_mu] = 0.0
        row_lower[self._row_u] = row_upper[self._row_u] = 0.0
        row_lower[self._row_psi] = row_upper[self._row_psi] = 0.0
        row_lower[self._row_y] = row_upper[self._row_y] = self._y_rhs
        row_lower[self._num_fixed_rows :] = row_upper[self._num_fixed_rows :] = 0.0
        return cost, matrix, row_lower, row_upper, lower, upper

    # ------------------------------------------------------------------ solve
    def solve(self, problem: RMPCProblem) -> RMPCSolution:
        """Solve ``problem`` (same structure and feedback options as the solver's).

        Raises
        ------
        ProblemError
            if ``problem`` has another structure or other feedback options.
        """
        start = time.perf_counter()
        differences = self._structure.differences(problem.structure)
        if problem.feedback != self._options:
            differences.append("feedback")
        if differences:
            raise ProblemError(
                f"the problem's structure differs from the solver's in {differences}",
                source="FeedbackSolver",
                field=differences[0],
                hint="build a new FeedbackSolver for a problem with another structure",
            )
        cost, matrix, row_lower, row_upper, col_lower, col_upper = self._assemble(problem)
        self.last_size = FeedbackLPSize(
            num_cols=matrix.shape[1],
            num_rows=matrix.shape[0],
            num_nonzeros=int(matrix.nnz),
            num_gains=self._gains.num_gains,
        )
        result = solve_lp(
            cost,
            matrix,
            row_lower,
            row_upper,
            col_lower,
            col_upper,
            time_limit_s=self._time_limit_s,
            method=self._method,
        )
        return self._solution(
            problem, result.status, result.x, result.message, start, result.time_s
        )

    def gains_tensor(self, theta: FloatArray, horizon: int, m: int, nd: int) -> FloatArray:
        """(N, N, m, nd) gains ``U_{k,j}`` (coefficient of w_j in u_k [kg/s per unit of w])
        from the gain values Θ."""
        gains = self._gains
        tensor = np.zeros((horizon, horizon, m, nd))
        if gains.num_gains:
            e_app = gains.app_entry
            np.add.at(
                tensor,
                (gains.app_step, gains.app_source, gains.entry_input[e_app]),
                theta[e_app][:, None] * gains.k_matrix[gains.entry_component[e_app]],
            )
        scaled: FloatArray = tensor * self._scale  # coefficient on w = coefficient on w̃ · ‖E_l‖
        return scaled

    def output_response(self, tensor: FloatArray) -> FloatArray:
        """(N, N, ny, nd) ``Y[k-1, j]``: coefficient of w_j in C x_k under the gains ``tensor``.

        ``tensor`` as from :meth:`gains_tensor` (per unit of w); so is the result.
        """
        horizon = tensor.shape[0]
        ny, nd = self._g_resp.shape[1:]
        lag = np.arange(horizon)[:, None] - np.arange(horizon)[None, :]  # (k-1) - j
        causal = (lag >= 0)[:, :, None, None]
        response = np.where(causal, self._g_resp[np.clip(lag, 0, None)], 0.0)
        h_full = np.where(causal, self._h_resp[np.clip(lag, 0, None)], 0.0)  # [k-1, t]
        # Σ_t H_{k-1-t} U_{t,j} with t ≤ k-1 (U_{t,j} = 0 for t ≤ j)
        response = response + np.einsum("ktab,tjbl->kjal", h_full, tensor / self._scale)
        result: FloatArray = response.reshape(horizon, horizon, ny, nd) * self._scale
        return result

    def _solution(
        self,
        problem: RMPCProblem,
        status: SolveStatus,
        values: FloatArray,
        message: str,
        start: float,
        highs_time: float,
    ) -> RMPCSolution:
        horizon, m, ny, nd = problem.horizon, problem.m, problem.ny, problem.nd
        size = self.last_size
        where = (
            f"feedback LP '{self._options.structure}' ({size.num_rows} rows, {size.num_cols} "
            f"columns, {size.num_nonzeros} nonzeros)"
            if size is not None
            else "feedback LP"
        )
        if not status.ok:
            return failed_solution(
                problem,
                status=status,
                message=f"{status.value}: {where}; {message}; no plan returned",
                delta=np.full((horizon, ny), np.nan),
                start=start,
                highs_time_s=highs_time,
                simplex_iterations=0,
                warm_start=False,
            )
        r = np.zeros((horizon, m))
        r[:, self._ridx] = np.maximum(values[self._col_r], 0.0)
        tensor = self.gains_tensor(values[self._col_theta], horizon, m, nd)
        # the margins the gains actually give: Σ_j |Y_{k,j}| σ_j
        delta = np.einsum("kjal,jl->ka", np.abs(self.output_response(tensor)), problem.d_sigma)
        return plan_solution(
            problem,
            status=status,
            message=f"optimal: {where}; {message}",
            u=values[self._col_v],
            r=r,
            slack=np.maximum(values[self._col_eps], 0.0),
            peak_charge_sgd=float(values[self._col_beta]),
            x_served=np.vstack([problem.x0, values[self._col_x]]),
            x_curtailed=np.vstack([problem.x0, values[self._col_z]]),
            delta=delta,
            start=start,
            highs_time_s=highs_time,
            simplex_iterations=0,
            warm_start=False,
            feedback_gains=tensor,
        )

    # ------------------------------------------------------------------ basis
    def get_basis(self) -> SolverBasis | None:
        """None: the feedback LP is solved cold every step (its size changes with σ, φ)."""
        return None

    def set_basis(self, basis: SolverBasis) -> None:
        """Refuse: a feedback solver keeps no basis (:meth:`get_basis` returns None)."""
        raise ProblemError(
            "a FeedbackSolver keeps no simplex basis",
            source="FeedbackSolver",
            field="basis",
            value=basis.fingerprint[:12],
            hint="the basis was saved by an open-loop RMPCSolver; resume with the same robust mode",
        )


def solve_feedback(problem: RMPCProblem, *, time_limit_s: float | None = None) -> RMPCSolution:
    """One-shot solve of a ``robust="feedback"`` problem (as :func:`hvacflex.opt.solve_rmpc`)."""
    return FeedbackSolver(problem, time_limit_s=time_limit_s).solve(problem)
