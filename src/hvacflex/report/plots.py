"""Figures of the paper (Fig. 2, 5, 6, 7) and beyond, as PNG files with their data as CSV.

Every function takes DataFrames and a PNG path, writes the figure there and the data behind
it to the same path with suffix ``.csv`` (so a figure can be checked, or redrawn, from
numbers), and returns the PNG path. Figures are drawn on :class:`matplotlib.figure.Figure`
with the Agg canvas directly: nothing here touches pyplot or the global backend.

Time axes show local wall-clock time of the results index (Asia/Singapore). Results frames
follow the *Results* table of ``docs/architecture.md``: row ``k`` is the period
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


def _new_figure(
    rows: int, cols: int = 1, *, sharex: bool = True, sharey: bool = False
) -> tuple[Figure, list[Axes]]:
    figure = Figure(figsize=(FIGURE_WIDTH_IN, max(PANEL_HEIGHT_IN * rows, 3.2)), dpi=DPI)
    FigureCanvasAgg(figure)
    grid = figure.subplots(rows, cols, sharex=sharex, sharey=sharey, squeeze=False)
    return figure, [ax for row in grid for ax in row]


def _save(figure: Figure, data: pd.DataFrame, path: str | Path, *, index: bool = False) -> Path:
    png = Path(path)
    png.parent.mkdir(parents=True, exist_ok=True)
    figure.tight_layout()
    figure.savefig(png, format="png", bbox_inches="tight")
    data.to_csv(csv_path(png), index=index)
    return png


def _require(frame: pd.DataFrame, columns: Sequence[str], what: str) -> None:
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


def _period_edges(results: pd.DataFrame) -> np.ndarray:
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


def _format_time_axis(ax: Axes) -> None:
    import matplotlib.dates as mdates

    locator = mdates.AutoDateLocator()  # type: ignore[no-untyped-call]
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
    reserve_synthetic : label the reserve series "synthetic" (docs/model.md §2: no public history).
    title : figure title; a default names the two series.

    Returns
    -------
    The PNG path. CSV columns: ``time``, ``energy_price_sgd_per_mwh``,
    ``reserve_price_sgd_per_mwh``, ``reserve_price_synthetic``.
    """
    columns = ["energy_price_sgd_per_mwh", "reserve_price_sgd_per_mwh"]
    _require(prices, columns, "price frame")
    reserve_label = "reserve (IL) price" + (" — synthetic" if reserve_synthetic else "")
    figure, (ax_energy, ax_reserve) = _new_figure(2)
    edges = _period_edges(prices)
    _step(ax_energy, edges, prices[columns[0]].to_numpy(float), color="C0", label="USEP")
    _step(ax_reserve, edges, prices[columns[1]].to_numpy(float), color="C3", label=reserve_label)
    ax_energy.set_ylabel("energy price\n[SGD/MWh]")
    ax_reserve.set_ylabel("reserve price\n[SGD/MWh]")
    ax_energy.legend(loc="upper left")
    ax_reserve.legend(loc="upper left")
    ax_reserve.set_xlabel(_TIME_LABEL)
    if isinstance(prices.index, pd.DatetimeIndex):
        _format_time_axis(ax_reserve)
    figure.suptitle(
        title
        or "Energy price (NEMS USEP) and "
        + ("synthetic reserve price" if reserve_synthetic else "reserve price")
    )
    data = prices[columns].copy()
    data["reserve_price_synthetic"] = reserve_synthetic
    return _save(figure, data.rename_axis("time"), path, index=True)


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
        ends = _period_edges(results)[1:]
        for zone in zones if zones is not None else kpi.zone_names(results):
            _require(results, [schema.TEMP_END.name(zone)], f"results of scenario {label!r}")
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


