"""Figures of the paper (Fig. 2, 5, 6, 7) and beyond, as PNG files with their data as CSV.

Every function takes DataFrames and a PNG path, writes the figure there and the data behind
it to the same path with suffix ``.csv`` (so a figure can be checked, or redrawn, from
numbers), and returns the PNG path. Figures are drawn on :class:`matplotlib.figure.Figure`
with the Agg canvas directly: nothing here touches pyplot or the global backend.

Time axes show local wall-clock time of the results index (Asia/Singapore). Results frames
follow the columns of ``docs/reference/results.md``: row ``k`` is the period
``[t_k, t_k + Δt)``; ``temp_end_<zone>_degc`` is measured at ``t_k + Δt`` and is drawn there.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hvacflex import kpi
from hvacflex import results as schema
from hvacflex.errors import DataError, InputError

DPI = 150
"""Resolution of the PNG files [dots per inch]."""

PANEL_HEIGHT_IN = 2.6
"""Height of one panel of a multi-panel figure [in]."""

FIGURE_WIDTH_IN = 9.0
"""Width of every figure [in]."""

LOG_AXIS_MIN_RATIO = 10.0
"""The PPP axis of Fig. 7 is logarithmic when max φ / min φ reaches this ratio."""

_TIME_LABEL = "time (local)"


# ----------------------------------------------------------------------------- helpers


def csv_path(png_path: str | Path) -> Path:
    """Path of the CSV written next to a figure: the PNG path with suffix ``.csv``."""
    return Path(png_path).with_suffix(".csv")


def new_figure(
    rows: int,
    cols: int = 1,
    *,
    sharex: bool | str = True,
    sharey: bool | str = False,
    dpi: int = DPI,
    panel_height_in: float = PANEL_HEIGHT_IN,
) -> tuple[Figure, list[Axes]]:
    """A figure of ``rows`` × ``cols`` panels on the Agg canvas (no pyplot), its axes row by
    row; :data:`FIGURE_WIDTH_IN` wide, ``panel_height_in`` [in] a row."""
    figure = Figure(figsize=(FIGURE_WIDTH_IN, max(panel_height_in * rows, 3.2)), dpi=dpi)
    FigureCanvasAgg(figure)
    grid = figure.subplots(rows, cols, sharex=sharex, sharey=sharey, squeeze=False)  # type: ignore[arg-type]
    return figure, [ax for row in grid for ax in row]


def save_figure(
    figure: Figure, data: pd.DataFrame, path: str | Path, *, index: bool = False
) -> Path:
    """Write ``figure`` as PNG at ``path`` and ``data`` beside it (:func:`csv_path`)."""
    png = Path(path)
    png.parent.mkdir(parents=True, exist_ok=True)
    figure.tight_layout()
    figure.savefig(png, format="png", bbox_inches="tight")
    data.to_csv(csv_path(png), index=index)
    return png


def require_columns(frame: pd.DataFrame, columns: Sequence[str], what: str) -> None:
    """Refuse ``frame`` (named ``what`` in the error) when it lacks any of ``columns``."""
    missing = [col for col in columns if col not in frame.columns]
    if missing:
        raise DataError(
            f"{what} lacks required columns",
            source=what,
            field=", ".join(missing),
            hint=f"columns present: {', '.join(map(str, frame.columns))}",
        )


def _local_times(index: pd.Index) -> np.ndarray:
    """Wall-clock times of a (tz-aware) DatetimeIndex as naive datetime64, else positions."""
    if isinstance(index, pd.DatetimeIndex):
        local = index.tz_localize(None) if index.tz is not None else index
        return np.asarray(local.to_numpy())
    return np.arange(len(index), dtype=float)


def period_edges(results: pd.DataFrame) -> np.ndarray:
    """(T+1,) period boundaries: the T period starts and the end of the last period."""
    starts = _local_times(results.index)
    if len(starts) == 0:
        return starts
    dt_h = kpi.step_hours(results)
    step = np.timedelta64(round(dt_h * 3600), "s") if starts.dtype.kind == "M" else 1.0
    return np.append(starts, starts[-1] + step)


def _step(ax: Axes, edges: np.ndarray, values: np.ndarray, **kwargs: Any) -> None:
    """Draw piecewise-constant period values over their periods."""
    ax.stairs(values, edges, baseline=None, **kwargs)


HALF_WIDTH_MAX_TICKS = 6
"""Most date ticks on a panel half the figure wide (Fig. 5's two columns; at least 3):
matplotlib's own choice put 9 on two days and their labels ran into each other
("Mar-0406:00")."""


def format_time_axis(ax: Axes, max_ticks: int | None = None) -> None:
    """Concise date ticks on a time axis of local wall-clock datetimes; ``max_ticks``: at
    most that many (None: matplotlib's choice, for a full-width panel)."""
    import matplotlib.dates as mdates

    locator = (
        mdates.AutoDateLocator()  # type: ignore[no-untyped-call]
        if max_ticks is None
        else mdates.AutoDateLocator(minticks=3, maxticks=max_ticks)  # type: ignore[no-untyped-call]
    )
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))  # type: ignore[no-untyped-call]


