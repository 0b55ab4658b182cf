"""``hvacflex report``: one self-contained HTML page for any closed-loop runs.

:func:`write_run_report` reads the runs (run folders or results Parquet files), draws three
figures — zone temperatures over the shaded comfort band, power with the reserve band and
the IL activations marked, and the prices — and tabulates the cost of every run under **one
tariff** (the same peak price φ for all; energy and reserve at the prices each run recorded)
and its KPIs, per run and per m² of floor, against a baseline run. The figures are PNG
embedded as base64 ``data:`` URIs by :func:`hvacflex.report.html.render_report`, so the page
requests nothing from elsewhere and runs no script.

Every number comes from :mod:`hvacflex.kpi`; the floor area is that of the building named in
the run's configuration (results metadata), and per-m² columns are NaN when that building
cannot be loaded (a building file moved since the run).
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hvacflex import kpi
from hvacflex import results as schema
from hvacflex.errors import HvacflexError, InputError
from hvacflex.report.html import Section, render_report
from hvacflex.report.tables import format_value
from hvacflex.units import W_PER_KW
from hvacflex.version import atomic_write_text

DPI = 110
"""Resolution of the embedded figures [dots per inch] (a page, not print)."""

FIGURE_WIDTH_IN = 10.0
"""Width of every figure [in]."""

PANEL_HEIGHT_IN = 2.4
"""Height of one panel [in]."""

COST_COLUMNS = (
    "energy_cost_sgd",
    "ppp_charge_sgd",
    "reserve_revenue_sgd",
    "il_penalty_sgd",
    "total_cost_sgd",
)
"""Columns of :func:`cost_breakdown` [SGD]; total = energy + billed peak − reserve + penalty."""

REPORT_KPIS = (
    "days",
    "energy_kwh",
    "peak_power_kw",
    "net_cost_with_ppp_sgd",
    "reserve_offered_mean_kw",
    "il_events",
    "il_delivered_ratio",
    "discomfort_kelvin_hours",
    "max_violation_k",
    "violation_share",
    "fallback_count",
)
"""KPIs (names of :func:`hvacflex.kpi.summary`) in the page's KPI table, in this order."""


@dataclass(frozen=True)
class ReportRun:
    """One run shown in the report.

    Attributes
    ----------
    name : label (the run folder's name, made unique).
    results : (T, ·) results frame (schema of :mod:`hvacflex.results`).
    floor_area_m2 : floor area of the run's building [m²]; None when it cannot be loaded.
    building : building named in the run's configuration ("" when unknown).
    """

    name: str
    results: pd.DataFrame
    floor_area_m2: float | None
    building: str


def _run_name(path: Path, taken: Sequence[str]) -> str:
    name = path.name if path.is_dir() else path.parent.name
    if not path.is_dir() and path.name != schema.RESULTS_FILENAME:
        name = path.stem
    unique, suffix = name, 2
    while unique in taken:
        unique, suffix = f"{name}#{suffix}", suffix + 1
    return unique


