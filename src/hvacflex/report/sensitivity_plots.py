"""Figures of the reserve-price sensitivity sweep and of the occupancy-seed spread.

Like :mod:`hvacflex.report.plots`: each function takes a frame and a PNG path, writes the figure
and the data behind it (same path, suffix ``.csv``) and returns the PNG path; Agg canvas only.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hvacflex.report.plots import DPI, FIGURE_WIDTH_IN, csv_path, require_columns

PANEL_HEIGHT_IN = 3.4
"""Height of the one row of panels [in]."""

SCENARIO_ORDER: tuple[str, ...] = ("a", "b", "c")
"""Panel and box order of the paper's scenarios."""

SPREAD_PANELS: tuple[tuple[str, str], ...] = (
    ("net_cost_sgd", "net cost [SGD]"),
    ("reserve_revenue_sgd", "reserve revenue [SGD]"),
    ("peak_power_kw", "peak power [kW]"),
    ("discomfort_kelvin_hours", "discomfort [K·h]"),
)
"""KPI column and axis label of each panel of :func:`plot_seed_spread`."""


def _panels(count: int, *, sharey: bool) -> tuple[Figure, list[Axes]]:
    figure = Figure(figsize=(FIGURE_WIDTH_IN, PANEL_HEIGHT_IN), dpi=DPI)
    FigureCanvasAgg(figure)
    grid = figure.subplots(1, max(count, 1), sharey=sharey, squeeze=False)
    return figure, list(grid[0])


def _save(figure: Figure, data: pd.DataFrame, path: str | Path) -> Path:
    png = Path(path)
    png.parent.mkdir(parents=True, exist_ok=True)
    figure.tight_layout()
    figure.savefig(png, format="png", bbox_inches="tight")
    data.to_csv(csv_path(png), index=False)
    return png


def plot_reserve_sensitivity(points: pd.DataFrame, path: str | Path) -> Path:
    """Revenue share [%] against the reserve-price scale, one line per correlation ρ, one
    panel per scenario.

    Parameters
    ----------
    points : one row per grid point × scenario with ``scenario``, ``reserve_price_scale``
        [SGD/MWh], ``reserve_price_correlation`` [—] and ``revenue_share`` [fraction].
    path : the PNG to write.
    """
    require_columns(
        points,
        ("scenario", "reserve_price_scale", "reserve_price_correlation", "revenue_share"),
        "sensitivity points",
    )
    letters = [s for s in SCENARIO_ORDER if s in set(points["scenario"])]
    figure, axes = _panels(len(letters), sharey=True)
    for ax, letter in zip(axes, letters, strict=False):
        rows = points[points["scenario"] == letter]
        for correlation, line in rows.groupby("reserve_price_correlation", sort=True):
            line = line.sort_values("reserve_price_scale")
            ax.plot(
                line["reserve_price_scale"],
                100.0 * line["revenue_share"].astype(float),
                marker="o",
                label=f"ρ = {correlation:g}",
            )
        ax.set_title(f"({letter})")
        ax.set_xlabel("reserve price scale [SGD/MWh] (SYNTHETIC)")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("reserve revenue / energy cost [%]")
    axes[0].legend(fontsize="small")
    columns = ["scenario", "reserve_price_scale", "reserve_price_correlation", "revenue_share"]
    return _save(figure, points[columns], path)


def plot_seed_spread(
    runs: pd.DataFrame,
    path: str | Path,
    panels: Sequence[tuple[str, str]] = SPREAD_PANELS,
) -> Path:
    """Box plots per scenario of the KPIs of ``panels`` over the week-seed runs, each run's
    value as a dot.

    Parameters
    ----------
    runs : one row per run with ``scenario`` and the ``panels``' KPI columns (units in names).
    path : the PNG to write.
    """
    require_columns(runs, ("scenario", *(key for key, _ in panels)), "seed runs")
    letters = [s for s in SCENARIO_ORDER if s in set(runs["scenario"])]
    figure, axes = _panels(len(panels), sharey=False)
    for ax, (key, label) in zip(axes, panels, strict=True):
        values = [runs.loc[runs["scenario"] == s, key].to_numpy(dtype=float) for s in letters]
        ax.boxplot(values, showfliers=False)
        ax.set_xticks(range(1, len(letters) + 1), [f"({s})" for s in letters])
        for i, v in enumerate(values, start=1):
            ax.plot(np.full(len(v), float(i)), v, ".", alpha=0.6)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    figure.suptitle("spread over representative weeks × occupancy seeds")
    return _save(figure, runs[["scenario", *(key for key, _ in panels)]], path)
