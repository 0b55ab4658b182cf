"""Files of the ASHRAE Standard 140 validation (the comparison table and its two figures) and
the EnergyPlus comparison's zone-air figure (:func:`plot_energyplus_zone_air`).

:func:`write_bestest_outputs` writes what ``hvacflex validate bestest`` leaves in its folder
from a :class:`hvacflex.validation.bestest.BestestResult`. Figures are drawn on
:class:`matplotlib.figure.Figure` with the Agg canvas directly, as in
:mod:`hvacflex.report.plots`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hvacflex.validation.bestest import (
    PROGRAMS,
    SUMMER_DAY,
    WINTER_DAY,
    BestestResult,
    table_markdown,
)
from hvacflex.validation.energyplus import EnergyPlusValidation

DPI = 110
"""Resolution of the PNG files [dots per inch]."""

BAR_GROUPS: tuple[tuple[str, list[str], list[str]], ...] = (
    ("Annual loads [MWh]", ["annual heating", "annual cooling"], ["600", "900"]),
    ("Peak loads [kW]", ["peak heating", "peak cooling"], ["600", "900"]),
    ("Free-float max [°C]", ["max temperature"], ["600FF", "900FF"]),
    ("Free-float min / mean [°C]", ["min temperature", "mean temperature"], ["600FF", "900FF"]),
)
"""Panels of the bar chart: (title, quantity kinds, cases); keys are ``f"{case} {kind}"``."""


def write_bestest_outputs(result: BestestResult, out_dir: Path) -> list[Path]:
    """Write ``bestest_results.csv``/``.md``, ``bestest_bars.png``,
    ``bestest_free_float_days.png`` and ``bestest_free_float_days.csv`` to ``out_dir``.

    Returns
    -------
    The written paths, in that order.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    table = result.table
    paths = [out_dir / "bestest_results.csv", out_dir / "bestest_results.md"]
    table.to_csv(paths[0], index=False, float_format="%.4f")
    paths[1].write_text(
        "# hvacflex vs ASHRAE Standard 140-2020 example results (Cases 600/900/600FF/900FF)\n\n"
        + table_markdown(table),
        encoding="utf-8",
    )
    paths.append(plot_bestest_bars(result, out_dir / "bestest_bars.png"))
    days = out_dir / "bestest_free_float_days.png"
    days_csv = out_dir / "bestest_free_float_days.csv"
    plot_free_float_days(result, days, days_csv)
    return [*paths, days, days_csv]


def plot_bestest_bars(result: BestestResult, png_path: Path) -> Path:
    """Bars of hvacflex and the six example programs per quantity, the min–max band dashed.

    Returns the PNG path.
    """
    table = result.table
    fig = Figure(figsize=(18, 5))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(BAR_GROUPS))
    colours = [f"C{j}" for j in range(len(PROGRAMS))]
    for ax, (title, kinds, case_names) in zip(axes, BAR_GROUPS, strict=True):
        keys = [f"{c} {k}" for k in kinds for c in case_names]
        rows = table.set_index("quantity").loc[keys]
        x = np.arange(len(keys))
        width = 0.8 / (len(PROGRAMS) + 1)
        for j, program in enumerate(PROGRAMS):
            ax.bar(x + (j - 3) * width, rows[program], width, color=colours[j], label=program)
        ax.bar(x + 3 * width, rows["hvacflex"], width, color="black", label="hvacflex")
        for i, (low, high) in enumerate(zip(rows["ref_min"], rows["ref_max"], strict=True)):
            ax.plot([i - 0.45, i + 0.45], [low, low], color="grey", lw=1, ls="--")
            ax.plot([i - 0.45, i + 0.45], [high, high], color="grey", lw=1, ls="--")
        ax.set_xticks(x, [k.replace(" temperature", "") for k in keys], rotation=20, fontsize=8)
        ax.set_title(title)
        ax.axhline(0.0, color="black", lw=0.5)
    axes[0].legend(fontsize=7, loc="upper right")
    fig.suptitle(
        f"hvacflex vs Standard 140-2020 example programs (dashed: min–max); "
        f"{result.n_in_range}/{len(table)} in range"
    )
    fig.tight_layout()
    fig.savefig(png_path, dpi=DPI)
    return png_path


