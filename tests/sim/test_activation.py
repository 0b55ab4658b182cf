from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.config import ActivationConfig
from hvacflex.errors import DataError
from hvacflex.sim.activation import ActivationFileWarning, activation_schedule

INDEX = pd.date_range("2014-03-03", periods=96, freq="30min", tz="Asia/Singapore")


def test_never_and_always() -> None:
    assert not activation_schedule(ActivationConfig(mode="never"), INDEX, seed=1).any()
    assert activation_schedule(ActivationConfig(mode="always"), INDEX, seed=1).all()


def _blocks(flags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices and lengths of the runs of True."""
    padded = np.concatenate([[False], flags, [False]])
    starts = np.flatnonzero(~padded[:-1] & padded[1:])
    ends = np.flatnonzero(padded[:-1] & ~padded[1:])
    return starts, ends - starts


def test_random_is_seeded_and_lasts_one_to_d_periods() -> None:
    year = pd.date_range("2014-01-01", periods=17_520, freq="30min", tz="Asia/Singapore")
    cfg = ActivationConfig(mode="random", events_per_year=50.0, duration_steps=3)
    one = activation_schedule(cfg, year, seed=7)
    assert np.array_equal(one, activation_schedule(cfg, year, seed=7))
    assert not np.array_equal(one, activation_schedule(cfg, year, seed=8))
    starts, lengths = _blocks(one)
    # durations 1 … D, all of them drawn; events never overlap nor touch
    assert set(lengths.tolist()) == {1, 2, 3}
    assert (np.diff(starts) > lengths[:-1]).all()
    # the rate is in events per year: 50 ± 4σ of a Poisson count
    assert abs(len(starts) - 50) < 4 * np.sqrt(50)


def test_random_duration_defaults_to_the_event_length_d() -> None:
    year = pd.date_range("2014-01-01", periods=17_520, freq="30min", tz="Asia/Singapore")
    cfg = ActivationConfig(mode="random", events_per_year=100.0)
    _, lengths = _blocks(activation_schedule(cfg, year, seed=1, max_steps=2))
    assert set(lengths.tolist()) == {1, 2}
    _, lengths = _blocks(activation_schedule(cfg, year, seed=1))  # the 120-min rule
    assert lengths.max() == 4


def test_stress_is_one_event_every_weekday_in_office_hours() -> None:
    # 1–30 March 2014 (from Saturday 1st): 20 weekdays (3–7, 10–14, 17–21, 24–28)
    month = pd.date_range("2014-03-01", periods=30 * 48, freq="30min", tz="Asia/Singapore")
    flags = activation_schedule(ActivationConfig(mode="stress"), month, seed=3)
    starts, lengths = _blocks(flags)
    start_times = month[starts]
    assert len(starts) == 20  # one on each weekday
    assert sorted(set(start_times.day)) == [
        d for d in range(1, 31) if pd.Timestamp(2014, 3, d).day_of_week < 5
    ]
    hours = start_times.hour + start_times.minute / 60
    assert (hours >= 8.0).all() and (hours < 18.0).all()
    assert lengths.min() >= 1 and lengths.max() <= 4 and len(set(lengths.tolist())) > 1
    again = activation_schedule(ActivationConfig(mode="stress"), month, seed=3)
    assert np.array_equal(flags, again)  # seeded
    other = activation_schedule(ActivationConfig(mode="stress"), month, seed=4)
    assert not np.array_equal(flags, other)
    short = activation_schedule(ActivationConfig(mode="stress", duration_steps=1), month, seed=3)
    assert _blocks(short)[1].max() == 1


def test_file_schedule_aligns_on_period_starts(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("time,activated\n2014-03-03T10:00:00+08:00,1\n2014-03-03T10:30:00+08:00,1\n")
    flags = activation_schedule(ActivationConfig(mode="file", file=str(path)), INDEX, seed=0)
    assert flags.sum() == 2
    assert flags[20] and flags[21]


def test_file_with_bad_flag_names_line_and_value(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("time,activated\n2014-03-03T10:00:00+08:00,yes\n")
    with pytest.raises(DataError, match=r"il.csv:2.*activated.*'yes'"):
        activation_schedule(ActivationConfig(mode="file", file=str(path)), INDEX, seed=0)


def test_file_missing_column(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("when,activated\n")
    with pytest.raises(DataError, match="time"):
        activation_schedule(ActivationConfig(mode="file", file=str(path)), INDEX, seed=0)


def test_file_with_a_period_twice_names_line(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("time,activated\n2014-03-03T10:00:00+08:00,1\n2014-03-03T10:00:00+08:00,0\n")
    with pytest.raises(DataError, match=r"il.csv:3.*twice"):
        activation_schedule(ActivationConfig(mode="file", file=str(path)), INDEX, seed=0)


def _schedule(path: Path) -> np.ndarray:
    return activation_schedule(ActivationConfig(mode="file", file=str(path)), INDEX, seed=0)


def test_empty_file_says_so(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("")
    with pytest.raises(DataError, match="activation file is empty"):
        _schedule(path)
    path.write_text("time,activated\n")
    with pytest.raises(DataError, match="no data rows"):
        _schedule(path)


def test_binary_garbage_is_not_a_csv(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(DataError, match=r"il\.csv.*not a readable CSV text file"):
        _schedule(path)


def test_a_row_not_on_a_period_start_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("time,activated\n2014-03-03T10:00,1\n2014-03-03T10:15,1\n")
    with pytest.raises(DataError, match=r"il.csv:3.*start of a 30-min period") as info:
        _schedule(path)
    assert info.value.value == "2014-03-03T10:15"


def test_an_unparseable_time_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("time,activated\n2014-03-03T10:00,1\nmonday,1\n")
    with pytest.raises(DataError, match=r"il.csv:3.*unparseable time"):
        _schedule(path)


def test_rows_outside_the_run_warn_and_are_ignored(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("time,activated\n2014-03-03T10:00,1\n2014-05-01T10:00,1\n2013-01-01,1\n")
    with pytest.warns(ActivationFileWarning, match=r"2 of 3 row\(s\) lie outside the run"):
        flags = _schedule(path)
    assert flags.sum() == 1 and flags[20]


def test_naive_times_are_local_and_aware_ones_are_converted(tmp_path: Path) -> None:
    path = tmp_path / "il.csv"
    path.write_text("time,activated\n2014-03-03T10:00,1\n2014-03-03T03:00:00+00:00,1\n")
    flags = _schedule(path)
    assert flags.sum() == 2 and flags[20] and flags[22]