# ----------------------------------------------------------------------------- Fig. 2


def plot_prices(
    prices: pd.DataFrame,
    path: str | Path,
    *,
    reserve_synthetic: bool = True,
    title: str | None = None,
) -> Path:
    """Fig. 2: energy price (USEP) and reserve price over the displayed days.

    Parameters
    ----------
    prices : (T, ≥2) frame on the period-start index with ``energy_price_sgd_per_mwh`` and
        ``reserve_price_sgd_per_mwh`` [SGD/MWh] (a results frame will do; select the days).
    path : PNG file to write; the CSV goes next to it.
    reserve_synthetic : label the reserve series "synthetic" (docs/explanation/model.md §2: no
    public history).
    title : figure title; a default names the two series.

    Returns
    -------
    The PNG path. CSV columns: ``time``, ``energy_price_sgd_per_mwh``,
    ``reserve_price_sgd_per_mwh``, ``reserve_price_synthetic``.
    """
    columns = ["energy_price_sgd_per_mwh", "reserve_price_sgd_per_mwh"]
    require_columns(prices, columns, "price frame")
    reserve_label = "reserve (IL) price" + (" — synthetic" if reserve_synthetic else "")
    figure, (ax_energy, ax_reserve) = new_figure(2)
    edges = period_edges(prices)
    _step(ax_energy, edges, prices[columns[0]].to_numpy(float), color="C0", label="USEP")
    _step(ax_reserve, edges, prices[columns[1]].to_numpy(float), color="C3", label=reserve_label)
    ax_energy.set_ylabel("energy price\n[SGD/MWh]")
    ax_reserve.set_ylabel("reserve price\n[SGD/MWh]")
    ax_energy.legend(loc="upper left")
    ax_reserve.legend(loc="upper left")
    ax_reserve.set_xlabel(_TIME_LABEL)
    if isinstance(prices.index, pd.DatetimeIndex):
        format_time_axis(ax_reserve)
    figure.suptitle(
        title
        or "Energy price (NEMS USEP) and "
        + ("synthetic reserve price" if reserve_synthetic else "reserve price")
    )
    data = prices[columns].copy()
    data["reserve_price_synthetic"] = reserve_synthetic
    return save_figure(figure, data.rename_axis("time"), path, index=True)


# ----------------------------------------------------------------------------- Fig. 5


TEMPERATURE_SERIES = {
    "temp_end": "realised",
    "temp_served": "served (predicted)",
    "temp_curtailed": "curtailed (predicted)",
    "event_worst": "worst IL event (predicted)",
}
"""Temperature columns of :func:`temperature_data` (prefix → legend label)."""

_TEMPERATURE_COLUMNS = {
    "temp_end": schema.TEMP_END,
    "temp_served": schema.TEMP_SERVED,
    "temp_curtailed": schema.TEMP_CURTAILED,
    "event_worst": schema.EVENT_WORST,
}
"""The results column of each :data:`TEMPERATURE_SERIES` prefix."""

_COMFORT_COLUMNS = {"lower": schema.COMFORT_LOWER, "upper": schema.COMFORT_UPPER}

_TEMPERATURE_STYLES = {
    "temp_end": "-",
    "temp_served": "--",
    "temp_curtailed": ":",
    "event_worst": "-.",
}


