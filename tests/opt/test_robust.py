"""Robust margins δ against brute force: explicit matrix powers and box-corner enumeration."""

from __future__ import annotations

import itertools

import numpy as np

from hvacflex.opt.robust import (
    comfort_margins,
    dual_row_entries,
    impulse_responses,
    margin_operator,
    robust_margins,
)
from hvacflex.opt.testing import random_model


def _delta_by_loops(a: np.ndarray, e: np.ndarray, c: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    horizon = sigma.shape[0]
    delta = np.zeros((horizon, c.shape[0]))
    for k in range(1, horizon + 1):
        for j in range(k):
            delta[k - 1] += np.abs(c @ np.linalg.matrix_power(a, k - 1 - j) @ e) @ sigma[j]
    return delta


def test_margins_equal_explicit_sum_of_matrix_powers() -> None:
    rng = np.random.default_rng(11)
    a, _, e, _ = random_model(rng, n=5, m=2, nd=3, dt_h=0.5)
    e[:, 1] *= -1.0  # a disturbance entering with negative sign
    c = rng.uniform(0.0, 1.0, (2, 5))
    sigma = rng.uniform(0.0, 1.0, (7, 3))
    np.testing.assert_allclose(comfort_margins(a, e, c, sigma), _delta_by_loops(a, e, c, sigma))


def test_margin_is_the_worst_box_corner() -> None:
    rng = np.random.default_rng(12)
    a, _, e, _ = random_model(rng, n=3, m=1, nd=2, dt_h=0.5)
    e[:, 0] *= -1.0
    c = np.eye(3)[:2]
    horizon = 3
    sigma = rng.uniform(0.1, 1.0, (horizon, 2))
    delta = comfort_margins(a, e, c, sigma)
    worst_hi = np.full((horizon, 2), -np.inf)
    worst_lo = np.full((horizon, 2), np.inf)
    for signs in itertools.product((-1.0, 1.0), repeat=horizon * 2):
        w = np.array(signs).reshape(horizon, 2) * sigma
        x = np.zeros(3)
        for k in range(horizon):
            x = a @ x + e @ w[k]
            worst_hi[k] = np.maximum(worst_hi[k], c @ x)
            worst_lo[k] = np.minimum(worst_lo[k], c @ x)
    np.testing.assert_allclose(delta, worst_hi, atol=1e-12)
    np.testing.assert_allclose(delta, -worst_lo, atol=1e-12)


def test_operator_layout_and_dual_entries() -> None:
    rng = np.random.default_rng(13)
    a, _, e, _ = random_model(rng, n=4, m=2, nd=2, dt_h=0.5)
    c = np.eye(4)[:2]
    horizon = 5
    responses = impulse_responses(a, e, c, horizon)
    operator = margin_operator(responses)
    assert operator.shape == (horizon * 2, horizon * 2)
    sigma = rng.uniform(0.0, 1.0, (horizon, 2))
    np.testing.assert_allclose(
        robust_margins(operator, sigma), _delta_by_loops(a, e, c, sigma), atol=1e-12
    )
    step, output, dist_step, channel, values = dual_row_entries(responses)
    assert step.size == 2 * 2 * horizon * (horizon + 1) // 2
    assert (dist_step <= step).all()
    # Σ |h| σ over a row's entries is that row's δ
    delta = np.zeros((horizon, 2))
    np.add.at(delta, (step, output), np.abs(values) * sigma[dist_step, channel])
    np.testing.assert_allclose(delta, robust_margins(operator, sigma), atol=1e-12)


# moved from tests/data/test_uncertainty.py with δ (one home: hvacflex.opt.robust)
def test_worst_case_margin_equals_brute_force_corner_search() -> None:
    rng = np.random.default_rng(0)
    nx, nd, ny, n = 3, 2, 2, 3
    a = rng.normal(scale=0.4, size=(nx, nx))  # mixed signs: the absolute value matters
    e = rng.normal(size=(nx, nd))
    c = rng.normal(size=(ny, nx))
    sigma = rng.uniform(0.1, 1.0, size=(n, nd))
    delta = comfort_margins(a, e, c, sigma)
    assert delta.shape == (n, ny)
    # Brute force: simulate x_{k+1} = A x_k + E w_k from x_0 = 0 for every corner of the box.
    best = np.zeros((n, ny))
    for signs in itertools.product((-1.0, 1.0), repeat=n * nd):
        w = np.array(signs).reshape(n, nd) * sigma
        x = np.zeros(nx)
        for k in range(n):
            x = a @ x + e @ w[k]
            best[k] = np.maximum(best[k], np.abs(c @ x))
    np.testing.assert_allclose(delta, best, rtol=1e-12)


def test_worst_case_margin_scalar_by_hand() -> None:
    # x+ = 0.5 x + 2 w, |w| ≤ 1: δ_1 = 2, δ_2 = 2 + 1, δ_3 = 2 + 1 + 0.5
    delta = comfort_margins(
        np.array([[0.5]]), np.array([[2.0]]), np.array([[1.0]]), np.ones((3, 1))
    )
    np.testing.assert_allclose(delta[:, 0], [2.0, 3.0, 3.5])


def test_shorter_sigma_uses_the_leading_block() -> None:
    rng = np.random.default_rng(3)
    a, _, e, _ = random_model(rng, n=4, m=2, nd=3, dt_h=0.5)
    c = np.eye(4)[:2]
    sigma = rng.uniform(0.0, 1.0, (6, 3))
    operator = margin_operator(impulse_responses(a, e, c, 10))
    np.testing.assert_allclose(
        robust_margins(operator, sigma), _delta_by_loops(a, e, c, sigma), rtol=1e-12
    )
