r"""CVXPY references of the open-loop LP families, written from their definitions.

Tests and benchmarks compare :class:`~hvacflex.opt.solve.RMPCSolver`'s optimum with these
models (``tests/opt/test_reference.py`` on recorded office5 steps and random problems,
``benchmarks/bench_cvxpy_events.py`` and ``benchmarks/bench_rmpc.py`` for the timing). They are
written from docs/explanation/model.md §3 and docs/explanation/il_events.md, vectorised, with
explicit impulse responses (matrix products, not :mod:`hvacflex.opt.robust`) and never from
hvacflex's LP builder, so a change of the LP that the definitions do not share shows as a different
optimum. Needs ``cvxpy`` (the ``dev`` extra); imported on first use.

Families (chosen by the problem, as :class:`~hvacflex.opt.solve.RMPCSolver` does):

* **whole-horizon** (``events`` None): the served x and the curtailed z
  (u − r for all N steps), both inside the δ-tightened band (the paper's eq. 11–13);
* **event model** (``events`` set, D = its ``max_steps``): the served plan plus, per output t, start
  s < t and zone, the allowance row of the longest event (L = D, bound + α while
  t − s ≤ D + R) and the strict row (L = min(D, t − s − R − 1), while t − s ≥ R + 2); the
  recovery's decaying allowance on outputs t ≤ c on the served and strict rows;
* **visible offers** (``offer_baselines`` set, event model): the reserve of step k is paid
  for ``min(q_k·r_k, every baseline's gap + ρ p_k·r_k)`` (a concave minimum, written as its
  hypograph), 0 on the steps that may not be paid, and a price b + 1e-6 SGD/kWh on the part
  below zero (docs/explanation/il_events.md, "The plan is paid for what the baselines see").

Both carry the committed reserve ``r_k`` = ``commitments.reserve_kg_s`` (k < g), the power
cap P ≤ ``power_cap.power_max_kw``, the reserve coefficient q
(``reserve_power_coeff_kw_per_kg_s``), the slack cap, the peak floor and both tie-breaks; the
objective is HiGHS's (tie-breaks included,
:meth:`~hvacflex.opt.solve.RMPCSolver.highs_objective_sgd`). ``robust="dual"`` has the
tightening form's optimum and is modelled as it; ``"none"`` has δ = 0.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from hvacflex.opt.options import (
    RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR,
    UNSEEN_TIE_BREAK_SGD_PER_KW_HOUR,
)
from hvacflex.opt.problem import BoolArray, FloatArray, IntArray, RMPCProblem
from hvacflex.units import KWH_PER_MWH

#: Singular values of E below this share of the largest are round-off (E's rank).
SVD_RANK_TOLERANCE = 1e-9

__all__ = ["ReferenceResult", "margins", "reference_event_rows", "solve_reference"]


@dataclass(frozen=True)
class ReferenceResult:
    """The reference model's optimum: ``objective_sgd`` (HiGHS's objective, tie-breaks
    included) [SGD], CVXPY's ``status``, the ``family`` solved and the paid reserve
    ``reserve_kw`` (N,) [kW] (q·r, or what the baselines see, ≥ 0)."""

    objective_sgd: float
    status: str
    family: str
    reserve_kw: FloatArray


def _cvxpy() -> Any:
    """The cvxpy module, imported on first use (the ``dev`` extra; untyped here)."""
    return importlib.import_module("cvxpy")


def margins(prob: RMPCProblem) -> FloatArray:
    """(N, ny) δ_k = Σ_{j<k} |C A^{k−1−j} E| σ_j [K] (0 for ``robust="none"``), by repeated
    products."""
    horizon = prob.horizon
    delta = np.zeros((horizon, prob.ny))
    if prob.robust == "none":
        return delta
    responses = np.empty((horizon, prob.ny, prob.nd))
    propagated = prob.e_matrix.copy()
    for lag in range(horizon):
        responses[lag] = np.abs(prob.c_matrix @ propagated)
        propagated = prob.a_matrix @ propagated
    for k in range(horizon):
        delta[k] = np.einsum("lij,lj->i", responses[k::-1], prob.d_sigma[: k + 1])
    return delta


def reference_event_rows(prob: RMPCProblem) -> tuple[IntArray, IntArray, IntArray, BoolArray]:
    """Per event row (zones apart): output step k = t − 1, first curtailed input s, number of
    curtailed inputs L and whether it is an allowance row (True) or a strict row (False), for
    every (t, s < t) of the event model (docs/explanation/il_events.md)."""
    assert prob.events is not None
    d, r = prob.events.max_steps, prob.events.recovery_steps
    steps, starts, lengths, allowance = [], [], [], []
    for t in range(1, prob.horizon + 1):
        for s in range(t):
            lag = t - s
            if lag <= d + r:  # some event (s, L ≤ D) still allows α at t: the longest one
                steps.append(t - 1)
                starts.append(s)
                lengths.append(min(d, lag))
                allowance.append(True)
            if lag >= r + 2:  # some event ended more than R steps before t: the longest one
                steps.append(t - 1)
                starts.append(s)
                lengths.append(min(d, lag - r - 1))
                allowance.append(False)
    return (
        np.array(steps, dtype=np.int64),
        np.array(starts, dtype=np.int64),
        np.array(lengths, dtype=np.int64),
        np.array(allowance, dtype=bool),
    )


def _carry(prob: RMPCProblem) -> FloatArray:
    """(N, ny) the recovery's decaying allowance α·min(1, (c − t + 1)/(R + 1)) on t ≤ c [K]."""
    t = np.arange(1, prob.horizon + 1)
    assert prob.events is not None
    carry_steps, recovery = prob.events.carry_steps, prob.events.recovery_steps
    share = np.clip((carry_steps - t + 1) / (recovery + 1), 0.0, 1.0) * (t <= carry_steps)
    return prob.events.allowance_kelvin * share[:, None] * np.ones(prob.ny)


