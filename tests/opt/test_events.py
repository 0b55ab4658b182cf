"""The IL event model (issue 14) against an independent brute-force model that enumerates every
event, sampled disturbance corners × events, the whole-horizon model, warm starts and the
validation of the event fields."""

from __future__ import annotations

import dataclasses
from typing import Any

import cvxpy as cp
import numpy as np
import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt import (
    ILEventModel,
    OfferBaselines,
    ReserveCommitment,
    RMPCProblem,
    RMPCSolver,
    SolveStatus,
    solve_rmpc,
)
from hvacflex.opt.events import (
    carry_allowance,
    event_rotation,
    event_row_bounds,
    event_rows,
    violated_rows,
    worst_event_output,
)
from hvacflex.opt.lp import build_lp
from hvacflex.opt.options import (
    RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR,
    UNSEEN_TIE_BREAK_SGD_PER_KW_HOUR,
)
from hvacflex.opt.testing import random_problem

REL_TOL = 1e-6
CONSTRAINT_TOL_K = 1e-6


def _model(prob: RMPCProblem) -> ILEventModel:
    """The problem's event model (these problems all have one)."""
    assert prob.events is not None
    return prob.events


def _with_events(prob: RMPCProblem, **changes: Any) -> RMPCProblem:
    """``prob`` with its event model changed (``ILEventModel`` fields)."""
    return dataclasses.replace(prob, events=dataclasses.replace(_model(prob), **changes))


def _max_steps(prob: RMPCProblem) -> int:
    """D of the problem's event model, N in the whole-horizon model."""
    return prob.horizon if prob.events is None else prob.events.max_steps


def _events(horizon: int, max_steps: int) -> list[tuple[int, int]]:
    """Every event (s, L): inputs s..s+L-1 curtailed, 1 ≤ L ≤ D, inside the horizon."""
    return [
        (s, length)
        for s in range(horizon)
        for length in range(1, max_steps + 1)
        if s + length <= horizon
    ]


def _margins(prob: RMPCProblem) -> np.ndarray:
    """δ_{t,i} = Σ_{j<t} |C A^{t-1-j} E|_i σ_j by explicit matrix powers (independent)."""
    a, e, c = prob.a_matrix, prob.e_matrix, prob.c_matrix
    delta = np.zeros((prob.horizon, prob.ny))
    for t in range(1, prob.horizon + 1):
        for j in range(t):
            delta[t - 1] += np.abs(c @ np.linalg.matrix_power(a, t - 1 - j) @ e) @ prob.d_sigma[j]
    return delta


def _upper_widening(prob: RMPCProblem, event: tuple[int, int] | None) -> np.ndarray:
    """(N,) α where output t = k+1 may use the allowance under ``event`` (None: served)."""
    model = _model(prob)
    alpha = model.allowance_kelvin
    widen = np.zeros(prob.horizon)
    carry, recovery = model.carry_steps, model.recovery_steps
    for t in range(1, carry + 1):  # the recovery's decaying allowance
        widen[t - 1] = alpha * min(1.0, (carry - t + 1) / (recovery + 1))
    if event is not None:
        s, length = event
        for k in range(prob.horizon):
            if s + 1 <= k + 1 <= s + length + recovery:
                widen[k] = alpha  # the event's own allowance (≥ the recovery's)
    return widen


