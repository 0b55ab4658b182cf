"""The version of the code that produced a result, and atomic writes of result files.

``__version__`` is the installed package's version (``hvacflex.__version__`` re-exports it).
:func:`code_version` identifies the running code: the package version plus a hash of the bytes
of every ``.py`` file of the installed ``hvacflex`` package. It enters the key of cached
results and is stored in checkpoints, so a result computed by other code is never re-used
silently. :func:`atomic_write` writes a file so that a reader (or a crash) never sees it half
written, with the permissions of any file the user creates (0644 under the usual umask 022).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import threading
from collections.abc import Callable
from functools import lru_cache
from importlib import metadata
from pathlib import Path

try:
    __version__ = metadata.version("hvacflex")
except metadata.PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

_SOURCE_HASH_CHARS = 12
"""Hex characters of the source hash kept in the version string."""


@lru_cache(maxsize=1)
def source_hash() -> str | None:
    """SHA-256 (first 12 hex characters) of the ``.py`` files of the installed package.

    Files are taken in the order of their path relative to the package folder, and each
    path enters the hash with its bytes, so adding, removing, renaming or editing a module
    changes it. Computed once per process. None when the sources cannot be read (e.g. a
    zip-imported package).
    """
    package_dir = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    try:
        files = sorted(package_dir.rglob("*.py"))
        if not files:
            return None
        for path in files:
            digest.update(path.relative_to(package_dir).as_posix().encode())
            digest.update(b"\0")
            digest.update(path.read_bytes())
            digest.update(b"\0")
    except OSError:
        return None
    return digest.hexdigest()[:_SOURCE_HASH_CHARS]


def code_version() -> str:
    """The running code: ``"<package version>+src.<source hash>"`` (or the package version).

    >>> code_version().startswith(__version__)
    True
    """
    digest = source_hash()
    return __version__ if digest is None else f"{__version__}+src.{digest}"


NEW_FILE_MODE = 0o666
"""Permissions a new file asks for before the umask, as ``open()`` does (0644 under 022)."""

_UMASK_LOCK = threading.Lock()


def current_umask() -> int:
    """The process's umask (read by setting and restoring it, under a lock)."""
    with _UMASK_LOCK:
        mask = os.umask(0o077)
        os.umask(mask)
    return mask


def atomic_write(
    path: str | Path, write: Callable[[Path], object], *, mode: int | None = None
) -> Path:
    """Write ``path`` atomically: ``write(tmp)`` fills a temporary file beside it, then rename.

    The temporary file is in the same folder (so the rename is atomic on POSIX and Windows)
    and is removed if ``write`` fails; an existing ``path`` is then left as it was.

    Parameters
    ----------
    path : the file to write.
    write : called with the temporary file's path; must write the whole content there.
    mode : permission bits of the file; None: those of a file created with ``open()``
        (``NEW_FILE_MODE`` less the umask, 0644 under the usual umask 022). The temporary
        file is private (0600) until it has them.

    Returns
    -------
    ``path`` as a :class:`~pathlib.Path`.
    """
    target = Path(path)
    fd, tmp_name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        write(tmp)
        os.chmod(tmp, NEW_FILE_MODE & ~current_umask() if mode is None else mode)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return target


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_write`)."""
    return atomic_write(path, lambda tmp: tmp.write_bytes(data))


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_write`)."""
    return atomic_write_bytes(path, text.encode("utf-8"))
