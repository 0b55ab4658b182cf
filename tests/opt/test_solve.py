"""The robust LP solved by HiGHS, against the dual form, an independent CVXPY model,
sampled disturbances and activation patterns, and the market logic of DESIGN §3."""

from __future__ import annotations

import dataclasses
import itertools
import pickle

import cvxpy as cp
import numpy as np
import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt import ILEventModel, RMPCProblem, RMPCSolver, SolveStatus, solve_rmpc
from hvacflex.opt.options import RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR
from hvacflex.opt.testing import random_problem

OBJECTIVE_TOL_SGD = 1e-5
CONSTRAINT_TOL_K = 1e-6


def _cvxpy_rmpc(prob: RMPCProblem) -> tuple[str, float]:
    """DESIGN §3 written independently: explicit matrix powers for δ, both trajectories,
    same reserve tie-break; solved with Clarabel (an interior-point solver, not HiGHS)."""
    a, b, e, c, g = prob.a_matrix, prob.b_matrix, prob.e_matrix, prob.c_matrix, prob.g
    horizon, n, m, ny = prob.horizon, prob.n, prob.m, prob.ny
    dt = prob.dt_h
    delta = np.zeros((horizon, ny))
    if prob.robust != "none":
        for k in range(1, horizon + 1):
            for j in range(k):
                impulse = c @ np.linalg.matrix_power(a, k - 1 - j) @ e
                delta[k - 1] += np.abs(impulse) @ prob.d_sigma[j]
    u = cp.Variable((horizon, m))
    r = cp.Variable((horizon, m))
    x = cp.Variable((horizon + 1, n))
    z = cp.Variable((horizon + 1, n))
    eps = cp.Variable((horizon, ny))
    beta = cp.Variable()
    mask = np.asarray(prob.reserve_mask)
    cons = [x[0] == prob.x0, z[0] == prob.x0, r >= 0, eps >= 0, beta >= 0]
    cons += [u - r >= prob.u_min, u <= prob.u_max]
    if (~mask).any():
        cons.append(r[:, ~mask] == 0)
    if prob.slack_max_kelvin is not None:
        cons.append(eps <= prob.slack_max_kelvin)
    power = []
    for k in range(horizon):
        drift = e @ prob.d_forecast[k] + g
        cons.append(x[k + 1] == a @ x[k] + b @ u[k] + drift)
        cons.append(z[k + 1] == a @ z[k] + b @ (u[k] - r[k]) + drift)
        for traj in (x, z):
            cons.append(c @ traj[k + 1] + delta[k] <= prob.y_max[k] + eps[k])
            cons.append(c @ traj[k + 1] - delta[k] >= prob.y_min[k] - eps[k])
        p_k = prob.power_offset_kw[k] + prob.power_coeff_kw_per_kg_s[k] @ u[k]
        power.append(p_k)
        cons.append(prob.phi[k] * p_k <= beta)
    cons.append(beta >= prob.phi[0] * prob.peak_floor_kw)
    energy = sum(dt * prob.energy_price_sgd_per_mwh[k] * power[k] / 1000 for k in range(horizon))
    revenue = sum(
        dt * prob.reserve_price_sgd_per_mwh[k] * (prob.power_coeff_kw_per_kg_s[k] @ r[k]) / 1000
        for k in range(horizon)
    )
    comfort = prob.comfort_penalty_sgd_per_kelvin_hour * dt * cp.sum(eps)
    tie = RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR * dt * cp.sum(r)
    model = cp.Problem(cp.Minimize(energy - revenue + comfort + beta + tie), cons)
    model.solve(solver=cp.CLARABEL)
    return str(model.status), float(model.value) if model.value is not None else np.nan


def _assert_cost_identity(sol, solver: RMPCSolver | None = None) -> None:  # type: ignore[no-untyped-def]
    parts = (
        sol.energy_cost_sgd
        - sol.reserve_revenue_sgd
        + sol.comfort_penalty_sgd
        + sol.peak_charge_sgd
    )
    assert sol.objective_sgd == pytest.approx(parts, abs=1e-9)
    if solver is not None:
        assert solver.highs_objective_sgd() == pytest.approx(
            sol.objective_sgd + sol.tie_break_sgd, abs=1e-6
        )


