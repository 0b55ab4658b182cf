"""The command line's shared help texts stay true to the code."""

from __future__ import annotations

from typing import Any

import typer
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.cli_help import DAYS_HELP, PRESET_EPILOG, START_HELP, preset_epilog
from hvacflex.constants import DEFAULT_START


def test_the_preset_help_names_every_preset_the_configuration_defines() -> None:
    from hvacflex.config.presets import PRESETS

    listed = [word for row in PRESET_EPILOG.splitlines()[2:] for word in row.split()]
    assert listed == list(PRESETS)


def test_the_preset_epilog_fits_the_width_and_is_not_rewrapped() -> None:
    epilog = preset_epilog(("a-long-name", "b", "c-d"), width=30)
    assert epilog.startswith("\b\n")  # click keeps the lines as they are
    rows = epilog.splitlines()[2:]
    assert rows == ["  a-long-name  b", "  c-d"]
    assert all(len(row) + 2 <= 30 for row in rows)  # with click's indent of an epilog


def test_the_days_help_gives_the_scenarios_default() -> None:
    from hvacflex.config import ScenarioConfig

    assert f"({ScenarioConfig().days:g} unless" in DAYS_HELP


def test_the_start_help_gives_the_default_start() -> None:
    assert DEFAULT_START in START_HELP and "YYYY-MM-DD" in START_HELP


def test_help_shows_click_type_names_not_typers() -> None:
    result = CliRunner().invoke(app, ["simulate", "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    assert "INTEGER" in result.output or "FLOAT" in result.output
    assert "<str>" not in result.output and "<bool>" not in result.output


def _command_paths(command: Any, path: list[str]) -> list[list[str]]:
    paths = [path]
    if hasattr(command, "commands"):  # a group (typer's own click)
        for name, sub in command.commands.items():
            paths += _command_paths(sub, [*path, name])
    return paths


def test_every_help_fits_80_columns() -> None:
    paths = _command_paths(typer.main.get_command(app), [])
    assert len(paths) > 30 and ["identify", "fit"] in paths
    for path in paths:
        result = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "80"})
        assert result.exit_code == 0, path
        too_long = [line for line in result.output.splitlines() if len(line) > 80]
        assert too_long == [], path