def _event_constraint(prob: RMPCProblem, y: Any, r: Any, eps: Any, delta: FloatArray) -> Any:
    """The event rows ``C x_t + Σ_j H_{t−1−j} r_j − ε_t ≤ y_hi − δ (+ α or the carry)`` as one
    vectorised CVXPY constraint (H_l = −C A^l B_r)."""
    cp = _cvxpy()
    from scipy import sparse

    horizon, ny = prob.horizon, prob.ny
    inputs = np.flatnonzero(np.asarray(prob.reserve_mask, dtype=bool))
    m_r = inputs.size
    warming = np.empty((horizon, ny, m_r))
    propagated = -prob.b_matrix[:, inputs]
    for lag in range(horizon):
        warming[lag] = prob.c_matrix @ propagated
        propagated = prob.a_matrix @ propagated
    step, start, length, allowance = reference_event_rows(prob)
    rows = np.arange(step.size)
    row_of, col_of, values = [], [], []
    for offset in range(int(length.max())):
        take = length > offset
        j = start[take] + offset
        for zone in range(ny):
            row_of.append(np.repeat(rows[take] * ny + zone, m_r))
            col_of.append((j[:, None] * m_r + np.arange(m_r)).ravel())
            values.append(warming[step[take] - j, zone].ravel())
    warming_rows = sparse.csr_matrix(
        (np.concatenate(values), (np.concatenate(row_of), np.concatenate(col_of))),
        shape=(step.size * ny, horizon * m_r),
    )
    out_index = (step[:, None] * ny + np.arange(ny)).ravel()
    assert prob.events is not None
    alpha = prob.events.allowance_kelvin
    widen = np.where(allowance[:, None], alpha, _carry(prob)[step]).ravel()
    upper = (prob.y_max - delta)[step].ravel() + widen
    lhs = (
        cp.vec(y, order="C")[out_index]
        + warming_rows @ cp.vec(_scaled(prob, r, inputs), order="C")
        - cp.vec(eps, order="C")[out_index]
    )
    return lhs <= upper