def _brute_force(prob: RMPCProblem) -> float:
    """The event model written from the issue's definition: one explicit trajectory per event
    (s, L ≤ D), every pattern inside the δ-tightened band (+α where allowed), same costs and
    tie-break as hvacflex; solved by HiGHS through CVXPY. Returns the optimal objective."""
    a, b, e, c, g = prob.a_matrix, prob.b_matrix, prob.e_matrix, prob.c_matrix, prob.g
    horizon, m, ny = prob.horizon, prob.m, prob.ny
    dt = prob.dt_h
    delta = _margins(prob)
    u = cp.Variable((horizon, m))
    r = cp.Variable((horizon, m))
    eps = cp.Variable((horizon, ny))
    beta = cp.Variable()
    mask = prob.reserve_mask
    power = [
        prob.power_offset_kw[k] + prob.power_coeff_kw_per_kg_s[k] @ u[k] for k in range(horizon)
    ]
    reserve = _paid_reserve(prob, r, power)
    cons: list[Any] = [r >= 0, eps >= 0, u <= prob.u_max, u - r >= prob.u_min]
    cons += [r[:, i] == 0 for i in range(m) if not mask[i]]
    if prob.commitments is not None and prob.commitments.steps:
        cons.append(r[: prob.commitments.steps] == prob.commitments.reserve_kg_s)
    cons += [beta >= prob.phi[k] * power[k] for k in range(horizon)]
    cons.append(beta >= prob.phi[0] * prob.peak_floor_kw)
    if prob.slack_max_kelvin is not None:
        cons.append(eps <= prob.slack_max_kelvin)
    patterns: list[tuple[int, int] | None] = [
        None,
        *_events(horizon, _max_steps(prob)),
    ]
    for event in patterns:
        curtailed = np.zeros(horizon)
        if event is not None:
            curtailed[event[0] : event[0] + event[1]] = 1.0
        widen = _upper_widening(prob, event)
        x: Any = prob.x0
        for k in range(horizon):
            flow = u[k] - curtailed[k] * r[k]
            x = a @ x + b @ flow + e @ prob.d_forecast[k] + g
            y = c @ x
            cons.append(y + delta[k] <= prob.y_max[k] + widen[k] + eps[k])
            cons.append(y - delta[k] >= prob.y_min[k] - eps[k])
    objective = (
        sum(dt * prob.energy_price_sgd_per_mwh[k] * power[k] / 1000.0 for k in range(horizon))
        - sum(dt * prob.reserve_price_sgd_per_mwh[k] * reserve[k] / 1000.0 for k in range(horizon))
        + dt * UNSEEN_TIE_BREAK_SGD_PER_KW_HOUR * sum(cp.pos(-x) for x in reserve)
        + dt * RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR * cp.sum(r)
        + prob.comfort_penalty_sgd_per_kelvin_hour * dt * cp.sum(eps)
        + beta
    )
    model = cp.Problem(cp.Minimize(objective), cons)
    model.solve(solver=cp.HIGHS)
    assert model.status == cp.OPTIMAL, model.status
    return float(model.value)


def _paid_reserve(prob: RMPCProblem, r: Any, power: list[Any]) -> list[Any]:
    """The capacity each step is paid for: q_k·r_k, or with offer baselines what they see of
    it, min(q_k·r_k, every baseline's gap + ρ p_k·r_k), written out per baseline (CVXPY's
    concave ``minimum``), 0 where the step may not be paid (committed, nothing seen, left
    out of ``offer_steps``, q_k = 0)."""
    q = prob.reserve_kw_per_kg_s
    baselines = prob.offer_baselines
    if baselines is None:
        return [q[k] @ r[k] for k in range(prob.horizon)]
    rho, tol = baselines.meter_ratio, baselines.tolerance_kw
    paid: list[Any] = []
    for k in range(prob.horizon):
        fixed = baselines.fixed_baseline_kw[k]
        unpaid = k < prob.fixed_reserve_steps or not baselines.offer_steps[k]
        if unpaid or fixed == -np.inf or not (q[k][prob.reserve_mask] > 0).any():
            paid.append(0.0)
            continue
        shed = rho * (prob.power_coeff_kw_per_kg_s[k] @ r[k])
        terms = [q[k] @ r[k]]
        if not np.isnan(fixed):
            level = rho if baselines.fixed_on_plan_scale[k] else 1.0
            terms.append(level * (fixed - power[k]) + shed + tol)
        if baselines.planned_baselines[k]:
            for lag in range(1, min(_max_steps(prob), k) + 1):
                terms.append(rho * (power[k - lag] - power[k]) + shed + tol)
        paid.append(cp.minimum(*terms) if len(terms) > 1 else terms[0])
    return paid


def _outputs(
    prob: RMPCProblem, u: np.ndarray, r: np.ndarray, event: tuple[int, int] | None, w: np.ndarray
) -> np.ndarray:
    """(N, ny) outputs of the linear model under ``event`` and disturbance errors ``w`` (N, nd)."""
    x = prob.x0.copy()
    out = np.empty((prob.horizon, prob.ny))
    for k in range(prob.horizon):
        flow = u[k].copy()
        if event is not None and event[0] <= k < event[0] + event[1]:
            flow = flow - r[k]
        x = (
            prob.a_matrix @ x
            + prob.b_matrix @ flow
            + prob.e_matrix @ (prob.d_forecast[k] + w[k])
            + prob.g
        )
        out[k] = prob.c_matrix @ x
    return out


