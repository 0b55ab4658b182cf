"""``hvacflex serve``'s command group (``hvacflex.cli_serve``): its place in the command line,
where its subcommands take the database from, and their option checks. The server, keys,
replay and VEN are exercised end to end in ``tests/service``."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.cli_serve import DB_ENV, DEFAULT_SERVE_DB

RUNNER = CliRunner()


def test_serve_is_a_group_of_the_command_line_with_its_subcommands() -> None:
    result = RUNNER.invoke(app, ["serve", "--help"])
    assert result.exit_code == 0
    for command in ("key", "replay", "openadr-ven"):
        assert command in result.output
    keys = RUNNER.invoke(app, ["serve", "key", "--help"])
    assert all(name in keys.output for name in ("create", "list", "revoke"))


@pytest.mark.parametrize("where", ["subcommand", "group", "environment"])
def test_a_key_command_takes_the_database_from_its_option_the_group_or_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str
) -> None:
    db = f"sqlite:///{tmp_path / 'keys.db'}"
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(DB_ENV, raising=False)
    create = ["key", "create", "--role", "operator"]
    if where == "subcommand":
        args = ["serve", *create, "--db", db]
    elif where == "group":
        args = ["serve", "--db", db, *create]
    else:
        monkeypatch.setenv(DB_ENV, db)
        args = ["serve", *create]
    created = RUNNER.invoke(app, args)
    assert created.exit_code == 0, created.output
    assert (tmp_path / "keys.db").is_file()
    assert not (tmp_path / DEFAULT_SERVE_DB.removeprefix("sqlite:///")).exists()
    listed = RUNNER.invoke(app, ["serve", "key", "list", "--db", db])
    assert listed.exit_code == 0 and "operator" in listed.output


def test_replay_checks_its_days_before_it_connects() -> None:
    result = RUNNER.invoke(app, ["serve", "replay", "--url", "http://127.0.0.1:1", "--days", "0"])
    assert result.exit_code == 2 and "--days" in result.output


@pytest.mark.parametrize(
    ("args", "extra", "module"),
    [
        (["serve"], "service", "fastapi"),
        (["serve", "key", "list"], "service", "sqlalchemy"),
        (
            [
                "serve",
                "openadr-ven",
                "--vtn-url",
                "http://127.0.0.1:8080/x",
                "--ven-name",
                "v",
                "--url",
                "http://127.0.0.1:8000",
            ],
            "openadr",
            "openleadr",
        ),
    ],
)
def test_a_missing_extra_exits_2_with_the_line_that_installs_it(
    monkeypatch: pytest.MonkeyPatch, args: list[str], extra: str, module: str
) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == module else real(name)
    )
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    assert f'pip install -e ".[{extra}]"' in result.output
    assert f"({module} is not installed)" in result.output
    assert "Traceback" not in result.output
