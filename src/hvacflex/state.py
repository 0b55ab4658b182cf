"""The one checkpoint format: a run's, a service building's or a fleet's state as data only.

A state is a tree of ``dict``, ``list``, ``tuple``, ``str``, ``int``, ``float``, ``bool``,
``None``, numpy arrays and scalars, :class:`pandas.Timestamp`, and hvacflex's own frozen
dataclasses and enums. :func:`encode` writes it as one ``.npz`` archive (numpy's zip of
``.npy`` arrays, read with ``allow_pickle=False``): the tree as JSON in ``manifest``, every
array beside it. Dataclasses and enums are named by module and qualified name and rebuilt
from their fields on :func:`decode`, which builds only the types registered with
:func:`register_stored_types` (the one list: :mod:`hvacflex.sim.stored_types`, registered
whenever :mod:`hvacflex.sim` is imported). A name is looked up in that registry, never
imported: reading a state imports no module and runs no code a file names (a pickle would
run whatever it holds).

Every state carries :data:`FORMAT` and :data:`VERSION`; a state of another version, or a
pickle written by an older hvacflex, is refused with :class:`StateFormatError` saying how to
start afresh.
"""

from __future__ import annotations

import dataclasses
import enum
import io
import json
import math
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.errors import StoredStateError
from hvacflex.version import atomic_write_bytes

FORMAT = "hvacflex-state"
VERSION = 1
"""Bumped whenever the meaning of a stored state changes; other versions are refused."""

_MANIFEST = "manifest"
_PICKLE_MAGIC = b"\x80"
_TAG = "__hvacflex__"

_STORED_TYPES: dict[str, type] = {}
"""``module:qualname`` → the dataclass or enum :func:`decode` may build (nothing else)."""


class StateFormatError(StoredStateError):
    """A stored state that this version of hvacflex does not read (or not a state at all)."""


class DamagedStateError(StateFormatError):
    """Bytes that are not a readable state at all (truncated, damaged, another file)."""


def register_stored_types(*types: type) -> None:
    """Allow :func:`decode` to build ``types`` (hvacflex's frozen dataclasses and enums).

    Raises
    ------
    TypeError : a type that is not an hvacflex dataclass or enum.
    """
    for cls in types:
        name = _class_name(cls)
        if not _is_hvacflex_module(cls.__module__) or not _is_dataclass_or_enum(cls):
            raise TypeError(f"{name}: only hvacflex dataclasses and enums are stored")
        _STORED_TYPES[name] = cls


def stored_types() -> dict[str, type]:
    """The registered types by ``module:qualname`` (a copy)."""
    return dict(_STORED_TYPES)


def encode(state: Any) -> bytes:
    """``state`` as the bytes of one ``.npz`` archive.

    Raises
    ------
    TypeError : a value of a type the format does not hold (the message names where).
    """
    arrays: dict[str, np.ndarray] = {}
    tree = _encode(state, arrays, "state")
    manifest = json.dumps(
        {"format": FORMAT, "version": VERSION, "state": tree}, allow_nan=False
    ).encode("utf-8")
    buffer = io.BytesIO()
    members: dict[str, Any] = {_MANIFEST: np.frombuffer(manifest, dtype=np.uint8), **arrays}
    savez: Any = np.savez  # its stubs read ** as the allow_pickle keyword
    savez(buffer, **members)
    return buffer.getvalue()


def decode(data: bytes, *, source: str = "state") -> Any:
    """The state :func:`encode` wrote.

    Parameters
    ----------
    data : the archive's bytes.
    source : where they came from (a file, a database row), for messages.

    Raises
    ------
    StateFormatError : a pickle of an older hvacflex, another format version, not a state,
        or a state naming a type that is not registered (:func:`register_stored_types`).
    """
    if data[:1] == _PICKLE_MAGIC:
        raise StateFormatError(
            "written by an older hvacflex in the pickle format, which is no longer read "
            "(loading a pickle can run any code it holds)",
            source=source,
            hint="start afresh: delete it (a run: `--fresh`), the state is rebuilt",
        )
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            manifest = json.loads(bytes(archive[_MANIFEST]).decode("utf-8"))
            arrays = {name: archive[name] for name in archive.files if name != _MANIFEST}
    except (ValueError, OSError, KeyError, zipfile.BadZipFile, UnicodeDecodeError) as err:
        raise DamagedStateError(
            f"not an hvacflex state ({type(err).__name__})",
            source=source,
            hint="start afresh: delete it",
        ) from None
    if manifest.get("format") != FORMAT or manifest.get("version") != VERSION:
        raise StateFormatError(
            f"state format {manifest.get('format')!r} version {manifest.get('version')!r}; "
            f"this hvacflex reads {FORMAT!r} version {VERSION}",
            source=source,
            hint="start afresh: delete it, or use the hvacflex version that wrote it",
        )
    return _decode(manifest["state"], arrays, source)


def save(path: Path, state: Any) -> None:
    """Write ``state`` to ``path`` atomically (a crash mid-write keeps the previous file)."""
    atomic_write_bytes(path, encode(state))


def load(path: Path) -> Any:
    """The state stored at ``path`` (see :func:`decode`)."""
    return decode(path.read_bytes(), source=str(path))


# -- the tree ---------------------------------------------------------------------------