def _building_of(path: Path) -> tuple[str, float | None]:
    """The building named in the run's configuration and its floor area [m²] (or None)."""
    from hvacflex.building.io import load_building
    from hvacflex.paths import resolve_building

    file = path / schema.RESULTS_FILENAME if path.is_dir() else path
    try:
        config = json.loads(schema.read_metadata(file).get("config", "{}"))
        building = str(config.get("building", ""))
        if not building:
            return "", None
        return building, float(load_building(resolve_building(building)).floor_area_m2)
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
        runs.append(ReportRun(name, results, area_m2, building))
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

    Columns :data:`COST_COLUMNS`: energy cost (each run's energy prices), billed peak
    (φ = ``peak_price_sgd_per_kw`` [SGD/kW] × each calendar month's largest 30-min power),
    reserve revenue (capacity offered × reserve price), IL non-delivery penalty, and
    ``total_cost_sgd`` = energy + billed peak − reserve revenue + penalty.
    """
    rows = {}
    for run in runs:
        frame = run.results
        energy = kpi.energy_cost_sgd(frame)
        peak = kpi.ppp_charge_sgd(frame, peak_price_sgd_per_kw)
        reserve = kpi.reserve_revenue_sgd(frame)
        penalty = kpi.il_penalty_sgd(frame)
        rows[run.name] = [energy, peak, reserve, penalty, energy + peak - reserve + penalty]
    return pd.DataFrame.from_dict(rows, orient="index", columns=list(COST_COLUMNS)).rename_axis(
        "run"
    )


def kpi_table(runs: Sequence[ReportRun], peak_price_sgd_per_kw: float) -> pd.DataFrame:
    """KPIs of every run, one column per run, rows :data:`REPORT_KPIS` (names and units of
    :func:`hvacflex.kpi.summary`, the peak billed at ``peak_price_sgd_per_kw`` [SGD/kW]) then
    ``energy_kwh_per_m2``, ``peak_power_w_per_m2``, ``net_cost_with_ppp_sgd_per_m2`` (per m²
    of floor; NaN when the floor area is unknown)."""
    columns: dict[str, dict[str, float]] = {}
    for run in runs:
        summary = kpi.summary(run.results, peak_price_sgd_per_kw)
        values = {name: summary.get(name, float("nan")) for name in REPORT_KPIS}
        area_m2 = run.floor_area_m2 if run.floor_area_m2 else float("nan")
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


COUNT_KPIS = ("il_events", "fallback_count")
"""KPIs of :data:`REPORT_KPIS` that count things: shown as whole numbers."""


def _kpi_text(name: str, value: float) -> str:
    if name in COUNT_KPIS and np.isfinite(value):
        return f"{value:,.0f}"
    return format_value(name, value)


def formatted_kpi_table(table: pd.DataFrame, changes: pd.DataFrame | None) -> pd.DataFrame:
    """The KPI table as display text: values by their KPI's unit
    (:func:`hvacflex.report.tables.format_value`; counts whole), changes as signed
    percentages."""
    shown = pd.DataFrame(
        {
            column: [_kpi_text(str(name), float(value)) for name, value in table[column].items()]
            for column in table.columns
        },
        index=table.index,
    )
    if changes is not None:
        for column in changes.columns:
            shown[f"Δ {column}"] = [format_value("change_pct", v) for v in changes[column]]
    return shown


# ----------------------------------------------------------------------------- figures


def _figure(rows: int) -> tuple[Figure, list[Axes]]:
    figure = Figure(figsize=(FIGURE_WIDTH_IN, max(PANEL_HEIGHT_IN * rows, 3.0)), dpi=DPI)
    FigureCanvasAgg(figure)
    grid = figure.subplots(rows, 1, sharex=False, squeeze=False)
    return figure, [row[0] for row in grid]


def _edges(results: pd.DataFrame) -> np.ndarray:
    """(T+1,) local wall-clock period boundaries (the starts and the last period's end)."""
    index = pd.DatetimeIndex(results.index)
    local = index.tz_localize(None) if index.tz is not None else index
    starts = local.to_numpy()
    step = np.timedelta64(round(kpi.step_hours(results) * 3600), "s")
    return np.append(starts, starts[-1] + step) if len(starts) else starts


def _mark_activations(ax: Axes, results: pd.DataFrame, edges: np.ndarray) -> None:
    if "il_activated" not in results.columns:
        return
    for i, k in enumerate(np.flatnonzero(results["il_activated"].to_numpy(bool))):
        ax.axvspan(
            edges[k],
            edges[k + 1],
            color="C3",
            alpha=0.25,
            linewidth=0,
            label="IL activated" if i == 0 else None,
        )


def _save_png(figure: Figure, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, format="png")
    return path


def plot_run_temperatures(runs: Sequence[ReportRun], path: Path) -> Path:
    """Zone temperatures at period end [°C] over the comfort band (shaded, first zone's),
    one panel per run; IL activations shaded red. Writes the PNG at ``path``."""
    figure, axes = _figure(len(runs))
    for ax, run in zip(axes, runs, strict=True):
        frame = run.results
        edges = _edges(frame)
        zones = kpi.zone_names(frame)
        lower = frame[schema.COMFORT_LOWER.name(zones[0])].to_numpy(float)
        upper = frame[schema.COMFORT_UPPER.name(zones[0])].to_numpy(float)
        ax.fill_between(
            edges,
            np.append(lower, lower[-1]),
            np.append(upper, upper[-1]),
            step="post",
            color="C2",
            alpha=0.18,
            label="comfort band",
        )
        _mark_activations(ax, frame, edges)
        for i, zone in enumerate(zones):
            ax.plot(
                edges[1:],
                frame[schema.TEMP_END.name(zone)].to_numpy(float),
                color=f"C{i % 10}",
                linewidth=1.1,
                label=zone,
            )
        ax.set_title(run.name, loc="left", fontsize="medium")
        ax.set_ylabel("temperature [°C]")
        ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1].set_xlabel("time (local)")
    figure.suptitle("Zone temperatures (period end) and the comfort band")
    return _save_png(figure, path)


def plot_run_power(runs: Sequence[ReportRun], path: Path) -> Path:
    """Per run two panels: electric power [kW] with the reserve band (served power down to
    served − reserve offered) and the IL activations marked, and the reserve offered [kW]."""
    figure, axes = _figure(2 * len(runs))
    for i, run in enumerate(runs):
        ax_power, ax_reserve = axes[2 * i], axes[2 * i + 1]
        frame = run.results
        edges = _edges(frame)
        power = frame["power_kw"].to_numpy(float)
        reserve = frame["reserve_kw"].to_numpy(float)
        served = (
            frame["power_served_kw"].to_numpy(float)
            if "power_served_kw" in frame.columns
            else power
        )
        served = np.where(np.isnan(served), power, served)
        ax_power.stairs(
            served,
            edges,
            baseline=served - reserve,
            fill=True,
            color="C2",
            alpha=0.35,
            label="reserve band",
        )
        _mark_activations(ax_power, frame, edges)
        ax_power.stairs(power, edges, baseline=None, color="C0", label="power drawn")
        ax_power.set_ylim(bottom=0.0)
        ax_power.set_ylabel("power [kW]")
        ax_power.set_title(f"{run.name}: power", loc="left", fontsize="medium")
        ax_reserve.stairs(reserve, edges, color="C2", fill=True, alpha=0.6, label="reserve offered")
        _mark_activations(ax_reserve, frame, edges)
        ax_reserve.set_ylim(bottom=0.0, top=max(1.0, 1.1 * float(np.nanmax(reserve, initial=0.0))))
        ax_reserve.set_ylabel("reserve [kW]")
        ax_reserve.set_title(f"{run.name}: reserve offered", loc="left", fontsize="medium")
        for ax in (ax_power, ax_reserve):
            ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1].set_xlabel("time (local)")
    figure.suptitle("HVAC power, reserve band and IL activations")
    return _save_png(figure, path)


def plot_run_prices(run: ReportRun, path: Path) -> Path:
    """Energy price (USEP) and reserve price [SGD/MWh] of one run, two panels."""
    figure, (ax_energy, ax_reserve) = _figure(2)
    frame = run.results
    edges = _edges(frame)
    ax_energy.stairs(
        frame["energy_price_sgd_per_mwh"].to_numpy(float), edges, baseline=None, color="C0"
    )
    ax_energy.set_ylabel("energy price\n[SGD/MWh]")
    ax_reserve.stairs(
        frame["reserve_price_sgd_per_mwh"].to_numpy(float), edges, baseline=None, color="C3"
    )
    ax_reserve.set_ylabel("reserve price\n[SGD/MWh]")
    ax_reserve.set_xlabel("time (local)")
    figure.suptitle(f"Prices of run {run.name}")
    return _save_png(figure, path)


# ----------------------------------------------------------------------------- page


def _period_text(runs: Sequence[ReportRun]) -> str:
    parts = []
    for run in runs:
        index = pd.DatetimeIndex(run.results.index)
        span = f"{index[0]:%Y-%m-%d %H:%M} – {index[-1]:%Y-%m-%d %H:%M}" if len(index) else "empty"
        area = f"{run.floor_area_m2:,.0f} m²" if run.floor_area_m2 else "floor area unknown"
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
        f"One tariff for every run: energy and reserve at the prices each run recorded, the "
        f"peak billed at φ = {phi:g} SGD/kW per calendar month's largest 30-min power "
        "(also for runs planned without a peak charge). Total = energy + billed peak − "
        "reserve revenue + IL penalty. Computed from the plant model's power (the RC plant "
        "or EnergyPlus, as each run's [plant] table says)."
    )
    kpis = kpi_table(shown, phi)
    changes = change_vs_baseline_pct(kpis, baseline.name) if baseline is not None else None
    kpi_text = (
        f"KPIs per run (peak billed at φ = {phi:g} SGD/kW); _per_m2 rows are per m² of the "
        "building's floor."
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
                "Power drawn (blue) with the reserve band it offered to shed "
                "(green) and the IL activations (red); below it the reserve "
                "offered."
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
            tables=[costs],
            table_captions=["Cost breakdown [SGD]"],
        ),
        Section(
            "KPIs",
            paragraphs=[kpi_text],
            tables=[formatted_kpi_table(kpis, changes)],
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
    runs = load_runs(paths)
    base = load_runs([baseline])[0] if baseline is not None else None
    if base is not None and base.name in {run.name for run in runs}:
        base = ReportRun(f"{base.name} (baseline)", base.results, base.floor_area_m2, base.building)
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


RUN_REPORT_FILENAME = "report.html"
"""Name of the page ``simulate`` writes into its run folder."""


def report_for_run_dir(run_dir: str | Path) -> Path:
    """Write :data:`RUN_REPORT_FILENAME` of one run folder into that folder (``simulate``)."""
    folder = Path(run_dir)
    return write_run_report([folder], folder / RUN_REPORT_FILENAME)