@pytest.mark.parametrize("seed", range(6))
def test_tightening_equals_dual_equals_cvxpy(seed: int) -> None:
    prob = random_problem(
        seed, peak_floor_kw=2.0 + seed, reserve_price_sgd_per_mwh=np.full(8, 400.0)
    )
    assert np.abs(prob.g).max() > 0
    solver = RMPCSolver(prob)
    tight = solver.solve(prob)
    assert tight.status is SolveStatus.OPTIMAL, tight.message
    _assert_cost_identity(tight, solver)
    dual = solve_rmpc(dataclasses.replace(prob, robust="dual"))
    assert dual.status is SolveStatus.OPTIMAL
    assert dual.objective_sgd == pytest.approx(tight.objective_sgd, abs=OBJECTIVE_TOL_SGD)
    np.testing.assert_allclose(dual.delta, tight.delta)
    status, value = _cvxpy_rmpc(prob)
    assert status == "optimal"
    assert value == pytest.approx(tight.objective_sgd + tight.tie_break_sgd, abs=OBJECTIVE_TOL_SGD)


@pytest.mark.parametrize("seed", range(6))
def test_hard_comfort_feasibility_agrees_with_cvxpy(seed: int) -> None:
    prob = random_problem(seed, slack_max_kelvin=0.0, d_sigma=np.full(3, 0.8 + 0.1 * seed))
    sol = solve_rmpc(prob)
    dual = solve_rmpc(dataclasses.replace(prob, robust="dual"))
    status, value = _cvxpy_rmpc(prob)
    assert sol.status is dual.status
    if status == "optimal":
        assert sol.status is SolveStatus.OPTIMAL
        assert value == pytest.approx(sol.objective_sgd + sol.tie_break_sgd, abs=OBJECTIVE_TOL_SGD)
    else:
        assert status == "infeasible"
        assert sol.status is SolveStatus.INFEASIBLE


def test_nominal_mode_has_no_margin_and_costs_less() -> None:
    prob = random_problem(3)
    robust = solve_rmpc(prob)
    nominal = solve_rmpc(dataclasses.replace(prob, robust="none"))
    assert np.all(nominal.delta == 0) and robust.delta.max() > 0
    assert nominal.objective_sgd <= robust.objective_sgd + 1e-9
    _, value = _cvxpy_rmpc(dataclasses.replace(prob, robust="none"))
    assert value == pytest.approx(nominal.objective_sgd + nominal.tie_break_sgd, abs=1e-5)


@pytest.mark.parametrize("seed", range(4))
def test_plan_is_robust_to_sampled_disturbances_and_activations(seed: int) -> None:
    prob = random_problem(seed, reserve_price_sgd_per_mwh=np.full(8, 3000.0))
    sol = solve_rmpc(prob)
    assert sol.ok and sol.r.sum() > 0.1
    rng = np.random.default_rng(100 + seed)
    horizon, nd, m = prob.horizon, prob.nd, prob.m
    samples = 400
    for sample in range(samples):
        if sample % 2:
            w = rng.uniform(-1.0, 1.0, (horizon, nd)) * prob.d_sigma
        else:  # box corners
            w = rng.choice([-1.0, 1.0], (horizon, nd)) * prob.d_sigma
        if sample % 3 == 0:
            activation = rng.random((horizon, 1)) < 0.5  # whole-building activation per step
        else:
            activation = rng.random((horizon, m)) < 0.5  # per input
        applied = sol.u - activation * sol.r
        x = prob.x0.copy()
        for k in range(horizon):
            x = (
                prob.a_matrix @ x
                + prob.b_matrix @ applied[k]
                + prob.e_matrix @ (prob.d_forecast[k] + w[k])
                + prob.g
            )
            y = prob.c_matrix @ x
            assert np.all(y <= prob.y_max[k] + sol.slack[k] + CONSTRAINT_TOL_K)
            assert np.all(y >= prob.y_min[k] - sol.slack[k] - CONSTRAINT_TOL_K)


