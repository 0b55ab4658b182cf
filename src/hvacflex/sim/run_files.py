"""The files of a run directory: results (Parquet with the run's metadata), summary,
configuration and checkpoint; their names, writers and readers, and the run key that decides
whether a stored result or checkpoint belongs to a configuration.

The results file itself (its columns, the Parquet writer and reader) is
:mod:`hvacflex.results`; this module adds what a run stores with it: the configuration, the
run key and the code version (:func:`run_metadata`)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex import results, state, version
from hvacflex.config import ScenarioConfig
from hvacflex.errors import StoredStateError
from hvacflex.paths import resolve_building
from hvacflex.results import RESULTS_FILENAME

RESULTS_FILE = RESULTS_FILENAME
CHECKPOINT_FILE = "checkpoint.npz"
OLD_CHECKPOINT_FILE = "checkpoint.pkl"
"""The pickle checkpoint of hvacflex before the data-only format (refused, never read)."""
SUMMARY_FILE = "summary.json"
CONFIG_FILE = "config.json"


def run_key(config: ScenarioConfig) -> str:
    """Identity of a run's inputs: the configuration and the bytes of its input files.

    The configuration names the building and data files; editing one of them (a building
    TOML, a price CSV) must not let a cached result or a checkpoint be re-used, so their
    contents enter the key. The shipped default data is fixed and stays out of it.
    """
    digest = hashlib.sha256(config.config_hash().encode())
    files = [resolve_building(config.building)]
    for name in ("weather_file", "usep_source", "reserve_source"):
        value = getattr(config.data, name)
        if value is not None:
            path = Path(value)
            files += sorted(path.glob("*")) if path.is_dir() else [path]
    if config.activation.mode == "file" and config.activation.file is not None:
        files.append(Path(config.activation.file))
    calibrate = config.uncertainty.calibrate
    if calibrate is not None and calibrate.prediction_errors is not None:
        files.append(Path(calibrate.prediction_errors))  # the training run sizes the box
    for path in files:
        digest.update(str(path.name).encode())
        if path.is_file():
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def run_metadata(config: ScenarioConfig) -> dict[str, str]:
    """What a run's results file stores in its metadata: the configuration (JSON), its hash,
    the run key and the code version (keys of :mod:`hvacflex.results`)."""
    return {
        results.META_CONFIG: json.dumps(config.to_dict()),
        results.META_CONFIG_HASH: config.config_hash(),
        results.META_RUN_KEY: run_key(config),
        results.META_VERSION: version.code_version(),
    }


def write_results(frame: pd.DataFrame, path: Path, config: ScenarioConfig) -> None:
    """A run's results file: :func:`hvacflex.results.write_results` with
    :func:`run_metadata`."""
    results.write_results(frame, path, run_metadata(config))


_FRESH_HINT = "delete the file or run again with --fresh (hvacflex simulate --fresh)"


def read_results(path: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    """A run's results file and the metadata stored with it: ``config`` (decoded; ``{}``
    when absent), ``config_hash``, ``run_key``, ``version`` (``""`` when absent).

    Raises
    ------
    StoredStateError
        When the file is not a readable Parquet file (e.g. truncated) or its hvacflex
        metadata is damaged.
    """
    frame, meta = results.read_results(path)
    try:
        config = json.loads(meta.get(results.META_CONFIG, "{}"))
    except json.JSONDecodeError as exc:
        raise StoredStateError(
            f"not a readable results file (truncated or damaged: {type(exc).__name__})",
            source=path,
            field=results.METADATA_PREFIX + results.META_CONFIG,
            hint=_FRESH_HINT,
        ) from None
    keys = (results.META_CONFIG_HASH, results.META_RUN_KEY, results.META_VERSION)
    return frame, {results.META_CONFIG: config} | {key: meta.get(key, "") for key in keys}


def read_summary(path: Path) -> dict[str, float]:
    """A run's ``summary.json``.

    Raises
    ------
    StoredStateError
        When the file is not a JSON object (e.g. truncated).
    """
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise StoredStateError(
            f"not a readable summary file (truncated or damaged: {type(exc).__name__})",
            source=path,
            hint=_FRESH_HINT,
        ) from None
    if not isinstance(summary, dict):
        raise StoredStateError(
            "not a summary file (expected a JSON object)", source=path, hint=_FRESH_HINT
        )
    return summary


def load_checkpoint(path: Path) -> dict[str, Any]:
    """The state stored by :meth:`ClosedLoop.save_checkpoint` (:mod:`hvacflex.state`).

    Raises
    ------
    StoredStateError
        When the file is not a checkpoint (truncated, damaged, another format version, or
        the pickle of an older hvacflex, which is never unpickled).
    """
    try:
        stored = state.load(path)
    except (OSError, state.DamagedStateError) as exc:
        raise StoredStateError(
            f"not a readable checkpoint (truncated or damaged: {type(exc).__name__})",
            source=path,
            hint=_FRESH_HINT,
        ) from None
    if not isinstance(stored, dict) or "config_hash" not in stored or "k" not in stored:
        raise StoredStateError("not a checkpoint of hvacflex", source=path, hint=_FRESH_HINT)
    return stored


def refuse_old_checkpoint(out_dir: Path) -> None:
    """Refuse a run folder holding the pickle checkpoint of an older hvacflex.

    Raises
    ------
    StoredStateError
        Naming the file and how to start afresh.
    """
    old = out_dir / OLD_CHECKPOINT_FILE
    if old.is_file():
        raise StoredStateError(
            "a checkpoint of an older hvacflex (pickle format), which is no longer read "
            "(loading a pickle can run any code it holds)",
            source=old,
            hint="run again with --fresh to start this run afresh (or delete the file)",
        )


def check_checkpoint_code(state: dict[str, Any], path: Path) -> None:
    """Refuse a checkpoint written by other code (its controller or plant may differ).

    Raises
    ------
    StoredStateError
        Naming the checkpoint's code version and this one, with the ``--fresh`` hint.
    """
    stored = str(state.get("code_version", "unknown (older hvacflex)"))
    current = version.code_version()
    if stored != current:
        raise StoredStateError(
            f"checkpoint was written by hvacflex {stored}, this is hvacflex {current}; "
            "resuming would mix two versions of the code in one run",
            source=path,
            field="code_version",
            hint="run again with --fresh to start this run afresh (or delete the checkpoint)",
        )
