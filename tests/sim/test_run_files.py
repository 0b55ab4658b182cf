"""A run folder is refused to another configuration, a scenario whose linearisation
temperature is impossible is refused naming the field the user wrote, and a summary is
written as strictly valid JSON."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import pytest

from hvacflex.config import preset
from hvacflex.errors import ConfigError, StoredStateError
from hvacflex.sim.run_files import (
    CHECKPOINT_FILE,
    CONFIG_FILE,
    RESULTS_FILE,
    SUMMARY_FILE,
    check_linearisation,
    check_out_dir,
    read_summary,
    summary_text,
    write_summary,
)


def _run_folder(tmp_path: Path, name: str = "thermostat", **overrides: object) -> Path:
    """A folder with the files of a run of preset ``name`` (their content is not read but
    config.json's)."""
    out = tmp_path / "run"
    out.mkdir()
    (out / CONFIG_FILE).write_text(json.dumps(preset(name, **overrides).to_dict()))
    for other in (RESULTS_FILE, SUMMARY_FILE, CHECKPOINT_FILE):
        (out / other).write_bytes(b"old")
    return out


def test_the_same_configuration_may_resume_or_reuse(tmp_path: Path) -> None:
    out = _run_folder(tmp_path, days=0.5)
    check_out_dir(out, preset("thermostat", days=0.5), fresh=False)
    renamed = replace(preset("thermostat", days=0.5), name="mine")  # a label, not a setting
    check_out_dir(out, renamed, fresh=False)
    assert (out / RESULTS_FILE).read_bytes() == b"old"


def test_another_configuration_is_refused_naming_what_differs(tmp_path: Path) -> None:
    out = _run_folder(tmp_path, days=0.5)
    with pytest.raises(StoredStateError) as err:
        check_out_dir(out, preset("thermostat", days=1.0), fresh=False)
    message = str(err.value)
    assert str(out) in message and "days 0.5 there, 1.0 here" in message
    assert "--fresh" in message
    assert (out / RESULTS_FILE).read_bytes() == b"old"


def test_fresh_replaces_another_configurations_run(tmp_path: Path) -> None:
    out = _run_folder(tmp_path, days=0.5)
    check_out_dir(out, preset("rmpc", days=0.5), fresh=True)
    assert not any((out / f).exists() for f in (RESULTS_FILE, SUMMARY_FILE, CHECKPOINT_FILE))
    assert not (out / CONFIG_FILE).exists()


def test_an_unreadable_stored_configuration_is_refused_unless_fresh(tmp_path: Path) -> None:
    out = _run_folder(tmp_path)
    (out / CONFIG_FILE).write_text('{"start": "04/03/2014"}')
    with pytest.raises(StoredStateError, match=r"cannot be read.*--fresh"):
        check_out_dir(out, preset("rmpc"), fresh=False)
    check_out_dir(out, preset("rmpc"), fresh=True)
    assert not (out / CONFIG_FILE).exists()


def test_a_folder_without_a_run_is_accepted(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("mine")
    check_out_dir(tmp_path, preset("rmpc"), fresh=True)
    check_out_dir(tmp_path / "new", preset("rmpc"), fresh=False)
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_a_comfort_band_below_the_supply_air_is_reported_against_the_band() -> None:
    cfg = preset("rmpc", **{"comfort.occupied_degc": (10.0, 12.0)})
    with pytest.raises(ConfigError) as err:
        check_linearisation(cfg, "s.toml")
    assert err.value.field == "comfort.occupied_degc" and err.value.source == "s.toml"
    assert "13 °C" in str(err.value)  # office5's supply air


def test_a_written_linearisation_temperature_is_reported_as_written() -> None:
    cfg = preset("rmpc", linearisation_temp_degc=12.0)
    with pytest.raises(ConfigError) as err:
        check_linearisation(cfg)
    assert err.value.field == "controller.linearisation_temp_degc" and err.value.value == 12.0
    check_linearisation(preset("rmpc"))  # 25 °C > 13 °C


def _strict_json(text: str) -> object:
    """``text`` parsed by a parser that refuses ``NaN`` / ``Infinity`` (RFC 8259)."""

    def refuse(constant: str) -> object:
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_a_summary_is_strict_json_with_null_for_what_is_not_finite(tmp_path: Path) -> None:
    summary = {"energy_kwh": 388.5, "over_kw": -float("inf"), "ratio": float("nan"), "steps": 48}
    with pytest.raises(ValueError, match="Infinity"):
        _strict_json(json.dumps(summary))  # what json.dumps alone would write
    parsed = _strict_json(summary_text(summary))
    assert parsed == {"energy_kwh": 388.5, "over_kw": None, "ratio": None, "steps": 48}
    path = write_summary(tmp_path / SUMMARY_FILE, summary)
    back = read_summary(path)  # null is read as NaN: the in-memory summary keeps its type
    assert back["energy_kwh"] == 388.5 and back["steps"] == 48
    assert math.isnan(back["over_kw"]) and math.isnan(back["ratio"])