def test_worst_case_corner_reaches_an_active_bound() -> None:
    prob = random_problem(1, reserve_price_sgd_per_mwh=np.full(8, 3000.0))
    sol = solve_rmpc(prob)
    y_curtailed = sol.x_curtailed[1:] @ prob.c_matrix.T
    gap = prob.y_max - sol.slack - (y_curtailed + sol.delta)
    k, i = np.unravel_index(np.argmin(gap), gap.shape)
    assert gap[k, i] == pytest.approx(0.0, abs=1e-7)  # the bound is active somewhere
    # the adversarial disturbance for that row realises exactly δ
    w = np.zeros((prob.horizon, prob.nd))
    for j in range(k + 1):
        impulse = prob.c_matrix[i] @ np.linalg.matrix_power(prob.a_matrix, k - j) @ prob.e_matrix
        w[j] = np.sign(impulse) * prob.d_sigma[j]
    x = prob.x0.copy()
    for step in range(k + 1):
        x = (
            prob.a_matrix @ x
            + prob.b_matrix @ (sol.u[step] - sol.r[step])
            + prob.e_matrix @ (prob.d_forecast[step] + w[step])
            + prob.g
        )
    assert prob.c_matrix[i] @ x == pytest.approx(prob.y_max[k, i] + sol.slack[k, i], abs=1e-6)


def test_no_reserve_without_reserve_price() -> None:
    prob = random_problem(1, reserve_price_sgd_per_mwh=np.zeros(8))
    sol = solve_rmpc(prob)
    assert sol.ok
    assert np.all(sol.r <= 1e-9) and np.all(sol.reserve_kw <= 1e-8)
    assert sol.reserve_revenue_sgd == pytest.approx(0.0, abs=1e-12)


def test_reserve_grows_with_price_until_comfort_or_minimum_flow_binds() -> None:
    base = random_problem(2)
    revenue_weight = []
    for scale in (0.0, 1.0, 10.0, 100.0, 1000.0):
        prob = dataclasses.replace(
            base, reserve_price_sgd_per_mwh=scale * base.reserve_price_sgd_per_mwh
        )
        sol = solve_rmpc(prob)
        assert sol.ok
        revenue_weight.append(float(base.reserve_price_sgd_per_mwh @ sol.reserve_kw))
    assert all(b >= a - 1e-6 for a, b in itertools.pairwise(revenue_weight))
    assert revenue_weight[-1] > revenue_weight[0] + 1.0
    # at a very high price every step with reserve room left is limited by curtailed comfort
    prob = dataclasses.replace(base, reserve_price_sgd_per_mwh=np.full(8, 1e5))
    sol = solve_rmpc(prob)
    y_curtailed = sol.x_curtailed[1:] @ prob.c_matrix.T
    tight_upper = y_curtailed + sol.delta >= prob.y_max + sol.slack - 1e-6
    for k in range(prob.horizon):
        room = sol.u[k] - sol.r[k] - prob.u_min[k]
        if np.any(room > 1e-6):
            assert tight_upper[k:].any(), f"step {k}: reserve could grow"


def test_masked_inputs_never_carry_reserve() -> None:
    prob = random_problem(
        3, reserve_price_sgd_per_mwh=np.full(8, 3000.0), reserve_mask=np.array([True, False])
    )
    sol = solve_rmpc(prob)
    assert sol.ok
    assert np.all(sol.r[:, 1] == 0.0)
    assert sol.r[:, 0].sum() > 0.1
    np.testing.assert_allclose(
        sol.reserve_kw, prob.power_coeff_kw_per_kg_s[:, 0] * sol.r[:, 0], atol=1e-12
    )


