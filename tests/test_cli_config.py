"""``hvacflex config reference``: prints, writes and checks the scenario-key reference."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.config.reference import reference_markdown


def test_reference_prints_the_markdown() -> None:
    result = CliRunner().invoke(app, ["config", "reference"])
    assert result.exit_code == 0
    assert result.stdout == reference_markdown()


def test_reference_writes_the_file_and_check_accepts_it(tmp_path: Path) -> None:
    out = tmp_path / "docs" / "reference" / "scenario_reference.md"
    written = CliRunner().invoke(app, ["config", "reference", "--out", str(out)])
    assert written.exit_code == 0, written.output
    assert out.read_text(encoding="utf-8") == reference_markdown()
    checked = CliRunner().invoke(app, ["config", "reference", "--out", str(out), "--check"])
    assert checked.exit_code == 0
    assert "up to date" in checked.stdout


def test_check_fails_on_a_stale_file_and_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "scenario_reference.md"
    out.write_text(reference_markdown().replace("`[plant]`", "`[plants]`"), encoding="utf-8")
    stale = out.read_text(encoding="utf-8")
    result = CliRunner().invoke(app, ["config", "reference", "--out", str(out), "--check"])
    assert result.exit_code == 1
    assert "out of date" in result.output
    assert f"hvacflex config reference --out {out}" in result.output
    assert out.read_text(encoding="utf-8") == stale


def test_check_without_a_file_is_bad_input() -> None:
    result = CliRunner().invoke(app, ["config", "reference", "--check"])
    assert result.exit_code == 2
    assert "--out" in result.output


def test_an_output_path_that_is_a_folder_exits_2(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["config", "reference", "--out", str(tmp_path)])
    assert result.exit_code == 2
    assert "folder" in result.output
    assert "Traceback" not in result.output
