"""Where the shipped data and building descriptions are found.

Both ship inside the package (:mod:`hvacflex.resources`, read through
:mod:`importlib.resources`), so an installed hvacflex needs nothing beside it.
``HVACFLEX_DATA_DIR`` points at another data folder (the same layout: ``nems_usep_2014/``,
``weather/``, ``bestest/``) and ``HVACFLEX_BUILDINGS_DIR`` at another folder of building
TOMLs. What hvacflex keeps for a user between runs (the OpenADR VEN's record) lies in the
user data folder, :func:`user_data_dir`.
"""

from __future__ import annotations

import os
import sys
import tempfile
from importlib.resources import files
from pathlib import Path

from hvacflex.errors import DataError, InputError

DATA_DIR_ENV = "HVACFLEX_DATA_DIR"
BUILDINGS_DIR_ENV = "HVACFLEX_BUILDINGS_DIR"
XDG_DATA_HOME_ENV = "XDG_DATA_HOME"
APP_FOLDER = "hvacflex"


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


def user_data_dir() -> Path:
    """The user's hvacflex data folder (as platformdirs' ``user_data_dir``; not created here):
    ``$XDG_DATA_HOME/hvacflex``, else ``~/.local/share/hvacflex`` (Linux and other Unix);
    ``~/Library/Application Support/hvacflex`` (macOS); ``%LOCALAPPDATA%\\hvacflex`` (Windows).
    A relative ``XDG_DATA_HOME`` is ignored, as the XDG specification asks."""
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or str(Path.home() / "AppData" / "Local")
        return Path(base) / APP_FOLDER
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Application Support" / APP_FOLDER
    xdg = os.environ.get(XDG_DATA_HOME_ENV, "")
    base_dir = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base_dir / APP_FOLDER


def energyplus_models_dir() -> Path:
    """Folder of the shipped EnergyPlus models (``5ZoneAirCooled.idf``, ``packaged_shops.idf``)."""
    return resources_dir() / "energyplus"


def shipped_idf_names() -> list[str]:
    """The names of the shipped EnergyPlus models, without ``.idf``."""
    return sorted(p.stem for p in energyplus_models_dir().glob("*.idf"))


def resolve_idf(name_or_path: str | Path, field: str = "plant.idf") -> Path:
    """An IDF file path: an existing path as is, else a shipped model's name such as
    ``5ZoneAirCooled`` (with or without ``.idf``; the file's own name when a path is given).

    Raises
    ------
    InputError
        naming ``field`` and the value, listing the shipped names, when neither exists.
    """
    path = Path(name_or_path).expanduser()
    if path.is_file():
        return path
    stem = path.name[: -len(".idf")] if path.name.lower().endswith(".idf") else path.name
    shipped = {name.lower(): name for name in shipped_idf_names()}
    if stem.lower() in shipped and not path.is_dir():
        return energyplus_models_dir() / f"{shipped[stem.lower()]}.idf"
    raise InputError(
        "IDF path is a folder" if path.is_dir() else "IDF file not found",
        field=field,
        value=str(name_or_path),
        hint="give the path to an EnergyPlus 25.2 .idf file or one of the shipped models "
        f"{shipped_idf_names()}" + (", or idf = 'generated'" if field == "plant.idf" else ""),
    )


def shipped_idf_name(path: str | Path) -> str | None:
    """The shipped model's name when ``path`` is a shipped IDF (else None)."""
    resolved = Path(path).resolve()
    for name in shipped_idf_names():
        if (energyplus_models_dir() / f"{name}.idf").resolve() == resolved:
            return name
    return None


def repo_root() -> Path:
    """The repository root of a source checkout (``src/hvacflex/..``); may not exist."""
    return Path(__file__).resolve().parents[2]


def check_output_dir(path: str | Path, field: str) -> Path:
    """Make sure results can be written into folder ``path``, before any work: create it
    (with its parents) and write and remove a probe file in it.

    Parameters
    ----------
    path : the output folder.
    field : the option or key that named it (``"--out"``), for the message.

    Raises
    ------
    InputError
        Naming ``field``, the path and why (a file is in the way, no permission, a read-only
        or virtual file system such as ``/proc``), with a hint.
    """
    return _writable_folder(Path(path), field, Path(path), "the output folder")


def _writable_folder(folder: Path, field: str, named: Path, what: str) -> Path:
    """:func:`check_output_dir` of ``folder``; messages say ``what`` ``named`` is."""
    blocker = next((p for p in (folder, *folder.parents) if p.exists() and not p.is_dir()), None)
    if blocker is not None:
        where = "is a file" if blocker == named else f"is inside {blocker}, which is a file"
        raise InputError(
            f"{what} {where}",
            field=field,
            value=str(named),
            hint=f"give {field} a path whose folders are folders, not files",
        )
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder, prefix=".hvacflex-probe-"):
            pass
    except OSError as exc:
        raise InputError(
            f"cannot write {what} there ({exc.strerror or type(exc).__name__})",
            field=field,
            value=str(named),
            hint=f"give {field} a folder you can write to",
        ) from None
    return folder


def check_output_file(path: str | Path, field: str) -> Path:
    """Make sure file ``path`` can be written, before any work: its folder is created and
    writable (:func:`check_output_dir`) and ``path`` is not a folder.

    Raises
    ------
    InputError
        Naming ``field``, the path and why, with a hint.
    """
    target = Path(path)
    if target.is_dir():
        raise InputError(
            "the output file is a folder",
            field=field,
            value=str(target),
            hint=f"give {field} the path of a file, not of a folder",
        )
    _writable_folder(target.parent, field, target, "the output file")
    return target