def _event_problem(seed: int, **overrides: Any) -> RMPCProblem:
    """A random small problem with reserve prices high enough that reserve is offered;
    ``overrides`` change its event model."""
    rng = np.random.default_rng(1000 + seed)
    n = int(rng.integers(3, 7))
    m = int(rng.integers(1, min(3, n) + 1))
    horizon = int(rng.integers(4, 9))
    fields: dict[str, Any] = dict(
        n=n,
        m=m,
        horizon=horizon,
        reserve_price_sgd_per_mwh=rng.uniform(20.0, 400.0, horizon),
        y_max=np.full((horizon, m), float(rng.uniform(25.0, 26.0))),
        events=ILEventModel(
            max_steps=int(rng.integers(1, horizon + 1)),
            recovery_steps=int(rng.integers(0, 3)),
            allowance_kelvin=float(rng.choice([0.0, 0.5, 1.0])),
            carry_steps=int(rng.integers(0, 3)),
        ),
    )
    prob = random_problem(seed, **fields)
    return _with_events(prob, **overrides) if overrides else prob


@pytest.mark.parametrize("seed", range(12))
def test_event_model_equals_brute_force_enumeration(seed: int) -> None:
    prob = _event_problem(seed)
    sol = solve_rmpc(prob)
    assert sol.status is SolveStatus.OPTIMAL, sol.message
    expected = _brute_force(prob)
    lp_objective = sol.objective_sgd + sol.tie_break_sgd
    assert lp_objective == pytest.approx(expected, rel=REL_TOL, abs=1e-7)
    # the plan itself is feasible in the brute-force model (checked by simulation)
    delta = _margins(prob)
    zero = np.zeros_like(prob.d_forecast)
    for event in [None, *_events(prob.horizon, _max_steps(prob))]:
        y = _outputs(prob, sol.u, sol.r, event, zero)
        widen = _upper_widening(prob, event)[:, None]
        assert (y + delta <= prob.y_max + widen + sol.slack + CONSTRAINT_TOL_K).all()
        assert (y - delta >= prob.y_min - sol.slack - CONSTRAINT_TOL_K).all()


def test_brute_force_cases_offer_reserve() -> None:
    """The comparison above is not vacuous: most cases carry reserve and use the allowance."""
    offered = [solve_rmpc(_event_problem(seed)).reserve_kw.sum() > 1e-6 for seed in range(12)]
    assert sum(offered) >= 8


@pytest.mark.parametrize("seed", range(6))
def test_plan_keeps_comfort_for_every_event_and_box_corner(seed: int) -> None:
    prob = _event_problem(seed, allowance_kelvin=1.0, recovery_steps=1)
    sol = solve_rmpc(prob)
    assert sol.ok and sol.reserve_kw.sum() > 0
    rng = np.random.default_rng(seed)
    sigma = prob.d_sigma
    corners = [sigma * rng.choice([-1.0, 1.0], size=sigma.shape) for _ in range(40)]
    # plus, per (output, zone), the corner that is worst for it: sign of C A^{t-1-j} E
    for k in range(prob.horizon):
        for i in range(prob.ny):
            w = np.zeros_like(sigma)
            for j in range(k + 1):
                h = prob.c_matrix[i] @ np.linalg.matrix_power(prob.a_matrix, k - j) @ prob.e_matrix
                w[j] = np.sign(h) * sigma[j]
            corners.append(w)
    worst_seen = np.full((prob.horizon, prob.ny), -np.inf)
    for event in [None, *_events(prob.horizon, _max_steps(prob))]:
        widen = _upper_widening(prob, event)[:, None]
        for w in corners:
            y = _outputs(prob, sol.u, sol.r, event, w)
            assert (y <= prob.y_max + widen + sol.slack + CONSTRAINT_TOL_K).all()
            assert (y >= prob.y_min - sol.slack - CONSTRAINT_TOL_K).all()
            worst_seen = np.maximum(worst_seen, y)
    # y_event_worst bounds every sampled output and is reached by a worst corner
    assert (worst_seen <= sol.y_event_worst + CONSTRAINT_TOL_K).all()
    np.testing.assert_allclose(worst_seen, sol.y_event_worst, atol=1e-6)


@pytest.mark.parametrize("seed", range(5))
def test_full_length_events_without_allowance_equal_the_whole_horizon_model(seed: int) -> None:
    base = random_problem(seed, reserve_price_sgd_per_mwh=np.full(8, 3000.0))
    whole = solve_rmpc(base)
    event = solve_rmpc(dataclasses.replace(base, events=ILEventModel(max_steps=8)))
    assert whole.ok and event.ok
    assert whole.reserve_kw.sum() > 0
    assert event.objective_sgd == pytest.approx(whole.objective_sgd, rel=1e-7)
    np.testing.assert_allclose(event.y_event_worst, whole.y_event_worst, atol=1e-6)
    np.testing.assert_allclose(event.x_curtailed, whole.x_curtailed, atol=1e-6)


