"""Linear model: analytic single node, A ≥ 0, stability, B ≤ 0, linear vs exact plant."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from building_fixtures import write_building
from scipy.integrate import solve_ivp

from hvacflex.building.discretize import (
    continuous_affine_model,
    delivered_flow_kg_s,
    linearize,
    zoh,
)
from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.building.rc import build_network
from hvacflex.building.summary import design_disturbance
from hvacflex.units import CP_AIR_J_PER_KG_K

SINGLE_NODE = """
name = "box"
[[zones]]
name = "box"
floor_area_m2 = 50.0
height_m = 3.0
capacitance_multiplier = 4.0
[[windows]]
name = "glass"
zone = "box"
area_m2 = 20.0
u_value_w_per_m2k = 2.5
shgc = 0.3
azimuth_deg = 90.0
[gains]
occupancy_m2_per_person = 10.0
sensible_w_per_person = 75.0
latent_w_per_person = 55.0
lighting_w_per_m2 = 10.0
equipment_w_per_m2 = 12.0
[hvac]
supply_temp_degc = 13.0
flow_min_kg_s = { box = FLOW_MIN }
flow_max_kg_s = { box = 0.5 }
outdoor_air_fraction = 0.3
cop = 4.5
fan_coeff_kw = 0.5
fan_exponent = 2.5
"""


def _single_node(tmp_path: Path, flow_min: float) -> Building:
    return load_building(write_building(tmp_path, SINGLE_NODE.replace("FLOW_MIN", repr(flow_min))))


@pytest.mark.parametrize("flow_min", [0.0, 0.1])
def test_single_rc_node_matches_the_exponential(tmp_path: Path, flow_min: float) -> None:
    b = _single_node(tmp_path, flow_min)
    lm = linearize(b, dt_s=1800.0)
    assert lm.a.shape == (1, 1)
    c = 4.0 * 1.2 * CP_AIR_J_PER_KG_K * 150.0  # J/K
    ua = 20.0 * 2.5  # W/K
    g_flow = flow_min * CP_AIR_J_PER_KG_K
    t0, t_out, sun, gain = 26.0, 31.0, 200.0, 900.0
    # at minimum flow: C dT/dt = UA (T_out − T) + ṁ c_p (T_s − T) + SHGC A q + q_int
    t_inf = (ua * t_out + g_flow * 13.0 + 0.3 * 20.0 * sun + gain) / (ua + g_flow)
    expected = t_inf + (t0 - t_inf) * math.exp(-1800.0 / (c / (ua + g_flow)))
    x_next = lm.step([t0], [flow_min], [t_out, sun, gain])
    assert x_next[0] == pytest.approx(expected, abs=1e-10)


def test_discrete_a_nonnegative_and_stable(shipped: Building) -> None:
    lm = linearize(shipped)
    assert lm.a.min() >= -1e-12
    assert np.max(np.abs(np.linalg.eigvals(lm.a))) < 1.0
    reserve = np.asarray(shipped.reserve_mask)
    assert lm.b[:, reserve].max() <= 0.0
    assert lm.e.shape == (len(lm.node_names), len(lm.channels))
    np.testing.assert_array_equal(
        lm.c @ np.arange(len(lm.node_names)), np.arange(len(shipped.zones))
    )


def test_contract_fields(office5: Building) -> None:
    lm = linearize(office5, dt_s=900.0, linearisation_temp_degc=23.0)
    assert lm.dt_s == 900.0
    assert lm.zone_names == office5.zone_names
    assert lm.g.shape == (len(lm.node_names),)
    # office5 is linearised at zero flow, so its constant term vanishes
    np.testing.assert_allclose(lm.g, 0.0, atol=1e-12)


def test_constant_term_at_nonzero_minimum_flow(room1: Building) -> None:
    lm = linearize(room1, linearisation_temp_degc=23.0)
    assert lm.g.max() > 0  # the constant term −ṁ_min c_p (T_s − T₀) / C is not optional


def test_linear_model_exact_at_minimum_flow(shipped: Building) -> None:
    lm = linearize(shipped)
    plant = NonlinearPlant(shipped)
    rng = np.random.default_rng(1)
    d = design_disturbance(shipped) * rng.uniform(0.5, 1.0, size=len(lm.channels))
    x = 22.0 + 6.0 * rng.uniform(size=len(lm.node_names))
    flow_min = np.asarray(shipped.hvac.flow_min_kg_s)
    np.testing.assert_allclose(lm.step(x, flow_min, d), plant.step(x, flow_min, d), atol=1e-9)


def test_linear_model_conservative_above_minimum_flow(shipped: Building) -> None:
    """With T_r ≥ T₀ along the plant trajectory, the linear model predicts no more cooling."""
    lm = linearize(shipped, linearisation_temp_degc=23.0)
    plant = NonlinearPlant(shipped)
    d = design_disturbance(shipped)
    x0 = plant.initial_state(28.0)
    zones = plant.network.zone_node_index
    low = np.asarray(shipped.hvac.flow_min_kg_s)
    high = np.asarray(shipped.hvac.flow_max_kg_s)
    errors = []
    for fraction in (0.25, 0.5, 1.0):
        flow = low + fraction * (high - low)
        sol = solve_ivp(
            lambda _t, y, f=flow: plant.derivative(y, f, d),
            (0.0, 1800.0),
            x0,
            rtol=1e-9,
            atol=1e-9,
            dense_output=True,
        )
        assert sol.sol(np.linspace(0, 1800, 300))[zones].min() >= 23.0  # precondition
        error = lm.step(x0, flow, d)[zones] - plant.step(x0, flow, d)[zones]
        assert error.min() >= -1e-9
        errors.append(error.max())
    assert min(errors) > 0.05  # the model–plant mismatch above the reference flow is real
    # size of the full-flow error over one 30-min step from 28 °C (see
    # docs/explanation/buildings.md); office5 is linearised at zero flow (its air handler may stop
    # when unoccupied)
    expected_full_flow_error_k = {"office5": 1.90, "room1": 1.38}[shipped.name]
    assert errors[-1] == pytest.approx(expected_full_flow_error_k, abs=0.05)


def _linearize_about_trajectory(
    b: Building, flows_kg_s: np.ndarray, temps_degc: np.ndarray, dt_s: float = 1800.0
) -> SimpleNamespace:
    """(K, …) stacked discrete a, b, e, g, step k linearised about (flows[k], temps[k])."""
    net = build_network(b)
    m = len(b.zones)
    parts = []
    for flow, temp in zip(np.atleast_2d(flows_kg_s), np.atleast_2d(temps_degc), strict=True):
        a_c, b_c, e_c, g_c = continuous_affine_model(b, net, flow, temp)
        a_d, held = zoh(a_c, np.hstack([b_c, e_c, g_c[:, None]]), dt_s)
        parts.append((a_d, held[:, :m], held[:, m:-1], held[:, -1]))
    a, b_d, e, g = (np.stack([p[i] for p in parts]) for i in range(4))
    return SimpleNamespace(a=a, b=b_d, e=e, g=g)


def test_trajectory_linearisation_exact_at_reference_flow(office5: Building) -> None:
    plant = NonlinearPlant(office5)
    d = design_disturbance(office5)
    flows = np.array([office5.hvac.flow_max_kg_s, office5.hvac.flow_min_kg_s]) * 0.8 + 0.1
    temps = np.array([[25.0] * 5, [24.0] * 5])
    tv = _linearize_about_trajectory(office5, flows, temps)
    assert len(tv.a) == 2
    x = plant.initial_state(26.5)
    for k in range(2):
        predicted = tv.a[k] @ x + tv.b[k] @ flows[k] + tv.e[k] @ d + tv.g[k]
        np.testing.assert_allclose(predicted, plant.step(x, flows[k], d), atol=1e-9)
    # the default model is the trajectory model about (ṁ_min, T₀)
    lm = linearize(office5)
    one = _linearize_about_trajectory(
        office5, np.array([office5.hvac.flow_min_kg_s]), np.array([[23.0] * 5])
    )
    np.testing.assert_allclose(one.a[0], lm.a, atol=1e-14)
    np.testing.assert_allclose(one.g[0], lm.g, atol=1e-10)


def test_steady_state_of_linear_model_is_a_fixed_point(room1: Building) -> None:
    lm = linearize(room1)
    d = design_disturbance(room1)
    u = np.asarray(room1.hvac.flow_max_kg_s)
    x = lm.steady_state(u, d)
    np.testing.assert_allclose(lm.step(x, u, d), x, atol=1e-9)


@pytest.mark.parametrize("inlet_temp_degc", [13.0, 20.0, 29.0])
def test_delivered_flow_reproduces_the_metered_cooling(
    room1: Building, inlet_temp_degc: float
) -> None:
    """The model input for metered air: its linearised HVAC term equals ṁ c_p (T_in − Ta)."""
    net = build_network(room1)
    lm = linearize(room1, linearisation_temp_degc=23.0, network=net)
    zones = net.zone_node_index
    m = len(zones)
    rng = np.random.default_rng(3)
    zone_temp = 22.0 + 8.0 * rng.uniform(size=m)
    flow = rng.uniform(0.1, 0.4, size=m)
    inlet = np.full(m, inlet_temp_degc)
    assert lm.supply_temp_degc == room1.hvac.supply_temp_degc  # the model carries its T_s
    u = delivered_flow_kg_s(lm, flow, zone_temp, inlet)
    a, b, _, g = continuous_affine_model(room1, net, lm.flow_ref_kg_s, lm.linearisation_temp_degc)
    x = np.full(net.n_nodes, 25.0)
    x[zones] = zone_temp
    hvac_term = (a - net.a_cont) @ x + b @ u + g  # the model's air-system heat [K/s]
    metered = flow * CP_AIR_J_PER_KG_K * (inlet - zone_temp) / net.capacitance_j_per_k[zones]
    np.testing.assert_allclose(hvac_term[zones], metered, rtol=1e-12, atol=1e-15)
    at_reference = delivered_flow_kg_s(  # air at T_s into zones at T₀: the flow itself
        lm, flow, lm.linearisation_temp_degc, np.full(m, lm.supply_temp_degc)
    )
    np.testing.assert_allclose(at_reference, flow, rtol=1e-12)
    no_air = delivered_flow_kg_s(  # no flow, no inlet reading: nothing delivered
        lm, np.zeros(m), zone_temp, np.full(m, np.nan)
    )
    assert np.all(np.isfinite(no_air))
    np.testing.assert_allclose(
        b @ no_air,
        (b @ delivered_flow_kg_s(lm, np.zeros(m), zone_temp, zone_temp)),
    )
