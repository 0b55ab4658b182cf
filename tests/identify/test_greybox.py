"""The grey-box model against independent references: scipy's matrix exponential and Riccati
solver, a single RC node's analytic step response, the steady-state heat balance."""

from __future__ import annotations

import itertools

import numpy as np
import scipy.linalg

from hvacflex.building.identified import WALL_ORIENTATIONS
from hvacflex.identify.greybox import (
    CHANGE_HOLD_SHARE,
    EXOGENOUS_INPUTS,
    MEASUREMENT_STD_K,
    PROCESS_STD_AIR_K,
    PROCESS_STD_MASS_K,
    ZONE_PARAMETERS,
    FilterNoise,
    GreyBoxParameters,
    continuous_matrices,
    cooling_change_kw,
    discretize,
    filter_states,
    one_step_predictions,
    simulate_windows,
    time_constants_s,
)

DT_S = 1800.0
COOLING = len(EXOGENOUS_INPUTS)
"""Where the cooling inputs start in ``u``."""


def _wall_shares(p: GreyBoxParameters) -> np.ndarray:
    """(m, 4) each zone's wall solar shares [m²]."""
    return np.column_stack([p.value(f"solar_wall_{o}_m2") for o, _ in WALL_ORIENTATIONS])


def _random_parameters(m: int, seed: int) -> GreyBoxParameters:
    rng = np.random.default_rng(seed)
    zone = np.column_stack(
        [
            rng.uniform(500, 5000, m),  # c_air
            rng.uniform(1e4, 1e6, m),  # c_mass
            rng.uniform(0.01, 0.5, m),
            rng.uniform(0.1, 3.0, m),
            rng.uniform(0.01, 0.5, m),
            rng.uniform(0, 10, m),
            rng.uniform(0, 10, m),
            rng.uniform(0, 4, (m, 4)),  # the wall shares
            rng.uniform(0, 3, m),
            rng.uniform(-1, 1, m),
        ]
    )
    assert zone.shape[1] == len(ZONE_PARAMETERS)
    pairs = np.array(list(itertools.combinations(range(m), 2)), dtype=np.int64).reshape(-1, 2)
    return GreyBoxParameters(zone, pairs, rng.uniform(0.01, 0.3, len(pairs)))


def test_discretisation_equals_the_augmented_matrix_exponential() -> None:
    p = _random_parameters(4, seed=3)
    model = discretize(p, DT_S)
    a_c, b_c = continuous_matrices(p)
    n, nu = b_c.shape
    big = np.zeros((2 * (n + nu), 2 * (n + nu)))
    big[:n, :n], big[:n, n : n + nu] = a_c * DT_S, b_c * DT_S
    big[: n + nu, n + nu :] = np.eye(n + nu) * DT_S
    e = scipy.linalg.expm(big)
    step, integral = e[: n + nu, : n + nu], e[: n + nu, n + nu :] / DT_S
    np.testing.assert_allclose(model.a, step[:n, :n], atol=1e-12)
    np.testing.assert_allclose(model.b, step[:n, n:], atol=1e-12)
    np.testing.assert_allclose(model.c_mean, integral[:4, :n], atol=1e-12)
    np.testing.assert_allclose(model.d_mean, integral[:4, n:], atol=1e-12)


def test_kalman_gain_equals_scipys_riccati_solution() -> None:
    p = _random_parameters(3, seed=5)
    model = discretize(p, DT_S)
    noise = np.diag(np.r_[np.full(3, PROCESS_STD_AIR_K), np.full(3, PROCESS_STD_MASS_K)] ** 2)
    r = np.eye(3) * MEASUREMENT_STD_K**2
    cov = scipy.linalg.solve_discrete_are(model.a.T, model.c_mean.T, noise, r)
    gain = model.a @ cov @ model.c_mean.T @ np.linalg.inv(model.c_mean @ cov @ model.c_mean.T + r)
    np.testing.assert_allclose(model.gain, gain, atol=1e-9)


def test_one_zone_with_a_stiff_mass_follows_the_rc_step_response() -> None:
    """Air node alone (mass coupling tiny, mass huge): T(t) = To + (T0 − To)·exp(−t UA/C)."""
    c_air, ua = 3000.0, 0.2
    zone = np.array([[c_air, 1e7, ua, 1e-7, 1e-7] + [0.0] * 8])
    p = GreyBoxParameters(zone, np.zeros((0, 2), dtype=np.int64), np.zeros(0))
    model = discretize(p, DT_S)
    u = np.array([[30.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]] * 4)
    x0 = np.array([[20.0, 20.0]])
    means = simulate_windows(model, x0, u[None], 4)[0, :, 0]
    tau = c_air / ua
    t = np.linspace(0.0, 4 * DT_S, 4001)
    exact = 30.0 + (20.0 - 30.0) * np.exp(-t / tau)
    expected = [exact[i * 1000 : (i + 1) * 1000 + 1].mean() for i in range(4)]
    np.testing.assert_allclose(means, expected, atol=1e-4)  # the mass coupling is negligible


