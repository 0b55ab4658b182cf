"""Affine disturbance-feedback RMPC (``robust="feedback"``, :mod:`hvacflex.opt.feedback`)."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt import FeedbackOptions, FeedbackSolver, RMPCSolution, SolveStatus, solve_rmpc
from hvacflex.opt.options import FEEDBACK_STRUCTURES
from hvacflex.opt.testing import random_problem

SEEDS = range(6)
OBJECTIVE_TOL_SGD = 1e-6
STATE_TOL_K = 1e-6
FLOW_TOL_KG_S = 1e-6


def _feedback(seed: int, structure: str, **overrides: Any) -> RMPCSolution:
    options = FeedbackOptions(
        structure=structure,  # type: ignore[arg-type]
        memory_steps=int(overrides.pop("memory_steps", 2)),
        zero_gains=bool(overrides.pop("zero_gains", False)),
    )
    return solve_rmpc(random_problem(seed, robust="feedback", feedback=options, **overrides))


@pytest.mark.parametrize("structure", FEEDBACK_STRUCTURES)
@pytest.mark.parametrize("seed", SEEDS)
def test_zero_sigma_equals_open_loop(seed: int, structure: str) -> None:
    sigma = np.zeros((8, 3))
    open_loop = solve_rmpc(random_problem(seed, d_sigma=sigma, robust="none"))
    closed = _feedback(seed, structure, d_sigma=sigma)
    assert open_loop.status is closed.status is SolveStatus.OPTIMAL
    assert closed.objective_sgd == pytest.approx(open_loop.objective_sgd, abs=OBJECTIVE_TOL_SGD)
    np.testing.assert_allclose(closed.delta, 0.0, atol=1e-12)


@pytest.mark.parametrize("structure", FEEDBACK_STRUCTURES)
@pytest.mark.parametrize("seed", SEEDS)
def test_zero_gains_equal_open_loop_rmpc(seed: int, structure: str) -> None:
    open_loop = solve_rmpc(random_problem(seed, robust="tightening"))
    closed = _feedback(seed, structure, zero_gains=True)
    assert closed.ok
    assert closed.objective_sgd == pytest.approx(open_loop.objective_sgd, abs=OBJECTIVE_TOL_SGD)
    np.testing.assert_allclose(closed.delta, open_loop.delta, atol=1e-9)
    assert closed.feedback_gains is not None
    assert not closed.feedback_gains.any()


@pytest.mark.parametrize("seed", SEEDS)
def test_never_worse_than_open_loop_and_full_is_best(seed: int) -> None:
    sigma = random_problem(seed).d_sigma * 2.0  # large enough that margins bind
    open_loop = solve_rmpc(random_problem(seed, d_sigma=sigma))
    results = {s: _feedback(seed, s, d_sigma=sigma) for s in FEEDBACK_STRUCTURES}
    for structure, sol in results.items():
        assert sol.ok, structure
        assert sol.objective_sgd <= open_loop.objective_sgd + OBJECTIVE_TOL_SGD, structure
    # every other structure's policies are special cases of the full causal policy
    for structure in ("memory", "zone-local", "time-invariant"):
        assert results["full"].objective_sgd <= results[structure].objective_sgd + 1e-6


def _simulate(
    seed: int, sol: RMPCSolution, w: np.ndarray, active: np.ndarray, **overrides: Any
) -> tuple[np.ndarray, np.ndarray]:
    """Apply the policy causally on the linear model: outputs (N, ny) and applied flows (N, m)."""
    prob = random_problem(seed, **overrides)
    gains = sol.feedback_gains
    assert gains is not None
    x = prob.x0.copy()
    outputs, flows = [], []
    for k in range(prob.horizon):
        u = sol.u[k] + np.einsum("jml,jl->m", gains[k, :k], w[:k])
        applied = u - active[k] * sol.r[k]
        x = (
            prob.a_matrix @ x
            + prob.b_matrix @ applied
            + prob.e_matrix @ (prob.d_forecast[k] + w[k])
            + prob.g
        )
        outputs.append(prob.c_matrix @ x)
        flows.append((u, applied))
    return np.array(outputs), np.array(flows)


@pytest.mark.parametrize("structure", FEEDBACK_STRUCTURES)
@pytest.mark.parametrize("seed", range(4))
def test_sampled_robustness(seed: int, structure: str) -> None:
    rng = np.random.default_rng(100 + seed)
    overrides: dict[str, Any] = {"peak_price_sgd_per_kw": 1.5}
    sol = _feedback(seed, structure, **overrides)
    assert sol.ok
    prob = random_problem(seed, **overrides)
    sigma = prob.d_sigma
    horizon = prob.horizon
    hard = sol.slack <= 1e-9  # (N, ny): rows whose comfort must hold for every w
    corners = [np.array(c) for c in itertools.product((-1.0, 1.0), repeat=prob.nd)]
    samples = []
    for _ in range(150):
        samples.append(rng.uniform(-1.0, 1.0, sigma.shape) * sigma)
    for _ in range(150):
        samples.append(np.array([corners[i] for i in rng.integers(len(corners), size=horizon)]))
        samples[-1] = samples[-1] * sigma
    for w in samples:
        active = rng.random(horizon) < rng.uniform(0.0, 1.0)
        y, flows = _simulate(seed, sol, w, active.astype(float), **overrides)
        upper_ok = y <= prob.y_max + STATE_TOL_K
        lower_ok = y >= prob.y_min - STATE_TOL_K
        assert (upper_ok | ~hard).all() and (lower_ok | ~hard).all()
        u, applied = flows[:, 0], flows[:, 1]
        assert (u <= prob.u_max + FLOW_TOL_KG_S).all()
        assert (applied >= prob.u_min - FLOW_TOL_KG_S).all()
        power = prob.power_offset_kw + np.einsum("km,km->k", prob.power_coeff_kw_per_kg_s, u)
        assert (prob.phi * power <= sol.peak_charge_sgd + 1e-6).all()


def test_validation() -> None:
    with pytest.raises(ProblemError, match="only to robust='feedback'"):
        random_problem(0, feedback=FeedbackOptions())
    with pytest.raises(ProblemError, match="unknown feedback structure"):
        FeedbackOptions(structure="diagonal")  # type: ignore[arg-type]
    with pytest.raises(ProblemError, match="memory"):
        FeedbackOptions(memory_steps=0)
    c = np.zeros((1, 4))
    c[0, 0] = 1.0
    with pytest.raises(ProblemError, match="zone-local"):
        random_problem(
            0,
            c_matrix=c,
            y_min=np.full(1, 22.0),
            y_max=np.full(1, 26.0),
            robust="feedback",
            feedback=FeedbackOptions(structure="zone-local"),
        )
    prob = random_problem(0, robust="feedback")
    assert prob.feedback == FeedbackOptions()
    solver = FeedbackSolver(prob)
    assert solver.get_basis() is None
    with pytest.raises(ProblemError, match="structure differs"):
        solver.solve(random_problem(0, robust="feedback", feedback=FeedbackOptions("full")))


def test_open_loop_solver_refuses_a_feedback_problem() -> None:
    from hvacflex.opt import RMPCSolver

    problem = random_problem(0, robust="feedback", feedback=FeedbackOptions())
    with pytest.raises(ProblemError, match="FeedbackSolver"):
        RMPCSolver(problem)


@pytest.mark.parametrize("structure", ["time-invariant", "zone-local"])
@pytest.mark.parametrize("seed", range(3))
def test_lag_response_equals_the_full_response(seed: int, structure: str) -> None:
    """The per-lag response (shift-invariant gains) is the full product's, block by block,
    and so are the realised margins reported in the solution."""
    from hvacflex.opt.feedback import feedback_maps
    from hvacflex.opt.feedback_result import (
        gains_tensor,
        lag_output_response,
        output_response,
        realised_margins,
    )

    options = FeedbackOptions(structure=structure, memory_steps=3)  # type: ignore[arg-type]
    problem = random_problem(seed, horizon=9, robust="feedback", feedback=options)
    maps = feedback_maps(problem, options)
    assert maps.gains.shift_invariant
    theta = np.random.default_rng(seed).normal(size=maps.gains.num_gains)
    tensor = gains_tensor(maps, theta, problem.horizon, problem.m, problem.nd)
    full = output_response(maps, tensor)
    lags = lag_output_response(maps, tensor)
    for k1, j in itertools.product(range(problem.horizon), repeat=2):
        expected = lags[k1 - j] if k1 >= j else np.zeros_like(lags[0])
        np.testing.assert_allclose(full[k1, j], expected, rtol=1e-12, atol=1e-12)
    general = np.einsum("kjal,jl->ka", np.abs(full), problem.d_sigma)
    np.testing.assert_allclose(
        realised_margins(maps, tensor, problem.d_sigma), general, rtol=1e-12, atol=1e-12
    )
    solution = FeedbackSolver(problem).solve(problem)
    assert solution.ok and np.any(solution.feedback_gains != 0.0)
    response = np.abs(output_response(maps, solution.feedback_gains))
    reported = np.einsum("kjal,jl->ka", response, problem.d_sigma)
    np.testing.assert_allclose(solution.delta, reported, rtol=1e-12, atol=1e-12)