def test_shorter_events_and_allowance_relax_the_problem() -> None:
    """Fewer or shorter events and a larger α give a larger feasible set: the objective falls
    monotonically, and D = 1 with α = 1 K offers more reserve than the whole-horizon model."""
    base = random_problem(3, reserve_price_sgd_per_mwh=np.full(8, 300.0))
    sols = {
        (d, alpha): solve_rmpc(
            dataclasses.replace(
                base, events=ILEventModel(max_steps=d, allowance_kelvin=alpha, recovery_steps=1)
            )
        )
        for d in (1, 4, 8)
        for alpha in (0.0, 1.0)
    }
    whole = solve_rmpc(base)
    objective = {key: sol.objective_sgd + sol.tie_break_sgd for key, sol in sols.items()}
    for alpha in (0.0, 1.0):
        assert objective[1, alpha] <= objective[4, alpha] + 1e-9 <= objective[8, alpha] + 2e-9
    for d in (1, 4, 8):
        assert objective[d, 1.0] <= objective[d, 0.0] + 1e-9
    assert objective[8, 0.0] <= whole.objective_sgd + whole.tie_break_sgd + 1e-9
    assert objective[1, 1.0] < objective[8, 0.0] - 1e-4
    assert sols[1, 1.0].reserve_kw.sum() > whole.reserve_kw.sum() + 1e-3


def test_carry_widens_the_served_band() -> None:
    """Outputs 1..c may use α even without reserve: the served plan saves energy there."""
    base = random_problem(
        4,
        reserve_mask=np.zeros(2, dtype=bool),
        x0=np.full(4, 25.8),
        y_max=np.full((8, 2), 25.0),
        events=ILEventModel(max_steps=2, allowance_kelvin=1.0),
    )
    strict = solve_rmpc(base)
    carried = solve_rmpc(_with_events(base, carry_steps=3))
    assert strict.ok and carried.ok
    assert carried.objective_sgd < strict.objective_sgd - 1e-6
    assert (strict.y_event_worst <= base.y_max + strict.slack + CONSTRAINT_TOL_K).all()
    assert (carried.y_event_worst[:3] <= base.y_max[:3] + 1.0 + carried.slack[:3] + 1e-6).all()


def test_event_rows_count_and_rotation_is_a_permutation() -> None:
    for horizon, d, r in ((8, 1, 0), (8, 3, 2), (12, 12, 0), (6, 2, 9)):
        rows = event_rows(horizon, 2, d, r)
        allowance = sum(min(d + r, t) for t in range(1, horizon + 1))
        strict = sum(max(0, t - r - 1) for t in range(1, horizon + 1))
        assert rows.num_rows == 2 * (allowance + strict)
        assert (rows.length >= 1).all() and (rows.length <= d).all()
        assert (rows.start + rows.length <= rows.step + 1).all()  # only inputs before t
        perm = event_rotation(rows)
        assert np.array_equal(np.sort(perm), np.arange(rows.num_rows))
        shifted = perm[rows.step < horizon - 1]
        kept = rows.step < horizon - 1
        assert np.array_equal(rows.step[shifted], rows.step[kept] + 1)
        assert np.array_equal(rows.start[shifted], rows.start[kept] + 1)


def _shifted_problems(steps: int, events: ILEventModel, horizon: int = 8) -> list[RMPCProblem]:
    """``steps`` problems of a receding horizon over one long random problem, with
    ``events`` (its carry c cycling 0, 1, 2)."""
    long = random_problem(7, horizon=horizon + steps)
    rng = np.random.default_rng(7)
    problems = []
    x0 = long.x0.copy()
    for step in range(steps):
        window = slice(step, step + horizon)
        problems.append(
            random_problem(
                7,
                horizon=horizon,
                x0=x0,
                d_forecast=long.d_forecast[window],
                d_sigma=long.d_sigma[window] * (1.0 + 0.1 * step),
                energy_price_sgd_per_mwh=long.energy_price_sgd_per_mwh[window],
                reserve_price_sgd_per_mwh=30.0 * long.reserve_price_sgd_per_mwh[window],
                power_offset_kw=long.power_offset_kw[window],
                power_coeff_kw_per_kg_s=long.power_coeff_kw_per_kg_s[window],
                events=dataclasses.replace(events, carry_steps=step % 3),
            )
        )
        x0 = x0 + rng.normal(0.0, 0.2, x0.shape)
    return problems


