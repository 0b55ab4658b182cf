"""``hvacflex identify fit`` end to end: trend file in; ``model.toml``, ``fit_report.csv``,
``fit_parameters.csv`` and (with a metered HVAC) ``power_report.csv`` out, side by side.

Which zones and which couplings: ``--template BUILDING`` takes the building file's zones
(their ``energyplus_zone``, else their name, is the data's zone) and couples the zones its
walls join; ``--zones Z1,Z2`` names the data's zones, and ``--adjacency "Z1-Z2,…"`` the
couplings (without it, with ``--idf`` the zones that share a surface in the IDF couple, each
coupling bounded by the shared area; without either every pair may couple and the fit
decides). The data's zones with a
temperature only (no supply air: a plenum, an attic) are boundaries of every fitted zone.
Days: ``--train A..B`` and ``--test C..D`` (``YYYY-MM-DD``, both ends included); by default the last
:data:`DEFAULT_TEST_DAYS` whole days are the test and the days before them the training.
"""

from __future__ import annotations

import datetime
import itertools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.building.identified import IdentifiedValidity
from hvacflex.building.io import load_building
from hvacflex.constants import PERIODS_PER_DAY
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
from hvacflex.identify.checks import (
    CHECKS_FILE,
    FitContext,
    parameter_rows,
    plausibility_checks,
    warning_lines,
)
from hvacflex.identify.fit import (
    WARMUP_DAYS,
    CouplingPhysics,
    FitData,
    FitResult,
    air_system,
    evaluate,
    fit_boundary_nodes,
    fit_inputs,
    fit_model,
    idle_air,
    mean_mass_temps_degc,
    one_step_errors,
    prediction_frame,
)
from hvacflex.identify.idf_geometry import (
    ZoneGeometry,
    idf_cooling_available,
    idf_fan_available,
    idf_floor_areas_m2,
    idf_zone_geometry,
)
from hvacflex.identify.model_file import IdentifiedModel, identifier, write_identified_model
from hvacflex.identify.physics import (
    ZonePhysics,
    building_zone_geometry,
    coupling_bounds,
    zone_physics,
)
from hvacflex.identify.power import evaluate_power, metered_power_model, power_inputs
from hvacflex.identify.trend import TrendData, read_trend, zone_column
from hvacflex.paths import check_output_file, resolve_idf

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
    checks : the plausibility checks (:mod:`hvacflex.identify.checks`), also ``checks_path``.
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
    checks: pd.DataFrame
    checks_path: Path
    baseline_path: Path | None = None

    @property
    def failed_checks(self) -> list[str]:
        """Each failed check as a line (``check zone parameter: detail``)."""
        return warning_lines(self.checks)


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


def day_range(text: str, option: str) -> tuple[datetime.date, datetime.date]:
    """``"YYYY-MM-DD..YYYY-MM-DD"`` → its first and last day (both included).

    Raises
    ------
    InputError : not two days joined by ``..``, naming ``option``.
    """
    parts = text.split("..")
    try:
        if len(parts) != 2:
            raise ValueError(text)
        first, last = (pd.Timestamp(p).date() for p in parts)
    except ValueError:
        raise InputError(
            "not a day range", field=option, value=text, hint="write YYYY-MM-DD..YYYY-MM-DD"
        ) from None
    return first, last


def check_train_test(train: str | None, test: str | None) -> None:
    """Refuse ``--train`` without ``--test`` (or the reverse) and day ranges that share a
    day: the test days must be days the fit never saw.

    Raises
    ------
    InputError : naming both ranges.
    """
    if (train is None) != (test is None):
        raise InputError("give both --train and --test, or neither", field="--train")
    if train is None or test is None:
        return
    train_first, train_last = day_range(train, "--train")
    test_first, test_last = day_range(test, "--test")
    if train_first <= test_last and test_first <= train_last:
        raise InputError(
            f"the test days overlap the training days (--train {train}, --test {test})",
            field="--test",
            value=test,
            hint="give --test days outside --train, e.g. the days after the training days",
        )


def parse_days(text: str, index: pd.DatetimeIndex, option: str) -> tuple[int, int]:
    """``"YYYY-MM-DD..YYYY-MM-DD"`` → (first, end) period positions (both days included)."""
    first, last = day_range(text, option)
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


