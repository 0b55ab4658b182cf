"""The results file of a closed-loop run (``results.parquet``) and its reader."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from hvacflex.errors import DataError

RESULTS_FILENAME = "results.parquet"
"""Name of the results file in a run directory."""


RESULTS_REQUIRED_COLUMNS = ("power_kw", "energy_price_sgd_per_mwh")
"""Columns every results file has; a Parquet file without them is not a results file."""


def load_results(path: str | Path) -> pd.DataFrame:
    """Read a run's results: a Parquet file, or a run directory holding ``results.parquet``.

    A ``time`` column (if the index was not stored) becomes the index.

    Raises
    ------
    DataError
        When the path does not exist, the directory holds no results file, or the file is
        not a Parquet file with the results columns (:data:`RESULTS_REQUIRED_COLUMNS`).
    """
    hint = f"pass a run directory holding {RESULTS_FILENAME} (written by hvacflex simulate) or "
    hint += "such a Parquet file"
    given = Path(path)
    if not given.exists():
        raise DataError(
            "results file not found: no such file or directory", source=given, hint=hint
        )
    file = given / RESULTS_FILENAME if given.is_dir() else given
    if not file.is_file():
        raise DataError(
            f"results file not found: the directory holds no {RESULTS_FILENAME}",
            source=given,
            hint=hint,
        )
    try:
        results = pd.read_parquet(file)
    except (OSError, ValueError, TypeError, RuntimeError) as exc:  # pyarrow: ArrowInvalid, …
        raise DataError(
            f"not a results file: cannot be read as Parquet ({type(exc).__name__})",
            source=file,
            hint=hint,
        ) from None
    missing = [c for c in RESULTS_REQUIRED_COLUMNS if c not in results.columns]
    if missing:
        raise DataError(
            "not a results file: required columns are missing",
            source=file,
            field=", ".join(missing),
            hint=hint + "; see the Results table of docs/architecture.md",
        )
    if not isinstance(results.index, pd.DatetimeIndex) and "time" in results.columns:
        results = results.set_index("time")
    return results