def _scaled(prob: RMPCProblem, flows: Any, inputs: IntArray | None = None) -> Any:
    """The flow variables (N, k) of ``inputs`` (all when None) as B's columns see them,
    s_k ⊙ flows with ``prob.input_scale`` (B_k = B diag(s_k)), else the flows."""
    if prob.input_scale is None:
        return flows
    scale = prob.input_scale if inputs is None else prob.input_scale[:, inputs]
    return _cvxpy().multiply(scale, flows)


def _paid_steps(prob: RMPCProblem, inputs: IntArray) -> BoolArray:
    """(N,) the steps whose offer may be paid: in ``offer_steps``, not committed, something
    seen (baseline ≠ −inf), q_k > 0 on some reserve input."""
    baselines = prob.offer_baselines
    assert baselines is not None
    paid = np.array(baselines.offer_steps, dtype=bool)
    paid[: prob.fixed_reserve_steps] = False
    paid &= ~np.isneginf(baselines.fixed_baseline_kw)
    paid &= (prob.reserve_kw_per_kg_s[:, inputs] > 0.0).any(axis=1)
    return paid


def _seen_offers(prob: RMPCProblem, r: Any, power: Any) -> tuple[Any, list[Any]]:
    """The capacity each step is paid for, a variable ``seen`` (N,) [kW] bounded by q_k·r_k
    and by every baseline's gap + ρ p_k·r_k (+ tolerance), 0 where unpaid; its constraints."""
    cp = _cvxpy()

    baselines = prob.offer_baselines
    assert baselines is not None and prob.events is not None
    inputs = np.flatnonzero(np.asarray(prob.reserve_mask, dtype=bool))
    horizon, rho, tol = prob.horizon, baselines.meter_ratio, baselines.tolerance_kw
    paid = _paid_steps(prob, inputs)
    offer = cp.sum(cp.multiply(prob.reserve_kw_per_kg_s[:, inputs], r), axis=1)
    shed = rho * cp.sum(cp.multiply(prob.power_coeff_kw_per_kg_s[:, inputs], r), axis=1)
    seen = cp.Variable(horizon)
    cons = [seen <= offer]
    if (~paid).any():
        cons.append(seen[np.flatnonzero(~paid)] == 0.0)
    fixed = baselines.fixed_baseline_kw
    usable = np.flatnonzero(paid & np.isfinite(fixed))
    if usable.size:
        level = np.where(baselines.fixed_on_plan_scale, rho, 1.0)[usable]
        gap = cp.multiply(level, fixed[usable] - power[usable])
        cons.append(seen[usable] <= gap + shed[usable] + tol)
    planned = paid & baselines.planned_baselines
    for lag in range(1, prob.events.max_steps + 1):
        steps = np.flatnonzero(planned[lag:]) + lag
        if steps.size:
            gap = rho * (power[steps - lag] - power[steps])
            cons.append(seen[steps] <= gap + shed[steps] + tol)
    return seen, cons


def _has_reserve(prob: RMPCProblem) -> bool:
    """Whether some input carries reserve."""
    return bool(np.asarray(prob.reserve_mask, dtype=bool).any())


def _reserve_columns(prob: RMPCProblem) -> IntArray:
    """The inputs r has columns for: the reserve-carrying ones, or input 0 as a placeholder
    held at r = 0 when none carries reserve."""
    inputs = np.flatnonzero(np.asarray(prob.reserve_mask, dtype=bool)).astype(np.int64)
    return inputs if inputs.size else np.zeros(1, dtype=np.int64)


