"""Where the shipped data and building descriptions are found.

Both ship inside the package (:mod:`hvacflex.resources`, read through
:mod:`importlib.resources`), so an installed hvacflex needs nothing beside it.
``HVACFLEX_DATA_DIR`` points at another data folder (the same layout: ``nems_usep_2014/``,
``weather/``, ``bestest/``) and ``HVACFLEX_BUILDINGS_DIR`` at another folder of building
TOMLs.
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

from hvacflex.errors import DataError

DATA_DIR_ENV = "HVACFLEX_DATA_DIR"
BUILDINGS_DIR_ENV = "HVACFLEX_BUILDINGS_DIR"


def resources_dir() -> Path:
    """The installed package-data folder ``hvacflex/resources``."""
    return Path(str(files("hvacflex.resources")))


def data_dir() -> Path:
    """Folder holding ``nems_usep_2014/``, ``weather/`` and ``bestest/``.

    The shipped package data, or the folder named by ``HVACFLEX_DATA_DIR``.
    """
    env = os.environ.get(DATA_DIR_ENV)
    if not env:
        return resources_dir()
    candidate = Path(env)
    if not (candidate / "nems_usep_2014").is_dir():
        raise DataError(
            "data folder has no nems_usep_2014/ folder",
            field=DATA_DIR_ENV,
            value=str(candidate),
            hint=(
                f"point {DATA_DIR_ENV} at a folder laid out like the shipped one "
                "(nems_usep_2014/, weather/, bestest/), or unset it to use the shipped data"
            ),
        )
    return candidate


def buildings_dir() -> Path:
    """Folder holding the building descriptions (``office5.toml``, ``room1.toml``…)."""
    env = os.environ.get(BUILDINGS_DIR_ENV)
    return Path(env) if env else resources_dir() / "buildings"


def resolve_building(name_or_path: str | Path) -> Path:
    """A building file path: an existing path as is, else a shipped name like ``office5``."""
    path = Path(name_or_path)
    if path.is_file():
        return path
    shipped = buildings_dir() / (path.name if path.suffix == ".toml" else f"{path.name}.toml")
    if shipped.is_file():
        return shipped
    available = sorted(p.stem for p in buildings_dir().glob("*.toml"))
    raise DataError(
        "building file not found",
        field="building",
        value=str(name_or_path),
        hint=f"give a path to a TOML file or one of the shipped names {available}",
    )


def repo_root() -> Path:
    """The repository root of a source checkout (``src/hvacflex/..``); may not exist."""
    return Path(__file__).resolve().parents[2]
