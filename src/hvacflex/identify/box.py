"""The identified model's calibrated uncertainty box and the scenario file beside the model.

The model error the robust MPC plans for is sized exactly as the forecast-error box is
(:func:`hvacflex.data.calibration.calibrate_box`, its keys and its quantile rule): per zone
``ε_z = Q_q(|e_z|)`` [K per step] of the one-step prediction errors ``e`` on the **test** days
(the filter's one-step predictions, predicted − measured), ``Q_q`` the empirical quantile
taking the next-higher sample. The coverage (:func:`hvacflex.data.calibration.
model_error_coverage`) is reported on the test days (≥ q by construction) and on the
training days (other days, from a model fitted on them).

Files written beside ``model.toml``:

* ``model_errors.parquet`` — the test days' errors as results columns
  ``prediction_error_<zone>_k`` (:data:`hvacflex.results.PREDICTION_ERROR`), which a scenario's
  ``[uncertainty] calibrate = {prediction_errors = …}`` reads;
* ``box_report.csv`` — per zone ``zone``, ``model_error_k``, ``coverage_test``,
  ``coverage_train``, ``quantile``;
* ``scenario.toml`` — ``preset = "rmpc"``, ``building`` the model, the calibrated box on the
  test days, and with an IDF the ``[plant]`` that controls the building the data came from
  (``kind = "energyplus"``, ``actuation = "setpoint"``). The estimation is the default: the
  measured zone air and boundary (plenum) temperatures, the mass nodes carried by the model
  from their estimated start (docs/guide/identify.md §6 measures it against the Kalman filter);
* ``baseline.toml`` — with an IDF, the building's own control on the same plant
  (``preset = "plant-baseline"``), what ``scenario.toml``'s runs are compared with.

Both scenarios name their files relative to their folder (a shipped IDF by its name), so the
folder can be moved or shared whole.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.data.calibration import calibrate_box, model_error_coverage
from hvacflex.identify.greybox import FloatArray
from hvacflex.paths import shipped_idf_name
from hvacflex.results import INDEX_NAME, PREDICTION_ERROR, write_results

DEFAULT_QUANTILE = 0.95
"""The quantile q of the calibrated model error (the forecast box's default)."""
ERRORS_FILE = "model_errors.parquet"
BOX_REPORT_FILE = "box_report.csv"
SCENARIO_FILE = "scenario.toml"
BASELINE_FILE = "baseline.toml"


@dataclass(frozen=True)
class ModelErrorBox:
    """The calibrated model-error term.

    Attributes
    ----------
    zones : (m,) the model's zone names; model_error_k : (m,) ε per zone [K per step];
    coverage_test, coverage_train : (m,) the share of one-step errors inside ±ε;
    quantile : q.
    """

    zones: tuple[str, ...]
    model_error_k: FloatArray
    coverage_test: FloatArray
    coverage_train: FloatArray
    quantile: float

    def frame(self) -> pd.DataFrame:
        """The ``box_report.csv`` table."""
        return pd.DataFrame(
            {
                "zone": list(self.zones),
                "model_error_k": self.model_error_k,
                "coverage_test": self.coverage_test,
                "coverage_train": self.coverage_train,
                "quantile": self.quantile,
            }
        )


def calibrate_model_error(
    zones: tuple[str, ...],
    test_errors_k: FloatArray,
    train_errors_k: FloatArray,
    quantile: float = DEFAULT_QUANTILE,
) -> ModelErrorBox:
    """Size ε from the test days' one-step errors (module docstring).

    Parameters
    ----------
    zones : (m,); test_errors_k : (T_test, m) and train_errors_k : (T_train, m) one-step
    prediction errors [K].
    """
    test = {z: test_errors_k[:, i] for i, z in enumerate(zones)}
    calibration = calibrate_box(
        np.zeros((0, 0)), np.zeros((0, 0)), (), quantile, prediction_error_k=test
    )
    epsilon = dict(calibration.model_error_k)
    train = {z: train_errors_k[:, i] for i, z in enumerate(zones)}
    inside_test = model_error_coverage(test, epsilon)
    inside_train = model_error_coverage(train, epsilon)
    return ModelErrorBox(
        zones=zones,
        model_error_k=np.array([epsilon[z] for z in zones]),
        coverage_test=np.array([inside_test[z] for z in zones]),
        coverage_train=np.array([inside_train[z] for z in zones]),
        quantile=quantile,
    )


def write_model_errors(
    zones: tuple[str, ...], index: pd.DatetimeIndex, errors_k: FloatArray, path: Path
) -> Path:
    """The (T, m) one-step errors [K] on ``index`` as a results-format Parquet file."""
    frame = pd.DataFrame(
        {PREDICTION_ERROR.name(z): errors_k[:, i] for i, z in enumerate(zones)},
        index=pd.DatetimeIndex(index, name=INDEX_NAME),
    )
    write_results(frame, path, {"kind": "identified model errors"})
    return path


def relative_to(target: Path, folder: Path) -> str:
    """``target`` as a POSIX path relative to ``folder`` (how a scenario file in ``folder``
    names it, so the folder can be moved or shared as a whole)."""
    return Path(os.path.relpath(Path(target).resolve(), Path(folder).resolve())).as_posix()


def _plant_and_data_lines(folder: Path, idf: Path | None, weather: Path | None) -> list[str]:
    """The ``[data]`` and ``[plant]`` tables of the scenarios beside the model: the weather
    file and the IDF relative to ``folder``, a shipped IDF by its name."""
    lines: list[str] = []
    if weather is not None:
        lines += ["", "[data]", f"weather_file = {json.dumps(relative_to(weather, folder))}"]
    if idf is not None:
        shipped = shipped_idf_name(idf)
        lines += [
            "",
            "[plant]",
            'kind = "energyplus"',
            f"idf = {json.dumps(shipped or relative_to(idf, folder))}",
            'actuation = "setpoint"',
        ]
    return lines


def write_scenario(
    path: Path,
    model_path: Path,
    errors_path: Path,
    test_days: str,
    quantile: float,
    idf: Path | None = None,
    weather: Path | None = None,
) -> Path:
    """``scenario.toml`` (module docstring); paths written relative to its folder (a shipped
    IDF by its name); ``weather``: the EPW the fit took its site from (``[data]
    weather_file``; None: the scenario's default)."""
    folder = path.parent
    lines = [
        'preset = "rmpc"',
        f"name = {json.dumps(model_path.parent.name or 'identified')}",
        f"building = {json.dumps(relative_to(model_path, folder))}",
        "",
        "[uncertainty.calibrate]",
        f"train = {json.dumps(test_days)}",
        f"quantile = {quantile!r}",
        f"prediction_errors = {json.dumps(relative_to(errors_path, folder))}",
    ]
    lines += _plant_and_data_lines(folder, idf, weather)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def write_baseline_scenario(
    path: Path, model_path: Path, idf: Path, weather: Path | None = None
) -> Path:
    """``baseline.toml``: the building's own control on the same plant (``preset =
    "plant-baseline"``: EnergyPlus runs the IDF's schedules and thermostats, hvacflex sends
    nothing), with the same ``building``, ``[data]`` and ``[plant]`` as ``scenario.toml``, so
    ``hvacflex kpi`` compares the two runs."""
    folder = path.parent
    lines = [
        'preset = "plant-baseline"',
        'name = "plant-baseline"',
        f"building = {json.dumps(relative_to(model_path, folder))}",
    ]
    lines += _plant_and_data_lines(folder, idf, weather)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
