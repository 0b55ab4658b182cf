"""docs/guide/quickstart.md stays true: its runnable blocks run, its other commands parse.

Every fenced ``bash`` block of the quick start carries a marker on the line before it:
``<!-- runnable -->`` (run as it stands, in order, in one empty folder, with ``hvacflex`` and
``python`` the ones under test) or ``<!-- checked -->`` (too long or a server: each
``hvacflex`` command is parsed by the command line itself, so a renamed command, a removed
option or a bad value fails here). ``python`` blocks marked runnable run as scripts.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import stat
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import typer

import hvacflex
from hvacflex.cli import app

ROOT = Path(__file__).resolve().parents[1]
QUICKSTART = ROOT / "docs" / "guide" / "quickstart.md"
SRC = Path(hvacflex.__file__).resolve().parents[1]
"""The source folder of the hvacflex under test (the blocks must run the same one)."""

MARKERS = ("runnable", "checked")
BLOCK = re.compile(r"(?:<!-- (\w+) -->\n)?```(\w+)\n(.*?)\n```", re.S)
OTHER_PROGRAMS = ("pip",)
"""Programs a checked block may call besides ``hvacflex`` (checked against the README)."""
TIMEOUT_S = 300
"""A runnable block takes under 30 s alone; the limit leaves room for a loaded machine."""


@dataclass(frozen=True)
class Block:
    """A fenced block of the quick start: its marker (None if unmarked), language, text."""

    marker: str | None
    language: str
    text: str


def blocks(markdown: str) -> list[Block]:
    """The fenced blocks of a Markdown text, with the marker comment right before each."""
    return [Block(m[1], m[2], m[3]) for m in BLOCK.finditer(markdown)]


def commands(text: str) -> list[list[str]]:
    """The command lines of a shell block as argument lists: comments and blank lines
    dropped, ``\\`` continuations joined, ``A && B`` split, leading ``VAR=value`` removed."""
    joined = text.replace("\\\n", " ")
    out: list[list[str]] = []
    for line in joined.splitlines():
        for part in line.split("&&"):
            words = shlex.split(part, comments=True)
            while words and re.fullmatch(r"[A-Z_]+=\S*", words[0]):
                words.pop(0)
            if words:
                out.append(words)
    return out


def parse_command(argv: list[str]) -> tuple[list[str], dict[str, Any]]:
    """Parse ``hvacflex ARGS`` with the command line's own parser, invoking nothing.

    Returns the subcommand path and the parsed parameters; raises the command line's usage
    error (unknown command or option, bad value) as any run would.
    """
    command: Any = typer.main.get_command(app)
    name, args, parent, path = "hvacflex", list(argv), None, []
    while True:
        context = command.make_context(name, args, parent=parent)
        rest = [*getattr(context, "_protected_args", []), *context.args]
        if not hasattr(command, "resolve_command") or not rest:
            return path, dict(context.params)
        name, command, args = command.resolve_command(context, rest)
        path.append(name)
        parent = context


def _markdown() -> str:
    return QUICKSTART.read_text(encoding="utf-8")


def test_every_shell_block_is_marked() -> None:
    shell = [b for b in blocks(_markdown()) if b.language == "bash"]
    assert len(shell) >= 8
    unmarked = [b.text.splitlines()[0] for b in shell if b.marker not in MARKERS]
    assert unmarked == [], "mark these blocks <!-- runnable --> or <!-- checked -->"


def test_the_parser_refuses_what_the_command_line_refuses() -> None:
    path, params = parse_command(["reproduce", "--quick"])
    assert (path, params["quick"], params["workers"]) == (["reproduce"], True, 2)
    assert parse_command(["serve", "key", "list"])[0] == ["serve", "key", "list"]
    assert parse_command(["serve", "--port", "8001"])[1]["port"] == 8001
    refused = {
        ("simulate", "--start", "03/04/2014"): "ISO 8601",
        ("simulate", "--bogus"): "--bogus",
        ("nope",): "nope",
    }
    for argv, message in refused.items():
        with pytest.raises(Exception, match=re.escape(message)):
            parse_command(list(argv))


def test_commands_split_like_a_shell() -> None:
    text = (
        "HVACFLEX_KEY=k hvacflex serve replay \\\n  --url U  # a comment\n\npip x && hvacflex kpi a"
    )
    assert commands(text) == [
        ["hvacflex", "serve", "replay", "--url", "U"],
        ["pip", "x"],
        ["hvacflex", "kpi", "a"],
    ]


def test_checked_commands_parse() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    checked = [b for b in blocks(_markdown()) if b.marker == "checked"]
    assert checked
    for block in checked:
        for argv in commands(block.text):
            if argv[0] == "hvacflex":
                parse_command(argv[1:])
            else:
                assert argv[0] in OTHER_PROGRAMS, argv
                assert shlex.join(argv) in readme, f"{argv} is not the README's set-up"


def assert_every_kpi_in_the_glossary(summary: dict[str, float]) -> None:
    """Every KPI of a run's summary is explained in docs/reference/glossary.md (a zone's name
    written as ``<zone>``)."""
    glossary = (ROOT / "docs" / "reference" / "glossary.md").read_text(encoding="utf-8")
    zones = {k.removeprefix("max_violation_").removesuffix("_k") for k in summary} - {
        "max_violation",
        "occupied",
        "unoccupied",
    }
    zones = {z for z in zones if f"max_violation_{z}_k" in summary}
    assert zones == {"north", "east", "south", "west", "core"}
    missing = []
    for key in summary:
        generic = key
        for zone in zones:
            generic = generic.replace(f"_{zone}_", "_<zone>_")
        if f"`{generic}`" not in glossary:
            missing.append(generic)
    assert missing == [], "explain these KPIs in docs/reference/glossary.md"


def _wrappers(folder: Path) -> dict[str, str]:
    """An environment whose ``hvacflex`` and ``python`` are the ones under test."""
    folder.mkdir()
    scripts = {
        "hvacflex": f'exec "{sys.executable}" -c "import sys; from hvacflex.cli import app; '
        f'sys.argv[0] = \'hvacflex\'; sys.exit(app())" "$@"',
        "python": f'exec "{sys.executable}" "$@"',
    }
    for name, body in scripts.items():
        path = folder / name
        path.write_text(f"#!/bin/sh\n{body}\n", encoding="utf-8")
        path.chmod(path.stat().st_mode | stat.S_IXUSR)
    python_path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])
    return {
        **os.environ,
        "PATH": f"{folder}{os.pathsep}{os.environ['PATH']}",
        "PYTHONPATH": python_path,
        "COLUMNS": "120",
    }


def _run(block: Block, cwd: Path, env: dict[str, str]) -> str:
    argv = ["bash", "-euo", "pipefail", "-c", block.text]
    if block.language == "python":
        argv = [sys.executable, "-c", block.text]
    done = subprocess.run(
        argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=TIMEOUT_S, check=False
    )
    assert done.returncode == 0, f"{block.text[:200]}\n--- stderr:\n{done.stderr[-3000:]}"
    return done.stdout


def test_runnable_blocks_run_in_order(tmp_path: Path) -> None:
    env = _wrappers(tmp_path / "bin")
    work = tmp_path / "work"
    work.mkdir()
    runnable = [b for b in blocks(_markdown()) if b.marker == "runnable"]
    outputs = [_run(block, work, env) for block in runnable]
    assert outputs[0].startswith(f"hvacflex {hvacflex.__version__}")
    for run in ("first", "baseline", "my_room", "py"):
        summary = json.loads((work / "results" / run / "summary.json").read_text())
        assert summary["steps"] == 48, run
    assert (work / "first.html").read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    kpis = (work / "kpis.csv").read_text(encoding="utf-8")
    assert "first" in kpis.splitlines()[0] and "baseline" in kpis.splitlines()[0]
    my_room = json.loads((work / "results" / "my_room" / "config.json").read_text())
    assert my_room["controller"]["peak_price_sgd_per_kw"] == 2.0
    assert my_room["comfort"]["occupied_degc"] == [23.0, 25.5]
    building = Path(my_room["building"])  # taken from the scenario file's folder
    assert (work / building).resolve() == (work / "my_room.toml").resolve()
    # the own reserve contract earns reserve, and its weekday activation settles some of it
    room = json.loads((work / "results" / "my_room" / "summary.json").read_text())
    assert room["reserve_revenue_sgd"] > 0.0 and room["reserve_revenue_settled_sgd"] > 0.0
    assert room["il_activated_steps"] > 0 and room["il_offered_kwh"] > 0.0
    assert_every_kpi_in_the_glossary(json.loads((work / "results/first/summary.json").read_text()))
    shown = next(out for out in outputs if "Building 'my_room'" in out)
    assert "WARNING" not in shown  # the page says the room's ventilation suffices
    assert "outdoor air at ventilation flow 88 L/s (need 84 L/s)" in shown
