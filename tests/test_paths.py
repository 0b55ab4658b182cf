"""Output paths are checked before any work: a file in the way, a folder that cannot be made."""

from __future__ import annotations

from pathlib import Path

import pytest

from hvacflex.errors import InputError
from hvacflex.paths import check_output_dir, check_output_file


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
