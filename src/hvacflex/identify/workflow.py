"""``hvacflex identify fit`` end to end: trend file in; ``model.toml``, ``fit_report.csv``,
``fit_parameters.csv`` and (with a metered HVAC) ``power_report.csv`` out, side by side.

Which zones and which couplings: ``--template BUILDING`` takes the building file's zones
(their ``energyplus_zone``, else their name, is the data's zone) and couples the zones its
walls join; ``--zones Z1,Z2`` names the data's zones, and ``--adjacency "Z1-Z2,…"`` the
couplings (without it every pair may couple and the fit decides). The data's zones with a
temperature only (no supply air: a plenum, an attic) are boundaries of every fitted zone.
Days: ``--train A..B`` and ``--test C..D`` (``YYYY-MM-DD``, both ends included); by default the last
:data:`DEFAULT_TEST_DAYS` whole days are the test and the days before them the training.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.building.io import load_building
from hvacflex.data.forecast import default_weather_file
from hvacflex.data.weather import EpwLocation, read_epw
from hvacflex.errors import InputError
from hvacflex.identify.box import (
    BASELINE_FILE,
    BOX_REPORT_FILE,
    DEFAULT_QUANTILE,
    ERRORS_FILE,
    SCENARIO_FILE,
    ModelErrorBox,
    calibrate_model_error,
    write_baseline_scenario,
    write_model_errors,
    write_scenario,
)
from hvacflex.identify.fit import (
    PERIODS_PER_DAY,
    WARMUP_DAYS,
    FitData,
    FitResult,
    air_system,
    evaluate,
    evaluate_power,
    fit_boundary_nodes,
    fit_inputs,
    fit_model,
    fit_power_model,
    mean_mass_temps_degc,
    one_step_errors,
    prediction_frame,
)
from hvacflex.identify.greybox import ZONE_PARAMETERS
from hvacflex.identify.model_file import IdentifiedModel, identifier, write_identified_model
from hvacflex.identify.trend import read_trend, zone_column
from hvacflex.paths import resolve_idf

FIT_STAGES = (
    "reading the trend data",
    "fitting the zones on the training days",
    "evaluating on the test days",
    "fitting the power model",
    "calibrating the model error",
)
"""The stages :func:`identify` reports to its ``progress`` callback, in order."""

DEFAULT_TEST_DAYS = 7
"""Test days at the end of the data when ``--test`` is not given."""


@dataclass(frozen=True)
class IdentifyOutcome:
    """What ``identify fit`` wrote and measured.

    Attributes
    ----------
    model_path, report_path, parameters_path : the files; power_path : or None.
    report : the fit report (one row per zone); power : daily power check or None.
    fit : the fit; predictions : the test days' measured and predicted series
    (:func:`~hvacflex.identify.fit.prediction_frame`, also ``fit_predictions.csv``);
    box : the calibrated model error; scenario_path : the scenario beside the model;
    baseline_path : the building's own control on the same plant (with an IDF; else None).
    """

    model_path: Path
    report_path: Path
    parameters_path: Path
    power_path: Path | None
    report: pd.DataFrame
    power: pd.DataFrame | None
    fit: FitResult
    predictions: pd.DataFrame
    box: ModelErrorBox
    scenario_path: Path
    baseline_path: Path | None = None


def site_of(weather: str | Path | None) -> EpwLocation:
    """The site of the data (where the wall irradiances are computed): the location of the
    EPW ``weather``, default the shipped weather file's (Singapore)."""
    if weather is not None and not Path(weather).is_file():
        raise InputError(
            "no such weather file",
            field="--weather",
            value=str(weather),
            hint="give the site's EPW, or leave --weather out for the shipped Singapore one",
        )
    return read_epw(default_weather_file() if weather is None else weather)[1]


