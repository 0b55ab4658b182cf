"""``hvacflex report``: one self-contained HTML page for any closed-loop runs.

:func:`write_run_report` reads the runs (run folders or results Parquet files), draws three
figures — zone temperatures over the shaded comfort band, power with the reserve band and
the IL activations marked, and the prices — and tabulates the cost of every run under **one
tariff** (the same peak price φ for all; energy and reserve at the prices each run recorded)
and its KPIs, per run and per m² of floor, against a baseline run. The figures are PNG
embedded as base64 ``data:`` URIs by :func:`hvacflex.report.html.render_report`, so the page
requests nothing from elsewhere and runs no script.

Every number comes from :mod:`hvacflex.kpi`; energy and peak are the HVAC's (``power_kw``),
the whole facility's beside them where the plant meters it (EnergyPlus). The floor area is
that of the building named in the run's configuration (results metadata); per-m² rows read
"not available" when it is not known (a building file moved since the run, or a model file
without floor areas). A baseline run that is also among the runs is shown once.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex import kpi
from hvacflex import results as schema
from hvacflex.errors import HvacflexError, InputError
from hvacflex.report import plots
from hvacflex.report.html import Section, render_report
from hvacflex.report.tables import format_value
from hvacflex.units import W_PER_KW
from hvacflex.version import atomic_write_text

DPI = 110
"""Resolution of the embedded figures [dots per inch] (a page, not print)."""

COST_COLUMNS = (
    "energy_cost_sgd",
    "ppp_charge_sgd",
    "il_penalty_sgd",
    "reserve_revenue_settled_sgd",
    "total_cost_sgd",
    "reserve_revenue_unsettled_sgd",
    "total_with_unsettled_sgd",
)
"""Columns of :func:`cost_breakdown` [SGD]; total = HVAC energy + billed HVAC peak (prorated to
the days covered) + IL penalty − settled reserve; beside it the unsettled availability
payments and the total with them."""

COST_LABELS = {
    "energy_cost_sgd": "HVAC energy cost [SGD]",
    "ppp_charge_sgd": "HVAC peak charge, prorated [SGD]",
    "il_penalty_sgd": "IL penalty [SGD]",
    "reserve_revenue_settled_sgd": "Settled reserve [SGD]",
    "total_cost_sgd": "Total [SGD]",
    "reserve_revenue_unsettled_sgd": "Unsettled reserve (availability) [SGD]",
    "total_with_unsettled_sgd": "Total with unsettled reserve [SGD]",
}
"""Headers of the cost table on the page."""

REPORT_KPIS = (
    "days",
    "energy_kwh",
    "facility_energy_kwh",
    "peak_power_kw",
    "facility_peak_power_kw",
    "net_cost_with_ppp_sgd",
    "reserve_offered_mean_kw",
    "il_events",
    "il_delivered_ratio",
    "discomfort_occupied_kelvin_hours",
    "discomfort_unoccupied_kelvin_hours",
    "max_violation_occupied_k",
    "planned_over_metered_occupied",
    "planned_over_metered_unoccupied",
    "weekday_peak_over_committed_max",
    "violation_share",
    "fallback_count",
    "planned_slack_share",
)
"""KPIs (names of :func:`hvacflex.kpi.summary`) in the page's KPI table, in this order; the
facility rows only where some run's plant meters the facility."""

