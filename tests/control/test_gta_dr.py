"""gta-dr: a fixed-share bid and a set-point raise by α that is a real flow reduction."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.config import preset
from hvacflex.control.base import PeriodInputs
from hvacflex.control.gta_dr import GtaDrController
from hvacflex.sim.setup import Setup, make_controller, prepare

AFTERNOON_STEP = 28
"""14:00 on 2014-03-03, occupied."""


@pytest.fixture(scope="module")
def setup() -> Setup:
    return prepare(preset("gta-dr", start="2014-03-03", days=1))


def _controller(setup: Setup, share: float = 0.2) -> GtaDrController:
    return GtaDrController(
        setup.model,
        setup.building.hvac,
        25.5,
        None,
        reserve_share=share,
        raise_k=1.0,
        event_steps=4,
        recovery_steps=2,
    )


def test_the_preset_builds_the_controller_with_the_event_allowance(setup: Setup) -> None:
    controller = make_controller(setup)
    assert isinstance(controller, GtaDrController)
    assert controller.raise_k == setup.config.reserve.event_allowance_k
    assert controller.reserve_share == setup.config.controller.reserve_share


def test_the_offer_is_a_fixed_share_of_the_predicted_load(setup: Setup) -> None:
    x = np.full(len(setup.model.node_names), 25.5)
    forecast = setup.forecaster.forecast(AFTERNOON_STEP, 9)
    action = _controller(setup, share=0.25).act(PeriodInputs(x, forecast, 0.0))
    assert action.planned_power_kw > 0
    assert action.reserve_kw == pytest.approx(0.25 * action.planned_power_kw)
    assert _controller(setup, share=0.0).act(PeriodInputs(x, forecast, 0.0)).reserve_kw == 0.0


def test_the_reserve_is_the_flow_cut_of_the_raised_setpoint(setup: Setup) -> None:
    model, hvac = setup.model, setup.building.hvac
    x = np.full(len(model.node_names), 25.5)
    forecast = setup.forecaster.forecast(AFTERNOON_STEP, 9)
    controller = _controller(setup)
    plan = controller.event_plan(x, forecast)
    assert plan.steps == 6
    low = hvac.flow_min_at([True])[0]
    reduction = plan.reserve_flow_kg_s
    assert np.all(reduction >= 0) and np.all(plan.flow_kg_s - reduction >= low - 1e-12)
    assert reduction[0].sum() > 0  # the zones may float up by α: the first period cuts most
    assert reduction[0].sum() >= reduction[1:4].sum(axis=1).max()
    assert np.all(reduction[4:] == 0) and np.all(plan.reserve_kw[4:] == 0)
    # curtailed: warmer than served, at most α above the upper bound
    assert np.all(plan.predicted_curtailed_degc[:4] >= plan.predicted_served_degc[:4] - 1e-9)
    upper = forecast.comfort_upper_degc[:4]
    assert np.all(plan.predicted_curtailed_degc[:4] <= upper + 1.0 + 1e-6)
    # the first curtailed period lands near the raised set-point (zones coupled through the
    # walls: a zone held at its minimum flow shifts the others' dead-beat landing a little)
    cut = plan.flow_kg_s[0] - reduction[0]
    free = ~np.isclose(cut, low)
    assert free.any()
    assert np.all(np.abs(plan.predicted_curtailed_degc[0][free] - 26.5) < 0.05)
    assert np.all(plan.predicted_curtailed_degc[0][~free] < 26.5)  # at its minimum flow