@pytest.mark.parametrize("mode", ["full", "lazy"])
@pytest.mark.parametrize("time_shift", [True, False])
def test_warm_started_event_solver_equals_cold_solves(time_shift: bool, mode: str) -> None:
    problems = _shifted_problems(
        10, ILEventModel(max_steps=2, recovery_steps=1, allowance_kelvin=0.5)
    )
    solver = RMPCSolver(problems[0], time_shift=time_shift, event_rows=mode)  # type: ignore[arg-type]
    zero = np.zeros((problems[0].horizon, problems[0].ny))
    assert solver.num_rows == build_lp(problems[0], zero)[1].num_rows
    for index, prob in enumerate(problems):
        warm = solver.solve(prob)
        cold = solve_rmpc(prob)
        assert warm.status is cold.status is SolveStatus.OPTIMAL
        assert warm.warm_start is (index > 0)
        assert warm.objective_sgd == pytest.approx(cold.objective_sgd, abs=1e-7)
        np.testing.assert_allclose(warm.power_kw, cold.power_kw, atol=1e-6)


def test_structure_holds_d_and_r_but_not_alpha_or_carry() -> None:
    prob = random_problem(1, events=ILEventModel(max_steps=2, recovery_steps=1))
    solver = RMPCSolver(prob)
    solver.solve(_with_events(prob, allowance_kelvin=1.0, carry_steps=2))
    for changed in (
        _with_events(prob, max_steps=3),
        _with_events(prob, recovery_steps=0),
        dataclasses.replace(prob, events=None),
    ):
        with pytest.raises(ProblemError, match="structure differs"):
            solver.solve(changed)
    other = _with_events(prob, max_steps=3)
    assert other.structure.fingerprint() != prob.structure.fingerprint()


def test_failed_solve_has_nan_worst_output() -> None:
    prob = random_problem(
        2,
        slack_max_kelvin=0.0,
        y_max=np.full((8, 2), 10.0),
        y_min=np.full((8, 2), 9.0),
        events=ILEventModel(max_steps=1),
    )
    sol = solve_rmpc(prob)
    assert not sol.ok
    assert sol.y_event_worst.shape == (8, 2) and np.isnan(sol.y_event_worst).all()


@pytest.mark.parametrize(
    ("fields", "field", "match"),
    [
        ({"max_steps": 0}, "events.max_steps", "value ≥ 1"),
        ({"max_steps": 2.0}, "events.max_steps", "integer"),
        ({"max_steps": True}, "events.max_steps", "integer"),
        ({"max_steps": 2, "allowance_kelvin": -0.5}, "events.allowance_kelvin", "≥ 0"),
        ({"max_steps": 2, "allowance_kelvin": float("nan")}, "events.allowance_kelvin", "finite"),
        ({"max_steps": 2, "recovery_steps": -1}, "events.recovery_steps", "value ≥ 0"),
        ({"max_steps": 2, "carry_steps": -1}, "events.carry_steps", "value ≥ 0"),
    ],
)
def test_event_model_is_validated_on_its_own(
    fields: dict[str, Any], field: str, match: str
) -> None:
    with pytest.raises(ProblemError, match=match) as info:
        ILEventModel(**fields)
    assert info.value.field == field


@pytest.mark.parametrize(
    ("events", "overrides", "field", "match"),
    [
        (ILEventModel(max_steps=9), {}, "events.max_steps", "1 ≤ value ≤ 8"),
        (ILEventModel(max_steps=2, carry_steps=9), {}, "events.carry_steps", "≤ 8"),
        (ILEventModel(max_steps=2), {"robust": "dual"}, "robust", "too large"),
        (ILEventModel(max_steps=2), {"robust": "feedback"}, "robust", "not supported"),
        ({"max_steps": 2}, {}, "events", "expected ILEventModel or None"),
    ],
)
def test_event_model_is_checked_against_the_problem(
    events: Any, overrides: dict[str, Any], field: str, match: str
) -> None:
    with pytest.raises(ProblemError, match=match) as info:
        random_problem(0, events=events, **overrides)
    assert info.value.field == field


def test_heating_reserve_is_refused_in_the_event_model() -> None:
    prob = random_problem(0)
    with pytest.raises(ProblemError, match="cooling reserve only") as info:
        dataclasses.replace(prob, b_matrix=-prob.b_matrix, events=ILEventModel(max_steps=2))
    assert info.value.field == "b_matrix"


