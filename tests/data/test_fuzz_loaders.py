"""Property-based fuzzing of the USEP and EPW loaders with mutated copies of the real files.

Each example takes a slice of a shipped file (the header and the first days), applies one to
four mutations (byte flips, dropped / duplicated / swapped lines, truncation, swapped
columns, huge / inf / NaN / missing-code numbers) and loads it. The loader must either
return data that passes the physical checks or raise :class:`~hvacflex.errors.DataError`;
any other exception fails the test. 200 examples per loader in the default suite, 2,000
under ``-m slow``.
"""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hvacflex.data.market import (
    ENERGY_PRICE_COLUMN,
    MAX_SYSTEM_DEMAND_MW,
    PRICE_CAP_SGD_PER_MWH,
    PRICE_FLOOR_SGD_PER_MWH,
    SYSTEM_DEMAND_COLUMN,
    load_usep,
)
from hvacflex.data.weather import (
    DEWPOINT_ABOVE_DRY_BULB_TOLERANCE_K,
    DIFFUSE_ABOVE_GLOBAL_TOLERANCE_WH_PER_M2,
    ELEVATION_RANGE_M,
    EPW_FIELDS,
    GROUND_TEMP_RANGE_DEGC,
    TIMEZONE_RANGE_H,
    night_hours,
    parse_epw_text,
)
from hvacflex.errors import DataError
from hvacflex.paths import data_dir

DEFAULT_EXAMPLES = 200
SLOW_EXAMPLES = 2000
EPW_HOURS = 72  # the first three days of the year
USEP_DAYS = 2
EPW_FILE = "SGP_SG_Singapore-Changi.Intl.AP.486980_TMYx.2009-2023.epw"
USEP_FILE = "USEP_Jan-2014.csv"

NASTY_NUMBERS = (
    "inf", "-inf", "nan", "NaN", "1e308", "-1e308", "1e309", "9999", "99.9", "999999", "-273",
    "", " ", "0", "-0", "1e-320", "123456789012345678901234567890", "0x10", "1_000", "∞",
)  # fmt: skip


