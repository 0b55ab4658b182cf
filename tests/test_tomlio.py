"""TOML files in, dicts out; every unreadable file is a ConfigError naming it."""

from __future__ import annotations

from pathlib import Path

import pytest

from hvacflex.errors import BuildingConfigError, ConfigError
from hvacflex.tomlio import read_toml


def test_a_toml_file_becomes_its_dict(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text("days = 2\n[controller]\npeak_price_sgd_per_kw = 1.5 # φ\n", encoding="utf-8")
    assert read_toml(path, what="scenario") == {
        "days": 2,
        "controller": {"peak_price_sgd_per_kw": 1.5},
    }


@pytest.mark.parametrize(
    ("content", "words", "line"),
    [
        (None, "scenario file not found", None),
        (b"", "the scenario file is empty", None),
        (b"# only a comment\n", "empty (only comments)", None),
        (b"days = \n", "not valid TOML", None),
        (b"days = 2\nname = '\xff'\n", "not UTF-8 text (byte 0xff at offset 17)", 2),
    ],
)
def test_an_unreadable_file_names_itself(
    tmp_path: Path, content: bytes | None, words: str, line: int | None
) -> None:
    path = tmp_path / "s.toml"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ConfigError, match=r"s\.toml") as err:
        read_toml(path, what="scenario")
    assert words in str(err.value)
    assert err.value.line == line and err.value.source == str(path)


def test_the_error_class_is_the_callers(tmp_path: Path) -> None:
    with pytest.raises(BuildingConfigError, match="building file not found"):
        read_toml(tmp_path / "missing.toml", what="building", error=BuildingConfigError)
