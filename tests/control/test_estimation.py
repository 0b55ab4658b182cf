"""Kalman filter, estimation margin, trajectory linearisation and prediction error."""

from __future__ import annotations

import os

import numpy as np
import pytest

from hvacflex.building.discretize import LinearModel, linearize
from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.control import estimation as est
from hvacflex.control.prediction_error import (
    one_step_prediction_error,
    prediction_error_max_k,
    prediction_error_rms_k,
)
from hvacflex.control.trajectory import (
    linearize_along,
    shifted_operating_points,
    step_matrices,
    time_varying_margins,
)
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.errors import ConfigError
from hvacflex.opt.robust import comfort_margins
from hvacflex.paths import resolve_building


@pytest.fixture(scope="module")
def office() -> Building:
    return load_building(resolve_building("office5"))


@pytest.fixture(scope="module")
def model(office: Building) -> LinearModel:
    return linearize(office, 1800.0, 25.0)


def _typical_d(model: LinearModel) -> np.ndarray:
    d = np.zeros(len(model.channels))
    for i, ch in enumerate(model.channels):
        d[i] = {"outdoor_temp": 30.0, "solar": 150.0}.get(ch.kind, 3000.0)
    return d


def _sigma(model: LinearModel, d: np.ndarray) -> np.ndarray:
    box = UncertaintyBox(
        relative={"solar": 0.05, "internal_gain": 0.05}, absolute={"outdoor_temp": 0.5}
    )
    return box.sigma(d[None, :], model.channels)[0]


def test_filter_error_converges_to_noise_level(model: LinearModel) -> None:
    rng = np.random.default_rng(1)
    cfg = est.KalmanConfig(measurement_noise_k=0.1)
    n, m = model.a.shape[0], model.c.shape[0]
    d = _typical_d(model)
    x = 25.0 + rng.uniform(-1.5, 1.5, n)  # walls unknown to the filter
    u = np.full(m, 0.6)

    def measure(x_now: np.ndarray) -> np.ndarray:
        return model.c @ x_now + rng.uniform(-0.1, 0.1, m)

    y = measure(x)
    state = est.kalman_update(est.initial_state(y, model, cfg), y, model, cfg)
    first_error = np.abs(x - state.x_degc).max()
    errors = []
    for _ in range(400):
        x = model.step(x, u, d)
        state = est.kalman_step(state, model, u, d, np.zeros_like(d), measure(x), cfg)
        errors.append(x - state.x_degc)
    late = np.array(errors[-100:])
    rms_nodes = float(np.sqrt(np.mean(late**2)))
    rms_zones = float(np.sqrt(np.mean((late @ model.c.T) ** 2)))
    assert first_error > 0.5
    # the noise has std a/√3 ≈ 0.058 K; the filter averages it down
    assert rms_zones < 0.1 / np.sqrt(3.0)
    assert rms_nodes < 0.1


def _track(model: LinearModel, gain_k: float, use_offset: bool) -> float:
    """Closed loop on the linear model with an unmeasured constant gain on every zone and an
    unconstrained one-step controller to 24.5 °C; returns the final |tracking error| [K]."""
    rng = np.random.default_rng(2)
    cfg = est.KalmanConfig(measurement_noise_k=0.1)
    n, m = model.a.shape[0], model.c.shape[0]
    d = _typical_d(model)
    target = np.full(m, 24.5)
    cb = model.c @ model.b
    x = np.full(n, 25.0)
    y = model.c @ x
    state = est.kalman_update(est.initial_state(y, model, cfg), y, model, cfg)
    true_temps = []
    for _ in range(300):
        offset = state.offset_k if use_offset else np.zeros(m)
        free = model.c @ (model.a @ state.x_degc + model.e @ d + model.g) + offset
        u = np.linalg.solve(cb, target - free)
        x = model.step(x, u, d) + model.c.T @ np.full(m, gain_k)
        true_temps.append(model.c @ x)
        y = model.c @ x + rng.uniform(-0.1, 0.1, m)
        state = est.kalman_step(state, model, u, d, np.zeros_like(d), y, cfg)
    return float(np.abs(np.mean(true_temps[-50:], axis=0) - target).max())


def test_offset_free_tracking_under_constant_unmeasured_gain(model: LinearModel) -> None:
    with_offset = _track(model, 0.3, use_offset=True)
    without_offset = _track(model, 0.3, use_offset=False)
    assert with_offset < 0.03
    assert without_offset > 0.2  # the offset state is what removes the bias