KPI_LABELS = {
    "days": "Days",
    "energy_kwh": "HVAC energy [kWh]",
    "facility_energy_kwh": "Facility energy [kWh]",
    "peak_power_kw": "HVAC peak, 30-min [kW]",
    "facility_peak_power_kw": "Facility peak, 30-min [kW]",
    "net_cost_with_ppp_sgd": "HVAC net cost with prorated peak charge [SGD]",
    "reserve_offered_mean_kw": "Reserve offered, mean [kW]",
    "il_events": "IL events (activations)",
    "il_delivered_ratio": "IL delivered / due (metered)",
    "discomfort_occupied_kelvin_hours": "Occupied discomfort [K·h]",
    "discomfort_unoccupied_kelvin_hours": "Unoccupied discomfort [K·h]",
    "max_violation_occupied_k": "Largest occupied violation [K]",
    "planned_over_metered_occupied": "Planned ÷ metered energy, occupied",
    "planned_over_metered_unoccupied": "Planned ÷ metered energy, unoccupied",
    "weekday_peak_over_committed_max": "Weekday metered peak ÷ committed, largest",
    "violation_share": "Periods outside the band",
    "fallback_count": "Fallback steps",
    "planned_slack_share": "Plans needing comfort slack",
    "energy_cost_sgd": "HVAC energy cost [SGD]",
    "reserve_revenue_settled_sgd": "Settled reserve [SGD]",
    "reserve_revenue_unsettled_sgd": "Unsettled reserve (availability) [SGD]",
    "ppp_charge_sgd": "HVAC peak charge, prorated [SGD]",
    "solve_time_mean_s": "Solve time, mean [s]",
    "energy_kwh_per_m2": "HVAC energy per m² [kWh/m²]",
    "peak_power_w_per_m2": "HVAC peak per m² [W/m²]",
    "net_cost_with_ppp_sgd_per_m2": "HVAC net cost per m² [SGD/m²]",
}
"""Row labels (with units) of the page's KPI table."""

PLANNED_SLACK_TEXT = (
    "Plans needing comfort slack (planned_slack_share): the share of periods whose plan "
    "could not keep every zone inside the comfort band tightened by the robust margin δ and "
    "planned a paid violation instead. It grades the plan, not the room: a high share with "
    "little discomfort means the margins were wider than the errors that came (typical in "
    "the narrow occupied band, and where δ exceeds half the band: max_delta_vs_half_band "
    "> 1); it stays 0 for a rule-based controller, which makes no plan."
)
"""What ``planned_slack_share`` means, as the page and the reproduction report say it."""


@dataclass(frozen=True)
class ReportRun:
    """One run shown in the report.

    Attributes
    ----------
    name : label (the run folder's name, made unique).
    results : (T, ·) results frame (schema of :mod:`hvacflex.results`).
    floor_area_m2 : floor area of the run's building [m²]; None when it cannot be loaded.
    building : building named in the run's configuration ("" when unknown).
    reserve_price_synthetic : the run's reserve price is hvacflex's synthetic one (its
        configuration names no reserve price file).
    """

    name: str
    results: pd.DataFrame
    floor_area_m2: float | None
    building: str
    reserve_price_synthetic: bool = True


def _run_name(path: Path, taken: Sequence[str]) -> str:
    name = path.name if path.is_dir() else path.parent.name
    if not path.is_dir() and path.name != schema.RESULTS_FILENAME:
        name = path.stem
    unique, suffix = name, 2
    while unique in taken:
        unique, suffix = f"{name}#{suffix}", suffix + 1
    return unique


def _stored_config(path: Path) -> dict[str, object]:
    """The configuration stored in the run's results metadata (``{}`` when unreadable)."""
    file = path / schema.RESULTS_FILENAME if path.is_dir() else path
    try:
        config = json.loads(schema.read_metadata(file).get("config", "{}"))
    except (HvacflexError, ValueError, OSError):
        return {}
    return config if isinstance(config, dict) else {}


def _reserve_price_synthetic(config: dict[str, object]) -> bool:
    data = config.get("data")
    return not (isinstance(data, dict) and data.get("reserve_source"))


def known_floor_area_m2(area_m2: float | None) -> float | None:
    """``area_m2`` [m²] when it is a floor area (finite and > 0), else None: a model file
    without floor areas gives NaN."""
    if area_m2 is None or not np.isfinite(area_m2) or area_m2 <= 0.0:
        return None
    return float(area_m2)