def test_peak_is_monotone_in_peak_price() -> None:
    base = random_problem(4, reserve_price_sgd_per_mwh=np.full(8, 50.0))
    peaks = []
    for phi in (0.0, 0.1, 0.5, 1.0, 1.5, 3.0, 5.0, 10.0, 30.0):
        sol = solve_rmpc(dataclasses.replace(base, peak_price_sgd_per_kw=phi))
        assert sol.ok
        _assert_cost_identity(sol)
        assert sol.peak_charge_sgd == pytest.approx(phi * sol.peak_kw, abs=1e-6)
        peaks.append(sol.peak_kw)
    assert all(b <= a + 1e-6 for a, b in itertools.pairwise(peaks))
    assert peaks[-1] < peaks[0] - 0.1


def test_time_varying_peak_price() -> None:
    phi = np.linspace(0.0, 3.0, 8)
    sol = solve_rmpc(random_problem(5, peak_price_sgd_per_kw=phi))
    assert sol.ok
    assert sol.peak_charge_sgd == pytest.approx(float(np.max(phi * sol.power_kw)), abs=1e-6)


def test_peak_floor_above_unconstrained_peak_leaves_plan_unchanged() -> None:
    free = solve_rmpc(random_problem(4, peak_price_sgd_per_kw=0.0))
    floor_kw = free.peak_kw + 5.0
    floored = solve_rmpc(random_problem(4, peak_price_sgd_per_kw=1.5, peak_floor_kw=floor_kw))
    assert floored.ok
    assert floored.peak_charge_sgd == pytest.approx(1.5 * floor_kw, abs=1e-9)
    assert floored.energy_cost_sgd == pytest.approx(free.energy_cost_sgd, abs=1e-7)
    assert floored.reserve_revenue_sgd == pytest.approx(free.reserve_revenue_sgd, abs=1e-7)
    np.testing.assert_allclose(floored.u, free.u, atol=1e-6)
    np.testing.assert_allclose(floored.r, free.r, atol=1e-6)


def test_infeasible_hard_comfort_is_reported_not_raised() -> None:
    prob = random_problem(0, y_min=np.full(2, 14.0), y_max=np.full(2, 15.0), slack_max_kelvin=0.0)
    sol = solve_rmpc(prob)
    assert sol.status is SolveStatus.INFEASIBLE and not sol.ok
    assert "infeasible" in sol.message and "slack_max_kelvin" in sol.message
    for array in (sol.u, sol.r, sol.power_kw, sol.x_served, sol.slack):
        assert np.isnan(array).all()
    assert np.isnan(sol.objective_sgd)
    # the same band with soft comfort is solved, with slack
    soft = solve_rmpc(dataclasses.replace(prob, slack_max_kelvin=None))
    assert soft.ok and soft.comfort_penalty_sgd > 0 and soft.slack.max() > 1.0


def test_time_limit_is_reported() -> None:
    big = random_problem(0, n=8, m=3, nd=3, horizon=24, robust="dual")
    sol = solve_rmpc(big, time_limit_s=1e-6)
    assert sol.status is SolveStatus.TIME_LIMIT
    assert "time limit" in sol.message
    assert np.isnan(sol.u).all()
    with pytest.raises(ProblemError, match="time limit"):
        RMPCSolver(big, time_limit_s=0.0)


def test_time_limit_is_per_solve_not_cumulative() -> None:
    """Regression: HiGHS measures ``time_limit`` on the Highs object's cumulative run clock;
    once the solves added up to the limit, every later solve hit TIME_LIMIT in a few ms."""
    limit_s = 0.5  # far above one solve (~2 ms), even on a loaded 2-core machine
    base = random_problem(0, n=8, m=3, nd=3, horizon=24)
    solver = RMPCSolver(base, time_limit_s=limit_s)
    rng = np.random.default_rng(0)
    total_s, solves = 0.0, 0
    while total_s < 3 * limit_s and solves < 5000:
        prob = dataclasses.replace(
            base,
            x0=base.x0 + rng.normal(0.0, 0.5, base.n),
            energy_price_sgd_per_mwh=rng.uniform(50.0, 300.0, base.horizon),
            reserve_price_sgd_per_mwh=rng.uniform(0.0, 500.0, base.horizon),
        )
        sol = solver.solve(prob)
        assert sol.status is SolveStatus.OPTIMAL, f"solve {solves}: {sol.message}"
        total_s += sol.highs_time_s
        solves += 1
    assert total_s >= 3 * limit_s  # the solves together ran well past the per-solve limit