def temperature_data(
    scenarios: Mapping[str, pd.DataFrame], zones: Sequence[str] | None = None
) -> pd.DataFrame:
    """Long table behind :func:`plot_temperatures`, one row per scenario, zone and period.

    Columns: ``scenario``, ``time_end`` (period end, local time), ``zone``,
    ``temp_end_degc`` (realised), ``temp_served_degc``, ``temp_curtailed_degc`` and
    ``event_worst_degc`` (one-step predictions; the last is the worst over the plan's
    IL event set × the uncertainty box; NaN when the results lack them), ``comfort_lower_degc``,
    ``comfort_upper_degc``, ``il_activated``.
    """
    rows = []
    for label, results in scenarios.items():
        ends = period_edges(results)[1:]
        for zone in zones if zones is not None else kpi.zone_names(results):
            require_columns(results, [schema.TEMP_END.name(zone)], f"results of scenario {label!r}")
            part = pd.DataFrame({"scenario": label, "time_end": ends, "zone": zone})
            for prefix in TEMPERATURE_SERIES:
                col = _TEMPERATURE_COLUMNS[prefix].name(zone)
                part[f"{prefix}_degc"] = (
                    results[col].to_numpy(float) if col in results.columns else np.nan
                )
            for bound, kind in _COMFORT_COLUMNS.items():
                col = kind.name(zone)
                part[f"comfort_{bound}_degc"] = (
                    results[col].to_numpy(float) if col in results.columns else np.nan
                )
            part["il_activated"] = (
                results["il_activated"].to_numpy(bool)
                if "il_activated" in results.columns
                else False
            )
            rows.append(part)
    return pd.concat(rows, ignore_index=True)


MAX_LINES_PER_PANEL = 5
"""Most temperature lines a panel draws (issue 28: a 16-entry legend of overlapping lines is
unreadable); a building with more zones shows its warmest ones."""


def warmest_zones(
    scenarios: Mapping[str, pd.DataFrame], count: int = MAX_LINES_PER_PANEL
) -> list[str]:
    """The ``count`` zones with the highest realised end-of-period temperature over all
    ``scenarios`` (ties in zone order), in the zone order of the first frame."""
    first = next(iter(scenarios.values()))
    zones = kpi.zone_names(first)
    hottest = {
        zone: max(
            float(np.nanmax(frame[schema.TEMP_END.name(zone)].to_numpy(float), initial=-np.inf))
            for frame in scenarios.values()
            if schema.TEMP_END.name(zone) in frame.columns
        )
        for zone in zones
    }
    chosen = set(sorted(zones, key=lambda z: -hottest[z])[:count])
    return [zone for zone in zones if zone in chosen]


def shade_comfort_band(ax: Axes, results: pd.DataFrame, zone: str) -> None:
    """Shade ``zone``'s comfort band [°C] over the periods of ``results`` (nothing when the
    results lack it)."""
    lower_col, upper_col = schema.COMFORT_LOWER.name(zone), schema.COMFORT_UPPER.name(zone)
    if lower_col not in results.columns or upper_col not in results.columns:
        return
    edges = period_edges(results)
    lower = results[lower_col].to_numpy(float)
    upper = results[upper_col].to_numpy(float)
    ax.fill_between(
        edges,
        np.append(lower, lower[-1:]),
        np.append(upper, upper[-1:]),
        step="post",
        color="C2",
        alpha=0.15,
        linewidth=0,
        label="comfort band",
    )


def temperature_panel(ax: Axes, results: pd.DataFrame, zones: Sequence[str], title: str) -> None:
    """One panel: the realised end-of-period temperature of each of ``zones`` (one colour a
    zone, at most :data:`MAX_LINES_PER_PANEL`) over the first zone's shaded comfort band, IL
    activations shaded grey."""
    shade_activations(ax, results)
    shade_comfort_band(ax, results, zones[0])
    ends = period_edges(results)[1:]
    for i, zone in enumerate(zones[:MAX_LINES_PER_PANEL]):
        ax.plot(
            ends,
            results[schema.TEMP_END.name(zone)].to_numpy(float),
            color=f"C{i % 10}",
            linewidth=1.1,
            label=zone,
        )
    ax.set_title(title, loc="left", fontsize="medium")
    ax.set_ylabel("temperature\n[°C]")