def test_estimation_margin_holds_by_sampling(model: LinearModel) -> None:
    """True outputs of a plan from the estimate stay within δ_k + |H F^k| ē (linear model)."""
    rng = np.random.default_rng(3)
    cfg = est.KalmanConfig(measurement_noise_k=0.15)
    n, m = model.a.shape[0], model.c.shape[0]
    d_hat = _typical_d(model)
    sigma = _sigma(model, d_hat)
    horizon = 24
    gain = est.steady_state_gain(model, sigma, cfg)
    bound = est.steady_state_error_bound(model, gain, sigma, cfg)
    extra = est.estimation_margins(model, bound, horizon)
    delta = comfort_margins(model.a, model.e, model.c, np.tile(sigma, (horizon, 1)))
    assert extra.shape == (horizon, m) and np.all(extra > 0)
    x = np.full(n, 25.0)
    state = est.EstimatorState(
        x_degc=x.copy(), offset_k=np.zeros(m), covariance=np.eye(n + m) * 1e-6
    )
    worst_ratio = 0.0
    for k in range(600):
        u = rng.uniform(0.2, 1.5, m)
        w = rng.uniform(-sigma, sigma)
        x = model.step(x, u, d_hat + w)
        prior = est.kalman_predict(state, model, u, d_hat, sigma, cfg)
        y = model.c @ x + rng.uniform(-cfg.measurement_noise_k, cfg.measurement_noise_k, m)
        state = est.kalman_update(prior, y, model, cfg, gain=gain)
        assert np.all(np.abs(x - state.x_degc) <= bound[:n] + 1e-9)
        if k % 25 == 24:
            plan_u = rng.uniform(0.2, 1.5, (horizon, m))
            x_pred, x_true = state.x_degc.copy(), x.copy()
            for j in range(horizon):
                x_pred = model.step(x_pred, plan_u[j], d_hat) + model.c.T @ state.offset_k
                x_true = model.step(x_true, plan_u[j], d_hat + rng.uniform(-sigma, sigma))
                gap = np.abs(model.c @ (x_true - x_pred))
                allowed = delta[j] + extra[j]
                assert np.all(gap <= allowed + 1e-9)
                worst_ratio = max(worst_ratio, float(np.max(gap / allowed)))
    assert worst_ratio > 0.05  # the test exercises the margin


def test_unstable_error_dynamics_are_refused(model: LinearModel) -> None:
    cfg = est.KalmanConfig()
    zero_gain = np.zeros((model.a.shape[0] + model.c.shape[0], model.c.shape[0]))
    with pytest.raises(ConfigError):  # no feedback: the offset integrator is not stable
        est.steady_state_error_bound(model, zero_gain, np.zeros(len(model.channels)), cfg)


def test_config_rejects_negative_noise() -> None:
    with pytest.raises(ConfigError):
        est.KalmanConfig(measurement_noise_k=-0.1)


def test_trajectory_linearisation_beats_fixed_at_high_flow(
    office: Building, model: LinearModel
) -> None:
    plant = NonlinearPlant(office)
    d = _typical_d(model)
    m = model.c.shape[0]
    x = plant.initial_state(26.0)
    flow = np.full(m, 1.7)
    x_next = plant.step(x, flow, d)
    # the previous plan: 1.6 kg/s at the temperatures it predicted, shifted by one step
    planned_flow = np.full((3, m), 1.6)
    planned_temp = np.vstack([np.full((2, m), 26.0), np.tile(model.c @ x_next + 0.2, (2, 1))])
    flow_ref, temp_ref = shifted_operating_points(planned_flow, planned_temp, model.c @ x, 1)
    tv = linearize_along(office, plant.network, model.c, flow_ref, temp_ref, 1800.0)
    fixed_error = one_step_prediction_error(model, x, flow, d, x_next)
    trajectory_error = one_step_prediction_error(step_matrices(tv, 0), x, flow, d, x_next)
    assert np.abs(fixed_error).max() > 0.5
    assert np.abs(trajectory_error).max() < 0.5 * np.abs(fixed_error).max()


def test_shifted_operating_points() -> None:
    flows = np.arange(8.0).reshape(4, 2)
    temps = 20.0 + np.arange(10.0).reshape(5, 2)
    flow_ref, temp_ref = shifted_operating_points(flows, temps, np.array([30.0, 31.0]), 4)
    assert np.array_equal(flow_ref[0], flows[1]) and np.array_equal(flow_ref[-1], flows[-1])
    assert np.allclose(temp_ref[0], 0.5 * (np.array([30.0, 31.0]) + temps[2]))
    assert np.allclose(temp_ref[1], 0.5 * (temps[2] + temps[3]))


