"""The files of a run directory: results (Parquet with the run's metadata), summary,
configuration and checkpoint; their names, writers and readers, and the run key that decides
whether a stored result or checkpoint belongs to a configuration.

The results file itself (its columns, the Parquet writer and reader) is
:mod:`hvacflex.results`; this module adds what a run stores with it: the configuration, the
run key and the code version (:func:`run_metadata`)."""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex import results, state, version
from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.config import (
    LINEARISATION_MARGIN_K,
    ActivationConfig,
    DataConfig,
    ScenarioConfig,
    config_from_dict,
    differing_settings,
)
from hvacflex.errors import ConfigError, HvacflexError, StoredStateError
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
    files = [resolve_building(config.building), *input_files(config.data, config.activation)]
    calibrate = config.uncertainty.calibrate
    if calibrate is not None and calibrate.prediction_errors is not None:
        files.append(Path(calibrate.prediction_errors))  # the training run sizes the box
    update_with_files(digest, files)
    return digest.hexdigest()[:16]


def input_files(data: DataConfig, activation: ActivationConfig) -> list[Path]:
    """The files named by a ``[data]`` and an ``[activation]`` table (a folder: its files),
    whose contents enter a run's key; the shipped default data stays out of it."""
    files: list[Path] = []
    for name in ("weather_file", "usep_source", "reserve_source"):
        value = getattr(data, name)
        if value is not None:
            path = Path(value)
            files += sorted(path.glob("*")) if path.is_dir() else [path]
    if activation.mode == "file" and activation.file is not None:
        files.append(Path(activation.file))
    return files


def update_with_files(digest: Any, files: Iterable[Path]) -> None:
    """Feed each file's name and bytes (a missing file: its name only) to a hashlib digest."""
    for path in files:
        digest.update(str(path.name).encode())
        if path.is_file():
            digest.update(path.read_bytes())


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


def summary_text(summary: Mapping[str, Any]) -> str:
    """A summary as strictly valid JSON (RFC 8259, no ``NaN`` or ``Infinity``): a value that
    is not a finite number (a KPI without a feeder limit, a ratio of nothing) is ``null``.

    Raises
    ------
    ValueError
        When a value is neither a number, a string, a bool nor None (a bug of the caller).
    """
    plain = {
        key: None if isinstance(value, float) and not math.isfinite(value) else value
        for key, value in summary.items()
    }
    return json.dumps(plain, indent=2, allow_nan=False)


def write_summary(path: Path, summary: Mapping[str, Any]) -> Path:
    """Write ``summary.json`` atomically (:func:`summary_text`)."""
    return version.atomic_write_text(path, summary_text(summary))