def _shifted_problems(seed: int, steps: int, horizon: int = 8) -> list[RMPCProblem]:
    """Consecutive receding-horizon problems cut from one long random series."""
    long = random_problem(seed, horizon=horizon + steps)
    rng = np.random.default_rng(seed)
    problems = []
    x0 = long.x0.copy()
    for step in range(steps):
        window = slice(step, step + horizon)
        problems.append(
            dataclasses.replace(
                random_problem(seed, horizon=horizon),
                x0=x0,
                d_forecast=long.d_forecast[window],
                d_sigma=long.d_sigma[window] * (1.0 + 0.1 * step),
                energy_price_sgd_per_mwh=long.energy_price_sgd_per_mwh[window],
                reserve_price_sgd_per_mwh=30.0 * long.reserve_price_sgd_per_mwh[window],
                power_offset_kw=long.power_offset_kw[window],
                power_coeff_kw_per_kg_s=long.power_coeff_kw_per_kg_s[window],
                peak_price_sgd_per_kw=float(step % 3),
            )
        )
        x0 = x0 + rng.normal(0.0, 0.2, x0.shape)
    return problems


@pytest.mark.parametrize(
    ("robust", "time_shift"), [("tightening", True), ("dual", True), ("tightening", False)]
)
def test_warm_started_solver_equals_cold_solves(robust: str, time_shift: bool) -> None:
    problems = [dataclasses.replace(p, robust=robust) for p in _shifted_problems(7, 12)]
    solver = RMPCSolver(problems[0], time_shift=time_shift)
    for index, prob in enumerate(problems):
        warm = solver.solve(prob)
        cold = solve_rmpc(prob)
        assert warm.status is cold.status is SolveStatus.OPTIMAL
        assert warm.warm_start is (index > 0)
        assert warm.objective_sgd == pytest.approx(cold.objective_sgd, abs=1e-7)
        np.testing.assert_allclose(warm.power_kw, cold.power_kw, atol=1e-6)
        _assert_cost_identity(warm, solver)


def test_basis_survives_pickling() -> None:
    problems = _shifted_problems(8, 3)
    solver = RMPCSolver(problems[0])
    solver.solve(problems[0])
    solver.solve(problems[1])
    basis = solver.get_basis()
    assert basis is not None
    restored = pickle.loads(pickle.dumps(basis))
    fresh = RMPCSolver(problems[2])
    fresh.set_basis(restored)
    resumed = fresh.solve(problems[2])
    reference = solver.solve(problems[2])
    assert resumed.warm_start
    assert resumed.objective_sgd == pytest.approx(reference.objective_sgd, abs=1e-7)
    assert resumed.simplex_iterations <= solve_rmpc(problems[2]).simplex_iterations
    other = RMPCSolver(random_problem(8, horizon=6))
    with pytest.raises(ProblemError, match="another problem structure"):
        other.set_basis(restored)


def test_saved_basis_is_the_optimal_basis() -> None:
    """The basis read back after a solve (basic list + values) is HiGHS's optimal basis:
    restored into a fresh solver without rotation, the same problem needs no iteration."""
    prob = random_problem(5, reserve_price_sgd_per_mwh=np.full(8, 3000.0))
    solver = RMPCSolver(prob)
    first = solver.solve(prob)
    basis = solver.get_basis()
    assert basis is not None
    assert (
        np.count_nonzero(basis.col_status == 1) + np.count_nonzero(basis.row_status == 1)
        == solver.num_rows
    )
    fresh = RMPCSolver(prob, time_shift=False)
    fresh.set_basis(basis)
    again = fresh.solve(prob)
    assert again.warm_start and again.simplex_iterations == 0
    assert again.objective_sgd == pytest.approx(first.objective_sgd, abs=1e-9)


