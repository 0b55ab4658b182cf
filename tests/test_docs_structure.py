"""docs/ is a guide, a reference and an explanation (docs/index.md says which is which): the
guide and the reference describe the program as it is (no issue numbers, no dated re-run
sections), every page is in the index, every docs path the code and the pages name exists,
the command-line reference is the command line's own, and every command the guide gives
parses."""

from __future__ import annotations

import importlib.util
import re
import subprocess
from pathlib import Path

import pytest

from test_quickstart import blocks, commands, parse_command

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PARTS = ("guide", "reference", "explanation")
CURRENT_PARTS = ("guide", "reference")

HISTORY_WORDS = re.compile(r"\bissues? \d+|\bsince issue\b|\buntil issue\b|\bbefore issue\b", re.I)
DATED_HEADING = re.compile(r"^#+ .*(\d{4}-\d{2}-\d{2}|re-?run|re-?measured)", re.I | re.M)


def _pages(part: str) -> list[Path]:
    return sorted((DOCS / part).glob("*.md"))


def test_docs_has_three_parts_and_nothing_loose() -> None:
    for part in PARTS:
        assert _pages(part), f"docs/{part}/ has no page"
    loose = [p.name for p in DOCS.glob("*.md") if p.name != "index.md"]
    assert loose == [], f"pages outside guide/, reference/, explanation/: {loose}"


def test_the_index_lists_every_page_under_its_part() -> None:
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    for part in PARTS:
        section = index[index.index(f"## {part.capitalize()}") :]
        for page in _pages(part):
            assert f"({part}/{page.name})" in section, (
                f"docs/index.md does not list {part}/{page.name}"
            )


@pytest.mark.parametrize("part", CURRENT_PARTS)
def test_guide_and_reference_describe_the_program_as_it_is(part: str) -> None:
    for page in _pages(part):
        text = page.read_text(encoding="utf-8")
        words = HISTORY_WORDS.findall(text)
        assert words == [], (
            f"{page.relative_to(ROOT)} speaks of issues: {words[:3]}"
            " (history goes to docs/history/)"
        )
        headings = DATED_HEADING.findall(text)
        assert headings == [], (
            f"{page.relative_to(ROOT)} has dated or re-run sections (move them to docs/history/)"
        )


def _named_docs_paths() -> set[str]:
    listed = subprocess.run(
        [
            "git",
            "ls-files",
            "src",
            "tests",
            "benchmarks",
            "scripts",
            "examples",
            "README.md",
            "CHANGELOG.md",
            "docs",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    named: set[str] = set()
    for name in listed:
        path = ROOT / name
        if (
            path.suffix not in (".py", ".md", ".toml")
            or not path.is_file()
            or "history" in path.parts
        ):
            continue
        named.update(re.findall(r"\bdocs/[\w/]+\.(?:md|png)", path.read_text(encoding="utf-8")))
    return named


def test_every_docs_path_the_code_and_pages_name_exists() -> None:
    missing = sorted(p for p in _named_docs_paths() if not (ROOT / p).exists())
    assert missing == []


def test_every_relative_link_between_pages_resolves() -> None:
    broken = []
    for page in DOCS.rglob("*.md"):
        if "history" in page.parts:
            continue
        for target in re.findall(
            r"\]\(([^)\s#]+)(?:#[^)\s]*)?\)", page.read_text(encoding="utf-8")
        ):
            if target.startswith(("http://", "https://", "mailto:")):
                continue
            if not (page.parent / target).exists():
                broken.append(f"{page.relative_to(ROOT)} → {target}")
    assert broken == []


def test_the_command_line_reference_is_the_command_line_s_own() -> None:
    spec = importlib.util.spec_from_file_location(
        "cli_reference", ROOT / "scripts" / "cli_reference.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    page = (DOCS / "reference" / "cli.md").read_text(encoding="utf-8")
    assert page == module.cli_reference(), (
        "docs/reference/cli.md is out of date: run python scripts/cli_reference.py"
    )


def test_every_command_the_guide_gives_parses() -> None:
    seen = 0
    for page in _pages("guide"):
        for block in blocks(page.read_text(encoding="utf-8")):
            if block.language not in ("bash", "sh", "console", "shell"):
                continue
            for argv in commands(block.text):
                if argv and argv[0] == "hvacflex":
                    if {"--help", "--version"} & set(argv):  # eager: they run, not parse
                        continue
                    parse_command(argv[1:])
                    seen += 1
    assert seen > 20
