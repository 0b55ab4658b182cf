"""Reading TOML files with errors that name the file and say what is wrong with it."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from hvacflex.errors import ConfigError


def read_toml(
    path: str | Path, *, what: str, error: type[ConfigError] = ConfigError
) -> dict[str, Any]:
    """Read a TOML file into a ``dict``, refusing files that cannot hold a configuration.

    Parameters
    ----------
    path : the ``.toml`` file.
    what : what the file describes, for messages (``"building"``, ``"scenario"``).
    error : the :class:`ConfigError` subclass to raise.

    Returns
    -------
    The parsed document (never empty).

    Raises
    ------
    error : the file is missing or unreadable, not UTF-8 text, empty (or comments only),
        or not valid TOML; the message names the file and, where known, the line.
    """
    source = Path(path)
    try:
        raw = source.read_bytes()
    except FileNotFoundError:
        raise error(f"{what} file not found", source=source, hint="check the path") from None
    except OSError as exc:
        raise error(f"cannot read the {what} file ({exc.strerror})", source=source) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise error(
            f"not UTF-8 text (byte {raw[exc.start]:#04x} at offset {exc.start})",
            source=source,
            line=line,
            hint=f"a {what} file is a TOML text file saved as UTF-8",
        ) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"not valid TOML: {exc}", source=source) from None
    if not data:
        raise error(
            f"the {what} file is empty" + (" (only comments)" if text.strip() else ""),
            source=source,
            hint=f"write the {what}'s settings as TOML key = value lines",
        )
    return data
