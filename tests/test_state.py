"""The checkpoint format: data only, every value back bit for bit, old and foreign states
refused."""

from __future__ import annotations

import io
import json
import pickle
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex import state
from hvacflex.errors import InputError
from hvacflex.opt.basis import SolverBasis
from hvacflex.opt.solution import SolveStatus
from hvacflex.sim.events import Role


def test_round_trip_keeps_types_and_bits() -> None:
    rng = np.random.default_rng(7)
    original = {
        "k": 3,
        "x": rng.normal(size=(4, 2)),
        "nan": float("nan"),
        "inf": -float("inf"),
        "np_float": np.float64(0.1),
        "flag": np.bool_(True),
        "statuses": np.array(["optimal", None], dtype=object),
        "tuple": (1, "a", None),
        "int_keys": {1: "one", 2: [1.5, 2.5]},
        "role": Role.EVENT_LOCKED,
        "status": SolveStatus.OPTIMAL,
        "basis": SolverBasis(
            "abc", np.array([0, 1, 2], dtype=np.int8), np.array([1], dtype=np.int8)
        ),
        "rng": rng.bit_generator.state,
        "when": pd.Timestamp("2014-03-03 08:00", tz="Asia/Singapore"),
    }
    back = state.decode(state.encode(original))
    assert back.keys() == original.keys()
    np.testing.assert_array_equal(back["x"], original["x"])
    assert back["x"].dtype == np.float64
    assert np.isnan(back["nan"]) and back["inf"] == -np.inf
    assert type(back["np_float"]) is np.float64 and back["np_float"] == 0.1
    assert type(back["flag"]) is np.bool_
    assert list(back["statuses"]) == ["optimal", None]
    assert back["tuple"] == (1, "a", None)
    assert back["int_keys"] == {1: "one", 2: [1.5, 2.5]}
    assert back["role"] is Role.EVENT_LOCKED and back["status"] is SolveStatus.OPTIMAL
    assert isinstance(back["basis"], SolverBasis)
    assert back["basis"].fingerprint == "abc"
    np.testing.assert_array_equal(back["basis"].col_status, [0, 1, 2])
    assert back["basis"].col_status.dtype == np.int8
    assert back["rng"] == original["rng"]
    assert back["when"] == original["when"] and str(back["when"].tz) == "Asia/Singapore"


def test_a_pickle_of_an_older_hvacflex_is_refused_not_run() -> None:
    blob = pickle.dumps({"k": 1})
    with pytest.raises(state.StateFormatError, match=r"older hvacflex.*pickle") as info:
        state.decode(blob, source="checkpoint.pkl")
    assert isinstance(info.value, InputError)  # the CLI exits 2 on it
    assert "checkpoint.pkl" in str(info.value) and "afresh" in str(info.value)


def test_another_version_and_garbage_are_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    blob = state.encode({"k": 1})
    monkeypatch.setattr(state, "VERSION", state.VERSION + 1)
    with pytest.raises(state.StateFormatError, match="version"):
        state.decode(blob)
    with pytest.raises(state.StateFormatError, match="not an hvacflex state"):
        state.decode(b"PK-but-not-a-zip")


@dataclass(frozen=True)
class _Foreign:
    x: int


def test_only_hvacflex_dataclasses_are_built() -> None:
    blob = state.encode({"v": _Foreign(1)})  # a test-module class: not in the package
    with pytest.raises(state.StateFormatError, match="outside hvacflex"):
        state.decode(blob)


def _crafted(entry: dict[str, object]) -> bytes:
    """A state file whose manifest holds ``entry``, written without :func:`state.encode`."""
    manifest = json.dumps({"format": state.FORMAT, "version": state.VERSION, "state": entry})
    buffer = io.BytesIO()
    np.savez(buffer, manifest=np.frombuffer(manifest.encode("utf-8"), dtype=np.uint8))
    return buffer.getvalue()


CRAFTED_MAIN = {"__hvacflex__": "enum", "cls": "hvacflex.__main__:app"}
"""The state of issue 56: loading it imported ``hvacflex.__main__``, which ran the CLI."""

_LOAD_CRAFTED = """
import sys
from pathlib import Path
from hvacflex import state
state.decode(state.encode({"warm": 1}))  # what reading any state imports (zip, codecs)
before = set(sys.modules)
try:
    state.load(Path(sys.argv[1]))
except state.StateFormatError as err:
    print("REFUSED", err)
print("IMPORTED", sorted(set(sys.modules) - before))
"""


def test_a_crafted_state_naming_main_is_refused_and_imports_nothing(tmp_path: Path) -> None:
    path = tmp_path / "checkpoint.npz"
    path.write_bytes(_crafted(CRAFTED_MAIN))
    with pytest.raises(state.StateFormatError, match="not a type hvacflex stores") as info:
        state.load(path)
    assert "hvacflex.__main__:app" in str(info.value) and str(path) in str(info.value)
    # in a fresh interpreter (with an argv the CLI would act on): refused, nothing imported
    done = subprocess.run(
        [sys.executable, "-c", _LOAD_CRAFTED, str(path), "--version"],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 2 and lines[0].startswith("REFUSED"), done.stdout
    assert lines[1] == "IMPORTED []"


@pytest.mark.parametrize(
    "entry",
    [
        {"__hvacflex__": "dataclass", "cls": "hvacflex.config:ScenarioConfig", "fields": {}},
        {"__hvacflex__": "enum", "cls": "os:system", "value": "ls"},
        {"__hvacflex__": "enum", "cls": ["hvacflex.opt.solution", "SolveStatus"], "value": 1},
    ],
    ids=["hvacflex-dataclass-not-stored", "outside-hvacflex", "not-a-name"],
)
def test_only_registered_types_are_built(entry: dict[str, object]) -> None:
    with pytest.raises(state.StateFormatError, match="not a type hvacflex stores"):
        state.decode(_crafted(entry), source="crafted.npz")


def test_a_stored_type_of_the_wrong_kind_or_fields_is_refused() -> None:
    as_enum = {"__hvacflex__": "enum", "cls": "hvacflex.opt.basis:SolverBasis", "value": 1}
    with pytest.raises(state.StateFormatError, match="as an enum"):
        state.decode(_crafted(as_enum))
    bad_value = {"__hvacflex__": "enum", "cls": "hvacflex.opt.solution:SolveStatus", "value": "x"}
    with pytest.raises(state.StateFormatError, match="cannot rebuild"):
        state.decode(_crafted(bad_value))
    bad_fields = {
        "__hvacflex__": "dataclass",
        "cls": "hvacflex.opt.basis:SolverBasis",
        "fields": {"no_such_field": 1},
    }
    with pytest.raises(state.StateFormatError, match="cannot rebuild"):
        state.decode(_crafted(bad_fields))


def test_only_hvacflex_dataclasses_and_enums_can_be_registered() -> None:
    with pytest.raises(TypeError, match="only hvacflex"):
        state.register_stored_types(_Foreign)
    assert "test_state:_Foreign" not in state.stored_types()


def test_values_the_format_does_not_hold_name_their_place() -> None:
    with pytest.raises(TypeError, match=r"state\['a'\]\[0\].*set"):
        state.encode({"a": [{1, 2}]})


def test_save_and_load_a_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "checkpoint.npz"
    state.save(path, {"x": np.arange(3.0)})
    np.testing.assert_array_equal(state.load(path)["x"], [0.0, 1.0, 2.0])