def _building_of(path: Path) -> tuple[str, float | None]:
    """The building named in the run's configuration and its floor area [m²] (or None when
    the building cannot be loaded or has no known floor area)."""
    from hvacflex.building.io import load_building
    from hvacflex.paths import resolve_building

    try:
        config = _stored_config(path)
        building = str(config.get("building", ""))
        if not building:
            return "", None
        area_m2 = float(load_building(resolve_building(building)).floor_area_m2)
        return building, known_floor_area_m2(area_m2)
    except (HvacflexError, ValueError, OSError):
        return "", None


def load_runs(paths: Sequence[str | Path]) -> list[ReportRun]:
    """The runs at ``paths`` (run folders holding ``results.parquet``, or Parquet files).

    Raises
    ------
    InputError
        When no path is given. Errors of :func:`hvacflex.results.load_results` (missing or
        damaged file) pass through.
    """
    if not paths:
        raise InputError("no runs given", field="RUN", hint="pass one or more run folders")
    runs: list[ReportRun] = []
    for given in paths:
        path = Path(given)
        results = schema.load_results(path)
        building, area_m2 = _building_of(path)
        name = _run_name(path, [run.name for run in runs])
        synthetic = _reserve_price_synthetic(_stored_config(path))
        runs.append(ReportRun(name, results, area_m2, building, synthetic))
    return runs


def tariff_peak_price_sgd_per_kw(runs: Sequence[ReportRun]) -> float:
    """The one peak price φ the report bills every run at [SGD/kW]: the largest φ any run
    recorded (column ``peak_price_sgd_per_kw``), so that a run planned without a peak charge
    is billed like one planned with it; 0 when no run has the column."""
    prices = [
        float(np.nanmax(run.results["peak_price_sgd_per_kw"].to_numpy(float)))
        for run in runs
        if "peak_price_sgd_per_kw" in run.results.columns and len(run.results)
    ]
    return max(prices, default=0.0)


def cost_breakdown(runs: Sequence[ReportRun], peak_price_sgd_per_kw: float) -> pd.DataFrame:
    """Cost of every run under one tariff [SGD], one row per run.

    Columns :data:`COST_COLUMNS`: HVAC energy cost (each run's energy prices), billed HVAC
    peak (φ = ``peak_price_sgd_per_kw`` [SGD/kW] × each calendar month's largest 30-min
    power, prorated to the days the run covers: :func:`hvacflex.kpi.ppp_charge_sgd`), IL
    non-delivery penalty, reserve revenue settled against the meter (activated periods),
    ``total_cost_sgd`` = energy + billed peak + penalty − settled reserve; then the unsettled
    availability payments and ``total_with_unsettled_sgd`` = total − them.
    """
    rows = {}
    for run in runs:
        frame = run.results
        energy = kpi.energy_cost_sgd(frame)
        peak = kpi.ppp_charge_sgd(frame, peak_price_sgd_per_kw)
        penalty = kpi.il_penalty_sgd(frame)
        settled = kpi.reserve_revenue_settled_sgd(frame)
        unsettled = kpi.reserve_revenue_unsettled_sgd(frame)
        total = energy + peak + penalty - settled
        rows[run.name] = [energy, peak, penalty, settled, total, unsettled, total - unsettled]
    return pd.DataFrame.from_dict(rows, orient="index", columns=list(COST_COLUMNS)).rename_axis(
        "run"
    )


