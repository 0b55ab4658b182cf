"""Market prices: NEMS USEP energy prices and interruptible-load (reserve) prices.

Half-hourly periods
-------------------
NEMS trades in 48 half-hourly periods a day. Period ``p`` (1…48) of date ``D`` covers
``[(p−1)·30, p·30)`` minutes after local midnight, Singapore time (SGT, UTC+8, no DST). Every
series returned here is indexed by the **period start**, tz-aware ``Asia/Singapore``, at a
30-minute frequency, and named with its unit (``energy_price_sgd_per_mwh`` …).

Energy prices (USEP)
--------------------
:func:`load_usep` reads EMC's monthly CSV downloads, in the older format shipped with
hvacflex (``PRICE ($/MWh)``, ``DEMAND (MW)``) and the newer one (``USEP ($/MWh)``,
``LCP ($/MWh)``, ``DEMAND (MW)``, ``TCL (MW)`` and later extras such as ``SOLAR(MW)``,
``RUSEP ($/MWh)``, ``MAP ($/MWh)``, ``MAPT ($/MWh)``, ``TPC Applied``; extras are ignored).
Every row is checked; a gap is an error unless ``fill="previous-day"`` is asked for
explicitly. Zero and negative prices are valid market outcomes and are kept.

Reserve prices
--------------
No public history of NEMS reserve / interruptible-load prices exists (see the data
provenance). :func:`synthetic_reserve_prices` generates a seeded, deterministic series
correlated with USEP and **marked synthetic** (``.attrs["synthetic"] is True``);
:func:`load_reserve_prices` reads real prices from a user CSV with the USEP period layout.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from hvacflex.constants import PERIOD, PERIODS_PER_DAY, TIMEZONE
from hvacflex.errors import DataError

ENERGY_PRICE_COLUMN = "energy_price_sgd_per_mwh"
SYSTEM_DEMAND_COLUMN = "system_demand_mw"
RESERVE_PRICE_COLUMN = "reserve_price_sgd_per_mwh"

FillMode = Literal["none", "previous-day"]
FILL_MODES: tuple[str, ...] = ("none", "previous-day")
"""How gaps in a price file are treated: ``"none"`` raises, ``"previous-day"`` copies the same
period of the nearest earlier complete day (and records what it filled)."""

_DATE_COLUMN = "DATE"
_PERIOD_COLUMN = "PERIOD"
_USEP_PRICE_COLUMNS = ("PRICE ($/MWh)", "USEP ($/MWh)")
_DEMAND_COLUMN = "DEMAND (MW)"
_RESERVE_PRICE_COLUMNS = (
    "RESERVE PRICE ($/MWh)",
    "IL PRICE ($/MWh)",
    "PRICE ($/MWh)",
    RESERVE_PRICE_COLUMN,
)
PRICE_CAP_SGD_PER_MWH = 4500.0
"""Highest price a NEMS period can clear at [SGD/MWh]: the energy offer price cap of the
Singapore Electricity Market Rules (Chapter 6, offer price limits; EMC, "Guide to Prices",
https://www.nems.emcsg.com/Guide-To-Prices). A price above it is a damaged file, not a
market outcome."""

PRICE_FLOOR_SGD_PER_MWH = -4500.0
"""Lowest price a NEMS period can clear at [SGD/MWh]: the offer price floor of the same
rules (−4,500 SGD/MWh)."""

MAX_SYSTEM_DEMAND_MW = 100_000.0
"""Upper bound on a plausible NEMS system demand [MW] (the 2014 peak is ≈ 6,800 MW); a larger
value is a damaged file."""

_DATE_FORMATS = ("%d %b %Y", "%d-%b-%Y", "%d-%b-%y", "%Y-%m-%d", "%d/%m/%Y")
_MAX_LISTED = 10

RESERVE_PRICE_SCALE = 48.5
"""Scale of the synthetic reserve price [SGD/MWh]: the reserve price when USEP equals
:data:`RESERVE_PRICE_REFERENCE_SGD_PER_MWH`, before noise (median ≈ 0.9 × scale, mean ≈ scale).

Calibrated once per model and frozen (docs/explanation/model.md §2): at this scale the product's
scenario (a) (nominal MPC, IL event model D = 4, α = 1 K, R = 2, reserve committed g = 2 periods
ahead, the EnergyPlus-following power model) earns reserve revenue ≈ 1 % of its energy cost
(the paper's Table 1) over four two-day periods, one per quarter of 2014 (run and numbers in
``docs/reference/data.md``; 2026-12-02). The previous 15 SGD/MWh was calibrated on the old power
model, under which a kg/s of curtailment saved ≈ 2.5× more power. It is about twenty times
docs/explanation/model.md §2's guess of 2–3 SGD/MWh: a kW of reserve held for a two-hour event needs
some pre-cooling bought at USEP, so reserve pays only where its price is a sizeable fraction of
the energy price.
"""

RESERVE_PRICE_REFERENCE_SGD_PER_MWH = 136.7
"""USEP at which the synthetic reserve price equals its scale: the 2014 mean USEP [SGD/MWh].
A fixed constant (not the mean of the series passed in) so that a period's reserve price does
not depend on the date range requested."""

RESERVE_PRICE_NOISE_SIGMA = 0.35
"""Standard deviation of the log of the multiplicative lognormal noise (mean-one noise)."""

RESERVE_PRICE_SPIKE_THRESHOLD_SGD_PER_MWH = 300.0
"""USEP above which reserve prices are amplified (≈ the 2014 99th percentile) [SGD/MWh]."""

RESERVE_PRICE_CORRELATION = 1.0
"""Default weight ρ of the USEP-driven part of the synthetic reserve price (0 … 1): 1 is the
calibrated series (the price follows USEP and its spikes), 0 a price independent of USEP
(``scale`` × the noise); in between a mix (:func:`synthetic_reserve_prices`)."""

RESERVE_PRICE_SPIKE_GAIN = 1.0
"""Extra amplification per multiple of the spike threshold: the factor is
``1 + gain · max(0, USEP/threshold − 1)``, so scarcity lifts reserve prices more than
proportionally, as in a co-optimised energy–reserve market."""


def _as_files(source: str | Path | Sequence[str | Path]) -> list[Path]:
    """One file, a list of files or a folder (its ``*.csv`` files, sorted) → list of files."""
    items = [source] if isinstance(source, str | Path) else list(source)
    if not items:
        raise DataError(
            "no price files given", field="source", value=[], hint="give a file or a folder"
        )
    files: list[Path] = []
    for item in items:
        path = Path(item)
        if path.is_dir():
            found = sorted(path.glob("*.csv")) + sorted(path.glob("*.CSV"))
            if not found:
                raise DataError(
                    "folder holds no .csv files",
                    source=path,
                    hint="point to a folder of EMC CSV downloads or list the files",
                )
            files.extend(found)
        elif path.is_file():
            files.append(path)
        else:
            raise DataError(
                "price file or folder not found",
                source=path,
                hint="check the path (the shipped data is in <data_dir>/nems_usep_2014)",
            )
    return files


def _normalise_header(name: str) -> str:
    return " ".join(str(name).strip().split()).upper().replace("/MWH", "/MWh")


def _parse_dates(values: pd.Series, path: Path, line: pd.Series) -> pd.Series:
    """Parse a DATE column with the first known format that reads its first row."""
    first = str(values.iloc[0])
    for fmt in _DATE_FORMATS:
        try:
            pd.to_datetime(first, format=fmt)
        except ValueError:
            continue
        parsed = pd.to_datetime(values, format=fmt, errors="coerce")
        bad = parsed.isna().to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise DataError(
                f"unparseable date ({int(bad.sum())} row(s) in this file)",
                source=path,
                line=int(line.iloc[i]),
                field=_DATE_COLUMN,
                value=str(values.iloc[i]),
                hint=f"dates in this file are written like {first!r} (format {fmt!r})",
            )
        return parsed
    raise DataError(
        "unparseable date",
        source=path,
        line=int(line.iloc[0]),
        field=_DATE_COLUMN,
        value=first,
        hint="write dates like '01 Jan 2014' (EMC) or '2014-01-01'",
    )


def _read_raw_csv(path: Path) -> pd.DataFrame:
    """The CSV as strings, one row per non-blank line, with its 1-based ``line`` number."""
    try:
        raw = pd.read_csv(
            path, dtype=str, keep_default_na=False, skip_blank_lines=False, skipinitialspace=True
        )
    except pd.errors.EmptyDataError:
        raise DataError("file is empty", source=path, hint="expected a header line") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise DataError(
            f"not a readable CSV file ({exc})", source=path, hint="expected an EMC CSV download"
        ) from None
    return raw


def _price_column(
    raw: pd.DataFrame,
    header: Mapping[str, str],
    path: Path,
    price_columns: Sequence[str],
    explicit_price_column: str | None,
) -> str:
    """The price column's name in ``raw``; refuses a header without DATE, PERIOD and a price."""
    if explicit_price_column is not None:
        candidates = [c for c in raw.columns if c.strip() == explicit_price_column]
        price_column = candidates[0] if candidates else None
    else:
        matches = [
            header[_normalise_header(c)] for c in price_columns if _normalise_header(c) in header
        ]
        price_column = matches[0] if matches else None
    missing = [c for c in (_DATE_COLUMN, _PERIOD_COLUMN) if c not in header]
    if missing or price_column is None:
        wanted = explicit_price_column or " or ".join(repr(c) for c in price_columns)
        raise DataError(
            "unknown header: expected columns DATE, PERIOD and a price column",
            source=path,
            line=1,
            value=list(raw.columns),
            hint=f"the price column must be {wanted}; is this an EMC USEP download?",
        )
    return price_column


def _numeric(raw: pd.DataFrame, column: str, path: Path, what: str, hint: str) -> pd.Series:
    """``raw[column]`` as numbers; refuses the first non-numeric row, naming its line."""
    values = pd.to_numeric(raw[column].str.strip(), errors="coerce")
    _refuse_rows(raw, column, path, values.isna().to_numpy(), f"non-numeric {what}", hint)
    return values


def _refuse_rows(
    raw: pd.DataFrame, column: str, path: Path, bad: np.ndarray, what: str, hint: str
) -> None:
    """Raise a :class:`DataError` naming the first row flagged in ``bad`` (if any)."""
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise DataError(
            f"{what} ({int(bad.sum())} row(s) in this file)",
            source=path,
            line=int(raw["line"].iloc[i]),
            field=column,
            value=str(raw[column].iloc[i]),
            hint=hint,
        )


def _check_within(
    raw: pd.DataFrame,
    column: str,
    path: Path,
    values: pd.Series,
    bounds: tuple[float, float],
    what: str,
) -> None:
    """Refuse the first row whose value is not finite or outside ``bounds`` = (low, high)."""
    low, high = bounds
    array = values.to_numpy(dtype=float)
    bad = ~(np.isfinite(array) & (array >= low) & (array <= high))
    _refuse_rows(
        raw,
        column,
        path,
        bad,
        f"{what} outside [{low:g}, {high:g}]",
        "the file looks damaged; compare it with the EMC download",
    )


def _read_period_csv(
    path: Path,
    price_columns: Sequence[str],
    explicit_price_column: str | None = None,
) -> pd.DataFrame:
    """Read one half-hourly CSV (DATE, PERIOD, price[, demand]) and check every row.

    Returns a frame with columns ``time`` (tz-aware period start), ``price``, ``demand``
    (NaN where absent), ``line`` (1-based line in ``path``) and ``file``.
    """
    raw = _read_raw_csv(path)
    header = {_normalise_header(c): c for c in raw.columns}
    price_column = _price_column(raw, header, path, price_columns, explicit_price_column)
    raw["line"] = np.arange(2, len(raw) + 2)
    blank = (raw.drop(columns="line") == "").all(axis=1)
    raw = raw.loc[~blank]
    if raw.empty:
        raise DataError("file holds no data rows", source=path, hint="expected 48 rows per day")
    line = raw["line"]
    dates = _parse_dates(raw[header[_DATE_COLUMN]].str.strip(), path, line)
    period_column = header[_PERIOD_COLUMN]
    period = _numeric(raw, period_column, path, "period", "periods are integers 1…48")
    _refuse_rows(
        raw,
        period_column,
        path,
        ((period < 1) | (period > PERIODS_PER_DAY) | (period != period.round())).to_numpy(),
        "period outside 1–48",
        "period p covers [(p−1)·30, p·30) min after local midnight, p = 1…48",
    )
    price = _numeric(
        raw, price_column, path, "price", "prices are numbers in SGD/MWh (zero and negative ok)"
    )
    _check_within(
        raw,
        price_column,
        path,
        price,
        (PRICE_FLOOR_SGD_PER_MWH, PRICE_CAP_SGD_PER_MWH),
        "price beyond the NEMS price floor/cap [SGD/MWh]",
    )
    if _normalise_header(_DEMAND_COLUMN) in header and explicit_price_column is None:
        demand_column = header[_DEMAND_COLUMN]
        demand = _numeric(raw, demand_column, path, "demand", "demand is a number in MW")
        _check_within(raw, demand_column, path, demand, (0.0, MAX_SYSTEM_DEMAND_MW), "demand [MW]")
    else:
        demand = pd.Series(np.nan, index=raw.index)
    start = dates + pd.to_timedelta((period.astype(int) - 1) * 30, unit="min")
    return pd.DataFrame(
        {
            "time": start.dt.tz_localize(TIMEZONE).to_numpy(),
            "price": price.to_numpy(dtype=float),
            "demand": demand.to_numpy(dtype=float),
            "line": line.to_numpy(),
            "file": str(path),
        }
    )


def _describe(times: pd.DatetimeIndex | pd.Series) -> list[str]:
    out = []
    for t in list(times)[:_MAX_LISTED]:
        ts = pd.Timestamp(t)
        period = (ts.hour * 60 + ts.minute) // 30 + 1
        out.append(f"{ts:%d %b %Y} P{period}")
    if len(times) > _MAX_LISTED:
        out.append(f"… {len(times) - _MAX_LISTED} more")
    return out


def _check_and_assemble(rows: pd.DataFrame, fill: FillMode, what: str) -> pd.DataFrame:
    """Reject duplicates, reject (or explicitly fill) missing periods; index by period start."""
    if fill not in FILL_MODES:
        raise DataError(
            "unknown fill mode",
            field="price_gap_fill",
            value=fill,
            hint=f"use one of {list(FILL_MODES)}",
        )
    duplicated = rows.duplicated("time", keep=False)
    if duplicated.any():
        dup = rows.loc[duplicated].sort_values(["time", "file", "line"])
        where = [f"{f}:{ln}" for f, ln in zip(dup["file"], dup["line"], strict=True)]
        first = dup.iloc[0]
        raise DataError(
            f"duplicate periods in {what} data: {_describe(dup['time'].drop_duplicates())} "
            f"at {where[:_MAX_LISTED]}",
            source=first["file"],
            line=int(first["line"]),
            field=_PERIOD_COLUMN,
            value=_describe(pd.Series([first["time"]]))[0],
            hint="each (DATE, PERIOD) may appear once; remove the repeated rows or files",
        )
    rows = rows.sort_values("time").set_index("time")
    first_day = rows.index.min().normalize()
    last_day = rows.index.max().normalize()
    full = pd.date_range(first_day, last_day + pd.Timedelta(days=1), freq=PERIOD, inclusive="left")
    full.name = "time"
    missing = full.difference(pd.DatetimeIndex(rows.index))
    frame = rows[["price", "demand"]].reindex(full)
    filled: list[pd.Timestamp] = []
    if len(missing):
        if fill == "none":
            raise DataError(
                f"{len(missing)} missing period(s) in {what} data between "
                f"{first_day:%d %b %Y} and {last_day:%d %b %Y}: {_describe(missing)}",
                source=", ".join(sorted(set(rows["file"])))[:300],
                field=_PERIOD_COLUMN,
                hint="add the missing rows, or fill each gap with the same period of the day "
                "before: the command-line option --price-gap-fill previous-day, the scenario "
                "setting data.price_gap_fill = 'previous-day', or load_usep(..., "
                "fill='previous-day') (the filled periods are recorded in "
                ".attrs['filled_periods'])",
            )
        values = frame.to_numpy(copy=True)
        gaps = np.isnan(values[:, 0])
        pos = np.flatnonzero(gaps)
        for p in pos:
            src = p - PERIODS_PER_DAY
            while src >= 0 and np.isnan(values[src, 0]):
                src -= PERIODS_PER_DAY
            if src < 0:
                src = p + PERIODS_PER_DAY
                while src < len(values) and np.isnan(values[src, 0]):
                    src += PERIODS_PER_DAY
            if src >= len(values):
                raise DataError(
                    f"cannot fill {what} period {_describe(full[[int(p)]])[0]}: that period is "
                    "missing on every day",
                    field=_PERIOD_COLUMN,
                    hint="supply the missing rows",
                )
            values[p] = values[src]
        frame = pd.DataFrame(values, index=full, columns=["price", "demand"])
        filled = list(full[pos])
    frame.attrs["filled_periods"] = filled
    frame.attrs["source_files"] = sorted(set(rows["file"]))
    return frame


def _stamps(files: Sequence[str]) -> tuple[tuple[int, int], ...]:
    """(modification time [ns], size [bytes]) per file: part of the cache key, so an edited
    file is read again."""
    out = []
    for f in files:
        stat = Path(f).stat()
        out.append((stat.st_mtime_ns, stat.st_size))
    return tuple(out)


@functools.lru_cache(maxsize=8)
def _load_usep_cached(
    files: tuple[str, ...], fill: FillMode, stamps: tuple[tuple[int, int], ...]
) -> pd.DataFrame:
    """:func:`_read_usep` from the disk cache (:mod:`hvacflex.data.cache`) when these files'
    bytes, ``fill`` and this code read them before."""
    from hvacflex.data.cache import cache_key, cached_frame

    def build() -> tuple[pd.DataFrame, dict[str, Any]]:
        frame = _read_usep(files, fill)
        filled = [pd.Timestamp(t).isoformat() for t in frame.attrs["filled_periods"]]
        return frame, {"filled_periods": filled, "source_files": frame.attrs["source_files"]}

    try:
        key = cache_key("usep", files, [files, fill])
    except OSError:  # unreadable: _read_usep names the file and the fix
        return _read_usep(files, fill)
    out, extra = cached_frame(key, build)
    index = pd.DatetimeIndex(out.index)
    filled_index = pd.DatetimeIndex(extra["filled_periods"])
    if len(filled_index):
        filled_index = filled_index.tz_convert(index.tz).as_unit(index.unit)
    out.attrs = {"filled_periods": list(filled_index), "source_files": extra["source_files"]}
    return out


def _read_usep(files: tuple[str, ...], fill: FillMode) -> pd.DataFrame:
    """The USEP table of :func:`load_usep` read and checked from ``files``."""
    rows = pd.concat(
        [_read_period_csv(Path(f), _USEP_PRICE_COLUMNS) for f in files],
        ignore_index=True,
    )
    frame = _check_and_assemble(rows, fill, "USEP")
    out = pd.DataFrame({ENERGY_PRICE_COLUMN: frame["price"]}, index=frame.index)
    if frame["demand"].notna().any():
        out[SYSTEM_DEMAND_COLUMN] = frame["demand"]
    out.attrs = dict(frame.attrs)
    return out


def load_usep(
    source: str | Path | Sequence[str | Path], *, fill: FillMode = "none"
) -> pd.DataFrame:
    """Read NEMS USEP half-hourly prices from EMC CSV downloads.

    Parameters
    ----------
    source : a CSV file, a list of files, or a folder (all its ``*.csv`` files).
    fill : ``"none"`` (default) raises on missing periods; ``"previous-day"`` copies the same
        period of the nearest earlier day that has it (later day at the very start) and lists
        the filled period starts in ``.attrs["filled_periods"]``.

    Returns
    -------
    DataFrame indexed by period start (tz ``Asia/Singapore``, 30 min, contiguous from the first
    day's 00:00 to the last day's 23:30) with ``energy_price_sgd_per_mwh`` [SGD/MWh] and, when
    the files have ``DEMAND (MW)``, ``system_demand_mw`` [MW]. ``.attrs["source_files"]``
    lists the files read. Columns other than date, period, price and demand (``LCP``,
    ``TCL``, ``SOLAR(MW)``, ``RUSEP``, ``MAP``, ``MAPT``, ``TPC Applied``, …) are ignored.

    Raises
    ------
    DataError
        naming file, line and value for an unknown header, a period outside 1–48, an
        unparseable date, a non-numeric or non-finite price, a price beyond the NEMS price
        floor/cap (:data:`PRICE_FLOOR_SGD_PER_MWH`, :data:`PRICE_CAP_SGD_PER_MWH`), a demand
        outside [0, :data:`MAX_SYSTEM_DEMAND_MW`], duplicate periods, or missing periods
        (unless ``fill="previous-day"``), or an unknown ``fill``.
    """
    files = tuple(str(p.resolve()) for p in _as_files(source))
    cached = _load_usep_cached(files, fill, _stamps(files))
    out = cached.copy()
    out.attrs = dict(cached.attrs)
    return out


def load_reserve_prices(
    source: str | Path | Sequence[str | Path],
    *,
    column: str | None = None,
    fill: FillMode = "none",
) -> pd.Series:
    """Read real reserve (interruptible-load) prices from CSV files with the USEP layout.

    Each file has a header line with ``DATE`` (e.g. ``01 Jan 2014``), ``PERIOD`` (1…48) and a
    price column in SGD/MWh: ``column`` if given, otherwise the first of
    ``RESERVE PRICE ($/MWh)``, ``IL PRICE ($/MWh)``, ``PRICE ($/MWh)``,
    ``reserve_price_sgd_per_mwh``. Other columns are ignored. Same checks as :func:`load_usep`.

    Returns
    -------
    Series ``reserve_price_sgd_per_mwh`` [SGD/MWh] on tz-aware (``Asia/Singapore``) period
    starts, ``.attrs["synthetic"] = False``.
    """
    files = [p.resolve() for p in _as_files(source)]
    rows = pd.concat(
        [_read_period_csv(f, _RESERVE_PRICE_COLUMNS, column) for f in files],
        ignore_index=True,
    )
    frame = _check_and_assemble(rows, fill, "reserve price")
    series = frame["price"].rename(RESERVE_PRICE_COLUMN)
    series.attrs = {**frame.attrs, "synthetic": False}
    return series


def synthetic_reserve_prices(
    energy_price: pd.Series,
    *,
    seed: int = 2014,
    scale_sgd_per_mwh: float = RESERVE_PRICE_SCALE,
    correlation: float = RESERVE_PRICE_CORRELATION,
) -> pd.Series:
    """Seeded **synthetic** reserve (IL) prices correlated with the energy price.

    No public NEMS reserve-price history exists, so hvacflex generates one
    (docs/explanation/model.md §2)::

        b_k = scale · n_k · (ρ · f_k + (1 − ρ)),
        f_k = (max(c_k, 0) / c_ref) · (1 + g · max(0, c_k / c_spike − 1))

    with ``c_k`` the USEP, ``c_ref`` = :data:`RESERVE_PRICE_REFERENCE_SGD_PER_MWH`,
    ``n_k`` mean-one lognormal noise (log-σ :data:`RESERVE_PRICE_NOISE_SIGMA`), spike
    threshold ``c_spike`` and gain ``g`` (:data:`RESERVE_PRICE_SPIKE_THRESHOLD_SGD_PER_MWH`,
    :data:`RESERVE_PRICE_SPIKE_GAIN`). With the default scale the typical price is 2–3 SGD/MWh
    and USEP spikes lift it to a few tens. The weight ``ρ`` (``correlation``) sets how much
    of the price follows USEP: ρ = 1 (the default) is ``scale · f_k · n_k`` exactly, where zero
    or negative USEP gives zero; ρ = 0 is ``scale · n_k``, independent of USEP (the same level
    at the reference price, no spikes). ``f_k`` is 1 at ``c_ref``, so ``scale`` keeps its
    meaning at every ρ; the Pearson correlation with USEP falls with ρ (the sensitivity sweep,
    :mod:`hvacflex.sensitivity`, reports the realised value).

    The noise of each period is drawn from a generator seeded with ``(seed, date)``, so a
    period's price does not depend on which date range is requested.

    Parameters
    ----------
    energy_price : (T,) USEP [SGD/MWh] on a tz-aware 30-min index of period starts.
    seed : random seed.
    scale_sgd_per_mwh : price at ``c_k = c_ref`` before noise [SGD/MWh]
        (default :data:`RESERVE_PRICE_SCALE`, calibrated on the simulator).
    correlation : weight ρ ∈ [0, 1] of the USEP-driven part (default
        :data:`RESERVE_PRICE_CORRELATION`: the calibrated series).

    Returns
    -------
    (T,) Series ``reserve_price_sgd_per_mwh`` [SGD/MWh] on the same index, with
    ``.attrs["synthetic"] = True`` and the seed, scale and ρ in ``.attrs``.
    """
    if not np.isfinite(scale_sgd_per_mwh) or scale_sgd_per_mwh < 0:
        raise DataError(
            "reserve price scale must be a finite number ≥ 0",
            field="scale_sgd_per_mwh",
            value=scale_sgd_per_mwh,
            hint=f"the default is {RESERVE_PRICE_SCALE} SGD/MWh",
        )
    if not 0.0 <= correlation <= 1.0:  # also refuses NaN
        raise DataError(
            "reserve price correlation must be a weight in [0, 1]",
            field="correlation",
            value=correlation,
            hint=f"1 follows USEP (the default, {RESERVE_PRICE_CORRELATION:g}), 0 ignores it",
        )
    index = energy_price.index
    if not isinstance(index, pd.DatetimeIndex):
        raise DataError(
            "energy price must be indexed by period start times",
            field="energy_price",
            value=type(index).__name__,
            hint="use the series returned by load_usep",
        )
    price = energy_price.to_numpy(dtype=float)
    local = index.tz_convert(TIMEZONE) if index.tz is not None else index
    days = local.normalize()
    slot = ((local - days) // PERIOD).to_numpy().astype(int) % PERIODS_PER_DAY
    noise_z = np.empty(len(price))
    day_codes, day_of_row = np.unique(days.to_numpy(), return_inverse=True)
    for i, day in enumerate(day_codes):
        ordinal = pd.Timestamp(day).toordinal()
        z = np.random.default_rng([seed, ordinal]).standard_normal(PERIODS_PER_DAY)
        rows = day_of_row == i
        noise_z[rows] = z[slot[rows]]
    sigma = RESERVE_PRICE_NOISE_SIGMA
    noise = np.exp(sigma * noise_z - 0.5 * sigma**2)
    base = np.maximum(price, 0.0) / RESERVE_PRICE_REFERENCE_SGD_PER_MWH
    spike = 1.0 + RESERVE_PRICE_SPIKE_GAIN * np.maximum(
        0.0, price / RESERVE_PRICE_SPIKE_THRESHOLD_SGD_PER_MWH - 1.0
    )
    if correlation == 1.0:  # the calibrated series, bit for bit (same operation order)
        values = scale_sgd_per_mwh * base * noise * spike
    else:
        values = scale_sgd_per_mwh * (correlation * base * spike + (1.0 - correlation)) * noise
    out = pd.Series(values, index=index, name=RESERVE_PRICE_COLUMN)
    out.attrs = {
        "synthetic": True,
        "seed": seed,
        "scale_sgd_per_mwh": scale_sgd_per_mwh,
        "correlation": correlation,
    }
    return out
