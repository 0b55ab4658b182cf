"""Where the shipped data and building descriptions are found.

The real data (NEMS USEP prices, weather files, BESTEST references) ships in the ``shared/data``
folder beside the repository checkout. Set ``HVACFLEX_DATA_DIR`` to point elsewhere.
Building descriptions ship in ``buildings/`` at the repository root (``HVACFLEX_BUILDINGS_DIR``
overrides).
"""

from __future__ import annotations

import os
from pathlib import Path

from hvacflex.errors import DataError

_REPO_ROOT = Path(__file__).resolve().parents[2]

DATA_DIR_ENV = "HVACFLEX_DATA_DIR"
BUILDINGS_DIR_ENV = "HVACFLEX_BUILDINGS_DIR"


def repo_root() -> Path:
    """The repository root of a source checkout (``src/hvacflex/..``)."""
    return _REPO_ROOT


def data_dir() -> Path:
    """Folder holding ``nems_usep_2014/``, ``weather/``, ``bestest/`` and ``building/``."""
    candidates = []
    env = os.environ.get(DATA_DIR_ENV)
    if env:
        candidates.append(Path(env))
    candidates += [_REPO_ROOT.parent / "shared" / "data", Path.cwd().parent / "shared" / "data"]
    for candidate in candidates:
        if (candidate / "nems_usep_2014").is_dir():
            return candidate
    raise DataError(
        "shipped data folder not found",
        field=DATA_DIR_ENV,
        value=[str(c) for c in candidates],
        hint=f"set {DATA_DIR_ENV} to the folder that holds nems_usep_2014/ and weather/",
    )


def buildings_dir() -> Path:
    """Folder holding the shipped building descriptions (``office5.toml``, ``room1.toml``…)."""
    env = os.environ.get(BUILDINGS_DIR_ENV)
    return Path(env) if env else _REPO_ROOT / "buildings"


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