def kpi_table(runs: Sequence[ReportRun], peak_price_sgd_per_kw: float) -> pd.DataFrame:
    """KPIs of every run, one column per run, rows :data:`REPORT_KPIS` (names and units of
    :func:`hvacflex.kpi.summary`, the peak billed at ``peak_price_sgd_per_kw`` [SGD/kW]) then
    ``energy_kwh_per_m2``, ``peak_power_w_per_m2``, ``net_cost_with_ppp_sgd_per_m2`` (per m²
    of floor; NaN when the floor area is unknown). The facility rows only where some run's
    plant meters the facility."""
    columns: dict[str, dict[str, float]] = {}
    metered = any(kpi.facility_metered(run.results) for run in runs)
    names = [n for n in REPORT_KPIS if metered or not n.startswith("facility_")]
    for run in runs:
        summary = kpi.summary(run.results, peak_price_sgd_per_kw)
        values = {name: summary.get(name, float("nan")) for name in names}
        area_m2 = known_floor_area_m2(run.floor_area_m2) or float("nan")
        values["energy_kwh_per_m2"] = values["energy_kwh"] / area_m2
        values["peak_power_w_per_m2"] = values["peak_power_kw"] * W_PER_KW / area_m2
        values["net_cost_with_ppp_sgd_per_m2"] = values["net_cost_with_ppp_sgd"] / area_m2
        columns[run.name] = values
    return pd.DataFrame(columns).rename_axis("kpi")


def change_vs_baseline_pct(table: pd.DataFrame, baseline: str) -> pd.DataFrame:
    """Relative change of every other run's KPIs against the ``baseline`` column [%]:
    ``100 (x − x_base) / |x_base|``, NaN where the baseline's value is 0. Columns are named
    ``<run> vs <baseline>``."""
    if baseline not in table.columns:
        raise InputError(
            "baseline is not a column of the KPI table",
            field="baseline",
            value=baseline,
            hint=f"one of {list(table.columns)}",
        )
    reference = table[baseline]
    changes = {
        f"{name} vs {baseline}": (100.0 * (table[name] - reference) / reference.abs()).where(
            reference != 0.0
        )
        for name in table.columns
        if name != baseline
    }
    return pd.DataFrame(changes, index=table.index)


COUNT_KPIS = kpi.COUNT_KPIS
"""KPIs (names of :func:`hvacflex.kpi.summary`) that count things: shown as whole numbers."""

RATIO_KPIS = ("il_delivered_ratio",)
"""KPIs that are ratios of events: "–" without events, and never a Δ."""


def _kpi_text(name: str, value: float) -> str:
    return format_value(name, value)  # per m² of an unknown floor area: "not available"


def formatted_kpi_table(table: pd.DataFrame, changes: pd.DataFrame | None) -> pd.DataFrame:
    """The KPI table (one row per KPI name, one column per run) as display text: values by
    their KPI's unit (:func:`hvacflex.report.tables.format_value`; counts whole), a delivery
    ratio without events (or without reserve due) as "–", per m² of an unknown floor area as
    "not available", changes as signed percentages (none for the event ratios: "–")."""
    no_events = (
        table.loc["il_events"].fillna(0.0) == 0.0
        if "il_events" in table.index
        else pd.Series(False, index=table.columns)
    )
    shown = pd.DataFrame(
        {
            column: [
                "–"
                if name in RATIO_KPIS and bool(no_events[column])
                else _kpi_text(str(name), float(value))
                for name, value in table[column].items()
            ]
            for column in table.columns
        },
        index=table.index,
    )
    if changes is not None:
        for column in changes.columns:
            shown[f"Δ {column}"] = [
                "–" if name in RATIO_KPIS else format_value("change_pct", v)
                for name, v in changes[column].items()
            ]
    return shown