def _tagged(kind: str, **content: Any) -> dict[str, Any]:
    return {_TAG: kind, **content}


def _class_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _encode(value: Any, arrays: dict[str, np.ndarray], where: str) -> Any:
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, np.ndarray):
        return _encode_array(value, arrays, where)
    if isinstance(value, np.generic):
        return _tagged("scalar", dtype=value.dtype.str, value=_encode(value.item(), arrays, where))
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else _tagged("float", value=repr(value))
    if isinstance(value, enum.Enum):
        return _tagged("enum", cls=_class_name(type(value)), value=value.value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {
            f.name: _encode(getattr(value, f.name), arrays, f"{where}.{f.name}")
            for f in dataclasses.fields(value)
            if f.init
        }
        return _tagged("dataclass", cls=_class_name(type(value)), fields=fields)
    if isinstance(value, pd.Timestamp):
        return _tagged(
            "timestamp", value=value.isoformat(), tz=None if value.tz is None else str(value.tz)
        )
    if isinstance(value, tuple | list):
        items = [_encode(v, arrays, f"{where}[{i}]") for i, v in enumerate(value)]
        return items if isinstance(value, list) else _tagged("tuple", items=items)
    if isinstance(value, dict):
        return _tagged(
            "dict",
            items=[
                [_encode(k, arrays, f"{where} key"), _encode(v, arrays, f"{where}[{k!r}]")]
                for k, v in value.items()
            ],
        )
    raise TypeError(f"{where}: a {type(value).__name__} cannot be stored in an hvacflex state")


def _encode_array(value: np.ndarray, arrays: dict[str, np.ndarray], where: str) -> Any:
    if value.dtype.hasobject:  # e.g. solve statuses: strings or None, kept as a list
        items = [_encode(v, arrays, f"{where}[{i}]") for i, v in enumerate(value.ravel())]
        return _tagged("object_array", shape=list(value.shape), items=items)
    name = f"a{len(arrays)}"
    arrays[name] = value
    return _tagged("array", name=name)


def _decode(tree: Any, arrays: dict[str, np.ndarray], source: str) -> Any:
    if isinstance(tree, list):
        return [_decode(v, arrays, source) for v in tree]
    if not isinstance(tree, dict):
        return tree
    kind = tree.get(_TAG)
    if kind == "array":
        return arrays[tree["name"]]
    if kind == "object_array":
        out = np.empty(len(tree["items"]), dtype=object)
        out[:] = [_decode(v, arrays, source) for v in tree["items"]]
        return out.reshape(tree["shape"])
    if kind == "scalar":
        return np.dtype(tree["dtype"]).type(_decode(tree["value"], arrays, source))
    if kind == "float":
        return float(tree["value"])
    if kind == "tuple":
        return tuple(_decode(v, arrays, source) for v in tree["items"])
    if kind == "dict":
        return {_decode(k, arrays, source): _decode(v, arrays, source) for k, v in tree["items"]}
    if kind == "timestamp":
        stamp = pd.Timestamp(tree["value"])
        return stamp if tree.get("tz") is None else stamp.tz_convert(tree["tz"])
    if kind in ("enum", "dataclass"):
        return _build(tree, arrays, source, kind)
    raise StateFormatError(f"unknown entry {kind!r}", source=source, hint="start afresh")


def _is_hvacflex_module(module_name: str) -> bool:
    return module_name == "hvacflex" or module_name.startswith("hvacflex.")


def _is_dataclass_or_enum(cls: type) -> bool:
    return isinstance(cls, type) and (dataclasses.is_dataclass(cls) or issubclass(cls, enum.Enum))


def _stored_class(name: Any, source: str, kind: str) -> Any:
    """The registered ``kind`` ("enum" or "dataclass") that ``name`` (``module:qualname``)
    names; a name is only looked up in the registry, never imported."""
    cls = _STORED_TYPES.get(name) if isinstance(name, str) else None
    if cls is None:
        outside = not _is_hvacflex_module(str(name).partition(":")[0])
        raise StateFormatError(
            f"names {name!r}{', a class outside hvacflex' if outside else ''}: "
            "not a type hvacflex stores (a state is never allowed to name code to import)",
            source=source,
            hint="start afresh: delete it, or use the hvacflex version that wrote it",
        )
    if (kind == "enum") != issubclass(cls, enum.Enum):
        raise StateFormatError(
            f"names {name!r} as an {kind}, which it is not", source=source, hint="start afresh"
        )
    return cls


def _build(tree: dict[str, Any], arrays: dict[str, np.ndarray], source: str, kind: str) -> Any:
    """The registered enum member or dataclass instance ``tree`` describes."""
    cls = _stored_class(tree.get("cls"), source, kind)
    stored_fields = tree.get("fields")
    fields = (
        {str(name): _decode(v, arrays, source) for name, v in stored_fields.items()}
        if kind == "dataclass" and isinstance(stored_fields, dict)
        else {}
    )
    try:
        return cls(tree.get("value")) if kind == "enum" else cls(**fields)
    except (TypeError, ValueError) as err:
        raise StateFormatError(
            f"a {tree.get('cls')} that this hvacflex cannot rebuild ({err})",
            source=source,
            hint="start afresh: delete it, or use the hvacflex version that wrote it",
        ) from None
