"""The open-loop RMPC as a sparse LP: one function per constraint family, one index allocator.

:class:`LPBuilder` hands out column and row index ranges and collects bounds, costs and
coefficients; every ``add_…`` function below adds one family of variables or constraints
(PyPSA/linopy manner) and says in its docstring which rows it adds. :func:`build_lp` calls
them in order; the affine-feedback LP (:mod:`hvacflex.opt.feedback`) reuses the shared ones
(plan variables, dynamics, comfort, plan costs) over the same builder. A new constraint family
is one more ``add_…`` function, called from :func:`build_lp`, plus a test; a new feature is one
more block of :mod:`hvacflex.opt.blocks` and its family in :data:`FEATURE_FAMILIES`.

Sparse LP (state-space form)
----------------------------
States stay variables, so the constraint matrix is banded and ``x_0``, ``d̂``, ``g``, bounds
and prices enter only right-hand sides, bounds and costs. Columns, in order:
``x_1..x_N`` (N·n), ``z_1..z_N`` (N·n, only if some input carries reserve), ``u`` (N·m),
``r`` (N·m_r, reserve-carrying inputs only), ``ε`` (N·ny), ``P`` (N), ``β`` (1), the slack
beyond a comfort knee ``ε⁺`` (N·ny, only with one), the visible offers' R and σ, then the
dual λ's. Rows: served and curtailed dynamics (N·n each, equalities), comfort upper/lower
rows per trajectory (N·ny each), ``u − r ≥ u_min`` (N·m_r), ``ε − ε⁺ ≤ δ`` (N·ny, only with
a comfort knee), power definition (N,
coefficients ``−p_k`` change every step), peak rows ``φ_k P_k − β ≤ 0`` (N), in the IL event
model (``p.events`` set; no z columns or rows then) the event rows of
:func:`add_il_event_comfort` (≈ N²·ny/2), and in the dual form one equality
``λ₁ − λ₂ = ±h`` per (robust row, disturbance entry).

The index allocator and the LP container (:class:`LPBuilder`, :class:`LinearProgram`) are
:mod:`hvacflex.opt.lp_builder`'s (re-exported here); constant and varying coefficients are
explained there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hvacflex.opt.events import (
    EventRows,
    carry_allowance,
    event_matrix,
    event_rotation,
    event_row_bounds,
    event_rows,
    reserve_responses,
)
from hvacflex.opt.lp_builder import LinearProgram, LPBuilder, Triplets, sparse_matrix
from hvacflex.opt.options import (
    RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR,
    UNSEEN_TIE_BREAK_SGD_PER_KW_HOUR,
)
from hvacflex.opt.problem import FloatArray, IntArray, RMPCProblem
from hvacflex.opt.robust import dual_row_entries, impulse_responses
from hvacflex.units import KWH_PER_MWH

__all__ = [
    "FEATURE_FAMILIES",
    "LPBuilder",
    "LPLayout",
    "LinearProgram",
    "PlanColumns",
    "Triplets",
    "add_comfort_knee",
    "add_comfort_with_margins",
    "add_committed_reserve",
    "add_curtailed_dynamics",
    "add_dual_robust_rows",
    "add_flow_and_reserve_bounds",
    "add_il_event_comfort",
    "add_peak_epigraph",
    "add_plan_variables",
    "add_power_cap",
    "add_power_definition",
    "add_served_dynamics",
    "add_visible_offers",
    "build_lp",
    "dynamics_rhs",
    "event_numbers",
    "set_objective",
    "set_plan_costs",
    "sparse_matrix",
]


# ---------------------------------------------------------------------- shared families


@dataclass(frozen=True, eq=False)
class PlanColumns:
    """Columns of the plan that both LPs share (index arrays shaped like the quantity).

    ``z`` is the curtailed trajectory; it is ``x`` itself when no input carries reserve and
    in the IL event model (``event_model``: event rows over x and r instead of z).
    ``power`` is (N,) in the open-loop LP and empty in the feedback LP.
    """

    x: IntArray  # (N, n)
    z: IntArray  # (N, n)
    u: IntArray  # (N, m)
    r: IntArray  # (N, m_r)
    eps: IntArray  # (N, ny)
    power: IntArray  # (N,) or (0,)
    beta: int
    reserve_inputs: IntArray  # (m_r,)
    event_model: bool = False

    @property
    def has_reserve(self) -> bool:
        """Whether some input carries reserve (r columns and ``u − r ≥ u_min`` rows exist)."""
        return self.reserve_inputs.size > 0

    @property
    def has_curtailed(self) -> bool:
        """Whether a separate curtailed trajectory z exists (reserve, whole-horizon model)."""
        return self.has_reserve and not self.event_model


def add_plan_variables(lp: LPBuilder, p: RMPCProblem, *, power_column: bool) -> PlanColumns:
    """States x, z [°C], flows u ∈ [u_min, u_max], reserve r ∈ [0, u_max − u_min] [kg/s],
    slack 0 ≤ ε ≤ ε_max [K], power P [kW] (if ``power_column``), peak charge β ≥ φ·floor.
    (The feature blocks narrow these bounds: :func:`add_committed_reserve`,
    :func:`add_power_cap`.)"""
    horizon = p.horizon
    reserve_inputs = np.flatnonzero(np.asarray(p.reserve_mask, dtype=bool)).astype(np.int64)
    event_model = p.events is not None
    x = lp.add_columns((horizon, p.n), time_indexed=True)
    z = x
    if reserve_inputs.size and not event_model:
        z = lp.add_columns((horizon, p.n), time_indexed=True)
    u = lp.add_columns((horizon, p.m), lower=p.u_min, upper=p.u_max, time_indexed=True)
    r_upper = np.array((p.u_max - p.u_min)[:, reserve_inputs], dtype=float)
    r = lp.add_columns(
        (horizon, reserve_inputs.size),
        lower=np.zeros_like(r_upper),
        upper=r_upper,
        time_indexed=True,
    )
    slack_max = np.inf if p.slack_max_kelvin is None else p.slack_max_kelvin
    eps = lp.add_columns((horizon, p.ny), lower=0.0, upper=slack_max, time_indexed=True)
    power = lp.add_columns((horizon if power_column else 0,), time_indexed=True)
    beta = int(lp.add_columns((1,), lower=float(p.phi[0]) * p.peak_floor_kw)[0])
    return PlanColumns(x, z, u, r, eps, power, beta, reserve_inputs, event_model)


def add_committed_reserve(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """r_k fixed at the commitment (``p.commitments``,
    :class:`~hvacflex.opt.blocks.ReserveCommitment`) on the committed steps k < g, clipped
    into the room u_max − u_min [kg/s]: column bounds, not rows, so committing changes no
    structure (nothing without a commitment)."""
    if p.commitments is None or p.commitments.steps == 0:
        return
    steps = p.commitments.steps
    room = np.array((p.u_max - p.u_min)[:steps, v.reserve_inputs], dtype=float)
    fixed = np.minimum(p.commitments.reserve_kg_s[:, v.reserve_inputs], room)
    lp.set_column_bounds(v.r[:steps], lower=fixed, upper=fixed)


def add_power_cap(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """P_k ≤ the cap (``p.power_cap``, :class:`~hvacflex.opt.blocks.PowerCap`) [kW]: column
    bounds of the power columns (nothing without a cap, or in the feedback LP, which has no
    P columns)."""
    if p.power_cap is None or v.power.size == 0:
        return
    lp.set_column_bounds(v.power, lower=-np.inf, upper=p.power_cap.kw)


def event_numbers(p: RMPCProblem) -> tuple[float, int, int]:
    """(α [K], c, R) of ``p.events``; (0, 0, 0) in the whole-horizon model."""
    if p.events is None:
        return 0.0, 0, 0
    return p.events.allowance_kelvin, p.events.carry_steps, p.events.recovery_steps


def dynamics_rhs(p: RMPCProblem) -> FloatArray:
    """(N, n) right-hand sides of the dynamics rows ``x_{k+1} − A x_k − B u_k = E d̂_k + g``
    (for k = 0 also ``+ A x_0``) [K]."""
    rhs: FloatArray = p.d_forecast @ p.e_matrix.T + p.g
    rhs[0] += p.a_matrix @ p.x0
    return rhs


def _add_dynamics(lp: LPBuilder, p: RMPCProblem, state: IntArray, v: PlanColumns) -> IntArray:
    rhs = dynamics_rhs(p)
    rows = lp.add_rows((p.horizon, p.n), lower=rhs, upper=rhs, time_indexed=True)
    lp.add_coefficients(rows[:, :, None], state[:, None, :], np.eye(p.n)[None])
    lp.add_coefficients(rows[1:, :, None], state[:-1, None, :], -p.a_matrix[None])
    add_input_coefficients(lp, p, rows, v.u, -1.0)
    return rows


def add_input_coefficients(
    lp: LPBuilder,
    p: RMPCProblem,
    rows: IntArray,
    flows: IntArray,
    sign: float,
    inputs: IntArray | None = None,
) -> None:
    """``sign`` · B_k on the flow columns ``flows`` (N, j) of the inputs ``inputs`` (all m
    when None) in the dynamics rows ``rows`` (N, n): B_k = B diag(s_k) with
    ``p.step_linearisation`` (:class:`~hvacflex.opt.blocks.StepLinearisation`), else B.
    The block's family: it adds no rows of its own but moves these coefficients of the
    core's dynamics (the event rows scale r's columns in :func:`add_il_event_comfort`)."""
    matrices = p.step_b_matrix if inputs is None else p.step_b_matrix[:, :, inputs]
    lp.add_coefficients(rows[:, :, None], flows[:, None, :], sign * matrices)


def add_served_dynamics(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """x_{k+1} = A x_k + B_k u_k + E d̂_k + g, k = 0..N-1 (N·n equality rows; B_k = B diag(s_k)
    with ``p.input_scale``, else B)."""
    _add_dynamics(lp, p, v.x, v)


def add_curtailed_dynamics(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """z_{k+1} = A z_k + B_k (u_k − r_k) + E d̂_k + g, z_0 = x_0 (N·n equality rows; none
    when no input carries reserve)."""
    if not v.has_curtailed:
        return
    rows = _add_dynamics(lp, p, v.z, v)
    add_input_coefficients(lp, p, rows, v.r, 1.0, v.reserve_inputs)


def add_comfort_with_margins(
    lp: LPBuilder,
    p: RMPCProblem,
    v: PlanColumns,
    margin_k: FloatArray,
    margin_cols: IntArray | None = None,
) -> list[tuple[IntArray, float]]:
    """C x_k − ε_k ≤ y_max − δ_k and C x_k + ε_k ≥ y_min + δ_k for each trajectory, k = 1..N
    (2·N·ny rows per trajectory, upper rows first).

    ``margin_k`` (N, ny) are constant margins δ [K]; ``margin_cols`` (N, ny), if given, are
    margin *variables* added as ``+δ`` on the upper and ``−δ`` on the lower rows. Returns the
    row blocks (N, ny) with their sign (+1 upper, −1 lower). In the IL event model the upper
    bound of outputs 1..c (``p.events.carry_steps``, the recovery from a real curtailment)
    is widened by the decaying allowance of :func:`~hvacflex.opt.events.carry_allowance`;
    never otherwise (α belongs to the event rows).
    """
    trajectories = [v.x, v.z] if v.has_curtailed else [v.x]
    shape = (p.horizon, p.ny)
    carry = carry_allowance(p.horizon, p.ny, *event_numbers(p))
    blocks: list[tuple[IntArray, float]] = []
    for state in trajectories:
        upper = lp.add_rows(shape, upper=p.y_max - margin_k + carry, time_indexed=True)
        lower = lp.add_rows(shape, lower=p.y_min + margin_k, time_indexed=True)
        for rows, sign in ((upper, 1.0), (lower, -1.0)):
            lp.add_coefficients(rows[:, :, None], state[:, None, :], p.c_matrix[None])
            lp.add_coefficients(rows, v.eps, -sign)
            if margin_cols is not None:
                lp.add_coefficients(rows, margin_cols, sign)
            blocks.append((rows, sign))
    return blocks


def add_comfort_knee(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> IntArray:
    """The slack beyond the knee δ (``p.comfort_knee``, :class:`~hvacflex.opt.blocks.ComfortKnee`):
    columns ε⁺ ≥ 0 (N, ny) costing (ρ₂ − ρ)·Δt and rows ``ε_k − ε⁺_k ≤ δ`` (N·ny, constant), so
    ε costs ρ up to δ and ρ₂ beyond. Returns the ε⁺ columns ((0, ny) without a knee)."""
    knee = p.comfort_knee
    if knee is None:
        return np.zeros((0, p.ny), dtype=np.int64)
    shape = (p.horizon, p.ny)
    beyond = lp.add_columns(shape, lower=0.0, time_indexed=True)
    rows = lp.add_rows(shape, upper=knee.knee_kelvin, time_indexed=True)
    lp.add_coefficients(rows, v.eps, 1.0)
    lp.add_coefficients(rows, beyond, -1.0)
    surcharge = knee.surcharge_sgd_per_kelvin_hour(p.comfort_penalty_sgd_per_kelvin_hour)
    lp.set_cost(beyond, surcharge * p.dt_h)
    return beyond


def set_plan_costs(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """Objective terms both LPs share: −reserve revenue b_k q_k·r_k Δt (plus the tie-break)
    on r, ρ·Δt on ε,
    1 on β [SGD]; the energy cost sits on P (open loop) or on u (feedback)."""
    dt = p.dt_h
    reserve_kw_per_kg_s = p.reserve_kw_per_kg_s[:, v.reserve_inputs]
    lp.set_cost(
        v.r,
        -dt * p.reserve_price_sgd_per_mwh[:, None] * reserve_kw_per_kg_s / KWH_PER_MWH
        + dt * RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR,
    )
    lp.set_cost(v.eps, p.comfort_penalty_sgd_per_kelvin_hour * dt)
    lp.set_cost(np.array(v.beta), 1.0)


# ---------------------------------------------------------------------- open-loop families


def add_flow_and_reserve_bounds(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """u_k − r_k ≥ u_min on reserve-carrying inputs (N·m_r rows; u ≤ u_max and r ≥ 0 are
    column bounds)."""
    rows = lp.add_rows(
        (p.horizon, v.reserve_inputs.size),
        lower=p.u_min[:, v.reserve_inputs],
        time_indexed=True,
    )
    lp.add_coefficients(rows, v.u[:, v.reserve_inputs], 1.0)
    lp.add_coefficients(rows, v.r, -1.0)


def add_power_definition(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """P_k − p_k·u_k = p0_k [kW] (N rows; −p_k varies from step to step)."""
    rows = lp.add_rows(
        (p.horizon,), lower=p.power_offset_kw, upper=p.power_offset_kw, time_indexed=True
    )
    lp.add_coefficients(rows, v.power, 1.0)
    lp.add_varying_coefficients(rows[:, None], v.u, -p.power_coeff_kw_per_kg_s)


def add_peak_epigraph(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """φ_k P_k − β ≤ 0 (N rows; φ_k varies from step to step)."""
    rows = lp.add_rows((p.horizon,), upper=0.0, time_indexed=True)
    lp.add_varying_coefficients(rows, v.power, p.phi)
    lp.add_coefficients(rows, np.array(v.beta), -1.0)


def add_dual_robust_rows(
    lp: LPBuilder, p: RMPCProblem, comfort_rows: list[tuple[IntArray, float]], responses: FloatArray
) -> None:
    """The paper's explicit dual (eq. 12–13): for every robust comfort row and disturbance
    entry a pair λ₁, λ₂ ≥ 0 with ``λ₁ − λ₂ = ±h`` and ``σ (λ₁ + λ₂)`` added to the row.

    ``comfort_rows`` are (row block (N, ny), sign) pairs, +1 for upper and −1 for lower rows;
    ``responses`` (N, ny, nd) the impulse responses ``C A^l E``. The σ coefficients vary.
    """
    step, output, dist_step, channel, h = dual_row_entries(responses)
    entries = step.size
    for row_block, sign in comfort_rows:
        rows = row_block[step, output]
        sigma = p.d_sigma[dist_step, channel] * sign
        lambda_1 = lp.add_columns((entries,), lower=0.0)
        lambda_2 = lp.add_columns((entries,), lower=0.0)
        lp.add_varying_coefficients(rows, lambda_1, sigma)
        lp.add_varying_coefficients(rows, lambda_2, sigma)
        equalities = lp.add_rows((entries,), lower=h * sign, upper=h * sign)
        lp.add_coefficients(equalities, lambda_1, 1.0)
        lp.add_coefficients(equalities, lambda_2, -1.0)


def add_il_event_comfort(
    lp: LPBuilder, p: RMPCProblem, v: PlanColumns, margin_k: FloatArray
) -> tuple[IntArray, EventRows]:
    """The IL event rows (:mod:`hvacflex.opt.events`): for each output t, start s and zone,
    ``C_i x_t + Σ_j H_{t−1−j,i} r_j − ε_{t,i} ≤ y^hi_t − δ_t (+ α)`` (≈ N²·ny/2 rows; none in
    the whole-horizon model, ``p.events`` None).

    The coefficients are constant (they depend on A, B, C, N, D, R and s only); α, the carry c and
    the margins ``margin_k`` (N, ny) [K] enter the row bounds. The block is not rectangular
    in the step, so its warm-start rotation is :func:`~hvacflex.opt.events.event_rotation`.
    Returns the row indices (num_event_rows,) and what each row is.
    """
    max_steps = None if p.events is None else p.events.max_steps
    alpha, carry_steps, recovery = event_numbers(p)
    rows = event_rows(p.horizon, p.ny, max_steps, recovery)
    if rows.num_rows == 0:
        return np.zeros(0, dtype=np.int64), rows
    lower, upper = event_row_bounds(rows, p.y_max, margin_k, alpha, carry_steps, recovery)
    index = lp.add_rows(
        (rows.num_rows,),
        lower=lower,
        upper=upper,
        time_permutation=event_rotation(rows) if lp.records_constants else None,
    )
    if lp.records_constants:
        b_reserve = p.b_matrix[:, v.reserve_inputs]
        block = event_matrix(
            rows,
            reserve_responses(p.a_matrix, b_reserve, p.c_matrix, p.horizon),
            p.c_matrix,
            col_x=v.x,
            col_r=v.r,
            col_eps=v.eps,
            num_cols=lp.num_cols,
        ).tocoo()
        data = block.data
        if p.input_scale is not None:  # H_l r_j becomes H_l diag(s_j) r_j: r's columns scale
            column_scale = np.ones(lp.num_cols)
            column_scale[v.r] = p.input_scale[:, v.reserve_inputs]
            data = data * column_scale[block.col]
        lp.add_coefficients(index[block.row], block.col, data)
    return index, rows


def add_visible_offers(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> tuple[IntArray, IntArray]:
    """Offered capacity R_k ≥ 0 [kW] paid only for what the settlement baselines see
    (``p.offer_baselines``, :class:`~hvacflex.opt.problem.OfferBaselines`; none: (0,)).

    With ρ the meter ratio, p_k·r_k the plan's shed and P the plan's power (N columns, the
    reserve revenue moves from r onto them; R_k fixed at 0 on the committed steps k < g,
    whose offers were sold before, and where nothing can be seen):

    * ``R_k − q_k·r_k ≤ 0`` (N rows; q already carries ρ);
    * the baseline the plan does not decide, B_k: ``R_k + ρ P_k − ρ p_k·r_k ≤ ρ B_k`` on the
      plan's scale, ``R_k + P_k − ρ p_k·r_k ≤ B_k`` metered (N rows; free where none);
    * the plan's own baselines, the power of the period before each start s = k − l + 1 ≥ 1
      of an activation covering k: ``R_k − ρ P_{k−l} + ρ P_k − ρ p_k·r_k ≤ 0``, l = 1 … D
      ((N, D) rows; free where l > k or a similar-days baseline replaces them).

    Every baseline gets ``tolerance_kw``. ρ, p and q vary from step to step (varying
    coefficients); the rows' structure depends on N and D only. σ costs the reserve price
    plus :data:`~hvacflex.opt.options.UNSEEN_TIE_BREAK_SGD_PER_KW_HOUR`, so R − σ is the
    paid capacity and σ is the unseen rise alone. A step whose q_k is 0 (ρ = 0) is not paid.
    Returns the columns of R and σ ((N,) each; (0,) without baselines).
    """
    baselines = p.offer_baselines
    horizon = p.horizon
    if baselines is None or not v.has_reserve or not v.event_model:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    assert p.events is not None  # checked by RMPCProblem
    max_steps = p.events.max_steps
    rho = baselines.meter_ratio
    tolerance = baselines.tolerance_kw
    fixed = baselines.fixed_baseline_kw
    paid = np.array(baselines.offer_steps, dtype=bool)
    paid[: p.fixed_reserve_steps] = False
    paid[np.isneginf(fixed)] = False
    paid &= (p.reserve_kw_per_kg_s[:, v.reserve_inputs] > 0.0).any(axis=1)
    offered = lp.add_columns(
        (horizon,), lower=0.0, upper=np.where(paid, np.inf, 0.0), time_indexed=True
    )
    shed = rho * p.power_coeff_kw_per_kg_s[:, v.reserve_inputs]  # (N, m_r)

    cap = lp.add_rows((horizon,), upper=0.0, time_indexed=True)
    lp.add_coefficients(cap, offered, 1.0)
    lp.add_varying_coefficients(cap[:, None], v.r, -p.reserve_kw_per_kg_s[:, v.reserve_inputs])

    on_plan = baselines.fixed_on_plan_scale
    level = np.where(on_plan, rho, 1.0)
    usable = np.isfinite(fixed) & paid
    bound = np.full(horizon, np.inf)
    bound[usable] = (level * np.where(usable, fixed, 0.0))[usable] + tolerance
    unseen = lp.add_columns(
        (horizon,), lower=0.0, upper=np.where(paid, np.inf, 0.0), time_indexed=True
    )
    own = lp.add_rows((horizon,), upper=bound, time_indexed=True)
    lp.add_coefficients(own, offered, 1.0)
    lp.add_coefficients(own, unseen, -1.0)
    lp.add_varying_coefficients(own, v.power, level)
    lp.add_varying_coefficients(own[:, None], v.r, -shed)

    lag = np.arange(1, max_steps + 1)
    step = np.arange(horizon)
    active = (lag[None, :] <= step[:, None]) & (baselines.planned_baselines & paid)[:, None]
    rows = lp.add_rows(
        (horizon, max_steps), upper=np.where(active, tolerance, np.inf), time_indexed=True
    )
    lp.add_coefficients(rows, offered[:, None], 1.0)
    lp.add_coefficients(rows, unseen[:, None], -1.0)
    lp.add_varying_coefficients(rows, v.power[:, None], np.full((horizon, max_steps), rho))
    lp.add_varying_coefficients(rows[:, :, None], v.r[:, None, :], -shed[:, None, :])
    k, l_index = np.nonzero(lag[None, :] <= step[:, None])
    lp.add_varying_coefficients(rows[k, l_index], v.power[k - lag[l_index]], -rho)
    # the revenue is paid on R, not on q·r (r keeps its tie-break)
    lp.set_cost(v.r, p.dt_h * RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR)
    lp.set_cost(offered, -p.dt_h * p.reserve_price_sgd_per_mwh / KWH_PER_MWH)
    lp.set_cost(
        unseen,
        p.dt_h * (p.reserve_price_sgd_per_mwh / KWH_PER_MWH + UNSEEN_TIE_BREAK_SGD_PER_KW_HOUR),
    )
    return offered, unseen


def set_objective(lp: LPBuilder, p: RMPCProblem, v: PlanColumns) -> None:
    """Energy cost Δt·c_k·P_k on P plus the shared plan costs (:func:`set_plan_costs`) [SGD]."""
    set_plan_costs(lp, p, v)
    lp.set_cost(v.power, p.dt_h * p.energy_price_sgd_per_mwh / KWH_PER_MWH)


@dataclass(frozen=True, eq=False)
class LPLayout:
    """The open-loop LP's plan columns, sizes and IL event rows (for extracting a solution).

    ``event_rows`` (num_event_rows,) are the LP rows of the event block (empty for the
    whole-horizon model), ``events`` says what each one is.
    """

    plan: PlanColumns
    num_cols: int
    num_rows: int
    event_rows: IntArray
    events: EventRows
    offered: IntArray  # (N,) R_k of add_visible_offers, or (0,)
    unseen: IntArray  # (N,) σ_k of add_visible_offers, or (0,)

    @property
    def has_curtailed(self) -> bool:
        """Whether a separate curtailed trajectory exists (some input carries reserve)."""
        return self.plan.has_curtailed


def build_lp(
    p: RMPCProblem,
    margin_k: FloatArray,
    *,
    responses: FloatArray | None = None,
    constants: bool = True,
    varying_pattern: Triplets | None = None,
) -> tuple[LinearProgram, LPLayout]:
    """The open-loop LP of ``p`` with comfort margins ``margin_k`` (N, ny) [K].

    In the dual form (``p.robust == "dual"``) pass ``margin_k = 0`` and the impulse
    ``responses`` (N, ny, nd): the λ's carry the robustness. ``constants=False`` skips the
    constant coefficients (see the module docstring); ``varying_pattern``, the ``varying``
    of an LP of the same structure, skips the varying coefficients' positions
    (:class:`LPBuilder`).
    """
    lp = LPBuilder(constants=constants, varying_pattern=varying_pattern)
    v = add_plan_variables(lp, p, power_column=True)
    add_committed_reserve(lp, p, v)
    add_power_cap(lp, p, v)
    add_served_dynamics(lp, p, v)
    add_curtailed_dynamics(lp, p, v)
    comfort_rows = add_comfort_with_margins(lp, p, v, margin_k)
    add_flow_and_reserve_bounds(lp, p, v)
    add_comfort_knee(lp, p, v)
    add_power_definition(lp, p, v)
    add_peak_epigraph(lp, p, v)
    set_objective(lp, p, v)
    offered, unseen = add_visible_offers(lp, p, v)
    event_index, events = add_il_event_comfort(lp, p, v, margin_k)
    if p.robust == "dual":
        if responses is None:
            responses = impulse_responses(p.a_matrix, p.e_matrix, p.c_matrix, p.horizon)
        add_dual_robust_rows(lp, p, comfort_rows, responses)
    program = lp.finish()
    layout = LPLayout(v, program.num_cols, program.num_rows, event_index, events, offered, unseen)
    return program, layout


FEATURE_FAMILIES = {
    "events": add_il_event_comfort,
    "commitments": add_committed_reserve,
    "offer_baselines": add_visible_offers,
    "power_cap": add_power_cap,
    "comfort_knee": add_comfort_knee,
    "step_linearisation": add_input_coefficients,
}
"""The ``add_…`` family of each open-loop feature block of :mod:`hvacflex.opt.blocks` (the
``feedback`` block has its own LP, :func:`hvacflex.opt.feedback.build_feedback_lp`)."""