def labelled(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with its KPI-name index shown as :data:`KPI_LABELS` (other names kept)."""
    return table.rename(index=lambda name: KPI_LABELS.get(str(name), str(name)))


# ----------------------------------------------------------------------------- figures
# The panels are those of the reproduction's figures (:mod:`hvacflex.report.plots`), drawn
# over each run's whole period.


def plot_run_temperatures(runs: Sequence[ReportRun], path: Path) -> Path:
    """Zone temperatures at period end [°C] over the shaded comfort band (the first zone's),
    one panel per run (at most :data:`~hvacflex.report.plots.MAX_LINES_PER_PANEL` zones, the
    warmest); IL activations shaded. Writes the PNG at ``path`` and its CSV beside it."""
    figure, axes = plots.new_figure(len(runs), sharex=False, dpi=DPI)
    for ax, run in zip(axes, runs, strict=True):
        zones = plots.warmest_zones({run.name: run.results})
        plots.temperature_panel(ax, run.results, zones, run.name)
        ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
        plots.format_time_axis(ax)
    axes[-1].set_xlabel("time (local)")
    figure.suptitle("Zone temperatures (period end) and the comfort band")
    data = plots.temperature_data({run.name: run.results for run in runs})
    return plots.save_figure(figure, data, path)


def plot_run_power(runs: Sequence[ReportRun], path: Path) -> Path:
    """Per run a power panel (power drawn [kW], the reserve band, IL activations, the peak
    marked) and, for a run that offered reserve, a reserve panel of its own; a rule-based run
    gets no empty reserve panel. Writes the PNG at ``path`` and its CSV beside it."""
    return plots.plot_power_reserve(
        {run.name: run.results for run in runs},
        path,
        whole_period=True,
        show_energy_price=False,
        title="HVAC power, reserve band and IL activations",
    )


def plot_run_prices(run: ReportRun, path: Path) -> Path:
    """Energy price (USEP) and reserve price [SGD/MWh] of one run, two panels."""
    return plots.plot_prices(
        run.results,
        path,
        reserve_synthetic=run.reserve_price_synthetic,
        title=f"Prices of run {run.name}",
    )


# ----------------------------------------------------------------------------- page


def _period_text(runs: Sequence[ReportRun]) -> str:
    parts = []
    for run in runs:
        index = pd.DatetimeIndex(run.results.index)
        span = f"{index[0]:%Y-%m-%d %H:%M} – {index[-1]:%Y-%m-%d %H:%M}" if len(index) else "empty"
        area = (
            f"{run.floor_area_m2:,.0f} m²"
            if run.floor_area_m2
            else "floor area not available (per-m² figures: not available)"
        )
        parts.append(
            f"- {run.name}: {len(index)} periods, {span}; building {run.building or '?'}, {area}"
        )
    return "\n".join(parts)


def run_report_sections(
    runs: Sequence[ReportRun],
    figure_dir: Path,
    *,
    baseline: ReportRun | None = None,
    peak_price_sgd_per_kw: float | None = None,
) -> list[Section]:
    """The sections of the page (figures written as PNG into ``figure_dir``)."""
    shown = [*runs, *([baseline] if baseline is not None else [])]
    phi = (
        tariff_peak_price_sgd_per_kw(shown)
        if peak_price_sgd_per_kw is None
        else peak_price_sgd_per_kw
    )
    costs = cost_breakdown(shown, phi)
    tariff = (
        f"One tariff for every run on the HVAC's electricity (power_kw): energy at the "
        f"prices each run recorded, the HVAC peak billed at φ = {phi:g} SGD/kW per calendar "
        "month's largest 30-min power (also for runs planned without a peak charge), "
        "prorated to the days each run covers (a one-day run bears 1/30 of a month's "
        "charge). Total = HVAC energy + billed peak + IL penalty − reserve revenue settled "
        "against the meter (the activated periods). Availability payments for reserve that "
        "no activation tested are shown apart (unsettled) and not in the total. Computed "
        "from the plant model's power (the RC plant or EnergyPlus, as each run's [plant] "
        "table says)."
    )
    kpis = kpi_table(shown, phi)
    changes = change_vs_baseline_pct(kpis, baseline.name) if baseline is not None else None
    kpi_text = (
        f"KPIs per run (HVAC peak billed at φ = {phi:g} SGD/kW, prorated); energy and peak "
        "are the HVAC's"
        + (
            ", the facility's beside them where the plant meters it"
            if "facility_energy_kwh" in kpis.index
            else " (this plant does not meter the whole facility)"
        )
        + "; per-m² rows are per m² of the building's floor ('not available' without a "
        "known floor area). Discomfort is split into the occupied periods (the schedule's "
        "occupied band) and the rest."
    )
    if baseline is not None:
        kpi_text += f" Δ columns: relative change against the baseline run {baseline.name}."
        lengths = {run.name for run in shown if len(run.results) != len(baseline.results)}
        if lengths:
            kpi_text += (
                f" Runs of another length than the baseline ({', '.join(sorted(lengths))}): "
                "their totals are not comparable with it."
            )
    return [
        Section("Runs", paragraphs=[_period_text(shown)]),
        Section(
            "Zone temperatures",
            figures=[plot_run_temperatures(shown, figure_dir / "temperatures.png")],
            figure_captions=[
                "Zone temperatures at period end; green: the comfort band; red: IL activations."
            ],
        ),
        Section(
            "Power and reserve",
            figures=[plot_run_power(shown, figure_dir / "power.png")],
            figure_captions=[
                "Power drawn (blue) with its peak marked, the reserve band it offered to "
                "shed (green) and the IL activations (red); below a run that offered "
                "reserve, the reserve offered (a rule-based run gets no empty panel)."
            ],
        ),
        Section(
            "Prices",
            figures=[plot_run_prices(shown[0], figure_dir / "prices.png")],
            figure_captions=[f"Energy (USEP) and reserve prices of run {shown[0].name}."],
        ),
        Section(
            "Cost under one tariff",
            paragraphs=[tariff],
            tables=[costs.rename(columns=COST_LABELS)],
            table_captions=["Cost breakdown, HVAC [SGD]"],
        ),
        Section(
            "KPIs",
            paragraphs=[kpi_text, PLANNED_SLACK_TEXT],
            tables=[labelled(formatted_kpi_table(kpis, changes))],
            table_captions=["KPIs per run"],
        ),
    ]


def write_run_report(
    paths: Sequence[str | Path],
    out: str | Path,
    *,
    baseline: str | Path | None = None,
    peak_price_sgd_per_kw: float | None = None,
    title: str | None = None,
) -> Path:
    """Write the HTML page for the runs at ``paths`` (and the ``baseline`` run) to ``out``.

    Parameters
    ----------
    paths : run folders (holding ``results.parquet``) or results Parquet files.
    out : the HTML file to write (its folder is created).
    baseline : a run to compare against (shown too); None: no comparison columns.
    peak_price_sgd_per_kw : φ of the one tariff [SGD/kW]; None: the largest any run recorded.
    title : page title; default names the runs.

    Returns
    -------
    The path written.

    Raises
    ------
    InputError, StoredStateError
        For missing, unreadable or empty runs.
    """
    base = load_runs([baseline])[0] if baseline is not None else None
    if baseline is not None:  # the baseline is shown once, as the baseline
        paths = [p for p in paths if not _same_run(Path(p), Path(baseline))]
        if not paths:
            paths = [baseline]
            base = None
    runs = load_runs(paths)
    if base is not None and base.name in {run.name for run in runs}:
        base = replace(base, name=f"{base.name} (baseline)")
    for run in [*runs, *([base] if base else [])]:
        if run.results.empty:
            raise InputError("run has no periods", source=run.name, hint="simulate it first")
    target = Path(out)
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        sections = run_report_sections(
            runs, Path(scratch), baseline=base, peak_price_sgd_per_kw=peak_price_sgd_per_kw
        )
        names = ", ".join(run.name for run in runs)
        document = render_report(title=title or f"hvacflex runs: {names}", sections=sections)
    return atomic_write_text(target, document)


def _same_run(a: Path, b: Path) -> bool:
    """Whether two paths name the same run (a folder or its results file)."""

    def file(path: Path) -> Path:
        return (path / schema.RESULTS_FILENAME if path.is_dir() else path).resolve()

    return file(a) == file(b)


RUN_REPORT_FILENAME = "report.html"
"""Name of the page ``simulate`` writes into its run folder."""


def report_for_run_dir(run_dir: str | Path) -> Path:
    """Write :data:`RUN_REPORT_FILENAME` of one run folder into that folder (``simulate``)."""
    folder = Path(run_dir)
    return write_run_report([folder], folder / RUN_REPORT_FILENAME)
