"""The plain-array checks shared by RMPCProblem and its feature blocks."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt.checks import (
    check_bounds,
    check_nonnegative,
    float_array,
    integer_in_range,
    matrix_shape,
)


def test_float_array_copies_broadcasts_and_locks() -> None:
    source = [1.0, 2.0]
    array = float_array("x", source, ((2,), (3, 2)), target=(3, 2))
    assert array.shape == (3, 2) and not array.flags.writeable
    np.testing.assert_array_equal(array[2], source)


@pytest.mark.parametrize(
    ("value", "fragment"),
    [
        (np.ones(3), "expected (2,), got (3,)"),
        ([1.0, np.nan], "NaN at index (1,)"),
        ([1.0, np.inf], "infinite value at index (1,)"),
        (["a", "b"], "numeric array"),
    ],
)
def test_float_array_refuses(value: object, fragment: str) -> None:
    with pytest.raises(ProblemError) as info:
        float_array("x", value, ((2,),))
    assert fragment in str(info.value) and info.value.field == "x"


def test_float_array_allows_the_infinities_asked_for() -> None:
    assert float_array("y_max", [np.inf, 1.0], ((2,),), allow_pos_inf=True)[0] == np.inf
    with pytest.raises(ProblemError, match="infinite"):
        float_array("y_max", [-np.inf, 1.0], ((2,),), allow_pos_inf=True)


def test_matrix_shape_and_integers() -> None:
    assert matrix_shape("a", np.ones((3, 3)), "(n, n)", lambda r, c: r == c) == (3, 3)
    with pytest.raises(ProblemError, match="expected \\(n, n\\), got \\(3, 2\\)"):
        matrix_shape("a", np.ones((3, 2)), "(n, n)", lambda r, c: r == c)
    assert integer_in_range("d", np.int64(3), 1, 4, "") == 3
    for bad in (0, 5, 2.0, True):
        with pytest.raises(ProblemError, match="integer with 1 ≤ value ≤ 4"):
            integer_in_range("d", bad, 1, 4, "")


def test_sign_and_order_checks_name_the_first_offending_index() -> None:
    check_nonnegative("s", np.zeros(3), "σ")
    with pytest.raises(ProblemError, match=r"σ must be ≥ 0, but at index \(1,\)"):
        check_nonnegative("s", np.array([0.0, -1.0, -2.0]), "σ")
    check_bounds("lo", np.zeros(2), "hi", np.ones(2))
    with pytest.raises(ProblemError, match=r"at index \(1,\) lo = 2.0 > hi = 1.0"):
        check_bounds("lo", np.array([0.0, 2.0]), "hi", np.ones(2))