def test_steady_state_balances_heat_in_and_out() -> None:
    p = _random_parameters(3, seed=7)
    a_c, b_c = continuous_matrices(p)
    walls = np.array([0.1, 0.4, 0.2, 0.3])
    u = np.r_[31.0, 0.6, 1.0, 1.0, walls, 2.0, 1.5, 0.5]
    x = np.linalg.solve(a_c, -b_c @ u)
    ua_o, ua_mo = p.value("ua_out_kw_per_k"), p.value("ua_mass_out_kw_per_k")
    lost_kw = (ua_o * (x[:3] - 31.0) + ua_mo * (x[3:] - 31.0)).sum()
    gains_kw = (
        0.6 * (p.value("solar_air_m2") + p.value("solar_mass_m2"))
        + _wall_shares(p) @ walls
        + p.value("occupied_gain_kw")
        + p.value("base_gain_kw")
    ).sum() - u[COOLING:].sum()
    assert abs(lost_kw - gains_kw) < 1e-9


def test_the_filter_converges_to_the_true_state_of_its_own_model() -> None:
    p = _random_parameters(2, seed=11)
    model = discretize(p, DT_S)
    steps = 400
    u = _driven_inputs(steps, seed=0)
    x = np.array([24.0, 25.0, 27.0, 28.0])
    truth, y = np.empty((steps, 4)), np.empty((steps, 2))
    for k in range(steps):
        truth[k] = x
        y[k] = model.c_mean @ x + model.d_mean @ u[k]
        x = model.a @ x + model.b @ u[k]
    estimates = filter_states(model, y, u)
    assert np.abs(estimates[-50:] - truth[-50:]).max() < 1e-3
    assert np.abs(estimates[0] - truth[0]).max() > 0.5  # it did start wrong


def test_time_constants_are_those_of_the_eigenvalues() -> None:
    p = _random_parameters(2, seed=1)
    taus = time_constants_s(p)
    eigenvalues = np.linalg.eigvals(continuous_matrices(p)[0])
    np.testing.assert_allclose(np.sort(taus), np.sort(-1.0 / eigenvalues.real))
    assert (taus > 0).all()


def test_a_boundary_zone_enters_the_balance_and_the_exponential() -> None:
    base = _random_parameters(2, seed=13)
    p = GreyBoxParameters(
        base.zone,
        base.couplings,
        base.coupling_ua_kw_per_k,
        boundaries=1,
        boundary_couplings=np.array([[0, 0], [1, 0]], dtype=np.int64),
        boundary_ua_kw_per_k=np.array([0.4, 0.1]),
    )
    a_c, b_c = continuous_matrices(p)
    assert b_c.shape == (4, COOLING + 2 + 1)
    walls = np.array([0.3, 0.0, 0.2, 0.1])
    u = np.r_[30.0, 0.5, 1.0, 1.0, walls, 2.0, 1.0, 27.0]
    x = np.linalg.solve(a_c, -b_c @ u)
    ua_o, ua_mo = p.value("ua_out_kw_per_k"), p.value("ua_mass_out_kw_per_k")
    lost_kw = (ua_o * (x[:2] - 30.0) + ua_mo * (x[2:] - 30.0)).sum()
    lost_kw += (np.array([0.4, 0.1]) * (x[:2] - 27.0)).sum()
    gains_kw = (
        0.5 * (p.value("solar_air_m2") + p.value("solar_mass_m2"))
        + _wall_shares(p) @ walls
        + p.value("occupied_gain_kw")
        + p.value("base_gain_kw")
    ).sum() - 3.0
    assert abs(lost_kw - gains_kw) < 1e-9
    model = discretize(p, DT_S)
    n, nu = b_c.shape
    big = np.zeros((n + nu, n + nu))
    big[:n, :n], big[:n, n:] = a_c * DT_S, b_c * DT_S
    step = scipy.linalg.expm(big)
    np.testing.assert_allclose(model.b, step[:n, n:], atol=1e-12)


