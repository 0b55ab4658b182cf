"""Each step linearised at the previous plan's zone temperature (``linearisation = "plan"``):
the scale and affine shift against an independent linearisation, with a minimum flow. The
problem a controller builds with it is in ``test_problem_builder.py``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from hvacflex.api import load_building
from hvacflex.building.discretize import linearize
from hvacflex.building.rc import build_network
from hvacflex.control.plan_linearisation import (
    plan_affine_shift,
    plan_input_scale,
    plan_linearisation,
)
from hvacflex.control.trajectory import linearize_along


def test_plan_linearisation_with_a_minimum_flow_is_the_model_at_each_steps_temperature() -> None:
    """With ṁ_ref ≠ 0 the affine term moves too: A, B diag(s_k) and g + shift_k are office5
    (a minimum flow in every zone) linearised at (ṁ_ref, T_k) and discretised, computed apart
    by :func:`hvacflex.control.trajectory.linearize_along`."""
    office5 = load_building("office5")
    m = len(office5.zones)
    hvac = replace(office5.hvac, flow_min_kg_s=np.linspace(0.1, 0.5, m))
    building = replace(office5, hvac=hvac)
    model = linearize(building, linearisation_temp_degc=25.0)
    temps = np.array([np.linspace(21.0, 23.0, m), np.full(m, 25.0), np.linspace(27.0, 24.0, m)])
    scale = plan_input_scale(model, temps)
    shift = plan_affine_shift(model, scale)
    flows = np.broadcast_to(model.flow_ref_kg_s, temps.shape)
    exact = linearize_along(building, build_network(building), model.c, flows, temps, model.dt_s)
    np.testing.assert_allclose(model.b[None] * scale[:, None, :], exact.b, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(model.g + shift, exact.g, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(np.broadcast_to(model.a, exact.a.shape), exact.a, atol=1e-13)
    np.testing.assert_allclose(scale[1], 1.0)  # at T₀: the fixed model
    assert np.abs(shift[0]).max() > 1e-3  # the shift is not vacuous


def test_without_a_plan_of_the_horizon_the_model_stays_at_t0() -> None:
    model = linearize(load_building("office5"))
    x = np.full(model.a.shape[0], 24.0)
    assert plan_linearisation(model, None, x, 48) is None