def test_time_varying_margins(office: Building, model: LinearModel) -> None:
    rng = np.random.default_rng(4)
    horizon, m = 6, model.c.shape[0]
    sigma = np.tile(_sigma(model, _typical_d(model)), (horizon, 1))
    constant = time_varying_margins(
        np.repeat(model.a[None], horizon, 0), np.repeat(model.e[None], horizon, 0), model.c, sigma
    )
    assert np.allclose(constant, comfort_margins(model.a, model.e, model.c, sigma))
    net = NonlinearPlant(office).network
    flows = rng.uniform(0.2, 1.7, (horizon, m))
    tv = linearize_along(office, net, model.c, flows, np.full((horizon, m), 25.0), 1800.0)
    delta = time_varying_margins(tv.a, tv.e, tv.c, sigma)
    for _ in range(200):  # sampled box errors stay inside δ_k
        dev = np.zeros(model.a.shape[0])
        for k in range(horizon):
            dev = tv.a[k] @ dev + tv.e[k] @ rng.uniform(-sigma[k], sigma[k])
            assert np.all(np.abs(model.c @ dev) <= delta[k] + 1e-12)


def test_prediction_error_kpis() -> None:
    errors = np.array([[3.0, -4.0], [np.nan, np.nan]])
    assert prediction_error_rms_k(errors) == pytest.approx(np.sqrt(12.5))
    assert prediction_error_max_k(errors) == pytest.approx(4.0)
    assert np.isnan(prediction_error_rms_k(np.full((2, 2), np.nan)))


def test_estimator_class_matches_functions(model: LinearModel) -> None:
    rng = np.random.default_rng(5)
    cfg = est.KalmanConfig()
    m, nd = model.c.shape[0], len(model.channels)
    estimator = est.KalmanEstimator(cfg)
    x = np.full(model.a.shape[0], 25.0)
    y0 = est.measure_zone_temps(rng, x, model.c, cfg.measurement_noise_k)
    assert np.all(np.abs(y0 - 25.0) <= cfg.measurement_noise_k)
    first = estimator.estimate(y0, model)
    reference = est.kalman_update(est.initial_state(y0, model, cfg), y0, model, cfg)
    assert np.allclose(first.x_degc, reference.x_degc)
    u, d = np.full(m, 0.8), _typical_d(model)
    estimator.applied(est.AppliedStep(model, u, d, np.zeros(nd)))
    y1 = model.c @ model.step(x, u, d)
    second = estimator.estimate(y1, model)
    expected = est.kalman_step(reference, model, u, d, np.zeros(nd), y1, cfg)
    assert np.allclose(second.x_degc, expected.x_degc)
    assert np.allclose(second.offset_k, expected.offset_k)
    restored = est.KalmanEstimator(cfg)
    restored.set_state(estimator.get_state())
    assert restored.state is estimator.state and restored.last is estimator.last


def test_tightened_bounds_meet_at_midpoint() -> None:
    lo, hi = est.tightened_bounds(
        np.array([[23.0, 23.0]]), np.array([[26.0, 26.0]]), np.array([[0.5, 2.0]])
    )
    assert np.allclose(lo, [[23.5, 24.5]]) and np.allclose(hi, [[25.5, 24.5]])


def test_relinearised_first_step_is_exact_at_the_planned_flow(
    office: Building, model: LinearModel
) -> None:
    from hvacflex.control.trajectory import relinearised_first_step

    plant = NonlinearPlant(office)
    m, n = model.c.shape[0], model.a.shape[0]
    d = _typical_d(model)
    x = plant.initial_state(25.5)
    flows = np.full((4, m), 1.2)
    states = np.tile(x, (5, 1))
    step = relinearised_first_step(
        office, plant.network, model.c, flows, states, model.c @ x, 1800.0
    )
    error = one_step_prediction_error(step, x, flows[1], d, plant.step(x, flows[1], d))
    assert step.a.shape == (n, n)
    assert np.abs(error).max() < 1e-6  # exact at ṁ = ṁ₀ for any temperature


def test_shifted_operating_points_clip_solver_round_off() -> None:
    flows = np.array([[0.5, 0.5], [-1e-12, 0.3]])
    flow_ref, _ = shifted_operating_points(flows, np.full((3, 2), 25.0), np.full(2, 25.0), 1)
    assert np.all(flow_ref >= 0.0) and flow_ref[0, 1] == 0.3


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: OpenBLAS runs one thread")
def test_the_model_and_steady_gain_do_not_depend_on_blas_threads() -> None:
    """office15's model (its matrix exponential) and its filter's steady gain (a Riccati
    equation of 74 states) are the same bits whether the process runs BLAS on one thread or
    two: both rounded differently before they ran on one (hvacflex.blas)."""
    from threadpoolctl import threadpool_limits

    office15 = load_building(resolve_building("office15"))
    cfg = est.KalmanConfig()

    def computed() -> tuple[np.ndarray, ...]:
        lm = linearize(office15, 1800.0, 25.0)
        gain = est.steady_state_gain(lm, _sigma(lm, _typical_d(lm)), cfg)
        return lm.a, lm.b, lm.e, gain

    with threadpool_limits(limits=1, user_api="blas"):
        one = computed()
    with threadpool_limits(limits=2, user_api="blas"):
        two = computed()
    for a, b in zip(one, two, strict=True):
        assert np.array_equal(a, b)