def test_rotated_basis_restarts_a_shifted_sequence_cheaply() -> None:
    """Over consecutive receding-horizon problems the rotated basis needs fewer iterations
    than the basis of the previous step taken position by position."""
    problems = _shifted_problems(9, 16, horizon=24)
    totals = {}
    for time_shift in (True, False):
        solver = RMPCSolver(problems[0], time_shift=time_shift)
        solutions = [solver.solve(prob) for prob in problems]
        assert all(sol.ok for sol in solutions)
        totals[time_shift] = sum(sol.simplex_iterations for sol in solutions[1:])
    assert totals[True] < totals[False]


def test_same_step_resolve_keeps_the_basis_unrotated() -> None:
    """A re-solve of the step just solved (``same_step``, as the fleet coordinator's rounds)
    goes on from HiGHS's optimal basis: no iteration for the same problem, and a price change
    gives the cold optimum; the next step's first solve is rotated as usual."""
    problems = _shifted_problems(10, 3, horizon=24)
    solver = RMPCSolver(problems[0])
    solver.solve(problems[0])
    first = solver.solve(problems[1])
    again = solver.solve(problems[1], same_step=True)
    assert again.warm_start and again.simplex_iterations == 0
    assert again.objective_sgd == pytest.approx(first.objective_sgd, abs=1e-9)
    rotated = solver.solve(problems[1])  # without same_step: the basis one step on
    assert rotated.simplex_iterations > 0
    priced = dataclasses.replace(
        problems[1], energy_price_sgd_per_mwh=problems[1].energy_price_sgd_per_mwh + 40.0
    )
    resolved = solver.solve(priced, same_step=True)
    assert resolved.objective_sgd == pytest.approx(solve_rmpc(priced).objective_sgd, abs=1e-7)
    nxt = solver.solve(problems[2])
    assert nxt.objective_sgd == pytest.approx(solve_rmpc(problems[2]).objective_sgd, abs=1e-7)


def test_set_basis_refuses_a_non_basis() -> None:
    problems = _shifted_problems(8, 2)
    solver = RMPCSolver(problems[0])
    solver.solve(problems[0])
    basis = solver.get_basis()
    assert basis is not None
    col_status = basis.col_status.copy()
    col_status[col_status == 1] = 0  # no basic column left
    broken = dataclasses.replace(basis, col_status=col_status)
    with pytest.raises(ProblemError, match="not a simplex basis"):
        RMPCSolver(problems[1]).set_basis(broken)


def test_solver_refuses_another_structure() -> None:
    solver = RMPCSolver(random_problem(0))
    with pytest.raises(ProblemError, match="a_matrix"):
        solver.solve(random_problem(1))
    with pytest.raises(ProblemError, match="robust"):
        solver.solve(random_problem(0, robust="none"))


def test_solution_shapes_and_units() -> None:
    prob = random_problem(6)
    solver = RMPCSolver(prob)
    sol = solver.solve(prob)
    horizon, n, m, ny = prob.horizon, prob.n, prob.m, prob.ny
    assert sol.u.shape == sol.r.shape == (horizon, m)
    assert sol.power_kw.shape == sol.reserve_kw.shape == (horizon,)
    assert sol.slack.shape == sol.delta.shape == (horizon, ny)
    assert sol.x_served.shape == sol.x_curtailed.shape == (horizon + 1, n)
    np.testing.assert_array_equal(sol.x_served[0], prob.x0)
    np.testing.assert_allclose(
        sol.power_kw,
        prob.power_offset_kw + np.sum(prob.power_coeff_kw_per_kg_s * sol.u, axis=1),
    )
    assert sol.peak_kw == pytest.approx(sol.power_kw.max())
    assert sol.energy_cost_sgd == pytest.approx(
        float(np.sum(prob.dt_h * prob.energy_price_sgd_per_mwh * sol.power_kw) / 1000)
    )
    assert 0 < sol.highs_time_s <= sol.solve_time_s
    assert solver.num_cols == 2 * horizon * n + 2 * horizon * m + horizon * ny + horizon + 1
    # served trajectory obeys the nominal dynamics
    for k in range(horizon):
        expected = (
            prob.a_matrix @ sol.x_served[k]
            + prob.b_matrix @ sol.u[k]
            + prob.e_matrix @ prob.d_forecast[k]
            + prob.g
        )
        np.testing.assert_allclose(sol.x_served[k + 1], expected, atol=1e-7)