def _plan(prob: RMPCProblem) -> tuple[dict[str, Any], list[Any]]:
    """The variables every open-loop family shares and their constraints: dynamics of the
    served x, flow and reserve bounds (committed steps fixed), slack, power (capped), peak."""
    cp = _cvxpy()

    horizon, n, m, ny = prob.horizon, prob.n, prob.m, prob.ny
    inputs = _reserve_columns(prob)
    v = {
        "u": cp.Variable((horizon, m)),
        "r": cp.Variable((horizon, inputs.size)),
        "x": cp.Variable((horizon, n)),
        "eps": cp.Variable((horizon, ny)),
        "beta": cp.Variable(),
    }
    u, r, x, eps = v["u"], v["r"], v["x"], v["eps"]
    v["power"] = prob.power_offset_kw + cp.sum(cp.multiply(prob.power_coeff_kw_per_kg_s, u), 1)
    v["drift"] = prob.d_forecast @ prob.e_matrix.T + prob.g
    x_prev = cp.vstack([prob.x0[None, :], x[:-1]])
    room = (prob.u_max - prob.u_min)[:, inputs]
    cons = [
        x == x_prev @ prob.a_matrix.T + _scaled(prob, u) @ prob.b_matrix.T + v["drift"],
        u >= prob.u_min,
        u <= prob.u_max,
        r >= 0,
        r <= room,
        u[:, inputs] - r >= prob.u_min[:, inputs],
        eps >= 0,
        cp.multiply(prob.phi, v["power"]) <= v["beta"],
        v["beta"] >= float(prob.phi[0]) * prob.peak_floor_kw,
    ]
    if not _has_reserve(prob):
        cons.append(r == 0.0)  # a placeholder column (CVXPY has no empty variables)
    committed = prob.fixed_reserve_steps
    if prob.commitments is not None and committed:
        fixed = prob.commitments.reserve_kg_s[:, inputs]
        cons.append(r[:committed] == np.minimum(fixed, room[:committed]))
    if prob.slack_max_kelvin is not None:
        cons.append(eps <= prob.slack_max_kelvin)
    power_max_kw = np.asarray(prob.power_max_kw, dtype=float)
    capped = np.flatnonzero(np.isfinite(power_max_kw))
    if capped.size:
        cons.append(v["power"][capped] <= power_max_kw[capped])
    return v, cons


def _comfort(prob: RMPCProblem, v: dict[str, Any], delta: FloatArray) -> list[Any]:
    """The served band (and the curtailed trajectory z of the whole-horizon model)."""
    cp = _cvxpy()

    y = v["x"] @ prob.c_matrix.T
    eps = v["eps"]
    if prob.events is not None:
        cons = [y - eps <= prob.y_max - delta + _carry(prob), y + eps >= prob.y_min + delta]
        if _has_reserve(prob):
            cons.append(_event_constraint(prob, y, v["r"], eps, delta))
        return cons
    cons = [y - eps <= prob.y_max - delta, y + eps >= prob.y_min + delta]
    inputs = _reserve_columns(prob)
    if _has_reserve(prob):
        z = cp.Variable((prob.horizon, prob.n))
        z_prev = cp.vstack([prob.x0[None, :], z[:-1]])
        b_reserve = prob.b_matrix[:, inputs]
        flows = (
            _scaled(prob, v["u"]) @ prob.b_matrix.T - _scaled(prob, v["r"], inputs) @ b_reserve.T
        )
        y_z = z @ prob.c_matrix.T
        cons += [
            z == z_prev @ prob.a_matrix.T + flows + v["drift"],
            y_z - eps <= prob.y_max - delta,
            y_z + eps >= prob.y_min + delta,
        ]
    return cons


