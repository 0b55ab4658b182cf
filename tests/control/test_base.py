"""The controller interface: the period's inputs, the action's applied flow, one act signature."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
from pathlib import Path

import numpy as np
import pytest

import hvacflex
from hvacflex.control.base import Action, Controller, PeriodInputs


def _action(flow_kg_s: list[float], reserve_flow_kg_s: list[float]) -> Action:
    nan = np.full(len(flow_kg_s), np.nan)
    return Action(
        flow_kg_s=np.array(flow_kg_s),
        reserve_flow_kg_s=np.array(reserve_flow_kg_s),
        reserve_kw=0.0,
        planned_power_kw=float("nan"),
        status="rule",
        fallback=False,
        solve_time_s=0.0,
        planned_slack_max_k=0.0,
        delta_max_k=0.0,
        predicted_served_degc=nan,
        predicted_curtailed_degc=nan,
    )


def test_the_applied_flow_is_u_minus_r_only_when_curtailed() -> None:
    action = _action([1.0, 0.5, 0.25], [0.25, 0.0, 0.125])
    np.testing.assert_array_equal(action.applied_flow_kg_s(curtailed=True), [0.75, 0.5, 0.125])
    served = action.applied_flow_kg_s(curtailed=False)
    np.testing.assert_array_equal(served, [1.0, 0.5, 0.25])
    assert served.dtype == np.float64


def test_period_inputs_are_frozen_and_default_to_nothing_carried_measured_or_planned() -> None:
    inputs = PeriodInputs(np.full(3, 25.0), None, 4.0)  # type: ignore[arg-type]
    assert inputs.peak_floor_kw == 4.0
    assert inputs.allowance_carry_steps == 0
    assert inputs.measured_zone_temp_degc is None and inputs.plan is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        inputs.peak_floor_kw = 5.0  # type: ignore[misc]
    carried = dataclasses.replace(inputs, allowance_carry_steps=2)
    assert (carried.allowance_carry_steps, inputs.allowance_carry_steps) == (2, 0)


CONTROLLER_PACKAGES = ("control", "fleet", "sim")
"""The packages whose modules may define a controller (the layers that drive one)."""


def _controller_classes() -> list[type]:
    """Every class of :data:`CONTROLLER_PACKAGES` that subclasses :class:`Controller`."""
    for package in CONTROLLER_PACKAGES:
        path = [str(Path(hvacflex.__file__).parent / package)]
        for module in pkgutil.iter_modules(path, f"hvacflex.{package}."):
            importlib.import_module(module.name)
    found: list[type] = []
    todo = list(Controller.__subclasses__())
    while todo:
        cls = todo.pop()
        found.append(cls)
        todo.extend(cls.__subclasses__())
    return [cls for cls in found if cls.__module__.startswith("hvacflex.")]


def test_every_controller_acts_on_one_period_inputs() -> None:
    classes = _controller_classes()
    names = {cls.__name__ for cls in classes}
    assert {"MPCController", "ThermostatController", "FleetController"} <= names
    for cls in classes:
        parameters = list(inspect.signature(cls.act).parameters.values())
        assert [p.name for p in parameters] == ["self", "inputs"], cls
        assert parameters[1].annotation in ("PeriodInputs", PeriodInputs), cls
