"""The flexibility envelope: the condensed hold model, the holds' LP and envelope.csv."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.envelope import (
    DURATIONS_MIN,
    ENVELOPE_COLUMNS,
    building_envelope,
    duration_steps,
    envelope_frame,
    hold_flows,
    hold_model,
)
from hvacflex.fleet.schema import load_fleet_document
from hvacflex.opt import RMPCProblem


@pytest.fixture(scope="module")
def problems(small_fleet: Path) -> list[RMPCProblem]:
    """The step problems of the small fleet's buildings at 10:00 (from 25 °C)."""
    fleet, doc = load_fleet_document(small_fleet)
    group = BuildingGroup(doc, [0, 1], FleetSettings.of(fleet, "2014-03-03T10:00", 0.25))
    group.begin_step()
    return group.problems()


def test_the_condensed_model_steps_as_the_dynamics(problems: list[RMPCProblem]) -> None:
    problem = problems[0]
    steps = 4
    model = hold_model(problem, steps)
    rng = np.random.default_rng(0)
    flows = rng.uniform(problem.u_min[:steps], problem.u_max[:steps])
    x = problem.x0.copy()
    g = problem.affine_term if problem.affine_term is not None else 0.0
    outputs = []
    for j in range(steps):
        x = problem.a_matrix @ x + problem.b_matrix @ flows[j]
        x = x + problem.e_matrix @ problem.d_forecast[j] + g
        outputs.append(problem.c_matrix @ x)
    np.testing.assert_allclose(model.free + model.gain @ flows.ravel(), np.concatenate(outputs))


def test_the_envelope_is_the_range_of_holds_that_keep_comfort(
    problems: list[RMPCProblem],
) -> None:
    steps = duration_steps()
    assert steps == (1, 2, 4)
    for problem in problems:
        envelope = building_envelope(problem, steps)
        assert envelope.shape == (3, 2)
        assert np.all(envelope[:, 0] < envelope[:, 1])
        # a longer hold is also a shorter one: its range lies inside the shorter's
        assert np.all(np.diff(envelope[:, 0]) >= -1e-6)
        assert np.all(np.diff(envelope[:, 1]) <= 1e-6)
        for h, (low, high) in zip(steps, envelope, strict=True):
            model = hold_model(problem, h)
            for level in (low, high):
                flows = hold_flows(problem, level, h)
                power = model.p0 + np.einsum("km,km->k", model.p, flows)
                np.testing.assert_allclose(power, level, atol=1e-5)
                outputs = model.free + model.gain @ flows.ravel()
                assert np.all(outputs >= model.y_min - 1e-6)
                assert np.all(outputs <= model.y_max + 1e-6)
            # just outside the range the hold leaves comfort (the LP takes slack)
            for level in (low - 1.0, high + 1.0):
                flows = hold_flows(problem, level, h)
                outputs = model.free + model.gain @ flows.ravel()
                outside = np.maximum(model.y_min - outputs, outputs - model.y_max)
                power = model.p0 + np.einsum("km,km->k", model.p, flows)
                assert outside.max() > 1e-6 or not np.allclose(power, level, atol=1e-5)


def test_the_plant_power_replaces_the_affine_level(problems: list[RMPCProblem]) -> None:
    problem = problems[0]
    affine = building_envelope(problem, (2,))
    doubled = building_envelope(problem, (2,), lambda flows: 2.0 * float(flows.sum()))
    assert not np.allclose(affine, doubled)
    flows = hold_flows(problem, float(affine[0, 1]), 2)
    assert doubled[0, 1] == pytest.approx(2.0 * float(flows.sum()), rel=1e-6)


def test_envelope_frame_rows() -> None:
    index = pd.date_range("2014-03-03", periods=2, freq="30min", tz="Asia/Singapore")
    envelope = np.arange(12, dtype=float).reshape(2, 3, 2)
    frame = envelope_frame(index, envelope)
    assert list(frame.columns) == list(ENVELOPE_COLUMNS)
    assert list(frame["duration_min"]) == list(DURATIONS_MIN) * 2
    assert list(frame["time"]) == [index[0]] * 3 + [index[1]] * 3
    assert list(frame["min_power_kw"]) == [0, 2, 4, 6, 8, 10]
    assert list(frame["max_power_kw"]) == [1, 3, 5, 7, 9, 11]


def test_a_hold_longer_than_the_horizon_is_refused(problems: list[RMPCProblem]) -> None:
    with pytest.raises(ValueError, match="does not fit"):
        hold_model(problems[0], problems[0].horizon + 1)