@pytest.mark.parametrize(
    ("max_steps", "recovery", "alpha"), [(1, 0, 0.0), (2, 1, 0.5), (4, 2, 1.0)]
)
def test_lazy_event_rows_equal_the_full_model(max_steps: int, recovery: int, alpha: float) -> None:
    """Lazy row generation over a recorded sequence of 24 shifted problems: the same optimum
    as all event rows (1e-9 relative) with fewer rows in HiGHS, and the plan keeps every row."""
    problems = _shifted_problems(
        24,
        ILEventModel(max_steps=max_steps, recovery_steps=recovery, allowance_kelvin=alpha),
        horizon=12,
    )
    full = RMPCSolver(problems[0], event_rows="full")
    lazy = RMPCSolver(problems[0], event_rows="lazy")
    assert lazy.num_rows == full.num_rows
    fewer = 0
    for prob in problems:
        a, b = full.solve(prob), lazy.solve(prob)
        assert a.ok and b.ok
        assert b.objective_sgd + b.tie_break_sgd == pytest.approx(
            a.objective_sgd + a.tie_break_sgd, rel=1e-9, abs=1e-9
        )
        np.testing.assert_allclose(b.y_event_worst, a.y_event_worst, atol=1e-6)
        # the lazy plan keeps the worst event inside the widened band (all rows hold)
        assert (b.y_event_worst - b.slack <= prob.y_max + alpha + 1e-6).all()
        fewer += lazy.num_model_rows < full.num_model_rows
    assert fewer == len(problems) >= 20


def test_violated_rows_are_every_absent_row_over_the_tolerance() -> None:
    violation = np.array([0.5, 2e-7, -1.0, 1e-8, 3.0, 0.2])
    absent = np.array([True, True, True, True, False, True])
    # row 4 is violated most but already in the LP; row 3 is within the tolerance
    assert violated_rows(violation, absent, 1e-7).tolist() == [0, 1, 5]
    assert violated_rows(violation, absent, 1.0).size == 0


def test_lazy_basis_covers_every_row_and_resumes_a_full_solver() -> None:
    problems = _shifted_problems(6, ILEventModel(max_steps=2, recovery_steps=1))
    lazy = RMPCSolver(problems[0], event_rows="lazy")
    for prob in problems[:3]:
        lazy.solve(prob)
    basis = lazy.get_basis()
    assert basis is not None and basis.row_status.size == lazy.num_rows
    full = RMPCSolver(problems[0], event_rows="full")
    full.set_basis(basis)
    resumed = full.solve(problems[3])
    assert resumed.ok and resumed.warm_start
    assert resumed.objective_sgd == pytest.approx(solve_rmpc(problems[3]).objective_sgd, abs=1e-7)


def test_unknown_event_row_mode_is_refused() -> None:
    with pytest.raises(ProblemError, match="event row mode") as info:
        RMPCSolver(random_problem(0), event_rows="some")  # type: ignore[arg-type]
    assert info.value.field == "event_rows"


def test_recovery_allowance_decays_to_the_strict_band() -> None:
    """c = R = 2: α·2/3, α·1/3, then the strict band; one step later (c = 1) the same
    instant keeps its α/3; outside a recovery (c = 0) nothing widens the served plan."""
    np.testing.assert_allclose(carry_allowance(4, 1, 1.5, 2, 2)[:, 0], [1.0, 0.5, 0.0, 0.0])
    np.testing.assert_allclose(carry_allowance(4, 1, 1.5, 1, 2)[:, 0], [0.5, 0.0, 0.0, 0.0])
    assert not carry_allowance(4, 2, 1.5, 0, 2).any()


# ------------------------------------------------- offers paid for what the baselines see


def test_seen_offers_by_hand() -> None:
    """ρ = 0.5, D = 2, the plan's power 10, 12, 11, 15 kW, a shed of 1 kW each step."""
    baselines = OfferBaselines(
        meter_ratio=0.5,
        fixed_baseline_kw=np.array([20.0, np.nan, np.nan, 14.0]),
        fixed_on_plan_scale=np.array([True, False, False, False]),
        planned_baselines=np.array([True, True, True, True]),
    )
    seen = baselines.seen_kw(
        np.array([10.0, 12.0, 11.0, 15.0]), np.ones(4), np.array([5.0, 5.0, 5.0, 0.2]), 2
    )
    # 0: the plan's own baseline, ρ·(20 − 10) + ρ·1 = 5.5 ≥ the offer 5
    # 1: after 10 kW, ρ·(10 − 12) + 0.5 = −0.5 (a rise the shed does not cover)
    # 2: min(ρ·(12 − 11), ρ·(10 − 11)) + 0.5 = 0
    # 3: metered 14 − 15 + 0.5 = −0.5; ρ·(11 − 15) + 0.5 = −1.5; ρ·(12 − 15) + 0.5 = −1
    np.testing.assert_allclose(seen, [5.0, -0.5, 0.0, -1.5])