def _prediction_panel(
    ax: Axes, results: pd.DataFrame, rows: pd.DataFrame, zone: str, series: Sequence[str]
) -> None:
    """One panel: ``zone``'s realised temperature and the plan's predictions (``series``)."""
    shade_activations(ax, results)
    shade_comfort_band(ax, results, zone)
    ends = rows["time_end"].to_numpy()
    for prefix in series:
        values = rows[f"{prefix}_degc"].to_numpy(float)
        if np.all(np.isnan(values)):
            continue
        ax.plot(
            ends,
            values,
            linestyle=_TEMPERATURE_STYLES[prefix],
            color="k" if prefix == "temp_end" else _PREDICTION_COLOURS[prefix],
            linewidth=1.1,
            label=TEMPERATURE_SERIES[prefix],
        )


_PREDICTION_COLOURS = {"temp_served": "C0", "temp_curtailed": "C1", "event_worst": "C3"}


def plot_temperatures(
    scenarios: Mapping[str, pd.DataFrame],
    path: str | Path,
    *,
    zones: Sequence[str] | None = None,
    title: str = "Served and curtailed zone temperatures",
    series: Sequence[str] = tuple(TEMPERATURE_SERIES),
) -> Path:
    """Fig. 5: zone temperatures over the shaded comfort band, one row per scenario.

    Left panel: the realised end-of-period temperature of every zone drawn (one colour a
    zone; at most :data:`MAX_LINES_PER_PANEL`, the warmest when there are more). Right panel,
    for the warmest zone: the realised temperature (black) and the plan's one-step
    predictions chosen by ``series`` — served (u, dashed), curtailed (u − r, dotted), the
    worst end-of-period temperature over the plan's IL event set × the uncertainty box
    (dash-dot; it may exceed the upper bound by the event allowance α). Periods with IL
    activated are shaded grey. So no panel holds more than five lines.

    Parameters
    ----------
    scenarios : scenario label → results frame (select the displayed days, e.g. 2 days).
    path : PNG file to write; the CSV (:func:`temperature_data`, every zone and series) goes
        next to it.
    zones : zones to draw; default the warmest :data:`MAX_LINES_PER_PANEL` of each frame.
    series : prefixes of :data:`TEMPERATURE_SERIES` for the right panel.

    Returns
    -------
    The PNG path.
    """
    unknown = [prefix for prefix in series if prefix not in TEMPERATURE_SERIES]
    if unknown:
        raise InputError(
            "unknown temperature series",
            field="series",
            value=unknown,
            hint=f"choose from {', '.join(TEMPERATURE_SERIES)}",
        )
    data = temperature_data(scenarios, zones)
    drawn = list(zones) if zones is not None else warmest_zones(scenarios)
    detail = warmest_zones(scenarios, 1)[0] if zones is None else drawn[0]
    figure, axes = new_figure(len(scenarios), 2, sharex="row", sharey=True)
    for row, (label, results) in enumerate(scenarios.items()):
        left, right = axes[2 * row], axes[2 * row + 1]
        temperature_panel(left, results, drawn, f"{label}: realised, per zone")
        rows = data[(data["scenario"] == label) & (data["zone"] == detail)]
        _prediction_panel(right, results, rows, detail, series)
        right.set_title(f"{label}: zone {detail}, realised and planned", loc="left",
                        fontsize="medium")  # fmt: skip
        if row == 0:
            left.legend(fontsize="x-small", loc="upper left", ncols=2)
            right.legend(fontsize="x-small", loc="upper left")
    for ax in axes:
        if isinstance(next(iter(scenarios.values())).index, pd.DatetimeIndex):
            format_time_axis(ax, HALF_WIDTH_MAX_TICKS)
    for ax in axes[-2:]:
        ax.set_xlabel(_TIME_LABEL)
    figure.suptitle(title)
    return save_figure(figure, data, path)


def shade_activations(ax: Axes, results: pd.DataFrame, *, color: str = "0.85") -> None:
    """Shade the periods with IL activated (column ``il_activated``; nothing without it)."""
    if "il_activated" not in results.columns:
        return
    edges = period_edges(results)
    active = results["il_activated"].to_numpy(bool)
    for i, k in enumerate(np.flatnonzero(active)):
        ax.axvspan(
            edges[k],
            edges[k + 1],
            color=color,
            linewidth=0,
            label=None if i else "IL activated",
        )