def plot_free_float_days(result: BestestResult, png_path: Path, csv_path: Path) -> Path:
    """Hourly free-float zone temperature of 600FF and 900FF on the winter and summer day,
    with the outdoor temperature; the plotted numbers go to ``csv_path``.

    Returns the PNG path.
    """
    fig = Figure(figsize=(13, 4.5))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2, sharey=False)
    day_frames = []
    hours = np.arange(1, 25)
    for ax, (month, day) in zip(axes, (WINTER_DAY, SUMMER_DAY), strict=True):
        for case in ("600FF", "900FF"):
            h = result.cases[case].hourly
            when = pd.DatetimeIndex(h.index)
            sel = h[(when.month == month) & (when.day == day)]
            ax.plot(hours, sel["zone_temp_degc"], marker="o", label=case)
            day_frames.append(
                pd.DataFrame(
                    {
                        "case": case,
                        "hour": hours,
                        "zone_temp_degc": sel["zone_temp_degc"].to_numpy(),
                        "outdoor_temp_degc": sel["outdoor_temp_degc"].to_numpy(),
                    },
                    index=sel.index,
                )
            )
        ax.plot(hours, sel["outdoor_temp_degc"], color="grey", ls="--", label="outdoor")
        ax.set_title(f"Hourly free-float zone temperature, {month:02d}-{day:02d}")
        ax.set_xlabel("hour (local standard time, hour ending)")
        ax.set_ylabel("°C")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(png_path, dpi=DPI)
    pd.concat(day_frames).to_csv(csv_path, float_format="%.3f")
    return png_path


def plot_energyplus_zone_air(hourly: pd.DataFrame, png_path: Path, *, title: str) -> Path:
    """Hourly zone air of hvacflex and EnergyPlus, one panel per zone.

    Parameters
    ----------
    hourly : rows ``time``, ``zone``, ``hvacflex_degc``, ``energyplus_degc`` (the ``hourly``
        frame of :mod:`hvacflex.validation.energyplus`'s comparisons) [°C].
    png_path : the PNG to write.
    title : the figure's title (case and week).

    Returns the PNG path.
    """
    zones = list(dict.fromkeys(hourly["zone"]))
    fig = Figure(figsize=(12, 2.2 * len(zones) + 0.6))
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(len(zones), 1, sharex=True))
    for ax, zone in zip(axes, zones, strict=True):
        rows = hourly[hourly["zone"] == zone]
        ax.plot(rows["time"], rows["hvacflex_degc"], label="hvacflex (RC plant)")
        ax.plot(rows["time"], rows["energyplus_degc"], ls="--", label="EnergyPlus 25.2")
        ax.set_ylabel(f"{zone} [°C]")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right")
    axes[0].set_title(title)
    fig.tight_layout()
    fig.savefig(png_path, dpi=DPI)
    return png_path


def write_energyplus_outputs(result: EnergyPlusValidation, out: Path) -> list[Path]:
    """Write ``temperatures.csv``, ``temperatures_hourly.csv``, ``energy.csv`` and one
    figure per case and week (``temperatures_<case>_<start>.png``) into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    for (case, label), frame in result.hourly.groupby(["case", "start"], sort=False):
        path = out / f"temperatures_{case}_{label}.png"
        title = f"{result.building}, {case}, from {label}: hourly zone air"
        plot_energyplus_zone_air(frame, path, title=title)
        paths.append(path)
    result.temperatures.to_csv(out / "temperatures.csv", index=False, float_format="%.3f")
    result.hourly.to_csv(out / "temperatures_hourly.csv", index=False, float_format="%.3f")
    result.energy.to_csv(out / "energy.csv", index=False, float_format="%.2f")
    return [*paths, out / "temperatures.csv", out / "temperatures_hourly.csv", out / "energy.csv"]