def parse_floor_areas(text: str, zones: tuple[str, ...]) -> tuple[float, ...]:
    """``"Z1=120.5,Z2=40"`` → (m,) the floor area [m²] of each of ``zones`` (the data's
    names, any case), every zone named once.

    Raises
    ------
    InputError
        naming the item that is not ``ZONE=M2`` with a positive number, a zone not fitted or
        one left out.
    """
    lookup = {z.lower(): z for z in zones}
    areas: dict[str, float] = {}
    for item in (i.strip() for i in text.split(",") if i.strip()):
        name, _, number = item.rpartition("=")
        try:
            area = float(number)
        except ValueError:
            area = float("nan")
        if name.strip().lower() not in lookup or not area > 0 or not np.isfinite(area):
            raise InputError(
                "not a fitted zone's floor area",
                field="--floor-area",
                value=item,
                hint=f"write ZONE=M2 (a positive number of m²) for each of {list(zones)}",
            )
        areas[name.strip().lower()] = area
    missing = [z for z in zones if z.lower() not in areas]
    if missing:
        raise InputError(
            "a fitted zone has no floor area",
            field="--floor-area",
            value=missing[0],
            hint=f"give every fitted zone's area: {','.join(f'{z}=M2' for z in zones)}",
        )
    return tuple(areas[z.lower()] for z in zones)


def zone_floor_areas_m2(
    zones: tuple[str, ...],
    floor_areas: str | None,
    idf: str | Path | None,
    template: str | Path | None,
) -> tuple[float, ...] | None:
    """(m,) the fitted zones' floor areas [m²]: ``--floor-area`` where given, else the IDF's
    zones' floors, else the template building's zones', else None (unknown: the model file
    gives none and per-m² figures are not available)."""
    if floor_areas is not None:
        return parse_floor_areas(floor_areas, zones)
    if idf is not None:
        return idf_floor_areas_m2(idf, zones)
    if template is not None:
        building = load_building(template)
        by_data_name = {(z.energyplus_zone or z.name).lower(): z for z in building.zones}
        return tuple(by_data_name[z.lower()].floor_area_m2 for z in zones)
    return None


def _pairs(zones: tuple[str, ...], couples: list[tuple[str, str]] | None) -> list[tuple[int, int]]:
    if couples is None:
        return list(itertools.combinations(range(len(zones)), 2))
    lower = [z.lower() for z in zones]
    found = {tuple(sorted((lower.index(a.lower()), lower.index(b.lower())))) for a, b in couples}
    return [(int(i), int(j)) for i, j in sorted(found) if i != j]


def _parameters_table(fit: FitResult, context: FitContext) -> pd.DataFrame:
    """``fit_parameters.csv``: ``zone``, ``parameter``, ``value``, ``std_error``, ``at_bound``
    (``true``/``false``: a free parameter the optimiser left on a bound) and ``prior`` (the
    prior's centre; a parameter fixed by physics has bounds, prior and value equal and
    standard error 0)."""
    assert fit.at_bound is not None and fit.prior is not None
    rows = [
        {
            "zone": label,
            "parameter": name,
            "value": value,
            "std_error": error[3],
            "at_bound": "true" if flag[3] > 0 else "false",
            "prior": prior[3],
        }
        for (label, name, _, value), error, flag, prior in zip(
            parameter_rows(fit.parameters, context),
            parameter_rows(fit.standard_errors, context),
            parameter_rows(fit.at_bound, context),
            parameter_rows(fit.prior, context),
            strict=True,
        )
    ]
    return pd.DataFrame(rows)


def described_geometry(
    idf: str | Path | None, template: str | Path | None
) -> dict[str, ZoneGeometry] | None:
    """The zones' geometry by lower-case data name: the IDF's where given
    (:func:`~hvacflex.identify.idf_geometry.idf_zone_geometry`), else the template building's
    (:func:`~hvacflex.identify.physics.building_zone_geometry`: the user's description), else
    None (façades and shared surfaces unknown)."""
    if idf is not None:
        return idf_zone_geometry(idf)
    if template is not None:
        return building_zone_geometry(load_building(template))
    return None


def geometry_couplings(
    zones: tuple[str, ...],
    boundaries: tuple[str, ...],
    geometry: dict[str, ZoneGeometry],
    couples: list[tuple[str, str]] | None,
) -> tuple[list[tuple[int, int]], CouplingPhysics]:
    """The couplings and their physics from the zones' geometry (an IDF's or a template's):
    without ``--adjacency`` (``couples`` None) the fitted zones that share a surface couple;
    each coupling, and each zone's to a boundary, bounded by its shared area
    (:func:`~hvacflex.identify.physics.coupling_bounds`; generic where they share none)."""
    shared = {
        zone.lower(): dict(geometry[zone.lower()].shared_m2) if zone.lower() in geometry else {}
        for zone in zones
    }
    if couples is None:
        pairs = [
            (i, j)
            for i, j in itertools.combinations(range(len(zones)), 2)
            if shared[zones[i].lower()].get(zones[j].lower(), 0.0) > 0.0
        ]
    else:
        pairs = _pairs(zones, couples)
    edges = [(i, b) for i in range(len(zones)) for b in range(len(boundaries))]
    ends = [(zones[i], zones[j]) for i, j in pairs] + [(zones[i], boundaries[b]) for i, b in edges]
    physics = tuple(
        coupling_bounds(area) if (area := shared[a.lower()].get(b.lower(), 0.0)) > 0 else None
        for a, b in ends
    )
    return pairs, physics


