"""The disk cache of derived tables (hvacflex.data.cache): a table read back equals the one
built (index, time zone, unit, frequency, columns, every bit), the key follows the files'
bytes, the arguments and the arrays, and a cache that is off, damaged or unwritable only
costs time."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from hvacflex.data import cache
from hvacflex.data.cache import CACHE_DIR_ENV, cache_dir, cache_key, cached_frame


def _frame() -> pd.DataFrame:
    index = pd.date_range("2014-03-03", periods=5, freq="30min", tz="Asia/Singapore", name="time")
    rng = np.random.default_rng(3)
    values = rng.standard_normal((5, 2)) * 1e3
    values[2, 1] = np.nan
    return pd.DataFrame({"a_w": values[:, 0], "b_degc": values[:, 1]}, index=index)


def _counting_builder(frame: pd.DataFrame, extra: dict[str, Any]) -> tuple[Any, list[int]]:
    calls: list[int] = []

    def build() -> tuple[pd.DataFrame, dict[str, Any]]:
        calls.append(1)
        return frame, extra

    return build, calls


def test_round_trip_is_exact_and_builds_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path / "c"))
    frame = _frame()
    build, calls = _counting_builder(frame, {"name": "Changi", "ground": [1.5, 2.0]})
    key = cache_key("test", [], [1])
    _, extra1 = cached_frame(key, build)
    second, extra2 = cached_frame(key, build)
    assert len(calls) == 1, "the second call must read the file, not build"
    assert len(list((tmp_path / "c").glob("*.npz"))) == 1
    pd.testing.assert_frame_equal(second, frame, check_exact=True)
    assert second.index.freq == frame.index.freq and second.index.unit == frame.index.unit
    assert extra1 == extra2 == {"name": "Changi", "ground": [1.5, 2.0]}


def test_key_follows_files_arguments_and_arrays(tmp_path: Path) -> None:
    path = tmp_path / "f.csv"
    path.write_text("1,2\n")
    base = cache_key("k", [path], [1], [np.arange(3.0)])
    assert cache_key("k", [path], [1], [np.arange(3.0)]) == base
    assert cache_key("k2", [path], [1], [np.arange(3.0)]) != base
    assert cache_key("k", [path], [2], [np.arange(3.0)]) != base
    assert cache_key("k", [path], [1], [np.arange(3.0) + 1e-12]) != base
    assert cache_key("k", [path], [1], [np.arange(3)]) != base  # dtype counts
    path.write_text("1,3\n")
    assert cache_key("k", [path], [1], [np.arange(3.0)]) != base
    with pytest.raises(OSError):
        cache_key("k", [tmp_path / "missing.csv"], [])


def test_off_damaged_or_unwritable_cache_only_builds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    frame = _frame()
    key = cache_key("test", [], [2])
    monkeypatch.setenv(CACHE_DIR_ENV, "off")
    assert cache_dir() is None
    build, calls = _counting_builder(frame, {})
    cached_frame(key, build)
    cached_frame(key, build)
    assert len(calls) == 2
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path))
    (tmp_path / f"{key}.npz").write_bytes(b"not a zip")
    build, calls = _counting_builder(frame, {})
    got, _ = cached_frame(key, build)
    pd.testing.assert_frame_equal(got, frame, check_exact=True)
    assert len(calls) == 1  # damaged: built anew and replaced
    cached_frame(key, build)
    assert len(calls) == 1
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv(CACHE_DIR_ENV, str(blocker / "sub"))  # cannot be created
    build, calls = _counting_builder(frame, {})
    got, _ = cached_frame(key, build)
    pd.testing.assert_frame_equal(got, frame, check_exact=True)


def test_default_folder_follows_xdg(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv(CACHE_DIR_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_dir() == tmp_path / "hvacflex"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/path")  # ignored, as XDG asks
    assert cache_dir() == Path.home() / ".cache" / "hvacflex"
    assert cache._FORMAT >= 1


def test_cached_weather_prices_and_facades_equal_the_built_ones(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, shared_data_dir: Path
) -> None:
    """The three cached tables of a run's start-up, built (cache off) and read back (second
    call in a fresh cache), are equal bit for bit."""
    from hvacflex.data import market, solar, weather

    epw = str(next((shared_data_dir / "weather").glob("*.epw")).resolve())
    usep = tuple(str(p.resolve()) for p in market._as_files(shared_data_dir / "nems_usep_2014"))
    surfaces = [(90.0, 90.0), (180.0, 90.0), (0.0, 0.0)]

    def tables() -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame, Any]:
        weather._weather_year.cache_clear()
        market._load_usep_cached.cache_clear()
        year, location = weather._weather_year(epw, 2014)
        prices = market._load_usep_cached(usep, "none", market._stamps(usep))
        facades = solar.surface_irradiance_w_per_m2(year.iloc[3000:3100], location, surfaces)
        return year, prices, facades, location

    monkeypatch.setenv(CACHE_DIR_ENV, "off")
    built = tables()
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path))
    tables()
    read = tables()
    assert len(list(tmp_path.glob("*.npz"))) == 3
    for a, b in zip(built[:3], read[:3], strict=True):
        pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert built[1].attrs == read[1].attrs
    assert built[3] == read[3]


def test_old_tables_of_a_kind_are_pruned(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path))
    monkeypatch.setattr(cache, "MAX_ENTRIES_PER_KIND", 3)
    frame = _frame()
    other = cache_key("other", [], [0])
    cached_frame(other, lambda: (frame, {}))
    keys = [cache_key("kind", [], [i]) for i in range(5)]
    for i, key in enumerate(keys):
        assert key.startswith("kind-")
        cached_frame(key, lambda: (frame, {}))
        os.utime(tmp_path / f"{key}.npz", ns=(10**18 + i, 10**18 + i))  # strictly newer
    kept = sorted(p.stem for p in tmp_path.glob("kind-*.npz"))
    assert kept == sorted(keys[2:])
    assert (tmp_path / f"{other}.npz").is_file()  # another kind is left alone
