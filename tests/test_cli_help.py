"""The command line's shared help texts stay true to the code."""

from __future__ import annotations

from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.cli_help import PRESET_HELP, START_HELP
from hvacflex.config import PRESET_NAMES
from hvacflex.constants import DEFAULT_START


def test_the_preset_help_names_every_preset() -> None:
    named = {name.strip(" .") for name in PRESET_HELP.split(":", 1)[1].split(",")}
    assert named == set(PRESET_NAMES)


def test_the_start_help_gives_the_default_start() -> None:
    assert DEFAULT_START in START_HELP and "YYYY-MM-DD" in START_HELP


def test_help_shows_click_type_names_not_typers() -> None:
    result = CliRunner().invoke(app, ["simulate", "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    assert "INTEGER" in result.output or "FLOAT" in result.output
    assert "<str>" not in result.output and "<bool>" not in result.output
