"""The trend reader: 30-min means, resampling of finer data, and every refusal naming the
file, line, column and value."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.errors import InputError
from hvacflex.identify.trend import read_trend, write_trend


def _frame(periods: int = 6, freq: str = "30min") -> pd.DataFrame:
    index = pd.date_range("2014-03-04", periods=periods, freq=freq, tz="Asia/Singapore")
    k = np.arange(periods, dtype=float)
    return pd.DataFrame(
        {
            "temp_Room-A_degc": 24.0 + 0.1 * k,
            "supply_flow_Room-A_kg_s": 0.2 + 0.0 * k,
            "supply_temp_Room-A_degc": 14.0 + 0.0 * k,
            "temp_PLENUM_degc": 26.0 + 0.0 * k,
            "outdoor_temp_degc": 30.0 + k,
            "ghi_w_per_m2": 100.0 * k,
            "occupied": (k >= 2).astype(float),
            "hvac_power_kw": 5.0 + k,
        },
        index=index,
    )


def _write(tmp_path: Path, frame: pd.DataFrame) -> Path:
    return write_trend(frame, tmp_path / "trend.csv")


def test_a_written_trend_reads_back_on_its_grid(tmp_path: Path) -> None:
    frame = _frame()
    data = read_trend(_write(tmp_path, frame))
    assert data.zones == ("Room-A", "PLENUM")
    assert str(data.index.tz) == "Asia/Singapore" and len(data.index) == 6
    np.testing.assert_allclose(data.column("outdoor_temp_degc"), frame["outdoor_temp_degc"])
    assert data.zone_series("supply_flow", ("Room-A",)) is not None
    assert data.zone_series("supply_flow", ("PLENUM",)) is None


def test_five_minute_data_becomes_thirty_minute_means(tmp_path: Path) -> None:
    frame = _frame(periods=12, freq="5min")
    data = read_trend(_write(tmp_path, frame))
    assert len(data.index) == 2
    # outdoor 30, 31, …, 41 at 5 min: the means of 30…35 and 36…41
    np.testing.assert_allclose(data.column("outdoor_temp_degc"), [32.5, 38.5])
    assert data.index[1] - data.index[0] == pd.Timedelta("30min")


def test_naive_times_are_local_time(tmp_path: Path) -> None:
    frame = _frame()
    frame.index = frame.index.tz_localize(None)
    data = read_trend(_write(tmp_path, frame))
    assert data.index[0] == pd.Timestamp("2014-03-04 00:00", tz="Asia/Singapore")


def _refusal(tmp_path: Path, frame: pd.DataFrame) -> InputError:
    with pytest.raises(InputError) as caught:
        read_trend(_write(tmp_path, frame))
    return caught.value


def test_a_gap_in_the_index_is_refused_with_its_line(tmp_path: Path) -> None:
    error = _refusal(tmp_path, _frame().drop(_frame().index[3]))
    assert error.line == 5 and error.field == "time" and "gap" in str(error)
    assert "fill the missing rows" in str(error).lower()


def test_a_duplicate_time_is_refused(tmp_path: Path) -> None:
    frame = _frame()
    frame = pd.concat([frame.iloc[:3], frame.iloc[2:]])
    error = _refusal(tmp_path, frame)
    assert error.line == 5 and "duplicate" in str(error)


def test_an_empty_cell_is_refused_with_line_and_column(tmp_path: Path) -> None:
    frame = _frame()
    frame.iloc[4, 0] = np.nan
    error = _refusal(tmp_path, frame)
    assert error.line == 6 and error.field == "temp_Room-A_degc" and "empty cell" in str(error)


def test_a_value_out_of_range_is_refused(tmp_path: Path) -> None:
    frame = _frame()
    frame.iloc[1, frame.columns.get_loc("occupied")] = 3.0
    error = _refusal(tmp_path, frame)
    assert error.line == 3 and error.value == "3" and "[0, 1]" in str(error)


def test_the_outdoor_humidity_is_read_as_a_ratio_and_a_slip_to_g_per_kg_refused(
    tmp_path: Path,
) -> None:
    frame = _frame(periods=12, freq="15min").assign(
        outdoor_humidity_ratio_kg_per_kg=np.linspace(0.017, 0.0225, 12)
    )
    data = read_trend(_write(tmp_path, frame))  # 15-min readings: their 30-min means
    np.testing.assert_allclose(
        data.column("outdoor_humidity_ratio_kg_per_kg"),
        frame["outdoor_humidity_ratio_kg_per_kg"].to_numpy().reshape(6, 2).mean(axis=1),
    )
    frame = _frame().assign(outdoor_humidity_ratio_kg_per_kg=0.018)
    frame.iloc[2, frame.columns.get_loc("outdoor_humidity_ratio_kg_per_kg")] = 18.5  # g/kg
    error = _refusal(tmp_path, frame)
    assert error.field == "outdoor_humidity_ratio_kg_per_kg" and error.line == 4


def test_unknown_and_incomplete_columns_are_refused(tmp_path: Path) -> None:
    frame = _frame().rename(columns={"ghi_w_per_m2": "ghi"})
    assert _refusal(tmp_path, frame).field == "ghi_w_per_m2"  # the required one is missing
    frame = _frame().assign(humidity=0.5)
    error = _refusal(tmp_path, frame)
    assert error.field == "humidity" and "unknown trend column" in str(error)
    frame = _frame().drop(columns=["supply_temp_Room-A_degc"])
    error = _refusal(tmp_path, frame)
    assert error.field == "supply_temp_Room-A_degc" and "come together" in str(error)


def test_a_step_coarser_than_thirty_minutes_is_refused(tmp_path: Path) -> None:
    error = _refusal(tmp_path, _frame(freq="1h"))
    assert "divide 30 min" in str(error)