# ----------------------------------------------------------------------------- Fig. 6


def power_reserve_data(scenarios: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """Long table behind :func:`plot_power_reserve`, one row per scenario and period.

    Columns: ``scenario``, ``time`` (period start, local time), ``power_kw``,
    ``power_served_kw``, ``power_curtailed_kw``, ``reserve_kw`` [kW], ``il_activated``,
    ``energy_price_sgd_per_mwh``; optional columns absent from the results are NaN. Then the
    reserve band [kW]: ``reserve_band_upper_kw`` (the served power, ``power_kw`` when the
    results lack it) and ``reserve_band_lower_kw`` = upper − ``reserve_kw`` (the power the
    building would draw if the offered reserve were called); ``is_peak``: the period of the
    frame's largest ``power_kw``.
    """
    columns = [
        "power_kw",
        "power_served_kw",
        "power_curtailed_kw",
        "reserve_kw",
        "il_activated",
        "energy_price_sgd_per_mwh",
    ]
    parts = []
    for label, results in scenarios.items():
        require_columns(results, ["power_kw", "reserve_kw"], f"results of scenario {label!r}")
        part = pd.DataFrame({"scenario": label, "time": _local_times(results.index)})
        for col in columns:
            part[col] = results[col].to_numpy() if col in results.columns else np.nan
        upper = part["power_served_kw"].to_numpy(float)
        upper = np.where(np.isnan(upper), part["power_kw"].to_numpy(float), upper)
        part["reserve_band_upper_kw"] = upper
        part["reserve_band_lower_kw"] = upper - part["reserve_kw"].to_numpy(float)
        power = part["power_kw"].to_numpy(float)
        part["is_peak"] = np.arange(len(part)) == (np.nanargmax(power) if len(part) else -1)
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def peak_day(results: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``results`` on the calendar day (local) of its largest ``power_kw``."""
    if not isinstance(results.index, pd.DatetimeIndex) or results.empty:
        return results
    day = pd.Timestamp(results.index[int(np.nanargmax(results["power_kw"].to_numpy(float)))])
    start = day.normalize()
    shown: pd.DataFrame = results[
        (results.index >= start) & (results.index < start + pd.Timedelta(days=1))
    ]
    return shown


def offers_reserve(results: pd.DataFrame) -> bool:
    """True when the run offered reserve in some period (``reserve_kw`` > 0)."""
    return "reserve_kw" in results.columns and bool((results["reserve_kw"] > 0).any())


def power_panel(ax: Axes, results: pd.DataFrame, title: str, *, mark_peak: bool = True) -> None:
    """One panel: the HVAC power drawn [kW] (steps), the reserve band it offered (served power
    down by ``reserve_kw``, filled green) and the IL activations (shaded red); the period of
    the largest power marked and labelled; the whole facility's metered power (grey) where
    the plant meters it (``facility_power_kw`` finite: EnergyPlus)."""
    edges = period_edges(results)
    power = results["power_kw"].to_numpy(float)
    if offers_reserve(results):
        data = power_reserve_data({title: results})
        ax.stairs(
            data["reserve_band_upper_kw"].to_numpy(float),
            edges,
            baseline=data["reserve_band_lower_kw"].to_numpy(float),
            fill=True,
            color="C2",
            alpha=0.35,
            label="reserve band (served → curtailed)",
        )
    shade_activations(ax, results, color="mistyrose")
    facility = results.get("facility_power_kw")
    if facility is not None and len(facility) and np.isfinite(facility.to_numpy(float)).all():
        _step(ax, edges, facility.to_numpy(float), color="0.55", label="facility power (metered)")
    _step(ax, edges, power, color="C0", label="HVAC power drawn")
    if mark_peak and len(power) and np.isfinite(power).any():
        k = int(np.nanargmax(power))
        middle = edges[k] + (edges[k + 1] - edges[k]) / 2
        ax.plot([middle], [power[k]], "v", color="C3", label=f"HVAC peak {power[k]:.1f} kW")
    ax.set_ylim(bottom=0.0)
    ax.set_ylabel("HVAC power\n[kW]")
    ax.set_title(title, loc="left", fontsize="medium")


def reserve_panel(ax: Axes, results: pd.DataFrame, title: str) -> None:
    """One panel: the reserve capacity offered [kW] (filled steps), IL activations shaded."""
    edges = period_edges(results)
    reserve = results["reserve_kw"].to_numpy(float)
    shade_activations(ax, results, color="mistyrose")
    ax.stairs(reserve, edges, fill=True, color="C2", alpha=0.6, label="reserve offered")
    ax.set_ylim(bottom=0.0, top=max(1.0, 1.15 * float(np.nanmax(reserve, initial=0.0))))
    ax.set_ylabel("reserve\n[kW]")
    ax.set_title(title, loc="left", fontsize="medium")


def _price_twin(ax: Axes, results: pd.DataFrame) -> None:
    """The energy price [SGD/MWh] on a faint right axis of ``ax``."""
    twin = ax.twinx()
    _step(
        twin,
        period_edges(results),
        results["energy_price_sgd_per_mwh"].to_numpy(float),
        color="0.6",
        linewidth=0.8,
        label="energy price (right)",
    )
    twin.set_ylabel("USEP\n[SGD/MWh]", color="0.5")


def plot_power_reserve(
    scenarios: Mapping[str, pd.DataFrame],
    path: str | Path,
    *,
    show_energy_price: bool = True,
    whole_period: bool = False,
    title: str = "HVAC power on each run's peak day, and the reserve it offered",
) -> Path:
    """Fig. 6: plant power and reserve capacity offered, per scenario.

    Each scenario gets a power panel (:func:`power_panel`: power drawn, reserve band, the
    peak marked; the energy price on a faint right axis) and, when it offers reserve at all,
    a reserve panel of its own (:func:`reserve_panel`). By default each scenario is drawn on
    its own peak day (:func:`peak_day`), where the peak-power price acts.

    Parameters
    ----------
    scenarios : scenario label → results frame.
    path : PNG file to write; the CSV (:func:`power_reserve_data` of the drawn days) goes
        next to it.
    show_energy_price : draw the energy price on a secondary axis.
    whole_period : draw every period of the frames instead of each one's peak day.

    Returns
    -------
    The PNG path.
    """
    shown = {
        label: (frame if whole_period else peak_day(frame)) for label, frame in scenarios.items()
    }
    panels = sum(1 + offers_reserve(frame) for frame in shown.values())
    figure, axes = new_figure(panels, sharex=False, panel_height_in=2.1)
    position = 0
    for label, results in shown.items():
        day = (
            f" — peak day {results.index[0]:%a %d %b}"
            if not whole_period and isinstance(results.index, pd.DatetimeIndex)
            else ""
        )
        ax = axes[position]
        power_panel(ax, results, f"{label}: power{day}")
        if show_energy_price and "energy_price_sgd_per_mwh" in results.columns:
            _price_twin(ax, results)
        ax.legend(fontsize="x-small", loc="upper left")
        position += 1
        if offers_reserve(results):
            reserve_panel(axes[position], results, f"{label}: reserve offered{day}")
            position += 1
    for ax in axes:
        if isinstance(next(iter(shown.values())).index, pd.DatetimeIndex):
            format_time_axis(ax)
    axes[-1].set_xlabel(_TIME_LABEL)
    figure.suptitle(title)
    return save_figure(figure, power_reserve_data(shown), path)


# ----------------------------------------------------------------------------- Fig. 7


def normalise_ppp_sweep(sweep: pd.DataFrame) -> pd.DataFrame:
    """The paper's Fig. 7 quantities, sorted by φ.

    ``normalised_total_cost_pct = 100 · cost_j / max_j cost`` and
    ``normalised_peak_power_pct = 100 · peak_j / max_j peak``.

    Parameters
    ----------
    sweep : (z, ≥3) frame with ``peak_price_sgd_per_kw`` [SGD/kW], ``total_cost_sgd``
        [SGD] and ``peak_power_kw`` [kW], one row per PPP value.

    Returns
    -------
    The input columns (extra ones kept) plus the two normalised ones [%].
    """
    columns = ["peak_price_sgd_per_kw", "total_cost_sgd", "peak_power_kw"]
    require_columns(sweep, columns, "PPP sweep")
    data = sweep.sort_values("peak_price_sgd_per_kw").reset_index(drop=True)
    data["normalised_total_cost_pct"] = (
        100.0 * data["total_cost_sgd"] / data["total_cost_sgd"].max()
    )
    data["normalised_peak_power_pct"] = 100.0 * data["peak_power_kw"] / data["peak_power_kw"].max()
    return data


def plot_ppp_sweep(
    sweep: pd.DataFrame,
    path: str | Path,
    *,
    title: str = "Peak reduction and cost increase under the peak-power price",
) -> Path:
    """Fig. 7: normalised total cost and normalised peak power [%] against φ [SGD/kW].

    See :func:`normalise_ppp_sweep` for the input and the definitions. The φ axis is
    logarithmic when the values span a factor :data:`LOG_AXIS_MIN_RATIO` or more.

    Returns
    -------
    The PNG path; the CSV holds :func:`normalise_ppp_sweep`'s table.
    """
    data = normalise_ppp_sweep(sweep)
    figure, (ax,) = new_figure(1)
    phi = data["peak_price_sgd_per_kw"].to_numpy(float)
    ax.plot(phi, data["normalised_total_cost_pct"], "o-", color="C3", label="normalised total cost")
    ax.plot(phi, data["normalised_peak_power_pct"], "s-", color="C0", label="normalised peak load")
    if phi.size and phi.min() > 0 and phi.max() / phi.min() >= LOG_AXIS_MIN_RATIO:
        ax.set_xscale("log")
    ax.set_xlabel("peak-power price φ [SGD/kW]")
    ax.set_ylabel("% of maximum")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    figure.suptitle(title)
    return save_figure(figure, data, path)


# ----------------------------------------------------------------------------- beyond the paper


def discomfort_data(scenarios: Mapping[str, pd.DataFrame] | pd.DataFrame) -> pd.DataFrame:
    """Discomfort [K·h] per scenario (rows) and zone (columns), plus a ``total`` column.

    Parameters
    ----------
    scenarios : either scenario label → results frame (discomfort computed per zone with
        :func:`hvacflex.kpi.discomfort_kelvin_hours`), or a precomputed DataFrame with one
        row per scenario (labels in a ``scenario`` column or the index) and either a
        ``discomfort_kelvin_hours`` column (totals) or one column per zone [K·h].
    """
    if isinstance(scenarios, pd.DataFrame):
        table = scenarios.set_index("scenario") if "scenario" in scenarios else scenarios.copy()
        if "discomfort_kelvin_hours" in table.columns:
            table = table[["discomfort_kelvin_hours"]].rename(
                columns={"discomfort_kelvin_hours": "all zones"}
            )
        table = table.drop(columns="total", errors="ignore").astype(float)
    else:
        table = pd.DataFrame(
            {label: kpi.discomfort_kelvin_hours(results) for label, results in scenarios.items()}
        ).T
    table["total"] = table.sum(axis=1)
    return table.rename_axis("scenario")


def plot_discomfort(
    scenarios: Mapping[str, pd.DataFrame] | pd.DataFrame,
    path: str | Path,
    *,
    title: str = "Thermal discomfort under the same realised disturbances",
) -> Path:
    """Bar chart of discomfort [K·h] per scenario, stacked by zone (BOPTEST ``tdis``).

    Parameters
    ----------
    scenarios : scenario label → results frame (same period and disturbances for a fair
        comparison), or a precomputed table; see :func:`discomfort_data`.
    path : PNG file to write; the CSV (:func:`discomfort_data`) goes next to it.

    Returns
    -------
    The PNG path.
    """
    data = discomfort_data(scenarios)
    zones = [col for col in data.columns if col != "total"]
    figure = Figure(figsize=(FIGURE_WIDTH_IN, max(1.6 + 0.42 * len(data), 3.2)), dpi=DPI)
    FigureCanvasAgg(figure)
    ax = figure.subplots()
    positions = np.arange(len(data))[::-1]  # the first scenario on top
    left = np.zeros(len(data))
    for i, zone in enumerate(zones):
        values = data[zone].to_numpy(float)
        ax.barh(positions, values, left=left, color=f"C{i % 10}", label=str(zone), height=0.6)
        left += values
    totals = data["total"].to_numpy(float)
    for y, total in zip(positions, totals, strict=True):
        ax.annotate(
            f" {kelvin_hours_text(total)}", (total, y), ha="left", va="center", fontsize="small"
        )
    ax.set_yticks(positions, [str(label) for label in data.index])
    ax.set_xlabel("discomfort [K·h] (time integral of the excursion outside the band)")
    ax.set_xlim(0.0, max(1.0, 1.25 * float(np.nanmax(totals, initial=0.0))))
    ax.grid(True, axis="x", alpha=0.3)
    if len(zones) > 1:
        ax.legend(fontsize="small", title="zone", loc="lower right")
    figure.suptitle(title)
    return save_figure(figure, data, path, index=True)


def kelvin_hours_text(value_kelvin_hours: float) -> str:
    """A discomfort [K·h] for a bar label: ``"0"``, ``"0.06"``, ``"2.75"``, ``"11.7"``, ``"336"``
    — three significant digits, so that 0.06 never reads "0.1"."""
    if not np.isfinite(value_kelvin_hours):
        return "–"
    if value_kelvin_hours == 0.0:
        return "0"
    return f"{value_kelvin_hours:.3g}" if value_kelvin_hours < 100 else f"{value_kelvin_hours:,.0f}"


ROBUSTNESS_COLUMNS = {
    "reserve_revenue_sgd": "reserve revenue [SGD]",
    "discomfort_kelvin_hours": "discomfort [K·h]",
    "planned_slack_share": "steps with planned slack [%]",
}
"""Columns drawn by :func:`plot_robustness_price` besides the cost (names as in
:func:`hvacflex.kpi.summary`)."""

ROBUSTNESS_COST_COLUMNS = {
    "net_cost_sgd": "net cost (energy − reserve) [SGD]",
    "energy_cost_sgd": "energy cost [SGD]",
}
"""Cost column of :func:`plot_robustness_price`: the first of these present is drawn."""


def plot_robustness_price(
    sweep: pd.DataFrame,
    path: str | Path,
    *,
    title: str = "The price of robustness",
) -> Path:
    """Cost, reserve revenue, discomfort and share of steps on slack vs uncertainty level.

    Parameters
    ----------
    sweep : one row per run with ``uncertainty_level`` (a fraction of the nominal
        disturbance: 0.5 = ±50 %, drawn in %), a cost column (``net_cost_sgd``, else
        ``energy_cost_sgd``), the :data:`ROBUSTNESS_COLUMNS` (``reserve_revenue_sgd``,
        ``discomfort_kelvin_hours``, ``planned_slack_share`` as a 0–1 share, drawn in %),
        and optionally ``controller`` (e.g. "open-loop", "closed-loop"): one line per
        controller. Other columns are kept in the CSV.
    path : PNG file to write; the CSV (the input sorted by level, stable, plus
        ``uncertainty_level_pct`` = 100 × the level, the axis) goes next to it.

    Returns
    -------
    The PNG path.
    """
    cost = [col for col in ROBUSTNESS_COST_COLUMNS if col in sweep.columns]
    require_columns(
        sweep, ["uncertainty_level", *cost[:1], *ROBUSTNESS_COLUMNS], "robustness sweep"
    )
    if not cost:
        require_columns(sweep, list(ROBUSTNESS_COST_COLUMNS), "robustness sweep")
    panels = {cost[0]: ROBUSTNESS_COST_COLUMNS[cost[0]], **ROBUSTNESS_COLUMNS}
    data = sweep.sort_values("uncertainty_level", kind="stable").reset_index(drop=True)
    data["uncertainty_level_pct"] = 100.0 * data["uncertainty_level"].astype(float)
    groups = list(data.groupby("controller", sort=False)) if "controller" in data else [("", data)]
    figure, axes = new_figure(2, 2)
    for ax, (col, label) in zip(axes, panels.items(), strict=True):
        scale = 100.0 if col == "planned_slack_share" else 1.0
        for i, (controller, rows) in enumerate(groups):
            ax.plot(
                rows["uncertainty_level_pct"].to_numpy(float),
                scale * rows[col].to_numpy(float),
                "o-",
                color=f"C{i % 10}",
                label=str(controller) or None,
            )
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        if len(groups) > 1:
            ax.legend(fontsize="small")
    for ax in axes[2:]:
        ax.set_xlabel("uncertainty level σ [% of the heat gains]")
    figure.suptitle(title)
    return save_figure(figure, data, path)