def parse_days(text: str, index: pd.DatetimeIndex, option: str) -> tuple[int, int]:
    """``"YYYY-MM-DD..YYYY-MM-DD"`` → (first, end) period positions (both days included)."""
    parts = text.split("..")
    try:
        if len(parts) != 2:
            raise ValueError(text)
        first, last = (pd.Timestamp(p).date() for p in parts)
    except ValueError:
        raise InputError(
            "not a day range", field=option, value=text, hint="write YYYY-MM-DD..YYYY-MM-DD"
        ) from None
    days = np.array([t.date() for t in index])
    inside = np.flatnonzero((days >= first) & (days <= last))
    if last < first or inside.size == 0:
        raise InputError(
            "the day range holds no data",
            field=option,
            value=text,
            hint=f"the data covers {days[0]} … {days[-1]}",
        )
    return int(inside[0]), int(inside[-1]) + 1


def _default_ranges(index: pd.DatetimeIndex) -> tuple[tuple[int, int], tuple[int, int]]:
    midnights = np.flatnonzero((index.hour == 0) & (index.minute == 0))
    whole = midnights[midnights + PERIODS_PER_DAY <= len(index)]
    if whole.size <= DEFAULT_TEST_DAYS:
        raise InputError(
            f"too few days: {whole.size} whole days, the default split tests on the last "
            f"{DEFAULT_TEST_DAYS}",
            field="--data",
            hint="give --train and --test, or more data",
        )
    split = int(whole[-DEFAULT_TEST_DAYS])
    return (0, split), (split, len(index))


def zones_and_couplings(
    zones: str | None, adjacency: str | None, template: str | Path | None
) -> tuple[tuple[str, ...], list[tuple[str, str]] | None]:
    """The data's zone names and the coupled pairs (None: every pair)."""
    if (zones is None) == (template is None):
        raise InputError(
            "give exactly one of --template and --zones",
            field="--zones",
            hint="--template BUILDING.toml or --zones Z1,Z2,…",
        )
    if template is not None:
        building = load_building(template)
        name_of = {z.name: z.energyplus_zone or z.name for z in building.zones}
        pairs = {
            tuple(sorted((name_of[w.zone], name_of[w.adjacent])))
            for w in building.walls
            if w.adjacent in name_of
        }
        return tuple(name_of.values()), [(a, b) for a, b in sorted(pairs)]
    assert zones is not None
    names = tuple(z.strip() for z in zones.split(",") if z.strip())
    if adjacency is None:
        return names, None
    couples = []
    for item in adjacency.split(","):
        ends = [e.strip() for e in item.split("-") if e.strip()] if item.count("-") == 1 else []
        lookup = {n.lower(): n for n in names}
        if len(ends) != 2 or any(e.lower() not in lookup for e in ends):
            raise InputError(
                "not a pair of the --zones",
                field="--adjacency",
                value=item,
                hint=f"write Z1-Z2 with zones of {list(names)} (names containing '-' need "
                "--template)",
            )
        couples.append((lookup[ends[0].lower()], lookup[ends[1].lower()]))
    return names, couples


def _pairs(zones: tuple[str, ...], couples: list[tuple[str, str]] | None) -> list[tuple[int, int]]:
    if couples is None:
        return list(itertools.combinations(range(len(zones)), 2))
    lower = [z.lower() for z in zones]
    found = {tuple(sorted((lower.index(a.lower()), lower.index(b.lower())))) for a, b in couples}
    return [(int(i), int(j)) for i, j in sorted(found) if i != j]


