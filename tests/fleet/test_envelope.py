"""The flexibility envelope: the condensed hold model, the holds' LP and envelope.csv."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import sparse

from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.envelope import (
    COMFORT_TOLERANCE_K,
    DURATIONS_MIN,
    ENVELOPE_COLUMNS,
    HoldModel,
    _hold_block,
    _hold_matrix,
    _solve_blocks,
    building_envelope,
    duration_steps,
    envelope_frame,
    fleet_envelope,
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
    envelope = np.arange(18, dtype=float).reshape(2, 3, 3)
    frame = envelope_frame(index, envelope)
    assert list(frame.columns) == list(ENVELOPE_COLUMNS)
    assert list(frame["duration_min"]) == list(DURATIONS_MIN) * 2
    assert list(frame["time"]) == [index[0]] * 3 + [index[1]] * 3
    assert list(frame["min_power_kw"]) == [0, 3, 6, 9, 12, 15]
    assert list(frame["max_power_kw"]) == [1, 4, 7, 10, 13, 16]
    assert list(frame["buildings"]) == [2, 5, 8, 11, 14, 17]


def test_the_fleet_sums_only_its_comfort_keeping_buildings() -> None:
    buildings = np.array(
        [
            [[10.0, 20.0], [np.nan, np.nan]],
            [[1.0, 2.0], [3.0, 4.0]],
        ]
    )
    fleet = fleet_envelope(buildings)
    np.testing.assert_array_equal(fleet, [[11.0, 22.0, 2.0], [3.0, 4.0, 1.0]])
    none = fleet_envelope(np.full((2, 1, 2), np.nan))
    assert np.isnan(none[0, :2]).all() and none[0, 2] == 0.0


def test_no_hold_that_leaves_comfort_enters_the_envelope(small_fleet: Path) -> None:
    """From 06:00 the first building cannot hold any level for 120 min in comfort (occupancy
    starts in the hold): its range is NaN there, not the least-slack level, and the fleet's
    120-min row sums the other building only."""
    fleet, doc = load_fleet_document(small_fleet)
    group = BuildingGroup(doc, [0, 1], FleetSettings.of(fleet, "2014-03-03T06:00", 0.25))
    group.begin_step()
    problems = group.problems()
    steps = duration_steps()
    envelopes = np.array([building_envelope(p, steps) for p in problems])
    # the least-slack 120-min hold of building 0 does leave comfort
    model = hold_model(problems[0], steps[-1])
    slack = [s.max_slack_k for s in _solve_blocks([_hold_block(model, 1.0)])]
    assert slack[0] > COMFORT_TOLERANCE_K
    assert np.isnan(envelopes[0, -1]).all()
    assert np.isfinite(envelopes[0, 0]).all()  # its 30-min hold keeps comfort
    assert np.isfinite(envelopes[1]).all()
    fleet_rows = fleet_envelope(envelopes)
    assert list(fleet_rows[:, 2]) == [2.0, 2.0, 1.0]
    np.testing.assert_allclose(fleet_rows[-1, :2], envelopes[1, -1])


def test_a_failed_block_leaves_the_others_and_is_logged(
    problems: list[RMPCProblem], caplog: pytest.LogCaptureFixture
) -> None:
    model = hold_model(problems[0], 2)
    impossible = _hold_block(model, 0.0, 1.0e6)  # a level no flow reaches: infeasible
    with caplog.at_level(logging.WARNING, logger="hvacflex.fleet.envelope"):
        good, bad = _solve_blocks([_hold_block(model, 1.0), impossible])
    assert good.ok and np.isfinite(good.x).all()
    assert not bad.ok and np.isnan(bad.x).all()
    assert "block 1 of 2 failed" in caplog.text


def test_a_hold_longer_than_the_horizon_is_refused(problems: list[RMPCProblem]) -> None:
    with pytest.raises(ValueError, match="does not fit"):
        hold_model(problems[0], problems[0].horizon + 1)


def _stacked_hold_matrix(model: HoldModel) -> sparse.csr_matrix:
    """The hold LP's rows assembled block by block from sparse parts (an independent
    construction of :func:`_hold_matrix`'s matrix)."""
    h, ny = model.steps, model.ny
    eye = sparse.identity(h * ny, format="csr")
    gain = sparse.csr_matrix(model.gain)
    zeros = sparse.csr_matrix((h * ny, 1))
    power = sparse.block_diag([row[None, :] for row in model.p], format="csr")
    return sparse.vstack(
        [
            sparse.hstack([gain, eye, zeros]),
            sparse.hstack([gain, -eye, zeros]),
            sparse.hstack([power, sparse.csr_matrix((h, h * ny)), -np.ones((h, 1))]),
        ],
        format="csr",
    )


def test_the_longest_hold_s_model_serves_the_shorter_ones(problems: list[RMPCProblem]) -> None:
    """One model built at the longest hold, cut to a shorter one, is the shorter hold's model
    bit for bit, and its LP rows are those assembled from sparse parts (so envelope.csv does
    not change with the way they are built)."""
    steps = duration_steps()
    for problem in problems:
        longest = hold_model(problem, max(steps))
        for h in steps:
            cut, built = longest.first(h), hold_model(problem, h)
            for name in ("gain", "free", "y_min", "y_max", "u_min", "u_max", "p0", "p"):
                np.testing.assert_array_equal(getattr(cut, name), getattr(built, name), name)
            fast, stacked = _hold_matrix(cut), _stacked_hold_matrix(built)
            fast.sort_indices()
            stacked.sort_indices()
            np.testing.assert_array_equal(fast.indptr, stacked.indptr)
            np.testing.assert_array_equal(fast.indices, stacked.indices)
            np.testing.assert_array_equal(fast.data, stacked.data)
    with pytest.raises(ValueError, match="does not fit"):
        hold_model(problems[0], 2).first(3)


def test_the_offers_call_carries_the_envelope_or_none(small_fleet: Path) -> None:
    """The step's offers and envelope come in one group call: the envelope equals the
    group's own, and none is computed for no durations."""
    fleet, doc = load_fleet_document(small_fleet)
    group = BuildingGroup(doc, [0, 1], FleetSettings.of(fleet, "2014-03-03T10:00", 0.25))
    group.begin_step()
    steps = duration_steps()
    offer, curtailed, baseline, envelope = group.staged_offer_kw(steps)
    (alone,) = group.envelope(steps)
    np.testing.assert_array_equal(envelope, alone)
    assert envelope.shape == (2, len(steps), 2) and np.isfinite(envelope).any()
    offer_off, curtailed_off, baseline_off, none = group.staged_offer_kw()
    assert none.shape == (2, 0, 2)
    np.testing.assert_array_equal(offer, offer_off)
    np.testing.assert_array_equal(curtailed, curtailed_off)
    np.testing.assert_array_equal(baseline, baseline_off)