def _driven_inputs(steps: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack(
        [
            30 + rng.normal(0, 1, steps),
            rng.uniform(0, 0.8, steps),
            rng.integers(0, 2, steps),
            np.ones(steps),
            rng.uniform(0, 0.5, (steps, 4)),  # the walls
            rng.uniform(0, 3, (steps, 2)),
        ]
    )


def test_without_a_gain_state_the_predictor_is_the_plain_filter() -> None:
    model = discretize(_random_parameters(2, seed=5), DT_S)
    u = _driven_inputs(200, seed=1)
    y = 25.0 + np.random.default_rng(2).normal(0, 0.5, (200, 2))
    states = filter_states(model, y, u)
    plain = states @ model.c_mean.T + u @ model.d_mean.T
    np.testing.assert_allclose(one_step_predictions(model, y, u, FilterNoise()), plain, atol=1e-9)


def test_the_gain_state_learns_a_heat_gain_the_inputs_miss() -> None:
    model = discretize(_random_parameters(2, seed=7), DT_S)
    steps = 300
    u = _driven_inputs(steps, seed=3)
    hidden_kw = np.where(np.arange(steps) % 100 < 50, 1.5, -1.0)  # a step gain in zone 0
    x, y = np.array([24.0, 25.0, 26.0, 26.0]), np.empty((steps, 2))
    for k in range(steps):
        u_true = u[k].copy()
        u_true[COOLING] -= hidden_kw[k]  # a gain is negative cooling
        y[k] = model.c_mean @ x + model.d_mean @ u_true
        x = model.a @ x + model.b @ u_true
    plain = one_step_predictions(model, y, u, FilterNoise())
    augmented = one_step_predictions(model, y, u, FilterNoise(gain_kw=0.5, gain_persistence=0.95))
    rmse_plain = np.sqrt(((plain[50:, 0] - y[50:, 0]) ** 2).mean())
    rmse_aug = np.sqrt(((augmented[50:, 0] - y[50:, 0]) ** 2).mean())
    assert rmse_aug < 0.5 * rmse_plain


def _sub_step_means(p: GreyBoxParameters, x0: np.ndarray, sub_u: np.ndarray) -> np.ndarray:
    """Reference: the period means of the air nodes from the inputs held over each third of
    a period (``sub_u`` (T, 3, nu)), by scipy's matrix exponential on 600-s steps."""
    a_c, b_c = continuous_matrices(p)
    n, nu, dt = a_c.shape[0], b_c.shape[1], DT_S / 3
    big = np.zeros((2 * (n + nu), 2 * (n + nu)))
    big[:n, :n], big[:n, n : n + nu] = a_c * dt, b_c * dt
    big[: n + nu, n + nu :] = np.eye(n + nu) * dt
    e = scipy.linalg.expm(big)
    step, integral = e[: n + nu, : n + nu], e[: n + nu, n + nu :] / dt
    x, means = x0.copy(), np.zeros((sub_u.shape[0], p.zones))
    for k in range(sub_u.shape[0]):
        for j in range(3):
            means[k] += (integral[:n, :n] @ x + integral[:n, n:] @ sub_u[k, j])[: p.zones] / 3
            x = step[:n, :n] @ x + step[:n, n:] @ sub_u[k, j]
    return means


def test_a_change_of_the_cooling_coming_early_equals_the_sub_step_model() -> None:
    """γ of the change ΔQ_k over the first third (CHANGE_HOLD_SHARE), the rest spread: the
    period means equal the model held over 10-min steps with Q_k + 2γΔQ_k, then Q_k − γΔQ_k."""
    assert CHANGE_HOLD_SHARE == 1.0 / 3.0
    p, share, steps = _random_parameters(2, seed=11), 0.3, 12
    u = _driven_inputs(steps, seed=4)
    change = cooling_change_kw(u, 2)
    assert np.allclose(change[1:], u[1:, COOLING : COOLING + 2] - u[:-1, COOLING : COOLING + 2])
    sub_u = np.repeat(u[:, None, :], 3, axis=1)
    sub_u[:, 0, COOLING : COOLING + 2] += 2 * share * change
    sub_u[:, 1:, COOLING : COOLING + 2] -= share * change[:, None, :]
    x0 = np.array([24.0, 26.0, 25.0, 27.0])
    expected = _sub_step_means(p, x0, sub_u)
    model = discretize(p, DT_S, cooling_change_share=share)
    means = simulate_windows(model, x0[None], u[None], steps, change[None])[0]
    np.testing.assert_allclose(means, expected, atol=1e-9)
    assert np.abs(means - simulate_windows(model, x0[None], u[None], steps)[0]).max() > 0.05


def test_the_change_hold_keeps_the_plain_model_for_steady_cooling() -> None:
    """Without a change (constant cooling) the hold changes nothing; γ = 0 is the plain hold."""
    p = _random_parameters(2, seed=12)
    plain, early = discretize(p, DT_S), discretize(p, DT_S, cooling_change_share=0.4)
    assert not plain.b_change.any() and not plain.d_change.any()
    u = np.tile(_driven_inputs(1, seed=5), (30, 1))
    y = 25.0 + np.random.default_rng(6).normal(0, 0.3, (30, 2))
    for noise in (FilterNoise(), FilterNoise(gain_kw=0.3, gain_persistence=0.8)):
        np.testing.assert_allclose(
            one_step_predictions(early, y, u, noise), one_step_predictions(plain, y, u, noise)
        )


def test_with_the_change_hold_the_predictor_without_gain_is_the_filter() -> None:
    model = discretize(_random_parameters(2, seed=5), DT_S, cooling_change_share=0.3)
    u = _driven_inputs(200, seed=1)
    y = 25.0 + np.random.default_rng(2).normal(0, 0.5, (200, 2))
    states = filter_states(model, y, u)
    change = cooling_change_kw(u, 2)
    plain = states @ model.c_mean.T + u @ model.d_mean.T + change @ model.d_change.T
    np.testing.assert_allclose(one_step_predictions(model, y, u, FilterNoise()), plain, atol=1e-9)
