"""The allow-list of stored types: registered on import, closed over the fields they hold."""

from __future__ import annotations

import dataclasses
import enum
import typing

import numpy as np

from hvacflex import state
from hvacflex.sim.stored_types import STORED_TYPES


def _held_types(annotation: object) -> typing.Iterator[type]:
    for arg in typing.get_args(annotation):
        yield from _held_types(arg)
    if isinstance(annotation, type):
        yield annotation


def test_importing_sim_registers_every_stored_type() -> None:
    registered = state.stored_types()
    for cls in STORED_TYPES:
        assert registered[f"{cls.__module__}:{cls.__qualname__}"] is cls


def test_stored_types_are_frozen_dataclasses_or_enums() -> None:
    for cls in STORED_TYPES:
        if issubclass(cls, enum.Enum):
            continue
        assert dataclasses.is_dataclass(cls), cls
        assert cls.__dataclass_params__.frozen, cls  # type: ignore[attr-defined]


def test_the_list_holds_every_hvacflex_type_its_fields_hold() -> None:
    names = {cls.__name__: cls for cls in STORED_TYPES}
    missing = set()
    for cls in STORED_TYPES:
        if not dataclasses.is_dataclass(cls):
            continue
        hints = typing.get_type_hints(cls, localns=names)
        for field in dataclasses.fields(cls):
            for held in _held_types(hints[field.name]):
                stored = dataclasses.is_dataclass(held) or issubclass(held, enum.Enum)
                if held.__module__.startswith("hvacflex.") and stored:
                    missing |= {held} - set(STORED_TYPES)
    assert missing == set()


def test_a_registered_type_round_trips() -> None:
    from hvacflex.opt.basis import SolverBasis
    from hvacflex.opt.solution import SolveStatus

    basis = SolverBasis("f", np.array([1, 0], dtype=np.int8), np.array([2], dtype=np.int8))
    back = state.decode(state.encode({"basis": basis, "status": SolveStatus.OPTIMAL}))
    assert back["status"] is SolveStatus.OPTIMAL
    np.testing.assert_array_equal(back["basis"].col_status, [1, 0])
