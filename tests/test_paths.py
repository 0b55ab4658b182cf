"""Where shipped data and buildings are found, the folders that replace them, and output
paths checked before any work (a file in the way, a folder that cannot be made)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from hvacflex.errors import DataError, InputError
from hvacflex.paths import (
    BUILDINGS_DIR_ENV,
    DATA_DIR_ENV,
    buildings_dir,
    check_output_dir,
    check_output_file,
    data_dir,
    resolve_building,
    resources_dir,
    user_data_dir,
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


def test_a_new_output_folder_is_created_with_its_parents(tmp_path: Path) -> None:
    folder = tmp_path / "a" / "b"
    assert check_output_dir(folder, "--out") == folder
    assert folder.is_dir() and not list(folder.iterdir())  # the probe file is gone


def test_an_output_folder_that_is_a_file_is_refused(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match=r"field '--out': the output folder is a file"):
        check_output_dir(tmp_path / "f", "--out")
    with pytest.raises(InputError, match=r"inside .*f, which is a file"):
        check_output_dir(tmp_path / "f" / "sub", "--out")


def test_an_unwritable_place_is_refused_naming_the_path() -> None:
    with pytest.raises(InputError, match=r"'--out'.*cannot write.*/proc/hvacflex-x"):
        check_output_dir("/proc/hvacflex-x", "--out")


def test_an_output_file_must_not_be_a_folder_nor_under_a_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"'--csv': the output file is a folder"):
        check_output_file(tmp_path, "--csv")
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match=r"'--csv': the output file is inside"):
        check_output_file(tmp_path / "f" / "x.csv", "--csv")
    target = tmp_path / "new" / "x.csv"
    assert check_output_file(target, "--csv") == target and target.parent.is_dir()
    assert not target.exists()


def test_the_user_data_folder_follows_xdg(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    assert user_data_dir() == tmp_path / "hvacflex"
    monkeypatch.setenv("XDG_DATA_HOME", "relative/path")  # ignored, as XDG asks
    assert user_data_dir() == Path.home() / ".local" / "share" / "hvacflex"
    monkeypatch.delenv("XDG_DATA_HOME")
    assert user_data_dir() == Path.home() / ".local" / "share" / "hvacflex"
    assert not (tmp_path / "hvacflex").exists()  # named, not created


def test_an_idf_is_a_path_or_a_shipped_models_name(tmp_path: Path) -> None:
    from hvacflex.paths import energyplus_models_dir, resolve_idf, shipped_idf_name

    shipped = energyplus_models_dir() / "5ZoneAirCooled.idf"
    assert shipped.is_file()
    for name in ("5ZoneAirCooled", "5ZoneAirCooled.idf", "5zoneaircooled", "x/5ZoneAirCooled.idf"):
        assert resolve_idf(name) == shipped, name
    own = tmp_path / "5ZoneAirCooled.idf"
    own.write_text("Version, 25.2;\n", encoding="utf-8")
    assert resolve_idf(own) == own  # a file that exists wins over the shipped one
    assert shipped_idf_name(shipped) == "5ZoneAirCooled" and shipped_idf_name(own) is None
    with pytest.raises(InputError) as refused:
        resolve_idf(tmp_path / "nope.idf", "--idf")
    message = str(refused.value)
    assert "--idf" in message and "nope.idf" in message
    assert "5ZoneAirCooled" in message and "packaged_shops" in message  # the shipped names
