"""Where shipped data and buildings are found, and the folders that replace them."""

from __future__ import annotations

from pathlib import Path

import pytest

from hvacflex.errors import DataError
from hvacflex.paths import (
    BUILDINGS_DIR_ENV,
    DATA_DIR_ENV,
    buildings_dir,
    data_dir,
    resolve_building,
    resources_dir,
)


def test_shipped_data_lies_in_the_package(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(DATA_DIR_ENV, raising=False)
    monkeypatch.delenv(BUILDINGS_DIR_ENV, raising=False)
    assert resources_dir().parts[-2:] == ("hvacflex", "resources")
    assert data_dir() == resources_dir() and (data_dir() / "nems_usep_2014").is_dir()
    assert buildings_dir() == resources_dir() / "buildings"


def test_a_building_is_a_path_or_a_shipped_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(BUILDINGS_DIR_ENV, raising=False)
    shipped = buildings_dir() / "office5.toml"
    assert resolve_building("office5") == shipped == resolve_building("office5.toml")
    own = tmp_path / "office5.toml"
    own.write_text("x = 1\n")
    assert resolve_building(own) == own  # an existing file wins over the shipped name
    with pytest.raises(DataError) as err:
        resolve_building("office55")
    assert err.value.field == "building" and "'room1'" in str(err.value)


def test_the_environment_points_at_other_folders(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "nems_usep_2014").mkdir()
    (tmp_path / "lab.toml").write_text("x = 1\n")
    monkeypatch.setenv(DATA_DIR_ENV, str(tmp_path))
    monkeypatch.setenv(BUILDINGS_DIR_ENV, str(tmp_path))
    assert data_dir() == tmp_path and resolve_building("lab") == tmp_path / "lab.toml"
    monkeypatch.setenv(DATA_DIR_ENV, str(tmp_path / "elsewhere"))
    with pytest.raises(DataError, match="no nems_usep_2014/ folder") as err:
        data_dir()
    assert err.value.field == DATA_DIR_ENV
