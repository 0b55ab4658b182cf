"""Nonlinear plant: exact step vs an ODE solver and vs the analytic single node; speed."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from building_fixtures import write_building
from scipy.integrate import solve_ivp
from test_discretize import SINGLE_NODE

from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.building.summary import design_disturbance
from hvacflex.errors import InputError
from hvacflex.units import CP_AIR_J_PER_KG_K


def test_single_node_with_flow_matches_the_exponential(tmp_path: Path) -> None:
    b = load_building(write_building(tmp_path, SINGLE_NODE.replace("FLOW_MIN", "0.05")))
    plant = NonlinearPlant(b)
    c = 4.0 * 1.2 * CP_AIR_J_PER_KG_K * 150.0
    ua, flow, t_s = 50.0, 0.3, 13.0
    t0, t_out, sun, gain = 27.0, 32.0, 300.0, 1500.0
    conductance = ua + flow * CP_AIR_J_PER_KG_K
    t_inf = (ua * t_out + flow * CP_AIR_J_PER_KG_K * t_s + 0.3 * 20.0 * sun + gain) / conductance
    expected = t_inf + (t0 - t_inf) * math.exp(-900.0 / (c / conductance))
    x = plant.step([t0], [flow], [t_out, sun, gain], dt_s=900.0)
    assert x[0] == pytest.approx(expected, abs=1e-10)


def test_step_matches_ode_solver(shipped: Building) -> None:
    plant = NonlinearPlant(shipped)
    rng = np.random.default_rng(7)
    d = design_disturbance(shipped) * rng.uniform(0.3, 1.0, size=plant.nd)
    x0 = 20.0 + 10.0 * rng.uniform(size=plant.n)
    low = np.asarray(shipped.hvac.flow_min_kg_s)
    high = np.asarray(shipped.hvac.flow_max_kg_s)
    flow = low + rng.uniform(size=plant.m) * (high - low)
    sol = solve_ivp(
        lambda _t, y: plant.derivative(y, flow, d), (0.0, 1800.0), x0, rtol=1e-11, atol=1e-11
    )
    np.testing.assert_allclose(plant.step(x0, flow, d), sol.y[:, -1], atol=1e-7)
    # cached path gives the same answer
    np.testing.assert_allclose(plant.step(x0, flow, d), sol.y[:, -1], atol=1e-7)


def test_bad_inputs_raise(office5: Building) -> None:
    plant = NonlinearPlant(office5)
    x = plant.initial_state(25.0)
    d = design_disturbance(office5)
    with pytest.raises(InputError, match="flow_kg_s"):
        plant.step(x, -np.ones(plant.m), d)
    with pytest.raises(InputError, match="x_degc"):
        plant.step(x[:3], np.ones(plant.m), d)
