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
