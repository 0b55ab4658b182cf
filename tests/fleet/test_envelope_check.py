"""The envelope checked in closed loop: the RC plants hold its ends within comfort and 5 %."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.fleet.envelope_check import (
    HOLD_COLUMNS,
    _error_fraction,
    _refuse_uncomfortable,
    check_holds,
)
from hvacflex.fleet.generate import generate_fleet, write_fleet
from hvacflex.fleet.schema import load_fleet_document


def _check(fleet_path: Path, start: str, hold_starts: list[int]) -> None:
    fleet, doc = load_fleet_document(fleet_path)
    holds = check_holds(fleet, doc, start, hold_starts, duration_min=60)
    assert list(holds.columns) == list(HOLD_COLUMNS)
    assert len(holds) == 2 * len(hold_starts)
    assert list(holds["end"]) == ["min", "max"] * len(hold_starts)
    levels = holds["envelope_kw"].to_numpy().reshape(-1, 2)
    assert np.all(levels[:, 0] < levels[:, 1])
    # the plants' meters hold the envelope's level within 5 % and the zones stay in band
    assert holds["error_pct"].max() <= 5.0
    assert holds["max_violation_k"].max() <= 1e-6
    assert holds["discomfort_kelvin_hours"].max() <= 1e-6


def test_one_building_holds_its_envelope_for_an_hour(tmp_path: Path) -> None:
    doc = generate_fleet(1, 3, feeder_limit_kw=float("inf"), min_bid_mw=0.1)
    _check(write_fleet(doc, tmp_path / "one.toml"), "2014-03-03T10:00", [0, 2])


@pytest.mark.slow
def test_eight_buildings_hold_their_envelope_from_three_periods(tmp_path: Path) -> None:
    doc = generate_fleet(8, 3, feeder_limit_kw=float("inf"), min_bid_mw=0.01)
    _check(write_fleet(doc, tmp_path / "eight.toml"), "2014-03-03T00:00", [20, 28, 31])


def test_a_duration_the_envelope_lacks_is_refused_before_running(tmp_path: Path) -> None:
    doc = generate_fleet(1, 3, feeder_limit_kw=float("inf"), min_bid_mw=0.1)
    fleet, document = load_fleet_document(write_fleet(doc, tmp_path / "one.toml"))
    with pytest.raises(ValueError, match=r"duration_min 45 .* use one of 30, 60, 120"):
        check_holds(fleet, document, "2014-03-03T10:00", [0], duration_min=45)


def test_the_error_of_a_zero_kw_level_is_nan_not_a_division_by_zero() -> None:
    metered = np.array([0.5, 1.0])
    assert np.isnan(_error_fraction(metered, 0.0)).all()
    np.testing.assert_allclose(_error_fraction(metered, 2.0), [0.75, 0.5])


def test_a_start_where_a_building_cannot_keep_comfort_is_refused() -> None:
    time = pd.Timestamp("2014-03-03T06:00")
    _refuse_uncomfortable(np.array([[1.0, 2.0], [3.0, 4.0]]), time, 120)
    with pytest.raises(ValueError, match=r"building\(s\) 1 cannot hold .* 120 min"):
        _refuse_uncomfortable(np.array([[1.0, 2.0], [np.nan, np.nan]]), time, 120)