def _parameters_table(
    fit: FitResult, zones: tuple[str, ...], boundaries: tuple[str, ...]
) -> pd.DataFrame:
    rows = []
    for i, zone in enumerate(zones):
        for j, (name, _) in enumerate(ZONE_PARAMETERS):
            rows.append(
                {
                    "zone": zone,
                    "parameter": name,
                    "value": fit.parameters.zone[i, j],
                    "std_error": fit.standard_errors.zone[i, j],
                }
            )
    for (i, j), ua, se in zip(
        fit.parameters.couplings,
        fit.parameters.coupling_ua_kw_per_k,
        fit.standard_errors.coupling_ua_kw_per_k,
        strict=True,
    ):
        rows.append(
            {
                "zone": f"{zones[i]}-{zones[j]}",
                "parameter": "ua_kw_per_k",
                "value": ua,
                "std_error": se,
            }
        )
    for (i, b), ua, se in zip(
        fit.parameters.boundary_couplings,
        fit.parameters.boundary_ua_kw_per_k,
        fit.standard_errors.boundary_ua_kw_per_k,
        strict=True,
    ):
        rows.append(
            {
                "zone": f"{zones[i]}-{boundaries[b]}",
                "parameter": "ua_kw_per_k",
                "value": ua,
                "std_error": se,
            }
        )
    return pd.DataFrame(rows)


