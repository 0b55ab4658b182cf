"""USEP and reserve-price loaders: shipped 2014 data and one malformed file per error class."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.data.market import (
    ENERGY_PRICE_COLUMN,
    RESERVE_PRICE_COLUMN,
    RESERVE_PRICE_CORRELATION,
    RESERVE_PRICE_NOISE_SIGMA,
    RESERVE_PRICE_REFERENCE_SGD_PER_MWH,
    RESERVE_PRICE_SCALE,
    RESERVE_PRICE_SPIKE_GAIN,
    RESERVE_PRICE_SPIKE_THRESHOLD_SGD_PER_MWH,
    load_reserve_prices,
    load_usep,
    synthetic_reserve_prices,
)
from hvacflex.errors import DataError

OLD_HEADER = '"INFORMATION TYPE","DATE","PERIOD","PRICE ($/MWh)","DEMAND (MW)"'
NEW_HEADER = (
    '"INFORMATION TYPE","DATE","PERIOD","USEP ($/MWh)","LCP ($/MWh)","DEMAND (MW)","TCL (MW)",'
    '"SOLAR(MW)","RUSEP ($/MWh)","MAP ($/MWh)","MAPT ($/MWh)","TPC Applied"'
)


def _old_rows(date: str = "01 Jan 2014", periods: range = range(1, 49)) -> list[str]:
    return [f'"USEP","{date}","{p}","{100 + p:.2f}","{5000 + p}.5"' for p in periods]


def _write(tmp_path: Path, lines: list[str], name: str = "usep.csv") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def usep_2014(shared_data_dir: Path) -> pd.DataFrame:
    return load_usep(shared_data_dir / "nems_usep_2014")


def test_shipped_2014_has_every_period(usep_2014: pd.DataFrame) -> None:
    assert len(usep_2014) == 17_520
    assert str(usep_2014.index.tz) == "Asia/Singapore"
    assert usep_2014.index[0] == pd.Timestamp("2014-01-01 00:00", tz="Asia/Singapore")
    assert usep_2014.index[-1] == pd.Timestamp("2014-12-31 23:30", tz="Asia/Singapore")
    assert (usep_2014.index[1:] - usep_2014.index[:-1] == pd.Timedelta(minutes=30)).all()
    assert list(usep_2014.columns) == [ENERGY_PRICE_COLUMN, "system_demand_mw"]


def test_shipped_2014_reproduces_provenance_statistics(usep_2014: pd.DataFrame) -> None:
    price = usep_2014[ENERGY_PRICE_COLUMN]
    assert price.mean() == pytest.approx(136.7, abs=0.05)
    assert price.median() == pytest.approx(127.4, abs=0.05)
    assert price.max() == pytest.approx(936.8, abs=0.05)
    assert price[price.index.month == 12].mean() == pytest.approx(92.6, abs=0.05)
    zeros = price[price == 0.0]
    assert [f"{t:%d %b} P{(t.hour * 60 + t.minute) // 30 + 1}" for t in zeros.index] == [
        "07 Jan P4",
        "21 Jan P3",
        "23 Jan P7",
        "23 Jan P8",
        "23 Jan P9",
    ]
    demand = usep_2014["system_demand_mw"]
    assert demand.min() == pytest.approx(3796, abs=1) and demand.max() == pytest.approx(6850, abs=1)


def test_period_p_starts_at_p_minus_one_half_hours(tmp_path: Path) -> None:
    frame = load_usep(_write(tmp_path, [OLD_HEADER, *_old_rows()]))
    assert frame[ENERGY_PRICE_COLUMN].iloc[0] == 101.0  # P1 → 00:00
    assert (
        frame.loc[pd.Timestamp("2014-01-01 23:30", tz="Asia/Singapore"), ENERGY_PRICE_COLUMN]
        == 148.0
    )


def test_new_format_with_extra_columns_and_negative_prices(tmp_path: Path) -> None:
    rows = [
        f'"USEP","02-Jan-2023","{p}","{-5.0 if p == 3 else 0.0 if p == 4 else 200.0}","190",'
        f'"6000","100","300","1","2","3","N"'
        for p in range(1, 49)
    ]
    frame = load_usep(_write(tmp_path, [NEW_HEADER, *rows]))
    assert frame.index[0] == pd.Timestamp("2023-01-02", tz="Asia/Singapore")
    assert frame[ENERGY_PRICE_COLUMN].iloc[2] == -5.0
    assert frame[ENERGY_PRICE_COLUMN].iloc[3] == 0.0
    assert frame["system_demand_mw"].iloc[0] == 6000.0


def test_list_of_files_and_folder(tmp_path: Path) -> None:
    a = _write(tmp_path, [OLD_HEADER, *_old_rows("01 Jan 2014")], "a.csv")
    b = _write(tmp_path, [OLD_HEADER, *_old_rows("02 Jan 2014")], "b.csv")
    assert len(load_usep([b, a])) == 96
    assert len(load_usep(tmp_path)) == 96


def test_unknown_header(tmp_path: Path) -> None:
    path = _write(tmp_path, ['"DATE","PERIOD","COST"', '"01 Jan 2014","1","5"'])
    with pytest.raises(DataError, match="unknown header") as info:
        load_usep(path)
    assert info.value.line == 1 and str(path) in str(info.value)


def test_period_outside_range(tmp_path: Path) -> None:
    rows = _old_rows()
    rows[4] = '"USEP","01 Jan 2014","49","100.00","5000"'
    with pytest.raises(DataError, match="period outside 1–48") as info:
        load_usep(_write(tmp_path, [OLD_HEADER, *rows]))
    assert info.value.line == 6 and info.value.value == "49"


def test_unparseable_date(tmp_path: Path) -> None:
    rows = _old_rows()
    rows[10] = '"USEP","32 Jan 2014","11","100.00","5000"'
    with pytest.raises(DataError, match="unparseable date") as info:
        load_usep(_write(tmp_path, [OLD_HEADER, *rows]))
    assert info.value.line == 12 and info.value.value == "32 Jan 2014"


def test_non_numeric_price(tmp_path: Path) -> None:
    rows = _old_rows()
    rows[7] = '"USEP","01 Jan 2014","8","n/a","5000"'
    with pytest.raises(DataError, match="non-numeric price") as info:
        load_usep(_write(tmp_path, [OLD_HEADER, *rows]))
    assert info.value.line == 9 and info.value.value == "n/a"


def test_duplicate_periods_across_files(tmp_path: Path) -> None:
    a = _write(tmp_path, [OLD_HEADER, *_old_rows()], "a.csv")
    b = _write(tmp_path, [OLD_HEADER, *_old_rows()], "b.csv")
    with pytest.raises(DataError, match="duplicate periods") as info:
        load_usep([a, b])
    assert "01 Jan 2014 P1" in str(info.value)
    assert "a.csv:2" in str(info.value) and "b.csv:2" in str(info.value)


def test_missing_periods_are_listed_and_filled_only_on_request(tmp_path: Path) -> None:
    day1 = _old_rows("01 Jan 2014")
    day2 = [r for i, r in enumerate(_old_rows("02 Jan 2014")) if i not in (4, 5)]
    path = _write(tmp_path, [OLD_HEADER, *day1, *day2])
    with pytest.raises(DataError, match="2 missing period") as info:
        load_usep(path)
    assert "02 Jan 2014 P5" in str(info.value) and "02 Jan 2014 P6" in str(info.value)
    assert "fill='previous-day'" in str(info.value)
    filled = load_usep(path, fill="previous-day")
    assert len(filled) == 96
    assert filled[ENERGY_PRICE_COLUMN].iloc[48 + 4] == filled[ENERGY_PRICE_COLUMN].iloc[4]
    assert len(filled.attrs["filled_periods"]) == 2


def test_prices_read_back_from_the_disk_cache_keep_their_filled_periods(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hvacflex.data import market
    from hvacflex.data.cache import CACHE_DIR_ENV

    day2 = [r for i, r in enumerate(_old_rows("02 Jan 2014")) if i != 7]
    path = _write(tmp_path, [OLD_HEADER, *_old_rows("01 Jan 2014"), *day2])
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path / "cache"))
    market._load_usep_cached.cache_clear()
    built = load_usep(path, fill="previous-day")
    market._load_usep_cached.cache_clear()
    read = load_usep(path, fill="previous-day")
    assert len(list((tmp_path / "cache").glob("*.npz"))) == 1
    pd.testing.assert_frame_equal(read, built, check_exact=True)
    assert read.attrs == built.attrs
    assert read.attrs["filled_periods"] == [pd.Timestamp("2014-01-02 03:30", tz="Asia/Singapore")]


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="not found"):
        load_usep(tmp_path / "nope.csv")


def test_reserve_price_csv(tmp_path: Path) -> None:
    header = '"DATE","PERIOD","RESERVE PRICE ($/MWh)"'
    rows = [f'"01 Jan 2014","{p}","{p / 10:.2f}"' for p in range(1, 49)]
    series = load_reserve_prices(_write(tmp_path, [header, *rows]))
    assert series.name == RESERVE_PRICE_COLUMN and series.attrs["synthetic"] is False
    assert series.iloc[-1] == pytest.approx(4.8)
    rows[3] = '"01 Jan 2014","4","--"'
    with pytest.raises(DataError, match="non-numeric price") as info:
        load_reserve_prices(_write(tmp_path, [header, *rows], "bad.csv"))
    assert info.value.line == 5


def test_synthetic_reserve_prices(usep_2014: pd.DataFrame) -> None:
    price = usep_2014[ENERGY_PRICE_COLUMN]
    reserve = synthetic_reserve_prices(price, seed=7)
    assert reserve.name == RESERVE_PRICE_COLUMN and reserve.attrs["synthetic"] is True
    assert reserve.index.equals(price.index)
    # median ≈ 0.9 × scale, mean ≈ scale (documented in RESERVE_PRICE_SCALE)
    assert 0.8 * RESERVE_PRICE_SCALE <= reserve.median() <= 1.0 * RESERVE_PRICE_SCALE
    assert 0.9 * RESERVE_PRICE_SCALE <= reserve.mean() <= 1.15 * RESERVE_PRICE_SCALE
    assert (reserve >= 0).all() and (reserve[price == 0] == 0).all()
    assert np.corrcoef(price, reserve)[0, 1] > 0.5
    spikes = price > 500
    assert reserve[spikes].mean() > 10 * reserve.median()
    # seeded and independent of the requested range
    again = synthetic_reserve_prices(price.iloc[5000:5100], seed=7)
    assert np.array_equal(again.to_numpy(), reserve.iloc[5000:5100].to_numpy())
    assert not np.array_equal(synthetic_reserve_prices(price, seed=8), reserve)


def _reserve_by_hand(price: pd.Series, seed: int, scale: float) -> np.ndarray:
    """The documented formula at ρ = 1, written out independently of the module."""
    local = price.index.tz_convert("Asia/Singapore")
    out = np.empty(len(price))
    for i, stamp in enumerate(local):
        slot = stamp.hour * 2 + stamp.minute // 30
        z = np.random.default_rng([seed, stamp.normalize().toordinal()]).standard_normal(48)[slot]
        noise = np.exp(RESERVE_PRICE_NOISE_SIGMA * z - 0.5 * RESERVE_PRICE_NOISE_SIGMA**2)
        c = float(price.iloc[i])
        spike = 1.0 + RESERVE_PRICE_SPIKE_GAIN * max(
            0.0, c / RESERVE_PRICE_SPIKE_THRESHOLD_SGD_PER_MWH - 1.0
        )
        out[i] = scale * (max(c, 0.0) / RESERVE_PRICE_REFERENCE_SGD_PER_MWH) * noise * spike
    return out


def test_reserve_price_correlation_default_is_the_calibrated_series(
    usep_2014: pd.DataFrame,
) -> None:
    price = usep_2014[ENERGY_PRICE_COLUMN].iloc[:480]
    default = synthetic_reserve_prices(price, seed=7)
    explicit = synthetic_reserve_prices(price, seed=7, correlation=RESERVE_PRICE_CORRELATION)
    assert RESERVE_PRICE_CORRELATION == 1.0
    assert np.array_equal(default.to_numpy(), explicit.to_numpy())
    np.testing.assert_allclose(default.to_numpy(), _reserve_by_hand(price, 7, RESERVE_PRICE_SCALE))


def test_reserve_price_correlation_weights_the_usep_part(usep_2014: pd.DataFrame) -> None:
    price = usep_2014[ENERGY_PRICE_COLUMN]
    full = synthetic_reserve_prices(price, seed=7, correlation=1.0)
    none = synthetic_reserve_prices(price, seed=7, correlation=0.0)
    half = synthetic_reserve_prices(price, seed=7, correlation=0.5)
    # ρ = 0: scale × the mean-one noise, whatever USEP does (also where USEP is 0)
    noise = none.to_numpy() / RESERVE_PRICE_SCALE
    assert abs(noise.mean() - 1.0) < 0.02 and (noise > 0).all()
    assert abs(np.corrcoef(price, none)[0, 1]) < 0.05
    # ρ = 0.5: the mean of the two drivers under the same noise
    np.testing.assert_allclose(half.to_numpy(), 0.5 * (full.to_numpy() + none.to_numpy()))
    pearson = [np.corrcoef(price, s)[0, 1] for s in (none, half, full)]
    assert pearson[0] < pearson[1] < pearson[2]
    assert half.attrs["correlation"] == 0.5


@pytest.mark.parametrize("weight", [-0.1, 1.01, float("nan")])
def test_reserve_price_correlation_outside_zero_one_is_refused(
    usep_2014: pd.DataFrame, weight: float
) -> None:
    with pytest.raises(DataError, match=r"weight in \[0, 1\]") as info:
        synthetic_reserve_prices(usep_2014[ENERGY_PRICE_COLUMN].iloc[:48], correlation=weight)
    assert info.value.field == "correlation"


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("inf", "price beyond the NEMS price floor/cap"),
        ("1e308", "price beyond the NEMS price floor/cap"),
        ("4500.01", r"outside \[-4500, 4500\]"),
        ("-4600", r"outside \[-4500, 4500\]"),
        ("nan", "non-numeric price"),
    ],
)
def test_price_beyond_the_nems_cap_or_not_finite(tmp_path: Path, value: str, message: str) -> None:
    rows = _old_rows()
    rows[9] = f'"USEP","01 Jan 2014","10","{value}","5010.5"'
    with pytest.raises(DataError, match=message) as info:
        load_usep(_write(tmp_path, [OLD_HEADER, *rows]))
    assert info.value.line == 11 and info.value.field == "PRICE ($/MWh)"
    assert info.value.value == value


def test_prices_at_the_cap_and_floor_are_kept(tmp_path: Path) -> None:
    rows = _old_rows()
    rows[0] = '"USEP","01 Jan 2014","1","4500","5001.5"'
    rows[1] = '"USEP","01 Jan 2014","2","-4500","5002.5"'
    price = load_usep(_write(tmp_path, [OLD_HEADER, *rows]))[ENERGY_PRICE_COLUMN]
    assert price.iloc[0] == 4500.0 and price.iloc[1] == -4500.0


@pytest.mark.parametrize("value", ["-1", "inf", "1e9"])
def test_demand_outside_its_range(tmp_path: Path, value: str) -> None:
    rows = _old_rows()
    rows[4] = f'"USEP","01 Jan 2014","5","104.00","{value}"'
    with pytest.raises(DataError, match="demand") as info:
        load_usep(_write(tmp_path, [OLD_HEADER, *rows]))
    assert info.value.line == 6 and info.value.field == "DEMAND (MW)"


def test_reserve_price_beyond_the_cap(tmp_path: Path) -> None:
    rows = [f'"01 Jan 2014","{p}","{9e9 if p == 3 else 2.0}"' for p in range(1, 49)]
    path = _write(tmp_path, ['"DATE","PERIOD","RESERVE PRICE ($/MWh)"', *rows], "il.csv")
    with pytest.raises(DataError, match="floor/cap") as info:
        load_reserve_prices(path)
    assert info.value.line == 4


def test_gap_error_names_the_command_line_option_and_the_scenario_key(tmp_path: Path) -> None:
    rows = [r for r in _old_rows() if '","7","' not in r]
    with pytest.raises(DataError, match="missing period") as info:
        load_usep(_write(tmp_path, [OLD_HEADER, *rows]))
    assert "--price-gap-fill previous-day" in str(info.value)
    assert "data.price_gap_fill" in str(info.value)
    with pytest.raises(DataError, match="unknown fill mode"):
        load_usep(_write(tmp_path, [OLD_HEADER, *rows]), fill="zero")  # type: ignore[arg-type]


def test_an_edited_file_is_read_again(tmp_path: Path) -> None:
    path = _write(tmp_path, [OLD_HEADER, *_old_rows()])
    assert load_usep(path)[ENERGY_PRICE_COLUMN].iloc[0] == 101.0
    rows = _old_rows()
    rows[0] = '"USEP","01 Jan 2014","1","55.5","5001.5"'
    _write(tmp_path, [OLD_HEADER, *rows])
    assert load_usep(path)[ENERGY_PRICE_COLUMN].iloc[0] == 55.5


def test_the_documented_scale_is_the_frozen_one() -> None:
    """The scenario reference states the calibrated default; it must be the frozen value."""
    from hvacflex.config import reference

    text = reference.reference_markdown()
    assert f"the calibrated default, {RESERVE_PRICE_SCALE:g} SGD/MWh" in text
