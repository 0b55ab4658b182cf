"""When interruptible load (IL) is activated.

The grid operator activates the reserve it bought; the building must then run its reduced
flows u − r for the activation's duration. Policies: never, always, random (seeded, an
activation starts in a period with probability ``rate`` and lasts ``duration_steps``), or
read from a CSV file with columns ``time`` (period start, ISO 8601) and ``activated`` (0/1).
"""

from __future__ import annotations

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


def read_activation_file(path: Path, index: pd.DatetimeIndex) -> BoolArray:
    """Activation flags from a CSV (``time``, ``activated``); periods not listed are False."""
    try:
        frame = pd.read_csv(path)
    except FileNotFoundError:
        raise DataError("activation file not found", source=path) from None
    for column in ("time", "activated"):
        if column not in frame.columns:
            raise DataError(
                "missing column",
                source=path,
                field=column,
                hint="the file needs columns 'time' (period start) and 'activated' (0/1)",
            )
    try:
        times = pd.DatetimeIndex(pd.to_datetime(frame["time"]))
    except (ValueError, TypeError) as exc:
        raise DataError(f"unparseable time: {exc}", source=path, field="time") from None
    if times.tz is None:
        times = times.tz_localize(index.tz)
    if times.has_duplicates:
        row = int(np.flatnonzero(times.duplicated())[0])
        raise DataError(
            "period listed twice",
            source=path,
            line=row + 2,
            field="time",
            value=frame["time"].iloc[row],
            hint="list each period start once",
        )
    flags = pd.to_numeric(frame["activated"], errors="coerce")
    bad = flags.isna() | ~flags.isin([0, 1])
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise DataError(
            "activated must be 0 or 1",
            source=path,
            line=row + 2,
            field="activated",
            value=frame["activated"].iloc[row],
        )
    series = pd.Series(flags.to_numpy(dtype=bool), index=times.tz_convert(index.tz))
    return series.reindex(index, fill_value=False).to_numpy(dtype=bool)