@pytest.mark.parametrize(
    ("fields", "field"),
    [
        ({"meter_ratio": 1.5}, "offer_baselines.meter_ratio"),
        ({"fixed_baseline_kw": np.array([1.0, np.inf])}, "offer_baselines.fixed_baseline_kw"),
        ({"planned_baselines": np.ones(3, dtype=bool)}, "offer_baselines.planned_baselines"),
    ],
)
def test_offer_baselines_are_validated(fields: dict[str, Any], field: str) -> None:
    values: dict[str, Any] = dict(
        meter_ratio=1.0,
        fixed_baseline_kw=np.full(2, np.nan),
        fixed_on_plan_scale=np.zeros(2, dtype=bool),
        planned_baselines=np.ones(2, dtype=bool),
    )
    values.update(fields)
    with pytest.raises(ProblemError) as caught:
        OfferBaselines(**values)
    assert caught.value.field == field


def test_offer_baselines_need_the_event_model_and_the_horizon() -> None:
    baselines = _random_baselines(np.random.default_rng(0), 8)
    with pytest.raises(ProblemError, match="event model"):
        random_problem(0, horizon=8, offer_baselines=baselines)
    with pytest.raises(ProblemError, match="cover 8 steps"):
        random_problem(0, horizon=6, events=ILEventModel(max_steps=2), offer_baselines=baselines)


def _random_baselines(rng: np.random.Generator, horizon: int) -> OfferBaselines:
    """Baselines of every kind: the plan's own, metered, none, nothing seen; some steps left
    out; some covered by a similar-days baseline."""
    fixed = rng.uniform(0.0, 6.0, horizon)
    kind = rng.integers(0, 4, horizon)
    fixed[kind == 2] = np.nan
    fixed[kind == 3] = -np.inf
    return OfferBaselines(
        meter_ratio=float(rng.choice([1.0, float(rng.uniform(0.3, 1.0))])),
        fixed_baseline_kw=fixed,
        fixed_on_plan_scale=(kind == 0),
        planned_baselines=rng.random(horizon) < 0.8,
        offer_steps=rng.random(horizon) < 0.85,
    )


def _baseline_problem(seed: int) -> RMPCProblem:
    rng = np.random.default_rng(500 + seed)
    base = _event_problem(seed)
    fixed_steps = int(rng.integers(0, 3))
    return dataclasses.replace(
        base,
        offer_baselines=_random_baselines(rng, base.horizon),
        commitments=ReserveCommitment(
            reserve_kg_s=np.full((min(fixed_steps, base.horizon - 1), base.m), 0.05)
        ),
    )


def test_baseline_cases_offer_and_bind() -> None:
    """The comparison below is not vacuous: most cases are paid for offers, and in every one
    the baselines cost the plan something against being paid q·r."""
    paid = bound = 0
    for seed in range(10):
        prob = _baseline_problem(seed)
        sol = solve_rmpc(prob)
        plain = solve_rmpc(dataclasses.replace(prob, offer_baselines=None))
        paid += bool((sol.reserve_kw > 1e-6).any())
        bound += sol.objective_sgd > plain.objective_sgd + 1e-4
    assert paid >= 8 and bound >= 9


@pytest.mark.filterwarnings("ignore:invalid value encountered in matmul:RuntimeWarning")
@pytest.mark.parametrize("seed", range(10))
def test_offers_paid_for_what_the_baselines_see_equal_the_brute_force(seed: int) -> None:
    """The LP's offer columns and rows (R, the unseen rise σ) against the definition written
    out with CVXPY's concave minimum: the same optimum, and R_k = max(0, what is seen)."""
    prob = _baseline_problem(seed)
    solver = RMPCSolver(prob)
    sol = solver.solve(prob)
    assert sol.status is SolveStatus.OPTIMAL, sol.message
    assert solver.highs_objective_sgd() == pytest.approx(_brute_force(prob), rel=REL_TOL, abs=1e-7)
    baselines = prob.offer_baselines
    assert baselines is not None
    seen = baselines.seen_kw(
        sol.power_kw,
        np.einsum("km,km->k", prob.power_coeff_kw_per_kg_s, sol.r),
        np.einsum("km,km->k", prob.reserve_kw_per_kg_s, sol.r),
        _model(prob).max_steps,
    )
    q_r = np.einsum("km,km->k", prob.reserve_kw_per_kg_s, sol.r)
    paid = baselines.offer_steps & ~np.isneginf(baselines.fixed_baseline_kw)
    paid &= (prob.reserve_kw_per_kg_s > 0).any(axis=1)
    g = prob.fixed_reserve_steps
    paid[:g] = False
    expected = np.where(paid, np.maximum(seen, 0.0), 0.0)
    expected[:g] = q_r[:g]  # the committed offers, sold before
    np.testing.assert_allclose(sol.reserve_kw, expected, atol=1e-6)
    assert sol.reserve_revenue_sgd == pytest.approx(
        prob.dt_h * prob.reserve_price_sgd_per_mwh @ sol.reserve_kw / 1000.0
    )