def _comfort_cost(prob: RMPCProblem, eps: Any) -> Any:
    """ρ·Δt·Σε, plus (ρ₂ − ρ)·Δt·Σ max(ε − δ, 0) with a comfort knee [SGD] (CVXPY)."""
    cp = _cvxpy()
    cost = prob.comfort_penalty_sgd_per_kelvin_hour * prob.dt_h * cp.sum(eps)
    knee = prob.comfort_knee
    if knee is None:
        return cost
    surcharge = knee.surcharge_sgd_per_kelvin_hour(prob.comfort_penalty_sgd_per_kelvin_hour)
    return cost + surcharge * prob.dt_h * cp.sum(cp.pos(eps - knee.knee_kelvin))


def solve_reference(prob: RMPCProblem, *, solver: str = "HIGHS") -> ReferenceResult:
    """Build ``prob``'s open-loop LP (whole-horizon or event model, with or without visible
    offers) in CVXPY from its definition and solve it with ``solver`` (a CVXPY solver name).

    ``robust="feedback"`` problems are solved by the affine-policy reference
    (:func:`_solve_feedback`).
    """
    cp = _cvxpy()

    if prob.robust == "feedback":
        return _solve_feedback(prob, solver)
    v, cons = _plan(prob)
    cons += _comfort(prob, v, margins(prob))
    inputs = _reserve_columns(prob)
    dt = prob.dt_h
    r = v["r"]
    if prob.offer_baselines is not None and _has_reserve(prob):
        paid, seen_cons = _seen_offers(prob, r, v["power"])
        cons += seen_cons
        unseen = dt * UNSEEN_TIE_BREAK_SGD_PER_KW_HOUR * cp.sum(cp.pos(-paid))
        family = "event model, visible offers"
    else:
        paid = cp.sum(cp.multiply(prob.reserve_kw_per_kg_s[:, inputs], r), axis=1)
        unseen = 0.0
        family = "whole-horizon" if prob.events is None else "event model"
    objective = (
        dt * (prob.energy_price_sgd_per_mwh @ v["power"]) / KWH_PER_MWH
        - dt * (prob.reserve_price_sgd_per_mwh @ paid) / KWH_PER_MWH
        + unseen
        + dt * RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR * cp.sum(r)
        + _comfort_cost(prob, v["eps"])
        + v["beta"]
    )
    model = cp.Problem(cp.Minimize(objective), cons)
    model.solve(solver=solver)
    return _result(model, family, paid)


def _result(model: Any, family: str, paid: Any) -> ReferenceResult:
    """The solved ``model``'s objective and status, and the paid reserve max(0, ``paid``)
    (NaN where CVXPY found no solution)."""
    value = np.nan if model.value is None else float(model.value)
    if paid.value is None:
        return ReferenceResult(value, str(model.status), family, np.full(paid.shape, np.nan))
    reserve = np.maximum(np.asarray(paid.value, dtype=float), 0.0)
    return ReferenceResult(value, str(model.status), family, reserve)


def _policy_gains(prob: RMPCProblem) -> dict[tuple[int, int], Any]:
    """U_{k,j} (m, nd) for every pair (k, j < k) that has a gain: Θ_{k,j} K for all pairs
    ("full"), for k − j ≤ L ("memory"), one Θ per lag k − j ≤ L ("time-invariant"), with K an
    orthonormal basis of E's row space (what the measured E w_j reveals of w_j, by SVD);
    "zone-local": diag(θ_{k−j}) C E, input i on its own zone's innovation, one θ per lag ≤ L."""
    cp = _cvxpy()

    options = prob.feedback
    assert options is not None
    structure, memory = options.structure, options.memory_steps
    if structure == "zone-local":
        k_matrix = prob.c_matrix @ prob.e_matrix
    else:
        _, singular, v_t = np.linalg.svd(prob.e_matrix)
        largest = float(singular[0]) if singular.size else 0.0
        k_matrix = v_t[: int(np.sum(singular > SVD_RANK_TOLERANCE * largest))]
    gains: dict[tuple[int, int], Any] = {}
    if options.zero_gains or k_matrix.shape[0] == 0:
        return gains
    by_lag: dict[int, Any] = {}
    for k in range(prob.horizon):
        for j in range(k):
            lag = k - j
            if structure != "full" and lag > memory:
                continue
            if structure == "zone-local":
                theta = by_lag.setdefault(lag, cp.Variable(prob.m))
                gains[k, j] = cp.diag(theta) @ k_matrix
                continue
            shape = (prob.m, k_matrix.shape[0])
            if structure == "time-invariant":
                theta = by_lag.setdefault(lag, cp.Variable(shape))
            else:
                theta = cp.Variable(shape)
            gains[k, j] = theta @ k_matrix
    return gains