def test_a_failed_warm_start_retries_from_the_unrotated_basis(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A solver error from the rotated basis (a numerically singular start) is retried from
    the previous basis unrotated, still warm, before any cold solve."""
    problems = _shifted_problems(9, 3)
    solver = RMPCSolver(problems[0])
    solver.solve(problems[0])
    solver.solve(problems[1])
    run = solver._session.run
    shifts: list[bool] = []
    start_from = solver._start_from

    def record_start(*, shift: bool = True) -> bool:
        shifts.append(shift)
        return start_from(shift=shift)

    def fail_first(warm: bool) -> tuple[float, SolveStatus]:
        if not shifts[1:]:
            return 0.0, SolveStatus.ERROR
        return run(warm)

    monkeypatch.setattr(solver._session, "run", fail_first)
    monkeypatch.setattr(solver, "_start_from", record_start)
    retried = solver.solve(problems[2])
    assert shifts == [True, False]
    assert retried.status is SolveStatus.OPTIMAL and retried.warm_start
    assert retried.objective_sgd == pytest.approx(solve_rmpc(problems[2]).objective_sgd, abs=1e-7)


@pytest.mark.parametrize("robust", ["tightening", "feedback"])
def test_make_solver_builds_the_solver_of_the_robust_mode_with_its_options(robust: str) -> None:
    from hvacflex.opt import FeedbackSolver, make_solver

    if robust == "feedback":
        problems = [random_problem(11, robust="feedback")] * 3  # re-solved: no time shift
    else:
        problems = _shifted_problems(11, 3)
    expected_class = FeedbackSolver if robust == "feedback" else RMPCSolver
    made = make_solver(problems[0], time_shift=False, feasibility_tolerance=1e-10)
    direct = expected_class(problems[0], time_shift=False, feasibility_tolerance=1e-10)
    assert type(made) is expected_class
    for problem in problems:
        a, b = made.solve(problem), direct.solve(problem)
        assert a.status is b.status is SolveStatus.OPTIMAL
        assert a.objective_sgd == b.objective_sgd
        assert a.simplex_iterations == b.simplex_iterations
        assert a.warm_start == b.warm_start
    highs = made._session.highs
    assert highs.getOptionValue("primal_feasibility_tolerance")[1] == 1e-10
    with pytest.raises(ProblemError, match="time limit"):
        make_solver(problems[0], time_limit_s=0.0)


@pytest.mark.parametrize("max_steps", [None, 2])
def test_warm_runs_price_as_measured_for_the_lp_family(max_steps: int | None) -> None:
    """The event model's warm runs price with Dantzig, the whole-horizon model's with Devex
    (highs_lp.WARM_PRICING, chosen by benchmarks/bench_pricing.py); both reach the cold
    optimum from the rotated basis."""
    from hvacflex.opt.highs_lp import DANTZIG_PRICING, DEVEX_PRICING

    problems = [
        dataclasses.replace(
            p, events=None if max_steps is None else ILEventModel(max_steps=max_steps)
        )
        for p in _shifted_problems(3, 4)
    ]
    solver = RMPCSolver(problems[0])
    for index, problem in enumerate(problems):
        warm = solver.solve(problem)
        cold = solve_rmpc(problem)
        assert warm.ok and cold.ok and warm.warm_start is (index > 0)
        assert warm.objective_sgd == pytest.approx(cold.objective_sgd, abs=1e-7)
    used = solver._session.highs.getOptionValue("simplex_dual_edge_weight_strategy")[1]
    assert used == (DEVEX_PRICING if max_steps is None else DANTZIG_PRICING)


# ---------------------------------------------------------------- moving rows


def _offer_problems(steps: int) -> list[RMPCProblem]:
    """Shifted event-model problems (D = 2, R = 1) whose offers are paid for what the
    baselines see, with a meter ratio that changes every step: every kind of step-varying
    coefficient (p_k, φ_k, q_k, ρ·p_k, ρ) moves."""
    from hvacflex.opt import OfferBaselines

    rng = np.random.default_rng(63)
    problems = []
    for step, prob in enumerate(_shifted_problems(11, steps, horizon=10)):
        fixed = rng.uniform(0.0, 6.0, prob.horizon)
        fixed[rng.random(prob.horizon) < 0.3] = np.nan
        problems.append(
            dataclasses.replace(
                prob,
                events=ILEventModel(max_steps=2, recovery_steps=1, allowance_kelvin=0.5),
                peak_price_sgd_per_kw=np.linspace(1.0, 0.5 + 0.1 * (step % 3), prob.horizon),
                offer_baselines=OfferBaselines(
                    meter_ratio=0.6 + 0.05 * (step % 4),
                    fixed_baseline_kw=fixed,
                    fixed_on_plan_scale=rng.random(prob.horizon) < 0.5,
                    planned_baselines=rng.random(prob.horizon) < 0.8,
                ),
            )
        )
    return problems


def test_moving_rows_leave_highs_the_lp_built_from_scratch() -> None:
    """After each warm solve (a same-step re-solve among them), HiGHS holds, row for row in
    its order, the rows of the LP built from scratch for that problem: the moving rows
    re-added in one block carry the step's coefficients and bounds."""
    import highspy
    from scipy import sparse

    from hvacflex.opt.lp import build_lp, sparse_matrix

    problems = _offer_problems(6)
    solver = RMPCSolver(problems[0])
    assert solver._held.moving is not None  # the product LP's family replaces its moving rows
    for index, prob in enumerate(problems):
        assert solver.solve(prob).ok
        if index == 3:
            priced = dataclasses.replace(prob, peak_price_sgd_per_kw=prob.phi * 0.9)
            assert solver.solve(priced, same_step=True).ok
            prob = priced
        lp, _ = build_lp(prob, solver._tightening(prob, solver._delta(prob)))
        assert lp.constant is not None
        expected = sparse_matrix(lp, lp.constant, keep_varying_zeros=False, csc=False)
        rows = solver._held.model_rows
        held = solver._highs.getLp()
        assert held.a_matrix_.format_ == highspy.MatrixFormat.kColwise
        matrix = sparse.csc_matrix(
            (
                np.asarray(held.a_matrix_.value_),
                np.asarray(held.a_matrix_.index_),
                np.asarray(held.a_matrix_.start_),
            ),
            shape=(held.num_row_, held.num_col_),
        )
        assert (abs(matrix - expected[rows]) > 1e-12).nnz == 0
        np.testing.assert_array_equal(np.asarray(held.row_lower_), lp.row_lower[rows])
        np.testing.assert_array_equal(np.asarray(held.row_upper_), lp.row_upper[rows])


def test_moving_rows_take_the_path_of_per_coefficient_changes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The same sequence with the moving coefficients changed one by one (``changeCoeff``):
    the same iterations and optima, since HiGHS holds the same LP in the same row order."""
    import hvacflex.opt.held_rows as held_rows

    problems = _offer_problems(8)
    replaced = RMPCSolver(problems[0])
    monkeypatch.setattr(held_rows, "MOVING_ROWS_MAX_NONZEROS_PER_VARYING", 0.0)
    one_by_one = RMPCSolver(problems[0])
    assert replaced._held.moving is not None and one_by_one._held.moving is None
    for prob in problems:
        a, b = replaced.solve(prob), one_by_one.solve(prob)
        assert a.ok and b.ok
        assert a.simplex_iterations == b.simplex_iterations
        assert a.objective_sgd == pytest.approx(b.objective_sgd, rel=1e-12, abs=1e-12)
        np.testing.assert_allclose(a.u, b.u, atol=1e-9)
        assert a.objective_sgd == pytest.approx(solve_rmpc(prob).objective_sgd, abs=1e-7)