def plot_temperatures(
    scenarios: Mapping[str, pd.DataFrame],
    path: str | Path,
    *,
    zones: Sequence[str] | None = None,
    title: str = "Served and curtailed zone temperatures",
    series: Sequence[str] = tuple(TEMPERATURE_SERIES),
) -> Path:
    """Fig. 5: zone temperatures with the comfort band, one panel per scenario.

    What is drawn per zone (one colour per zone) is what the results hold:

    * ``temp_end_<zone>_degc`` (solid): the realised temperature at period end — the served
      trajectory when IL was not activated, the curtailed one when it was (activated periods
      are shaded);
    * ``temp_served_<zone>_degc`` (dashed) and ``temp_curtailed_<zone>_degc`` (dotted), when
      present: the plan's one-step prediction of the served (u) and curtailed (u − r)
      temperature at period end — the paper's X^NC and X^C;
    * ``event_worst_<zone>_degc`` (dash-dot), when present: the plan's worst end-of-period
      temperature over its IL event set × the uncertainty box (``y_event_worst``);
    * the comfort band (black steps) of the first zone drawn, and of any other zone whose
      band differs from it.

    Parameters
    ----------
    scenarios : scenario label → results frame (select the displayed days, e.g. 2 days).
    path : PNG file to write; the CSV (:func:`temperature_data`) goes next to it.
    zones : zones to draw; default all zones of each frame.
    series : prefixes of :data:`TEMPERATURE_SERIES` to draw (the CSV holds them all).

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
    figure, axes = _new_figure(len(scenarios), sharey=True)
    for ax, (label, results) in zip(axes, scenarios.items(), strict=True):
        part = data[data["scenario"] == label]
        _shade_activation(ax, results)
        first_band: np.ndarray | None = None
        for i, (zone, rows) in enumerate(part.groupby("zone", sort=False)):
            color = f"C{i % 10}"
            ends = rows["time_end"].to_numpy()
            for prefix in series:
                name = TEMPERATURE_SERIES[prefix]
                values = rows[f"{prefix}_degc"].to_numpy(float)
                if np.all(np.isnan(values)):
                    continue
                ax.plot(
                    ends,
                    values,
                    linestyle=_TEMPERATURE_STYLES[prefix],
                    color=color,
                    label=f"{zone} {name}",
                )
            band = rows[["comfort_lower_degc", "comfort_upper_degc"]].to_numpy(float)
            if first_band is None or not np.allclose(band, first_band, equal_nan=True):
                edges = _period_edges(results)
                for k, bound in enumerate(("lower", "upper")):
                    _step(
                        ax,
                        edges,
                        band[:, k],
                        color="k" if first_band is None else color,
                        linewidth=1.0,
                        label=None
                        if bound == "upper"
                        else "comfort band" + ("" if first_band is None else f" ({zone})"),
                    )
                first_band = band if first_band is None else first_band
        ax.set_title(label, loc="left", fontsize="medium")
        ax.set_ylabel("temperature\n[°C]")
        if ax is axes[0]:
            ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1].set_xlabel(_TIME_LABEL)
    if isinstance(next(iter(scenarios.values())).index, pd.DatetimeIndex):
        _format_time_axis(axes[-1])
    figure.suptitle(title)
    return _save(figure, data, path)


def _shade_activation(ax: Axes, results: pd.DataFrame) -> None:
    if "il_activated" not in results.columns:
        return
    edges = _period_edges(results)
    active = results["il_activated"].to_numpy(bool)
    labelled = False
    for k in np.flatnonzero(active):
        ax.axvspan(
            edges[k],
            edges[k + 1],
            color="0.85",
            linewidth=0,
            label=None if labelled else "IL activated",
        )
        labelled = True


# ----------------------------------------------------------------------------- Fig. 6


def power_reserve_data(scenarios: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """Long table behind :func:`plot_power_reserve`, one row per scenario and period.

    Columns: ``scenario``, ``time`` (period start, local time), ``power_kw``,
    ``power_served_kw``, ``power_curtailed_kw``, ``reserve_kw`` [kW], ``il_activated``,
    ``energy_price_sgd_per_mwh``; optional columns absent from the results are NaN. Then the
    reserve band [kW]: ``reserve_band_upper_kw`` (the served power, ``power_kw`` when the
    results lack it) and ``reserve_band_lower_kw`` = upper − ``reserve_kw`` (the power the
    building would draw if the offered reserve were called).
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
        _require(results, ["power_kw", "reserve_kw"], f"results of scenario {label!r}")
        part = pd.DataFrame({"scenario": label, "time": _local_times(results.index)})
        for col in columns:
            part[col] = results[col].to_numpy() if col in results.columns else np.nan
        upper = part["power_served_kw"].to_numpy(float)
        upper = np.where(np.isnan(upper), part["power_kw"].to_numpy(float), upper)
        part["reserve_band_upper_kw"] = upper
        part["reserve_band_lower_kw"] = upper - part["reserve_kw"].to_numpy(float)
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def plot_power_reserve(
    scenarios: Mapping[str, pd.DataFrame],
    path: str | Path,
    *,
    show_energy_price: bool = True,
    title: str = "HVAC power and reserve capacity",
) -> Path:
    """Fig. 6: plant power and reserve capacity offered, one panel per scenario.

    Draws ``power_kw`` (the power actually drawn, steps), the reserve band (filled between the
    served power and served − ``reserve_kw``: the capacity ``pᵀr`` offered, shown where it
    would be shed from), ``reserve_kw`` itself (thin steps from zero) and, on a faint right
    axis, the energy price, so that load shifting away from expensive periods is visible.

    Parameters
    ----------
    scenarios : scenario label → results frame (the displayed days).
    path : PNG file to write; the CSV (:func:`power_reserve_data`) goes next to it.
    show_energy_price : draw the energy price on a secondary axis.

    Returns
    -------
    The PNG path.
    """
    data = power_reserve_data(scenarios)
    figure, axes = _new_figure(len(scenarios), sharey=True)
    price_axes: list[Axes] = []
    for ax, (label, results) in zip(axes, scenarios.items(), strict=True):
        edges = _period_edges(results)
        band = data[data["scenario"] == label]
        ax.stairs(
            band["reserve_band_upper_kw"].to_numpy(float),
            edges,
            baseline=band["reserve_band_lower_kw"].to_numpy(float),
            fill=True,
            color="C2",
            alpha=0.4,
            label="reserve band (served → curtailed)",
        )
        _step(ax, edges, results["power_kw"].to_numpy(float), color="C0", label="power")
        _step(
            ax,
            edges,
            band["reserve_kw"].to_numpy(float),
            color="C2",
            linewidth=0.8,
            label="reserve capacity",
        )
        handles, labels = ax.get_legend_handles_labels()
        if show_energy_price and "energy_price_sgd_per_mwh" in results.columns:
            twin = ax.twinx()
            if price_axes:
                twin.sharey(price_axes[0])
            price_axes.append(twin)
            _step(
                twin,
                edges,
                results["energy_price_sgd_per_mwh"].to_numpy(float),
                color="0.6",
                linewidth=0.8,
                label="energy price (right)",
            )
            twin.set_ylabel("USEP\n[SGD/MWh]", color="0.5")
            twin_handles, twin_labels = twin.get_legend_handles_labels()
            handles, labels = handles + twin_handles, labels + twin_labels
        ax.set_title(label, loc="left", fontsize="medium")
        ax.set_ylabel("power\n[kW]")
        ax.set_ylim(bottom=0.0)
        if ax is axes[0]:  # beside the panels, so that it hides no data
            ax.legend(
                handles, labels, fontsize="x-small", loc="upper left", bbox_to_anchor=(1.17, 1.0)
            )
    axes[-1].set_xlabel(_TIME_LABEL)
    if isinstance(next(iter(scenarios.values())).index, pd.DatetimeIndex):
        _format_time_axis(axes[-1])
    figure.suptitle(title)
    return _save(figure, data, path)


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
    _require(sweep, columns, "PPP sweep")
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
    figure, (ax,) = _new_figure(1)
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
    return _save(figure, data, path)


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
    figure, (ax,) = _new_figure(1)
    positions = np.arange(len(data))
    bottom = np.zeros(len(data))
    for i, zone in enumerate(zones):
        values = data[zone].to_numpy(float)
        ax.bar(positions, values, bottom=bottom, color=f"C{i % 10}", label=str(zone))
        bottom += values
    for x, total in zip(positions, data["total"].to_numpy(float), strict=True):
        ax.annotate(f"{total:.1f}", (x, total), ha="center", va="bottom", fontsize="small")
    ax.set_xticks(positions, [str(label) for label in data.index])
    ax.set_ylabel("discomfort [K·h]")
    ax.legend(fontsize="small", title="zone")
    figure.suptitle(title)
    return _save(figure, data, path, index=True)


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
    path : PNG file to write; the CSV (the input sorted by level, stable) goes next to it.

    Returns
    -------
    The PNG path.
    """
    cost = [col for col in ROBUSTNESS_COST_COLUMNS if col in sweep.columns]
    _require(sweep, ["uncertainty_level", *cost[:1], *ROBUSTNESS_COLUMNS], "robustness sweep")
    if not cost:
        _require(sweep, list(ROBUSTNESS_COST_COLUMNS), "robustness sweep")
    panels = {cost[0]: ROBUSTNESS_COST_COLUMNS[cost[0]], **ROBUSTNESS_COLUMNS}
    data = sweep.sort_values("uncertainty_level", kind="stable").reset_index(drop=True)
    groups = list(data.groupby("controller", sort=False)) if "controller" in data else [("", data)]
    figure, axes = _new_figure(2, 2)
    for ax, (col, label) in zip(axes, panels.items(), strict=True):
        scale = 100.0 if col == "planned_slack_share" else 1.0
        for i, (controller, rows) in enumerate(groups):
            ax.plot(
                100.0 * rows["uncertainty_level"].to_numpy(float),
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
        ax.set_xlabel("uncertainty level [% of nominal disturbance]")
    figure.suptitle(title)
    return _save(figure, data, path)