def identify(
    data_path: str | Path,
    out: str | Path,
    *,
    zones: str | None = None,
    adjacency: str | None = None,
    template: str | Path | None = None,
    train: str | None = None,
    test: str | None = None,
    idf: str | Path | None = None,
    weather: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
    heartbeat: Callable[[str], None] | None = None,
) -> IdentifyOutcome:
    """Fit, evaluate and write (module docstring); ``idf``: the EnergyPlus model the data
    came from (a path or a shipped model's name), the plant of the scenarios written beside
    the model; ``weather``: an EPW of the site (where the wall irradiances are computed;
    default the shipped Singapore file's); ``progress``: called with each stage's name as it
    starts (:data:`FIT_STAGES`, in that order); ``heartbeat``: called during the long fit
    with the count of model evaluations so far (``"1,200 model evaluations"``)."""
    say = progress if progress is not None else (lambda _: None)
    out = Path(out)
    idf_file = None if idf is None else resolve_idf(idf, "--idf")
    say(FIT_STAGES[0])
    data = read_trend(data_path)
    names, couples = zones_and_couplings(zones, adjacency, template)
    fitted = {n.lower() for n in names}
    boundaries = tuple(
        z
        for z in data.zones
        if z.lower() not in fitted and not data.has(zone_column("supply_flow", z))
    )
    inputs = fit_inputs(data, names, site_of(weather), boundaries)
    if (train is None) != (test is None):
        raise InputError("give both --train and --test, or neither", field="--train")
    if train is None or test is None:
        train_range, test_range = _default_ranges(inputs.index)
    else:
        train_range = parse_days(train, inputs.index, "--train")
        test_range = parse_days(test, inputs.index, "--test")
    say(FIT_STAGES[1])
    fit = fit_model(inputs, _pairs(inputs.zones, couples), train_range, _counter(heartbeat))
    say(FIT_STAGES[2])
    report = fit_report(fit, inputs, test_range)
    ids = tuple(report["zone"])
    say(FIT_STAGES[3])
    power = fit_power_model(data, inputs, train_range)
    model = IdentifiedModel(
        name=f"identified from {Path(data_path).name}",
        zones=ids,
        energyplus_zones=inputs.zones,
        parameters=fit.parameters,
        boundaries=inputs.boundaries,
        boundary_nodes=fit_boundary_nodes(fit.parameters, inputs, train_range, test_range),
        air=air_system(inputs, data, train_range, mean_mass_temps_degc(fit, inputs, test_range)),
        power=power,
        provenance={
            "data": str(data_path),
            "train": _days_text(inputs.index, train_range),
            "test": _days_text(inputs.index, test_range),
        },
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    model_path = write_identified_model(model, out)
    report_path = out.parent / "fit_report.csv"
    report.to_csv(report_path, index=False, float_format="%.4g")
    parameters_path = out.parent / "fit_parameters.csv"
    _parameters_table(fit, ids, inputs.boundaries).to_csv(
        parameters_path, index=False, float_format="%.5g"
    )
    power_table = None if power is None else evaluate_power(power, data, inputs, test_range)
    power_path = None
    if power_table is not None:
        power_path = out.parent / "power_report.csv"
        power_table.to_csv(power_path, index=False, float_format="%.4g")
    predictions = prediction_frame(fit, inputs, test_range)
    predictions.to_csv(out.parent / "fit_predictions.csv", float_format="%.4f")
    say(FIT_STAGES[4])
    box, scenario_path = _box_and_scenario(
        fit, inputs, ids, (train_range, test_range), out, idf=idf_file, weather=weather
    )
    baseline_path = _baseline(model_path, idf_file, weather)
    return IdentifyOutcome(
        model_path,
        report_path,
        parameters_path,
        power_path,
        report,
        power_table,
        fit,
        predictions,
        box,
        scenario_path,
        baseline_path,
    )


def _baseline(model_path: Path, idf: Path | None, weather: str | Path | None) -> Path | None:
    """``baseline.toml`` beside the model (:func:`~hvacflex.identify.box.
    write_baseline_scenario`) when the data came from an IDF, else None."""
    if idf is None:
        return None
    site = None if weather is None else Path(weather)
    return write_baseline_scenario(model_path.parent / BASELINE_FILE, model_path, idf, site)


def _counter(heartbeat: Callable[[str], None] | None) -> Callable[[], None] | None:
    """An ``on_evaluation`` callback that tells ``heartbeat`` the evaluations so far."""
    if heartbeat is None:
        return None
    count = 0

    def evaluated() -> None:
        nonlocal count
        count += 1
        heartbeat(f"{count:,} model evaluation{'' if count == 1 else 's'}")

    return evaluated


def fit_report(fit: FitResult, inputs: FitData, test: tuple[int, int]) -> pd.DataFrame:
    """The fit report (``fit_report.csv``): one row per zone, its test-day errors
    (:func:`~hvacflex.identify.fit.evaluate`), its model name and data name
    (``energyplus_zone``), whether the fit converged, and the fit's warnings about it."""
    report = evaluate(fit, inputs, test)
    report.insert(1, "energyplus_zone", list(inputs.zones))
    report["zone"] = [identifier(z) for z in inputs.zones]
    report["converged"] = fit.converged
    report["warnings"] = [
        "; ".join(
            w
            for w in fit.warnings
            if w.startswith(f"{zone}:") or not any(w.startswith(f"{z}:") for z in inputs.zones)
        )
        for zone in inputs.zones
    ]
    return report


def _days_text(index: pd.DatetimeIndex, periods: tuple[int, int]) -> str:
    """``"YYYY-MM-DD..YYYY-MM-DD"``: the first and last day of the periods ``(first, end)``
    (the form :func:`parse_days` reads)."""
    first, end = periods
    return f"{index[first].date().isoformat()}..{index[end - 1].date().isoformat()}"


def _box_and_scenario(
    fit: FitResult,
    inputs: FitData,
    ids: tuple[str, ...],
    ranges: tuple[tuple[int, int], tuple[int, int]],
    model_path: Path,
    *,
    idf: str | Path | None,
    weather: str | Path | None,
) -> tuple[ModelErrorBox, Path]:
    """The calibrated model error, its files and the scenario (:mod:`hvacflex.identify.box`);
    ``idf`` the scenario's plant and ``weather`` its EPW, each None if not given."""
    (train_first, train_end), test_range = ranges
    index, test_errors = one_step_errors(fit, inputs, test_range)
    warm = (train_first + WARMUP_DAYS * PERIODS_PER_DAY, train_end)
    _, train_errors = one_step_errors(fit, inputs, warm)
    box = calibrate_model_error(ids, test_errors, train_errors, DEFAULT_QUANTILE)
    folder = model_path.parent
    box.frame().to_csv(folder / BOX_REPORT_FILE, index=False, float_format="%.4g")
    errors_path = write_model_errors(ids, index, test_errors, folder / ERRORS_FILE)
    scenario = write_scenario(
        folder / SCENARIO_FILE,
        model_path,
        errors_path,
        _days_text(inputs.index, test_range),
        DEFAULT_QUANTILE,
        None if idf is None else Path(idf),
        None if weather is None else Path(weather),
    )
    return box, scenario
