"""A disk cache of derived data tables, so a run after the first skips their slow building.

The 30-min weather of a year (solar geometry over 17,520 periods, the EPW parsed and checked)
and the checked price tables take about a second to build and never change for the same input
files and code. :func:`cached_frame` keeps such a table on disk under a key made of the bytes
of the input files, the arguments that shape the table and :func:`~hvacflex.version.code_version`
(every ``.py`` file of the package), so a change to any of them builds the table anew: a
cached table is always the one the running code would build, bit for bit.

The format is data only: one ``.npz`` (numpy, ``allow_pickle=False``) holding the index as
int64 ticks with their unit and time zone, the column names, one float64 column each and a JSON
text of the caller's extra data (e.g. an :class:`~hvacflex.data.weather.EpwLocation`).

Where: ``$HVACFLEX_CACHE_DIR``, else ``$XDG_CACHE_HOME/hvacflex``, else
``~/.cache/hvacflex`` (:func:`cache_dir`); ``HVACFLEX_CACHE_DIR=off`` turns the cache off. A
cache that cannot be read or written is skipped silently (the table is then built as without
a cache): it only saves time, it never changes a result.
"""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.version import atomic_write, code_version

__all__ = [
    "CACHE_DIR_ENV",
    "CACHE_OFF",
    "MAX_ENTRIES_PER_KIND",
    "cache_dir",
    "cache_key",
    "cached_frame",
]

CACHE_DIR_ENV = "HVACFLEX_CACHE_DIR"
"""Environment variable naming the cache folder (or :data:`CACHE_OFF`)."""

CACHE_OFF = "off"
"""``HVACFLEX_CACHE_DIR=off``: no disk cache."""

_FORMAT = 1
"""Version of the file layout below; part of every key."""

MAX_ENTRIES_PER_KIND = 32
"""Tables kept per kind (weather year, price table, façade irradiance, holidays): the oldest written
beyond these are removed when a new one is stored."""


def cache_dir() -> Path | None:
    """The cache folder (not created here), or None when the cache is off."""
    env = os.environ.get(CACHE_DIR_ENV)
    if env:
        return None if env.strip().lower() == CACHE_OFF else Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".cache"
    return base / "hvacflex"


def cache_key(
    kind: str,
    files: Sequence[str | Path],
    arguments: Sequence[object],
    arrays: Sequence[np.ndarray] = (),
) -> str:
    """``"<kind>-<SHA-256 hex>"``: the digest of ``kind``, the bytes of each of ``files`` (in
    order), ``arguments`` (their ``repr``), the dtype, shape and bytes of each of ``arrays``,
    the code version and the layout version.

    Raises
    ------
    OSError
        when one of ``files`` cannot be read (the caller's reader then names it).
    """
    digest = hashlib.sha256()
    for part in (kind, code_version(), str(_FORMAT), repr(tuple(arguments))):
        digest.update(part.encode("utf-8") + b"\0")
    for path in files:
        digest.update(Path(path).read_bytes())
        digest.update(b"\0")
    for array in arrays:
        contiguous = np.ascontiguousarray(array)
        digest.update(f"{contiguous.dtype.str}{contiguous.shape}".encode())
        digest.update(contiguous.tobytes())
    return f"{kind}-{digest.hexdigest()}"


def _write(path: Path, frame: pd.DataFrame, extra: dict[str, Any]) -> None:
    index = pd.DatetimeIndex(frame.index)
    tz = "" if index.tz is None else str(index.tz)
    columns = {f"column_{i}": frame[c].to_numpy(dtype=float) for i, c in enumerate(frame)}

    def write(tmp: Path) -> None:
        arrays: dict[str, np.ndarray] = {
            "index_ticks": index.asi8,
            "meta": np.array(
                json.dumps(
                    {
                        "tz": tz,
                        "unit": index.unit,
                        "freq": index.freqstr,
                        "name": index.name,
                        "columns": list(frame),
                        "extra": extra,
                    }
                )
            ),
            **columns,
        }
        with tmp.open("wb") as handle:
            np.savez(handle, allow_pickle=False, **arrays)

    atomic_write(path, write)


def _read(path: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    with np.load(path, allow_pickle=False) as stored:
        meta = json.loads(str(stored["meta"]))
        ticks = stored["index_ticks"].astype(f"datetime64[{meta['unit']}]")
        index = pd.DatetimeIndex(ticks, name=meta["name"])
        if meta["tz"]:
            index = index.tz_localize("UTC").tz_convert(meta["tz"])
        if meta["freq"]:
            index = pd.DatetimeIndex(index, freq=meta["freq"])
        data = {c: stored[f"column_{i}"] for i, c in enumerate(meta["columns"])}
    return pd.DataFrame(data, index=index), dict(meta["extra"])


def cached_frame(
    key: str, build: Callable[[], tuple[pd.DataFrame, dict[str, Any]]]
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The table and extra data stored under ``key``, or ``build()``'s (then stored).

    Parameters
    ----------
    key : from :func:`cache_key`.
    build : makes (frame, extra): a frame with a DatetimeIndex and float columns, extra data
        that JSON can hold.

    Returns
    -------
    (frame, extra) equal to ``build()``'s: the same index (time zone and name), columns and
    float64 values.
    """
    folder = cache_dir()
    path = None if folder is None else folder / f"{key}.npz"
    if path is not None and path.is_file():
        try:
            return _read(path)
        except (OSError, ValueError, KeyError, zipfile.BadZipFile):
            pass  # a damaged or foreign file: build anew and replace it
    frame, extra = build()
    if path is not None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            _write(path, frame, extra)
            _prune(path)
        except OSError:
            pass  # a read-only or full disk: run without the cache
    return frame, extra


def _prune(newest: Path) -> None:
    """Keep the :data:`MAX_ENTRIES_PER_KIND` most recently written tables of ``newest``'s
    kind (the part of its name before the digest), so that edited code or other run windows
    do not fill the disk."""
    kind = newest.name.rsplit("-", 1)[0]
    entries = sorted(
        newest.parent.glob(f"{kind}-*.npz"), key=lambda p: p.stat().st_mtime_ns, reverse=True
    )
    for old in entries[MAX_ENTRIES_PER_KIND:]:
        if old != newest:
            old.unlink(missing_ok=True)
