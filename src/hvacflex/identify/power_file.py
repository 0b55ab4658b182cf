"""``hvacflex identify power``: a power model fitted to a plant's meter, for a designed
building (docs/guide/identify.md §3, docs/explanation/model.md §1).

A designed building (office5) plans with its design curves unless its file carries a power
model fitted to the meter of the plant it runs on, ``[power_models.rc]`` or
``[power_models.energyplus]`` (:meth:`hvacflex.building.model.Building.with_power_model_for`
picks the one for the scenario's ``[plant] kind``). This command fits one
(:mod:`hvacflex.identify.power`) from either

* a trend CSV (``hvacflex identify collect`` on the building's exported IDF: EnergyPlus), or
* a run's folder or ``results.parquet`` (``hvacflex simulate`` on the RC plant), read with the
  building's zones and supply temperature,

and writes the table (``--out``, TOML, pasted into the building file or read with
:func:`read_power_table`) and ``power_report.csv`` beside it: the model against the meter
on the test days, occupied and unoccupied hours apart.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from hvacflex.building.identified import IdentifiedPower
from hvacflex.building.model import Building
from hvacflex.errors import InputError
from hvacflex.identify.power import (
    PowerInputs,
    evaluate_power,
    fit_power_model,
    power_inputs,
    power_inputs_from_results,
    power_model_table,
)
from hvacflex.identify.trend import read_trend
from hvacflex.identify.workflow import train_test_ranges
from hvacflex.paths import check_output_file
from hvacflex.version import atomic_write_text

PLANT_KINDS = ("rc", "energyplus")
"""The plants a building file's ``[power_models.<kind>]`` may name."""
POWER_REPORT = "power_report.csv"


@dataclass(frozen=True)
class PowerOutcome:
    """What ``identify power`` wrote: ``model_path`` (the table), ``report_path``
    (``power_report.csv``), the ``power`` model and its ``report``."""

    model_path: Path
    report_path: Path
    power: IdentifiedPower
    report: pd.DataFrame


def read_power_inputs(data_path: str | Path, building: Building | None) -> PowerInputs:
    """The inputs of a trend CSV, or of a run's results (a folder holding ``results.parquet``,
    or the file; ``building`` gives its zones and supply temperature).

    Raises
    ------
    InputError
        for a run's results without ``building``, or a trend without a meter.
    """
    path = Path(data_path)
    if path.is_dir():
        path = path / "results.parquet"
    if path.suffix != ".parquet":
        return power_inputs(read_trend(path))
    if building is None:
        raise InputError(
            "a run's results are read with the building that ran",
            source=str(path),
            field="--building",
            hint="give --building (the building file or shipped name of the run)",
        )
    if not path.is_file():
        raise InputError("no such results file", source=str(path), field="--data")
    results = pd.read_parquet(path)
    return power_inputs_from_results(results, building.zone_names, building.hvac.supply_temp_degc)


def identify_power(
    data_path: str | Path,
    plant: str,
    out: str | Path,
    *,
    building: Building | None = None,
    train: str | None = None,
    test: str | None = None,
) -> PowerOutcome:
    """Fit the power model of ``plant``'s meter to ``data_path`` (module docstring) on the
    ``train`` days, grade it on the ``test`` days (``YYYY-MM-DD..YYYY-MM-DD``, both or
    neither: default the last days), write ``out`` and ``power_report.csv`` beside it. Bad
    input (an unknown plant, no meter, too few running periods, an unwritable ``out``) is
    refused before anything is written."""
    if plant not in PLANT_KINDS:
        raise InputError("unknown plant", field="--plant", value=plant, hint="use rc or energyplus")
    out = Path(out)
    inputs = read_power_inputs(data_path, building)
    train_range, test_range = train_test_ranges(inputs.index, train, test)
    check_output_file(out, "--out")
    power = fit_power_model(inputs, train_range, source=str(data_path))
    report = evaluate_power(power, inputs, test_range)
    days = (
        f"{inputs.index[train_range[0]].date()}..{inputs.index[train_range[1] - 1].date()}",
        f"{inputs.index[test_range[0]].date()}..{inputs.index[test_range[1] - 1].date()}",
    )
    lines = [
        f"# fitted to the {plant} plant's meter by hvacflex identify power",
        f"# data: {Path(data_path).name}; train {days[0]}; test {days[1]} ({POWER_REPORT})",
        f"[power_models.{plant}]",
    ] + [f"{key} = {value!r}" for key, value in power_model_table(power).items()]
    atomic_write_text(out, "\n".join(lines) + "\n")
    report_path = out.parent / POWER_REPORT
    report.to_csv(report_path, index=False, float_format="%.4g")
    return PowerOutcome(out, report_path, power, report)


def read_power_table(path: str | Path, plant: str) -> IdentifiedPower:
    """The ``[power_models.<plant>]`` table of a file ``identify power`` wrote."""
    document = tomllib.loads(Path(path).read_text())
    return IdentifiedPower(**document["power_models"][plant])
