"""When the grid operator activates the interruptible load (IL).

The grid operator activates the reserve it bought after a contingency; the building then
curtails its consumption (:mod:`hvacflex.sim.closed_loop` says how). Modes:

* ``never``;
* ``random``: activations start at ``events_per_year`` (a Poisson process of that rate,
  seeded), each lasting 1 … D periods (uniform), never overlapping and separated by at least
  one period so that each stays one event;
* ``stress``: one activation every weekday (local time), starting at a period start
  between :data:`STRESS_FIRST_START_H` and :data:`STRESS_LAST_START_H` (office hours, when the
  building has load to shed), lasting 1 … D periods (uniform), seeded;
* ``file``: a CSV with columns ``time`` (period start, ISO 8601) and ``activated`` (0/1);
* ``always``: every period, the paper's literal case (under the event model the periods after
  the first D are beyond the model and counted as such).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd

from hvacflex.config import NEMS_MAX_INTERRUPTION_STEPS, ActivationConfig
from hvacflex.constants import PERIOD_FREQ
from hvacflex.errors import DataError
from hvacflex.units import SECONDS_PER_HOUR

BoolArray = npt.NDArray[np.bool_]

HOURS_PER_YEAR = 8760.0
"""Hours in a (non-leap) year: the unit of ``events_per_year``."""

_SEED_STREAM = 0xA11
"""Mixed into the scenario seed so the activation draws are independent of the others."""

STRESS_FIRST_START_H = 8.0
"""Earliest start of a ``stress`` activation [h, local time]."""
STRESS_LAST_START_H = 18.0
"""``stress`` activations start before this hour [h, local time]."""


def activation_schedule(
    config: ActivationConfig,
    index: pd.DatetimeIndex,
    *,
    seed: int,
    max_steps: int | None = None,
) -> BoolArray:
    """(T,) bool: True in the periods of ``index`` where IL is activated.

    Parameters
    ----------
    config : the ``[activation]`` table.
    index : (T,) the run's period starts (tz-aware, 30 min apart).
    seed : the scenario seed (``random`` and ``stress``).
    max_steps : longest random activation D [periods]; ``None`` = ``config.duration_steps``,
        else the NEMS 120-min rule (4 periods).
    """
    steps = len(index)
    longest = max_steps or config.duration_steps or NEMS_MAX_INTERRUPTION_STEPS
    if config.mode == "never":
        return np.zeros(steps, dtype=bool)
    if config.mode == "always":
        return np.ones(steps, dtype=bool)
    if config.mode == "stress":
        return stress_events(index, longest, seed)
    if config.mode == "random":
        return random_events(
            steps, config.events_per_year, longest, seed, step_h=_step_hours(index)
        )
    if config.file is None:  # guarded by config validation; kept for the type checker
        raise DataError("activation mode 'file' needs a file", field="activation.file")
    return read_activation_file(Path(config.file), index)


def _step_hours(index: pd.DatetimeIndex) -> float:
    if len(index) < 2:
        return 0.5
    return float((index[1] - index[0]).total_seconds()) / SECONDS_PER_HOUR


def random_events(
    steps: int, events_per_year: float, max_steps: int, seed: int, *, step_h: float = 0.5
) -> BoolArray:
    """(T,) bool: seeded random activations, none overlapping.

    An event may start in a free period with probability ``events_per_year · Δt / 8760``; it
    lasts a uniform 1 … ``max_steps`` periods, and the next may start one period after its
    end at the earliest (two events never merge into one longer block).
    """
    rng = np.random.default_rng([seed, _SEED_STREAM])
    start_draws = rng.random(steps)
    durations = rng.integers(1, max_steps + 1, size=steps)
    probability = min(events_per_year * step_h / HOURS_PER_YEAR, 1.0)
    active = np.zeros(steps, dtype=bool)
    free_from = 0
    for start in np.flatnonzero(start_draws < probability).tolist():
        if start < free_from:
            continue
        length = int(durations[start])
        active[start : start + length] = True
        free_from = start + length + 1
    return active


def stress_events(index: pd.DatetimeIndex, max_steps: int, seed: int) -> BoolArray:
    """(T,) bool: one seeded activation on every weekday of ``index`` (local time).

    Each starts at a period start drawn uniformly from those in [08:00, 18:00)
    (:data:`STRESS_FIRST_START_H`, :data:`STRESS_LAST_START_H`) and lasts a uniform 1 …
    ``max_steps`` periods (cut at the end of the run). Days are drawn in calendar order from
    one seeded stream, so a run's first days are activated alike whatever its length.
    """
    rng = np.random.default_rng([seed, _SEED_STREAM, 1])
    local = index.tz_localize(None) if index.tz is not None else index
    hours = np.asarray(local.hour + local.minute / 60.0)
    days = np.asarray(local.normalize().asi8)
    weekday = np.asarray(local.day_of_week < 5)
    window = weekday & (hours >= STRESS_FIRST_START_H) & (hours < STRESS_LAST_START_H)
    active = np.zeros(len(index), dtype=bool)
    for day in np.unique(days).tolist():
        slots = np.flatnonzero(window & (days == day))
        start_draw, length = rng.random(), int(rng.integers(1, max_steps + 1))
        if slots.size == 0:
            continue
        start = int(slots[min(int(start_draw * slots.size), slots.size - 1)])
        active[start : start + length] = True
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
    off_grid = np.asarray(times != times.floor(PERIOD_FREQ))
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