def zone_physics_of(
    zones: tuple[str, ...],
    areas_m2: tuple[float, ...] | None,
    geometry: dict[str, ZoneGeometry] | None,
) -> tuple[ZonePhysics, ...]:
    """(m,) what is known of each fitted zone (the data's names): its floor area and its
    façades from ``geometry`` (:func:`described_geometry`;
    :func:`~hvacflex.identify.physics.zone_physics`)."""
    return tuple(
        zone_physics(
            None if geometry is None else geometry.get(zone.lower()),
            None if areas_m2 is None else areas_m2[i],
        )
        for i, zone in enumerate(zones)
    )


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
    floor_areas: str | None = None,
    progress: Callable[[str], None] | None = None,
    heartbeat: Callable[[str], None] | None = None,
) -> IdentifyOutcome:
    """Fit, evaluate, check and write (module docstring); ``idf``: the EnergyPlus model the
    data came from (a path or a shipped model's name), the plant of the scenarios written
    beside the model and where the zones' floor areas and façades come from; ``weather``: an
    EPW of the site (where the wall irradiances are computed; default the shipped Singapore
    file's); ``floor_areas``: ``"Z1=M2,…"``, the fitted zones' floor areas
    (:func:`zone_floor_areas_m2`); ``progress``: called with each stage's name as it starts
    (:data:`FIT_STAGES`, in that order); ``heartbeat``: called during the long fit with the
    count of model evaluations so far (``"1,200 model evaluations"``)."""
    say = progress if progress is not None else (lambda _: None)
    out = Path(out)
    check_train_test(train, test)
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
    areas_m2 = zone_floor_areas_m2(inputs.zones, floor_areas, idf_file, template)
    geometry = described_geometry(idf_file, template)
    physics = zone_physics_of(inputs.zones, areas_m2, geometry)
    train_range, test_range = train_test_ranges(inputs.index, train, test)
    check_output_file(out, "--out")  # after the inputs are checked, before the fit
    pairs, coupling_physics = _pairs(inputs.zones, couples), None
    if geometry is not None:
        pairs, coupling_physics = geometry_couplings(
            inputs.zones, inputs.boundaries, geometry, couples
        )
    power = metered_power_model(data, inputs.zones, train_range)  # refused before the fit
    say(FIT_STAGES[1])
    fit = fit_model(
        inputs, pairs, train_range, physics, coupling_physics, on_evaluation=_counter(heartbeat)
    )
    say(FIT_STAGES[2])
    ids = tuple(identifier(z) for z in inputs.zones)
    say(FIT_STAGES[3])
    air = air_system(inputs, data, train_range, mean_mass_temps_degc(fit, inputs, test_range))
    coil_schedule = fan_schedule = None
    if idf_file is not None:
        coil_schedule = idf_cooling_available(idf_file, inputs.index[slice(*train_range)])
        fan_schedule = idf_fan_available(idf_file, inputs.index[slice(*train_range)])
    model = IdentifiedModel(
        name=f"identified from {Path(data_path).name}",
        zones=ids,
        energyplus_zones=inputs.zones,
        parameters=fit.parameters,
        boundaries=inputs.boundaries,
        boundary_nodes=fit_boundary_nodes(fit.parameters, inputs, train_range, test_range),
        air=air,
        power=power,
        floor_areas_m2=areas_m2,
        validity=validity_range(inputs, train_range),
        idle_air=idle_air(inputs, data, train_range, air, coil_schedule, fan_schedule),
        provenance={
            "data": str(data_path),
            "train": _days_text(inputs.index, train_range),
            "test": _days_text(inputs.index, test_range),
        },
    )
    context = FitContext(ids, physics, inputs.boundaries, model.boundary_nodes, model.validity)
    out.parent.mkdir(parents=True, exist_ok=True)
    return _write_fit(
        fit, model, context, (data, inputs), (train_range, test_range), out, idf_file, weather, say
    )