def _solve_feedback(prob: RMPCProblem, solver: str) -> ReferenceResult:
    """The affine disturbance-feedback LP (docs/explanation/model.md, :mod:`hvacflex.opt.feedback`'s
    definition): u_k(w) = v_k + Σ_{j<k} U_{k,j} w_j, r fixed; every row robust for the box
    |w_j| ≤ σ_j (|coefficient|·σ summed); served x and curtailed z share the response to w;
    nominal cost."""
    cp = _cvxpy()

    horizon, n, m = prob.horizon, prob.n, prob.m
    a, b, c = prob.a_matrix, prob.b_matrix, prob.c_matrix
    inputs = _reserve_columns(prob)
    gains = _policy_gains(prob)
    v, cons = _plan(prob)
    # the response D_{k,j} (n, nd) of x_{k+1} to w_j, j ≤ k, under the policy
    comfort_margin: list[Any] = []
    input_margin: list[Any] = []
    power_margin: list[Any] = []
    response: dict[int, Any] = {}
    for k in range(horizon):
        for j in range(k):
            response[j] = a @ response[j] + b @ gains[k, j] if (k, j) in gains else a @ response[j]
        response[k] = prob.e_matrix
        sigma = prob.d_sigma
        comfort_margin.append(sum(cp.abs(c @ response[j]) @ sigma[j] for j in range(k + 1)))
        terms = [(j, gains[k, j]) for j in range(k) if (k, j) in gains]
        zero_m = np.zeros(m)
        input_margin.append(sum((cp.abs(g) @ sigma[j] for j, g in terms), zero_m))
        p_k = prob.power_coeff_kw_per_kg_s[k]
        power_margin.append(sum((cp.abs(p_k @ g) @ sigma[j] for j, g in terms), 0.0))
    delta = cp.vstack(comfort_margin)
    mu = cp.vstack(input_margin)
    x, eps, r = v["x"], v["eps"], v["r"]
    trajectories = [x @ c.T]
    if _has_reserve(prob):
        z = cp.Variable((horizon, n))
        z_prev = cp.vstack([prob.x0[None, :], z[:-1]])
        flows = v["u"] @ b.T - r @ b[:, inputs].T
        cons.append(z == z_prev @ a.T + flows + v["drift"])
        trajectories.append(z @ c.T)
    for y in trajectories:
        cons += [y + delta - eps <= prob.y_max, y - delta + eps >= prob.y_min]
    reduced = v["u"] - r @ np.eye(m)[inputs]
    cons += [v["u"] + mu <= prob.u_max, reduced - mu >= prob.u_min]
    peak = cp.hstack(power_margin)
    cons.append(cp.multiply(prob.phi, v["power"] + peak) <= v["beta"])
    dt = prob.dt_h
    paid = cp.sum(cp.multiply(prob.reserve_kw_per_kg_s[:, inputs], r), axis=1)
    objective = (
        dt * (prob.energy_price_sgd_per_mwh @ v["power"]) / KWH_PER_MWH
        - dt * (prob.reserve_price_sgd_per_mwh @ paid) / KWH_PER_MWH
        + dt * RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR * cp.sum(r)
        + _comfort_cost(prob, eps)
        + v["beta"]
    )
    model = cp.Problem(cp.Minimize(objective), cons)
    model.solve(solver=solver)
    return _result(model, f"feedback ({prob.feedback})", paid)