def read_summary(path: Path) -> dict[str, float]:
    """A run's ``summary.json`` (``null`` read as NaN: :func:`summary_text` wrote a
    non-finite value).

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
    return {key: math.nan if value is None else value for key, value in summary.items()}


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


RUN_FILES = (RESULTS_FILE, SUMMARY_FILE, CONFIG_FILE, CHECKPOINT_FILE)
"""Every file a run writes into its folder."""

_SHOWN_SETTINGS = 4
"""Differing settings named in the message of :func:`check_out_dir` (then "and N more")."""


def stored_config(out_dir: Path) -> ScenarioConfig | None:
    """The configuration of the run stored in ``out_dir``: its ``config.json`` (written before
    the first step, so a folder with only a checkpoint has one too), else the configuration in
    its results file's metadata; None when the folder holds no run.

    Raises
    ------
    StoredStateError
        When the stored configuration is unreadable or not one this hvacflex accepts.
    """
    config_path, results_path = out_dir / CONFIG_FILE, out_dir / RESULTS_FILE
    source = config_path
    try:
        if config_path.is_file():
            document = json.loads(config_path.read_text(encoding="utf-8"))
        elif results_path.is_file():
            source, document = results_path, read_results(results_path)[1]["config"]
        else:
            return None
        if not isinstance(document, dict):
            raise TypeError("not a JSON object")
        return config_from_dict(document, source=source)
    except (OSError, UnicodeDecodeError, ValueError, TypeError, HvacflexError) as exc:
        raise StoredStateError(
            f"the folder holds a run whose configuration cannot be read ({exc})",
            source=source,
            hint="use another --out folder, or run again with --fresh to replace that run",
        ) from None


def check_out_dir(out_dir: str | Path, config: ScenarioConfig, fresh: bool) -> None:
    """Refuse to write ``config``'s run over a folder holding another configuration's run.

    The same configuration (every setting but ``name``) resumes from its checkpoint or re-uses
    its results as before; with ``fresh`` another configuration's files (results, summary,
    config, checkpoint) are removed, so the folder never mixes two runs. Call it before any
    work.

    Raises
    ------
    StoredStateError
        Naming the folder, the settings that differ (theirs and ours) and the fixes.
    """
    out = Path(out_dir)
    if not out.is_dir():
        return
    try:
        stored = stored_config(out)
    except StoredStateError:
        if not fresh:
            raise
        stored = None
    if stored is None:
        if fresh:
            _remove_run_files(out)
        return
    differ = differing_settings(stored, config)
    if not differ:
        return
    if fresh:
        _remove_run_files(out)
        return
    shown = ", ".join(
        f"{name} {_setting(stored, name)!r} there, {_setting(config, name)!r} here"
        for name in differ[:_SHOWN_SETTINGS]
    )
    more = f" and {len(differ) - _SHOWN_SETTINGS} more" if len(differ) > _SHOWN_SETTINGS else ""
    raise StoredStateError(
        f"the folder holds the run of another configuration ('{stored.name}': {shown}{more})",
        source=out,
        hint="give another --out folder, or run again with --fresh to replace that run",
    )


def _setting(config: ScenarioConfig, dotted: str) -> object:
    value: object = config
    for part in dotted.split("."):
        value = getattr(value, part)
    return value


def _remove_run_files(out: Path) -> None:
    for name in RUN_FILES:
        (out / name).unlink(missing_ok=True)


def check_linearisation(
    config: ScenarioConfig, source: str | Path | None = None, building: Building | None = None
) -> None:
    """Refuse, before any work, a scenario whose linearisation temperature T₀ is at or below
    the building's supply-air temperature, naming the setting the user wrote: T₀ itself
    (``controller.linearisation_temp_degc``) or, when it is derived from the comfort band
    (T₀ = occupied upper bound − ``LINEARISATION_MARGIN_K``), ``comfort.occupied_degc``.

    Raises
    ------
    ConfigError
        Naming ``source`` (the scenario file), the field, the value and a hint.
    """
    if building is None:  # else a description received as content
        building = load_building(resolve_building(config.building))
    supply_degc = building.hvac.supply_temp_degc
    written = config.controller.linearisation_temp_degc
    upper_degc = config.comfort.occupied_degc[1]
    temp_ref_degc = upper_degc - LINEARISATION_MARGIN_K if written is None else written
    if temp_ref_degc > supply_degc:
        return
    if written is not None:
        raise ConfigError(
            f"must be above the supply-air temperature {supply_degc:g} °C of building "
            f"'{building.name}'",
            source=source,
            field="controller.linearisation_temp_degc",
            value=written,
            hint=f"set it between {supply_degc:g} and the occupied upper comfort bound",
        )
    raise ConfigError(
        f"the occupied upper comfort bound less {LINEARISATION_MARGIN_K:g} K (the "
        f"linearisation temperature) must be above the supply-air temperature "
        f"{supply_degc:g} °C of building '{building.name}'",
        source=source,
        field="comfort.occupied_degc",
        value=list(config.comfort.occupied_degc),
        hint=f"raise the upper bound above {supply_degc + LINEARISATION_MARGIN_K:g} °C, "
        "or set controller.linearisation_temp_degc",
    )
