"""Checks of the plain arrays and numbers that make an :class:`~hvacflex.opt.problem.RMPCProblem`
and its feature blocks (:mod:`hvacflex.opt.blocks`): each copies or refuses one value with a
:class:`~hvacflex.errors.ProblemError` naming the field, the value and what would be valid.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from hvacflex.errors import ProblemError

FloatArray = NDArray[np.float64]

#: The ``source`` of every error raised here.
SOURCE = "RMPCProblem"
_SOURCE = SOURCE


def _shape_text(shapes: tuple[tuple[int, ...], ...]) -> str:
    return " or ".join(str(s) for s in shapes)


def float_array(
    name: str,
    value: object,
    shapes: tuple[tuple[int, ...], ...],
    *,
    target: tuple[int, ...] | None = None,
    allow_neg_inf: bool = False,
    allow_pos_inf: bool = False,
) -> FloatArray:
    """Copy ``value`` to a read-only float array of one of ``shapes``, broadcast to ``target``."""
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ProblemError(
            "must be a numeric array",
            source=_SOURCE,
            field=name,
            value=type(value).__name__,
            hint=f"pass an array of shape {_shape_text(shapes)}",
        ) from exc
    if array.shape not in shapes:
        raise ProblemError(
            f"wrong shape: expected {_shape_text(shapes)}, got {array.shape}",
            source=_SOURCE,
            field=name,
            hint="N is the number of rows of d_forecast; n, m, nd, ny come from the matrices",
        )
    if np.isnan(array).any():
        raise ProblemError(
            f"contains NaN at index {tuple(int(i) for i in np.argwhere(np.isnan(array))[0])}",
            source=_SOURCE,
            field=name,
            hint="fill missing values before building the problem",
        )
    bad = np.isinf(array)
    if allow_neg_inf:
        bad &= array > 0
    if allow_pos_inf:
        bad &= array < 0
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ProblemError(
            f"contains an infinite value at index {index}",
            source=_SOURCE,
            field=name,
            value=float(array[index]),
            hint="only y_min may be -inf and y_max +inf (no bound)",
        )
    if target is not None and array.shape != target:
        array = np.broadcast_to(array, target).copy()
    array.setflags(write=False)
    return array


def matrix_shape(
    name: str, value: object, expected: str, fits: Callable[[int, int], bool]
) -> tuple[int, int]:
    """The (rows, columns) of ``value`` if it is 2-D and ``fits(rows, columns)``; else raise."""
    shape = np.asarray(value).shape
    if len(shape) != 2 or not fits(shape[0], shape[1]):
        raise ProblemError(
            f"wrong shape: expected {expected}, got {shape}", source=_SOURCE, field=name
        )
    return int(shape[0]), int(shape[1])


def integer_in_range(name: str, value: object, low: int, high: int | None, hint: str) -> int:
    """``value`` as an int if it is an integer (not a bool) in [low, high] (high None: no
    upper end); else raise with ``hint``."""
    number = (
        int(value) if isinstance(value, int | np.integer) and not isinstance(value, bool) else None
    )
    if number is None or number < low or (high is not None and number > high):
        bound = f"{low} ≤ value ≤ {high}" if high is not None else f"value ≥ {low}"
        raise ProblemError(
            f"must be an integer with {bound}", source=_SOURCE, field=name, value=value, hint=hint
        )
    return number


def check_nonnegative(name: str, values: FloatArray, what: str) -> None:
    """Refuse a negative entry of ``values`` (``what`` says what they are)."""
    if (values < 0).any():
        index = tuple(int(i) for i in np.argwhere(values < 0)[0])
        raise ProblemError(
            f"{what} must be ≥ 0, but at index {index} it is {float(values[index])!r}",
            source=_SOURCE,
            field=name,
        )


def check_bounds(lower_name: str, lower: FloatArray, upper_name: str, upper: FloatArray) -> None:
    """Refuse an entry where ``lower`` exceeds ``upper`` (same shapes)."""
    if (lower > upper).any():
        index = tuple(int(i) for i in np.argwhere(lower > upper)[0])
        raise ProblemError(
            f"{lower_name} must not exceed {upper_name}, but at index {index} "
            f"{lower_name} = {float(lower[index])!r} > {upper_name} = "
            f"{float(upper[index])!r}",
            source=_SOURCE,
            field=lower_name,
            hint="index is (step, input) or (step, output)",
        )
