"""When interruptible load (IL) is activated.

The grid operator activates the reserve it bought; the building must then run its reduced
flows u − r for the activation's duration. Policies: never, always, random (seeded, an
activation starts in a period with probability ``rate`` and lasts ``duration_steps``), or
read from a CSV file with columns ``time`` (period start, ISO 8601) and ``activated`` (0/1).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd

from hvacflex.config import ActivationConfig
from hvacflex.errors import DataError

BoolArray = npt.NDArray[np.bool_]


def activation_schedule(
    config: ActivationConfig, index: pd.DatetimeIndex, *, seed: int
) -> BoolArray:
    """(T,) bool: True in the periods of ``index`` where IL is activated."""
    steps = len(index)
    if config.mode == "never":
        return np.zeros(steps, dtype=bool)
    if config.mode == "always":
        return np.ones(steps, dtype=bool)
    if config.mode == "random":
        return _random_schedule(steps, config.rate, config.duration_steps, seed)
    if config.file is None:  # guarded by config validation; kept for the type checker
        raise DataError("activation mode 'file' needs a file", field="activation.file")
    return read_activation_file(Path(config.file), index)


def _random_schedule(steps: int, rate: float, duration_steps: int, seed: int) -> BoolArray:
    rng = np.random.default_rng([seed, 0xA11])
    starts = rng.random(steps) < rate
    active = np.zeros(steps, dtype=bool)
    for start in np.flatnonzero(starts):
        active[start : start + duration_steps] = True
    return active


class ActivationFileWarning(UserWarning):
    """An activation file lists periods outside the run (they are ignored)."""


_COLUMNS_HINT = "the file needs a header line 'time,activated' and one row per period start"


def read_activation_file(path: Path, index: pd.DatetimeIndex) -> BoolArray:
    """Activation flags from a CSV (``time``, ``activated``); periods not listed are False.

    Parameters
    ----------
    path : CSV with columns ``time`` (period start, ISO 8601; local ``index`` time if naive)
        and ``activated`` (0/1).
    index : (T,) the run's period starts (tz-aware, 30 min apart).

    Returns
    -------
    (T,) bool flags.

    Raises
    ------
    DataError
        naming file, line and value for an empty or unreadable (binary, not UTF-8) file, a
        missing column, an unparseable time, a time not on a period start (:00 or :30), a
        period listed twice, or a flag other than 0/1.

    Warns
    -----
    ActivationFileWarning
        when rows fall outside the run: they are ignored, and the warning says how many.
    """
    try:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, encoding="utf-8")
    except FileNotFoundError:
        raise DataError("activation file not found", source=path) from None
    except IsADirectoryError:
        raise DataError("activation file is a folder", source=path, hint=_COLUMNS_HINT) from None
    except pd.errors.EmptyDataError:
        raise DataError("activation file is empty", source=path, hint=_COLUMNS_HINT) from None
    except (UnicodeDecodeError, pd.errors.ParserError, ValueError) as exc:
        raise DataError(
            f"not a readable CSV text file ({type(exc).__name__})", source=path, hint=_COLUMNS_HINT
        ) from None
    frame.columns = [str(c).strip() for c in frame.columns]
    for column in ("time", "activated"):
        if column not in frame.columns:
            raise DataError(
                "missing column",
                source=path,
                line=1,
                field=column,
                value=list(frame.columns)[:5],
                hint=_COLUMNS_HINT,
            )
    if frame.empty:
        raise DataError("activation file has no data rows", source=path, hint=_COLUMNS_HINT)
    lines = np.arange(2, len(frame) + 2)
    times = _parse_times(path, frame["time"].str.strip(), lines, index)
    off_grid = np.asarray(times != times.floor("30min"))
    if off_grid.any():
        row = int(np.flatnonzero(off_grid)[0])
        raise DataError(
            f"not the start of a 30-min period ({int(off_grid.sum())} row(s))",
            source=path,
            line=int(lines[row]),
            field="time",
            value=frame["time"].iloc[row],
            hint="periods start at :00 and :30, e.g. 2014-03-03T10:30",
        )
    if times.has_duplicates:
        row = int(np.flatnonzero(times.duplicated())[0])
        raise DataError(
            "period listed twice",
            source=path,
            line=int(lines[row]),
            field="time",
            value=frame["time"].iloc[row],
            hint="list each period start once",
        )
    flags = pd.to_numeric(frame["activated"].str.strip(), errors="coerce")
    bad = flags.isna() | ~flags.isin([0, 1])
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise DataError(
            "activated must be 0 or 1",
            source=path,
            line=int(lines[row]),
            field="activated",
            value=frame["activated"].iloc[row],
        )
    outside = ~np.asarray(times.isin(index))
    if outside.any() and len(index):
        row = int(np.flatnonzero(outside)[0])
        warnings.warn(
            ActivationFileWarning(
                f"{path}: {int(outside.sum())} of {len(times)} row(s) lie outside the run "
                f"{index[0]:%Y-%m-%d %H:%M} … {index[-1]:%Y-%m-%d %H:%M} and are ignored "
                f"(first: line {int(lines[row])}, {frame['time'].iloc[row]!r})"
            ),
            stacklevel=2,
        )
    series = pd.Series(flags.to_numpy(dtype=bool), index=times)
    return series.reindex(index, fill_value=False).to_numpy(dtype=bool)


def _parse_times(
    path: Path, texts: pd.Series, lines: np.ndarray, index: pd.DatetimeIndex
) -> pd.DatetimeIndex:
    """Period starts in the tz of ``index`` (naive times are local to it)."""
    parsed = []
    for text, line in zip(texts, lines, strict=True):
        stamp: pd.Timestamp | None
        try:
            stamp = pd.Timestamp(text)
        except (ValueError, TypeError, OverflowError):
            stamp = None
        if stamp is None or pd.isna(stamp):
            raise DataError(
                "unparseable time",
                source=path,
                line=int(line),
                field="time",
                value=text[:40],
                hint="write ISO 8601 period starts, e.g. 2014-03-03T10:30 or "
                "2014-03-03T10:30:00+08:00",
            )
        if stamp.tzinfo is None:
            stamp = stamp.tz_localize(index.tz) if index.tz is not None else stamp
        elif index.tz is not None:
            stamp = stamp.tz_convert(index.tz)
        parsed.append(stamp)
    return pd.DatetimeIndex(parsed)