def _fuzz_settings(examples: int) -> settings:
    return settings(
        max_examples=examples,
        deadline=None,
        derandomize=examples == DEFAULT_EXAMPLES,  # the default suite is reproducible
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


# ------------------------------------------------------------------------------- mutations


@st.composite
def _mutated(draw: st.DrawFn, original: bytes) -> bytes:
    """``original`` with one to four random mutations."""
    data = original
    for _ in range(draw(st.integers(1, 4))):
        lines = data.split(b"\n")
        kind = draw(
            st.sampled_from(
                ["flip", "drop", "duplicate", "swap_lines", "truncate", "swap_columns", "number"]
            )
        )
        if kind == "flip" and data:
            at = draw(st.integers(0, len(data) - 1))
            data = data[:at] + bytes([draw(st.integers(0, 255))]) + data[at + 1 :]
            continue
        if kind == "truncate":
            data = data[: draw(st.integers(0, len(data)))]
            continue
        i = draw(st.integers(0, len(lines) - 1))
        j = draw(st.integers(0, len(lines) - 1))
        if kind == "drop":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "swap_lines":
            lines[i], lines[j] = lines[j], lines[i]
        else:
            rows = range(len(lines)) if draw(st.booleans()) else [i]  # whole column or one cell
            a = draw(st.integers(0, 40))
            b = draw(st.integers(0, 40))
            value = draw(st.sampled_from(NASTY_NUMBERS)).encode()
            for r in rows:
                fields = lines[r].split(b",")
                if kind == "swap_columns" and max(a, b) < len(fields):
                    fields[a], fields[b] = fields[b], fields[a]
                elif kind == "number" and a < len(fields):
                    quoted = fields[a].startswith(b'"')
                    fields[a] = b'"' + value + b'"' if quoted else value
                lines[r] = b",".join(fields)
        data = b"\n".join(lines)
    return data


# ------------------------------------------------------------------------------- USEP


@functools.cache
def _usep_slice() -> bytes:
    lines = (data_dir() / "nems_usep_2014" / USEP_FILE).read_bytes().split(b"\n")
    return b"\n".join(lines[: 1 + 48 * USEP_DAYS]) + b"\n"


def _check_usep(data: bytes, fill: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / USEP_FILE
        path.write_bytes(data)
        try:
            frame = load_usep(path, fill=fill)  # type: ignore[arg-type]
        except DataError:
            return
    index = frame.index
    assert isinstance(index, pd.DatetimeIndex) and str(index.tz) == "Asia/Singapore"
    assert len(index) > 0 and len(index) % 48 == 0
    assert (index[1:] - index[:-1] == pd.Timedelta(minutes=30)).all()
    price = frame[ENERGY_PRICE_COLUMN].to_numpy()
    assert np.isfinite(price).all()
    assert (price >= PRICE_FLOOR_SGD_PER_MWH).all() and (price <= PRICE_CAP_SGD_PER_MWH).all()
    if SYSTEM_DEMAND_COLUMN in frame:
        demand = frame[SYSTEM_DEMAND_COLUMN].to_numpy()
        assert np.isfinite(demand).all()
        assert (demand >= 0).all() and (demand <= MAX_SYSTEM_DEMAND_MW).all()


# Deferred: the shipped files are read when the first example is drawn, not at import.
_USEP_CASES = st.deferred(
    lambda: st.tuples(_mutated(_usep_slice()), st.sampled_from(["none", "previous-day"]))
)
_EPW_CASES = st.deferred(lambda: _mutated(_epw_slice()))


@_fuzz_settings(DEFAULT_EXAMPLES)
@given(_USEP_CASES)
def test_usep_loader_loads_valid_data_or_raises_data_error(case: tuple[bytes, str]) -> None:
    _check_usep(*case)


@pytest.mark.slow
@_fuzz_settings(SLOW_EXAMPLES)
@given(_USEP_CASES)
def test_usep_loader_fuzz_long(case: tuple[bytes, str]) -> None:
    _check_usep(*case)


# ------------------------------------------------------------------------------- EPW


@functools.cache
def _epw_slice() -> bytes:
    lines = (data_dir() / "weather" / EPW_FILE).read_bytes().split(b"\n")
    return b"\n".join(lines[: 8 + EPW_HOURS]) + b"\n"


def _check_epw(data: bytes) -> None:
    text = data.decode("latin-1")  # as read_epw reads a file
    try:
        frame, location = parse_epw_text(text, "fuzz.epw", hours=EPW_HOURS)
    except DataError:
        return
    assert len(frame) == EPW_HOURS
    for spec in EPW_FIELDS:
        values = frame[spec.column].to_numpy(dtype=float)
        if not spec.required:  # a missing optional value is NaN
            values = values[np.isfinite(values)]
        assert np.isfinite(values).all(), spec.column
        assert (values >= spec.minimum).all() and (values <= spec.maximum).all(), spec.column
        if spec.missing is not None:
            assert (values < spec.missing).all(), spec.column
    # fields that contradict each other are refused (tolerances in hvacflex.data.weather)
    dew_excess = frame["dewpoint_degc"] - frame["outdoor_temp_degc"]
    assert (dew_excess.round(6) <= DEWPOINT_ABOVE_DRY_BULB_TOLERANCE_K).all()
    diffuse_excess = frame["dhi_w_per_m2"] - frame["ghi_w_per_m2"]
    assert (diffuse_excess <= DIFFUSE_ABOVE_GLOBAL_TOLERANCE_WH_PER_M2).all()
    night = night_hours(location, EPW_HOURS)
    assert (frame.loc[night, ["ghi_w_per_m2", "dni_w_per_m2"]].to_numpy() == 0).all()
    starts = pd.date_range("2001-01-01", periods=EPW_HOURS, freq="h")
    assert (frame["month"].to_numpy() == starts.month).all()
    assert (frame["day"].to_numpy() == starts.day).all()
    assert (frame["hour"].to_numpy() == starts.hour + 1).all()
    assert -90 <= location.latitude_deg <= 90 and -180 <= location.longitude_deg <= 180
    assert TIMEZONE_RANGE_H[0] <= location.tz_offset_h <= TIMEZONE_RANGE_H[1]
    assert ELEVATION_RANGE_M[0] <= location.elevation_m <= ELEVATION_RANGE_M[1]
    ground = np.asarray(location.ground_temp_monthly_degc, dtype=float)
    assert len(ground) in (0, 12)
    assert ((ground >= GROUND_TEMP_RANGE_DEGC[0]) & (ground <= GROUND_TEMP_RANGE_DEGC[1])).all()


@_fuzz_settings(DEFAULT_EXAMPLES)
@given(_EPW_CASES)
def test_epw_loader_loads_valid_data_or_raises_data_error(data: bytes) -> None:
    _check_epw(data)


@pytest.mark.slow
@_fuzz_settings(SLOW_EXAMPLES)
@given(_EPW_CASES)
def test_epw_loader_fuzz_long(data: bytes) -> None:
    _check_epw(data)


def test_the_unmutated_slices_load() -> None:
    """The fuzz starts from data the loaders accept (else every example would be an error)."""
    frame, _ = parse_epw_text(_epw_slice().decode("latin-1"), "slice.epw", hours=EPW_HOURS)
    assert len(frame) == EPW_HOURS
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / USEP_FILE
        path.write_bytes(_usep_slice())
        assert len(load_usep(path)) == 48 * USEP_DAYS
