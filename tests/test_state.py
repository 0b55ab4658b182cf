"""The checkpoint format: data only, every value back bit for bit, old and foreign states
refused."""

from __future__ import annotations

import pickle
from dataclasses import dataclass

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


def test_values_the_format_does_not_hold_name_their_place() -> None:
    with pytest.raises(TypeError, match=r"state\['a'\]\[0\].*set"):
        state.encode({"a": [{1, 2}]})


def test_save_and_load_a_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "checkpoint.npz"
    state.save(path, {"x": np.arange(3.0)})
    np.testing.assert_array_equal(state.load(path)["x"], [0.0, 1.0, 2.0])
