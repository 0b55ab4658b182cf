"""The code version that keys cached results, and atomic writes."""

from __future__ import annotations

from pathlib import Path

import pytest

from hvacflex import __version__
from hvacflex.version import atomic_write, atomic_write_text, code_version, source_hash


def test_code_version_is_the_package_version_and_a_source_hash() -> None:
    version = code_version()
    digest = source_hash()
    assert digest is not None and len(digest) == 12
    assert version == f"{__version__}+src.{digest}"
    assert code_version() == version  # stable within a process


def test_source_hash_changes_with_the_package_sources(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.version as version_mod

    package = tmp_path / "pkg"
    package.mkdir()
    (package / "version.py").write_text("x = 1\n")
    (package / "other.py").write_text("y = 2\n")
    monkeypatch.setattr(version_mod, "__file__", str(package / "version.py"))
    source_hash.cache_clear()
    try:
        before = source_hash()
        source_hash.cache_clear()
        (package / "other.py").write_text("y = 3\n")
        after = source_hash()
    finally:
        source_hash.cache_clear()
    assert before is not None and after is not None and before != after


def test_atomic_write_replaces_the_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "summary.json"
    atomic_write_text(target, "old")
    atomic_write_text(target, "new")
    assert target.read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]


def test_a_failed_write_keeps_the_previous_file(tmp_path: Path) -> None:
    target = tmp_path / "results.parquet"
    atomic_write_text(target, "complete")

    def half_then_crash(tmp: Path) -> None:
        tmp.write_text("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        atomic_write(target, half_then_crash)
    assert target.read_text() == "complete"
    assert [p.name for p in tmp_path.iterdir()] == ["results.parquet"]


@pytest.mark.parametrize(("umask", "expected"), [(0o022, 0o644), (0o027, 0o640), (0o002, 0o664)])
def test_atomic_writes_get_the_mode_of_a_new_file_under_the_umask(
    tmp_path: Path, umask: int, expected: int
) -> None:
    import os
    import stat

    old = os.umask(umask)
    try:
        written = atomic_write_text(tmp_path / "summary.json", "{}")
        plain = tmp_path / "plain.txt"
        plain.write_text("x")  # what open() gives, for comparison
    finally:
        os.umask(old)
    assert stat.S_IMODE(written.stat().st_mode) == expected
    assert stat.S_IMODE(plain.stat().st_mode) == expected


def test_atomic_write_keeps_an_explicit_private_mode(tmp_path: Path) -> None:
    import stat

    written = atomic_write(tmp_path / "key", lambda tmp: tmp.write_bytes(b"k"), mode=0o600)
    assert stat.S_IMODE(written.stat().st_mode) == 0o600