def _write_fit(
    fit: FitResult,
    model: IdentifiedModel,
    context: FitContext,
    sources: tuple[TrendData, FitData],
    ranges: tuple[tuple[int, int], tuple[int, int]],
    out: Path,
    idf: Path | None,
    weather: str | Path | None,
    say: Callable[[str], None],
) -> IdentifyOutcome:
    """Write the model file, ``fit_report.csv``, ``fit_parameters.csv``, ``checks.csv``, the
    power check and the test days' predictions beside ``out``, then calibrate the model
    error and write the scenarios (``scenario.toml``, ``baseline.toml`` with an IDF)."""
    data, inputs = sources
    test_range = ranges[1]
    checks = plausibility_checks(fit, context)
    report = _fit_report(fit, inputs, test_range, checks)
    model_path = write_identified_model(model, out)
    report.to_csv(out.parent / "fit_report.csv", index=False, float_format="%.4g")
    parameters_path = out.parent / "fit_parameters.csv"
    _parameters_table(fit, context).to_csv(parameters_path, index=False, float_format="%.5g")
    checks.to_csv(out.parent / CHECKS_FILE, index=False)
    power = model.power
    power_table = None
    if power is not None:
        power_table = evaluate_power(power, power_inputs(data, inputs.zones), test_range)
    power_path = None
    if power_table is not None:
        power_path = out.parent / "power_report.csv"
        power_table.to_csv(power_path, index=False, float_format="%.4g")
    predictions = prediction_frame(fit, inputs, test_range)
    predictions.to_csv(out.parent / "fit_predictions.csv", float_format="%.4f")
    say(FIT_STAGES[4])
    box, scenario_path = _box_and_scenario(
        fit, inputs, model.zones, ranges, out, idf=idf, weather=weather
    )
    return IdentifyOutcome(
        model_path,
        out.parent / "fit_report.csv",
        parameters_path,
        power_path,
        report,
        power_table,
        fit,
        predictions,
        box,
        scenario_path,
        checks=checks,
        checks_path=out.parent / CHECKS_FILE,
        baseline_path=_baseline(model_path, idf, weather),
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


def validity_range(inputs: FitData, train: tuple[int, int]) -> IdentifiedValidity:
    """The training periods' range (``[identified.validity]``): each zone's lowest and highest
    air temperature and the outdoor air's [°C]."""
    first, end = train
    zone_temp, outdoor = inputs.y[first:end], inputs.u[first:end, 0]
    return IdentifiedValidity(
        zone_temp_min_degc=tuple(float(v) for v in zone_temp.min(axis=0)),
        zone_temp_max_degc=tuple(float(v) for v in zone_temp.max(axis=0)),
        outdoor_temp_min_degc=float(outdoor.min()),
        outdoor_temp_max_degc=float(outdoor.max()),
    )


def train_test_ranges(
    index: pd.DatetimeIndex, train: str | None, test: str | None
) -> tuple[tuple[int, int], tuple[int, int]]:
    """The training and test periods of ``--train`` and ``--test`` (both or neither)."""
    if (train is None) != (test is None):
        raise InputError("give both --train and --test, or neither", field="--train")
    if train is None or test is None:
        return _default_ranges(index)
    return parse_days(train, index, "--train"), parse_days(test, index, "--test")


def _fit_report(
    fit: FitResult, inputs: FitData, test_range: tuple[int, int], checks: pd.DataFrame
) -> pd.DataFrame:
    """``fit_report.csv``: :func:`~hvacflex.identify.fit.evaluate`'s rows with the zones'
    identifiers, their data names, ``converged`` and each zone's ``warnings``: the fit's and
    the failed plausibility checks naming the zone (or one of its couplings) or the whole fit."""
    report = evaluate(fit, inputs, test_range)
    report.insert(1, "energyplus_zone", list(inputs.zones))
    ids = [identifier(z) for z in inputs.zones]
    report["zone"] = ids
    report["converged"] = fit.converged
    failed = checks[checks["status"] == "warning"]
    lines = warning_lines(failed)
    labels = list(failed["zone"])
    report["warnings"] = [
        "; ".join(
            [
                w
                for w in fit.warnings
                if w.startswith(f"{zone}:") or not any(w.startswith(f"{z}:") for z in inputs.zones)
            ]
            + [
                line
                for line, label in zip(lines, labels, strict=True)
                if label == ident or label.startswith(f"{ident}-") or not label
            ]
        )
        for zone, ident in zip(inputs.zones, ids, strict=True)
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