def test_baselines_that_see_everything_change_nothing() -> None:
    """No baseline binds (none fixed, none planned): the optimum is the q·r model's."""
    prob = _event_problem(3)
    horizon = prob.horizon
    free = OfferBaselines(
        meter_ratio=1.0,
        fixed_baseline_kw=np.full(horizon, np.nan),
        fixed_on_plan_scale=np.zeros(horizon, dtype=bool),
        planned_baselines=np.zeros(horizon, dtype=bool),
    )
    plain, visible = solve_rmpc(prob), solve_rmpc(dataclasses.replace(prob, offer_baselines=free))
    assert plain.reserve_kw.sum() > 1e-3  # not vacuous
    assert visible.objective_sgd == pytest.approx(plain.objective_sgd, rel=1e-9, abs=1e-9)
    np.testing.assert_allclose(visible.reserve_kw, plain.reserve_kw, atol=1e-6)


@pytest.mark.parametrize("mode", ["full", "lazy"])
def test_warm_started_solver_with_offer_baselines_equals_cold_solves(mode: str) -> None:
    """The offer columns and rows are time-indexed: the rotated basis stays valid."""
    rng = np.random.default_rng(11)
    problems = [
        dataclasses.replace(prob, offer_baselines=_random_baselines(rng, prob.horizon))
        for prob in _shifted_problems(
            8, ILEventModel(max_steps=2, recovery_steps=1, allowance_kelvin=0.5)
        )
    ]
    solver = RMPCSolver(problems[0], event_rows=mode)  # type: ignore[arg-type]
    for index, prob in enumerate(problems):
        warm, cold = solver.solve(prob), solve_rmpc(prob)
        assert warm.status is cold.status is SolveStatus.OPTIMAL
        assert warm.warm_start is (index > 0)
        assert warm.objective_sgd == pytest.approx(cold.objective_sgd, abs=1e-7)
    assert (
        problems[0].structure.fingerprint()
        != dataclasses.replace(problems[0], offer_baselines=None).structure.fingerprint()
    )


@pytest.mark.parametrize(("horizon", "max_steps"), [(6, 1), (6, 3), (6, 6), (7, None), (1, 1)])
def test_worst_event_output_equals_every_event_enumerated(
    horizon: int, max_steps: int | None
) -> None:
    """The worst output over every event (s, L ≤ D), summed by hand, with the served plan."""
    rng = np.random.default_rng(horizon * 10 + (max_steps or 0))
    ny, m_r = 2, 3
    responses = rng.uniform(0.0, 1.0, (horizon, ny, m_r))
    served = rng.normal(24.0, 1.0, (horizon, ny))
    reserve = rng.uniform(0.0, 2.0, (horizon, m_r))
    delta = rng.uniform(0.0, 0.3, (horizon, ny))
    d = max_steps or horizon
    expected = served.copy()
    for start in range(horizon):
        for length in range(1, d + 1):
            for k in range(horizon):  # output k + 1 sees the inputs j ≤ k
                inputs = range(start, min(start + length, k + 1))
                rise = sum((responses[k - j] @ reserve[j] for j in inputs), np.zeros(ny))
                expected[k] = np.maximum(expected[k], served[k] + rise)
    got = worst_event_output(responses, served, reserve, delta, max_steps)
    np.testing.assert_allclose(got, expected + delta, rtol=1e-12, atol=1e-12)


def test_event_row_bounds_by_hand_and_cached_arrays_are_read_only() -> None:
    rows = event_rows(3, 2, 2, 1)
    y_max = np.array([[25.0, 26.0], [25.5, 26.5], [24.0, 27.0]])
    delta = np.full((3, 2), 0.25)
    lower, upper = event_row_bounds(rows, y_max, delta, 1.5, 2, 1)
    carry = carry_allowance(3, 2, 1.5, 2, 1)
    for e in range(rows.num_rows):
        k, i = rows.step[e], rows.output[e]
        widening = 1.5 if rows.allowance[e] else carry[k, i]
        assert upper[e] == y_max[k, i] - 0.25 + widening
    assert np.isneginf(lower).all()
    np.testing.assert_array_equal(rows.flat_index, rows.step * 2 + rows.output)
    assert not carry.flags.writeable and not rows.flat_index.flags.writeable
