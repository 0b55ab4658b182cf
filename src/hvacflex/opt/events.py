r"""Interruptible-load (IL) events: the exact robust counterpart as LP rows
(docs/explanation/il_events.md).

Model
-----
An **event** ``(s, L)`` curtails the reserve-carrying inputs ``s … s+L−1`` (``1 ≤ L ≤ D``):
they run at ``u_j − r_j`` instead of ``u_j``; every other input is served. The event set
holds the served plan and every single event. With the reserve response
``H_l = −C A^l B_r`` (ny × m_r, ``l ≥ 0``), the nominal output at ``t = 1 … N`` (state after
input ``t−1``) under event ``(s, L)`` is

.. math::

    y_t^{(s,L)} = C x_t + \sum_{j=s}^{\min(s+L-1,\,t-1)} H_{t-1-j}\, r_j ,

and the disturbance box moves every pattern by the same amount (open loop), so the robust
margin δ_t of :mod:`hvacflex.opt.robust` applies unchanged. For cooling reserve (``B_r ≤ 0``,
``A ≥ 0``, ``C ≥ 0``, ``r ≥ 0``) every ``H_l ≥ 0``: curtailment only warms. Hence

* the **lower** comfort bound is worst on the served plan (no event rows);
* the **upper** bound, at output ``t`` and start ``s < t``, is worst for the longest event that
  the bound at ``t`` still has to hold for. Event ``(s, L)`` lets output ``t`` use the
  allowance α while ``t ≤ s + L + R`` (during the event and R recovery steps):

  - *allowance row* (needed if ``t − s ≤ D + R``; some L ≤ D reaches t):
    worst ``L = D``: ``C x_t + Σ_{j=s}^{min(s+D−1, t−1)} H_{t−1−j} r_j − ε_t ≤ y^hi_t − δ_t + α``;
  - *strict row* (needed if ``t − s ≥ R + 2``; some L ≥ 1 ended more than R steps before t):
    worst ``L = min(D, t − s − R − 1)``:
    ``C x_t + Σ_{j=s}^{s+L−1} H_{t−1−j} r_j − ε_t ≤ y^hi_t − δ_t``.

  A row with a smaller L is implied by the one with the largest L (the extra terms are ≥ 0),
  so these at most two rows per (t, s, zone) are the exact robust counterpart.

Outputs ``t ≤ c`` (``ILEventModel.carry_steps``) belong to the recovery from an event that
ended before the horizon (the zone is still warm from a real curtailment): the served plan and
the strict rows get a decaying allowance ``α · min(1, (c − t + 1)/(R + 1))``
(:func:`carry_allowance`); outside such a recovery (c = 0) the served plan never gets α, only
the event rows do. The
event rows share the slack ``ε_t`` of the served rows (as the whole-horizon model's curtailed
rows do). With ``D = N``, ``α = 0`` and ``R = 0`` the row at ``(t, s = 0)`` is the
whole-horizon curtailed row ``C z_t ≤ y^hi_t − δ_t + ε_t`` and implies every other one, so
the optimum equals the whole-horizon model's.

Row count: allowance rows ``Σ_t min(D+R, t)`` and strict rows ``Σ_t max(0, t − R − 1)`` per
zone, i.e. at most ``N(D+R) + N(N−R−1)/2`` per zone, ≈ N²·ny/2. Rows of different starts s
sum different windows of ``r``, so none is dominated independently of the data (rows are not
dropped: the LP structure depends only on N, ny, D and R; α, c and δ enter row bounds).

Warm start: the rows are indexed by (output t, lag t − s, kind, zone). One step later the
row (t, lag) of the new problem is the row (t + 1, lag) of the old one; the old rows with
s = 0 (no successor) take the places of the new rows at t = N, lag by lag and kind by kind —
a permutation, so the rotated basis keeps its number of basic variables
(:func:`event_rotation`).

Everything here is plain numpy/scipy (no solver, no other hvacflex.opt module):
:class:`hvacflex.opt.blocks.ILEventModel` holds D, α, R and c,
:func:`hvacflex.opt.lp.add_il_event_comfort` adds the rows, :mod:`hvacflex.opt.solution`
reports the worst event output.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


__all__ = [
    "EventRows",
    "carry_allowance",
    "event_matrix",
    "event_rotation",
    "event_row_bounds",
    "event_rows",
    "event_trajectory",
    "reserve_responses",
    "violated_rows",
    "worst_event_output",
]


@dataclass(frozen=True, eq=False)
class EventRows:
    """The event rows of one structure, one entry per row (all arrays (num_rows,)).

    ``step`` is the output index k = t − 1 (0-based, the row of ``col_x``/``col_eps``),
    ``output`` the comfort output (zone), ``start`` the event's first input s, ``length`` the
    number of curtailed inputs summed (the worst L, truncated at t − 1), ``allowance`` True
    for allowance rows (bound widened by α), False for strict rows.
    """

    step: IntArray
    output: IntArray
    start: IntArray
    length: IntArray
    allowance: BoolArray

    @property
    def num_rows(self) -> int:
        """Number of event rows."""
        return int(self.step.size)

    @functools.cached_property
    def flat_index(self) -> IntArray:
        """(num_rows,) each row's (step, output) as a flat index into a C-ordered (N, ny)
        array (computed once; read-only)."""
        ny = int(self.output.max(initial=-1)) + 1
        flat: IntArray = self.step * ny + self.output
        flat.setflags(write=False)
        return flat


@functools.lru_cache(maxsize=16)
def event_rows(horizon: int, ny: int, max_steps: int | None, recovery_steps: int) -> EventRows:
    """The event rows for horizon N, ny outputs, D = ``max_steps`` and R = ``recovery_steps``.

    Ordered by output t, then kind (allowance, strict), then lag t − s, then zone. Empty for
    ``max_steps=None`` (the whole-horizon model has no event rows). Cached (the arrays are
    read-only).
    """
    steps: list[int] = []
    starts: list[int] = []
    lengths: list[int] = []
    kinds: list[bool] = []
    if max_steps is not None:
        d, r = max_steps, recovery_steps
        for t in range(1, horizon + 1):
            for lag in range(1, min(d + r, t) + 1):  # allowance rows
                s = t - lag
                steps.append(t - 1)
                starts.append(s)
                lengths.append(min(d, t - s))
                kinds.append(True)
            for lag in range(r + 2, t + 1):  # strict rows
                s = t - lag
                steps.append(t - 1)
                starts.append(s)
                lengths.append(min(d, t - s - r - 1))
                kinds.append(False)
    count = len(steps)
    arrays = (
        np.repeat(np.array(steps, dtype=np.int64), ny),
        np.tile(np.arange(ny, dtype=np.int64), count),
        np.repeat(np.array(starts, dtype=np.int64), ny),
        np.repeat(np.array(lengths, dtype=np.int64), ny),
        np.repeat(np.array(kinds, dtype=bool), ny),
    )
    for array in arrays:
        array.setflags(write=False)
    step, output, start, length, allowance = arrays
    return EventRows(step=step, output=output, start=start, length=length, allowance=allowance)


def reserve_responses(
    a_matrix: FloatArray, b_reserve: FloatArray, c_matrix: FloatArray, horizon: int
) -> FloatArray:
    """(N, ny, m_r) warming responses ``H_l = −C A^l B_r`` [K per kg/s] (≥ 0 for cooling).

    ``H_l`` is the effect of one kg/s curtailed at input j on the output at step j + 1 + l.
    """
    ny, m_r = c_matrix.shape[0], b_reserve.shape[1]
    responses = np.empty((horizon, ny, m_r))
    propagated = -b_reserve.copy()
    for lag in range(horizon):
        responses[lag] = c_matrix @ propagated
        propagated = a_matrix @ propagated
    return responses


def event_matrix(
    rows: EventRows,
    responses: FloatArray,
    c_matrix: FloatArray,
    *,
    col_x: IntArray,
    col_r: IntArray,
    col_eps: IntArray,
    num_cols: int,
) -> sparse.csr_matrix:
    """(num_event_rows, num_cols) CSR block of the event rows over the LP's columns.

    Row e: ``C_i x_t + Σ_j H_{t−1−j,i} r_j − ε_{t,i}``; ``col_x`` (N, n), ``col_r`` (N, m_r),
    ``col_eps`` (N, ny) are the LP's column indices. The coefficients depend only on the
    structure (A, B, C, N, D, R).
    """
    parts_r: list[IntArray] = []
    parts_c: list[IntArray] = []
    parts_v: list[FloatArray] = []
    index = np.arange(rows.num_rows, dtype=np.int64)
    c_rows = c_matrix[rows.output]  # (E, n)
    parts_r.append(np.repeat(index, c_matrix.shape[1]))
    parts_c.append(col_x[rows.step].ravel())
    parts_v.append(c_rows.ravel())
    parts_r.append(index)
    parts_c.append(col_eps[rows.step, rows.output])
    parts_v.append(np.full(rows.num_rows, -1.0))
    m_r = col_r.shape[1]
    if m_r:
        for offset in range(int(rows.length.max(initial=0))):
            take = rows.length > offset
            j = rows.start[take] + offset
            lag = rows.step[take] - j
            parts_r.append(np.repeat(index[take], m_r))
            parts_c.append(col_r[j].ravel())
            parts_v.append(responses[lag, rows.output[take]].ravel())
    r_all, c_all, v_all = (np.concatenate(p) for p in (parts_r, parts_c, parts_v))
    keep = v_all != 0.0
    matrix = sparse.csr_matrix(
        (v_all[keep], (r_all[keep], c_all[keep])), shape=(rows.num_rows, num_cols)
    )
    matrix.sum_duplicates()
    matrix.sort_indices()
    return matrix


@functools.lru_cache(maxsize=64)
def carry_allowance(
    horizon: int, ny: int, allowance_kelvin: float, carry_steps: int, recovery_steps: int = 0
) -> FloatArray:
    """(N, ny) widening of the upper bound during the recovery from an event that ended
    before the horizon [K]: a decaying allowance ``α · min(1, (c − t + 1) / (R + 1))`` on
    outputs t = 1 … c, 0 elsewhere. Cached (a read-only array: a controller asks for the same
    few every step).

    With c = R (the plan made as the curtailment ends) the widening falls from α·R/(R+1) at
    t = 1 to α/(R+1) at t = R; one step later (c = R − 1) the same instants get the same
    widening, so a recovery is bounded consistently from plan to plan and reaches the strict
    band one period after it ends.
    """
    widening = np.zeros((horizon, ny))
    steps = np.arange(1, min(carry_steps, horizon) + 1)
    share = np.minimum(1.0, (carry_steps - steps + 1) / (recovery_steps + 1))
    widening[: steps.size] = allowance_kelvin * share[:, None]
    widening.setflags(write=False)
    return widening


def event_row_bounds(
    rows: EventRows,
    y_max: FloatArray,
    delta: FloatArray,
    allowance_kelvin: float,
    carry_steps: int,
    recovery_steps: int = 0,
) -> tuple[FloatArray, FloatArray]:
    """Lower (−inf) and upper bounds of the event rows [°C].

    Upper: ``y^hi_t − δ_t + α`` on allowance rows, ``y^hi_t − δ_t`` plus the recovery's
    decaying allowance (:func:`carry_allowance`) on strict rows. ``y_max`` and ``delta`` are
    (N, ny).
    """
    horizon, ny = y_max.shape
    widening = _row_widening(rows, horizon, ny, allowance_kelvin, carry_steps, recovery_steps)
    upper = np.subtract(y_max, delta).ravel()[rows.flat_index]
    return np.full(rows.num_rows, -np.inf), upper + widening


@functools.lru_cache(maxsize=64)
def _row_widening(
    rows: EventRows,
    horizon: int,
    ny: int,
    allowance_kelvin: float,
    carry_steps: int,
    recovery_steps: int,
) -> FloatArray:
    """(num_rows,) α on allowance rows, the recovery's decaying allowance on strict rows [K]
    (:func:`event_row_bounds`; cached, read-only)."""
    carry = carry_allowance(horizon, ny, allowance_kelvin, carry_steps, recovery_steps)
    widening: FloatArray = np.where(
        rows.allowance, allowance_kelvin, carry.ravel()[rows.flat_index]
    )
    widening.setflags(write=False)
    return widening


def event_rotation(rows: EventRows) -> IntArray:
    """Permutation ``perm`` such that row e of the next step starts from old row ``perm[e]``.

    Row (t, lag, kind, zone) takes the old row (t + 1, lag, kind, zone); the rows at t = N
    take the old rows with s = 0 of the same (lag, kind, zone) (see the module docstring).
    """
    if rows.num_rows == 0:
        return np.zeros(0, dtype=np.int64)
    horizon = int(rows.step.max()) + 1
    lag = rows.step + 1 - rows.start
    kind = rows.allowance.astype(np.int64)
    ny = int(rows.output.max()) + 1
    table = np.full((horizon, horizon + 1, 2, ny), -1, dtype=np.int64)
    table[rows.step, lag, kind, rows.output] = np.arange(rows.num_rows, dtype=np.int64)
    source = np.where(rows.step + 1 < horizon, rows.step + 1, lag - 1)  # last: old s = 0
    perm: IntArray = table[source, lag, kind, rows.output]
    return perm


def violated_rows(violation: FloatArray, candidate: BoolArray, tolerance_k: float) -> IntArray:
    """Event rows to add in lazy row generation: every ``candidate`` row (not in the LP yet,
    (num_rows,)) whose ``violation`` (activity − upper bound [K], (num_rows,)) exceeds
    ``tolerance_k``. Sorted ids.

    Adding every violated row rather than the most violated one per (output, zone, kind)
    takes fewer re-solves (each re-solve re-factorises the basis): on office5's ``rmpc-ppp``
    1.62 instead of 1.79 runs per step for 1 % more rows (docs/reference/performance.md, issue 32).
    """
    chosen: IntArray = np.flatnonzero(candidate & (violation > tolerance_k)).astype(np.int64)
    return chosen


@functools.lru_cache(maxsize=8)
def _lower_triangle(horizon: int) -> tuple[IntArray, IntArray, IntArray]:
    """``np.tril_indices(horizon)`` (row, column ≤ row) and their difference, cached
    (read-only arrays)."""
    rows, cols = np.tril_indices(horizon)
    lags = rows - cols
    for array in (rows, cols, lags):
        array.setflags(write=False)
    return rows, cols, lags


@functools.lru_cache(maxsize=8)
def _full_windows(horizon: int, max_steps: int) -> BoolArray:
    """(N − D, N + 1 − D) whether the window a … a + D − 1 (column a) lies within the inputs
    0 … k of output k = D + i (row i), cached (read-only)."""
    steps = np.arange(horizon)
    inside: BoolArray = (
        steps[None, : horizon + 1 - max_steps] + max_steps <= steps[max_steps:, None] + 1
    )
    inside.setflags(write=False)
    return inside


def worst_event_output(
    responses: FloatArray,
    served_outputs: FloatArray,
    r_reserve: FloatArray,
    delta: FloatArray,
    max_steps: int | None,
) -> FloatArray:
    """(N, ny) worst upper-side output over the event set × the box [°C].

    ``max(C x_t, max over events of C x_t + event sum) + δ_t``. The event set is every
    (s, L ≤ D) with D = ``max_steps``, or D = N for the whole-horizon model (None; its worst
    pattern, for cooling reserve, is the curtailed trajectory z). ``responses`` (N, ny, m_r)
    from :func:`reserve_responses`, ``served_outputs`` (N, ny) = C x_1..C x_N [°C],
    ``r_reserve`` (N, m_r) reserve of the reserve-carrying inputs [kg/s], ``delta`` (N, ny) [K].
    """
    horizon, ny = served_outputs.shape
    extra = np.zeros_like(served_outputs)
    if r_reserve.shape[1]:
        d = max_steps or horizon
        # contrib[k, j] = H_{k-j} r_j (ny) for j ≤ k, else 0. Under the sign conditions it is
        # ≥ 0 (cooling) or ≤ 0 (heating: then the served plan is the upper-side worst); the
        # clip removes round-off and the heating case.
        # every H_l r_j as one product, [l, :, j]; then contrib[k, j] = H_{k-j} r_j
        products = (responses.reshape(horizon * ny, -1) @ r_reserve.T).reshape(horizon, ny, -1)
        output, source, lag = _lower_triangle(horizon)
        contrib = np.zeros((horizon, horizon, ny))
        contrib[output, source] = np.maximum(products[lag, :, source], 0.0)
        prefix = np.zeros((horizon, horizon + 1, ny))  # [k, b] = Σ_{j<b} contrib[k, j]
        np.cumsum(contrib, axis=1, out=prefix[:, 1:])
        # contributions ≥ 0: the worst window for output k+1 has length min(D, k+1)
        short = min(d, horizon)  # outputs k < D: the window 0..k
        steps = np.arange(short)
        extra[:short] = prefix[steps, steps + 1]
        if short < horizon:  # outputs k ≥ D: the largest window a..a+D−1 within 0..k
            sums = prefix[short:, d:] - prefix[short:, :-d]
            masked = np.where(_full_windows(horizon, d)[..., None], sums, -np.inf)
            extra[short:] = masked.max(axis=1)
    worst: FloatArray = served_outputs + extra + delta
    return worst


def event_trajectory(
    a_matrix: FloatArray,
    b_reserve: FloatArray,
    x_served: FloatArray,
    r_reserve: FloatArray,
    max_steps: int | None,
) -> FloatArray:
    """(N+1, n) nominal trajectory under the event (s = 0, L = D) [°C] (D = N if None).

    ``b_reserve`` (n, m_r) the reserve-carrying columns of B, ``x_served`` (N+1, n) from x0,
    ``r_reserve`` (N, m_r) [kg/s].
    """
    horizon = r_reserve.shape[0]
    d = max_steps or horizon
    shifts = np.empty((horizon, a_matrix.shape[0]))  # the event's effect on x_1 … x_N
    shift = np.zeros(a_matrix.shape[0])
    for k in range(horizon):
        shift = a_matrix @ shift
        if k < d:
            shift = shift - b_reserve @ r_reserve[k]
        shifts[k] = shift
    curtailed = x_served.copy()
    curtailed[1 : horizon + 1] += shifts
    return curtailed
