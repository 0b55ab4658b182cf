"""The figure of an identified model's fit: measured vs predicted zone air on the test days.

Drawn on :class:`matplotlib.figure.Figure` with the Agg canvas directly, as in
:mod:`hvacflex.report.plots`, from the series ``hvacflex identify fit`` writes
(``fit_predictions.csv``: ``measured_<zone>_degc``, ``predicted_24h_<zone>_degc``,
``predicted_1step_<zone>_degc``).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

DPI = 110
"""Resolution of the PNG file [dots per inch]."""
PANEL_HEIGHT_IN = 2.0
"""Height of one zone's panel [in]."""


def plot_identified_fit(predictions: pd.DataFrame, path: str | Path) -> Path:
    """One panel per zone: measured, 24-h-ahead and one-step predicted air temperature [°C].

    Parameters
    ----------
    predictions : (T, 3m) the test days' series (module docstring), index period starts.
    path : the PNG to write.
    """
    zones = [
        c[len("measured_") : -len("_degc")]
        for c in predictions.columns
        if c.startswith("measured_")
    ]
    figure = Figure(figsize=(10.0, PANEL_HEIGHT_IN * max(len(zones), 1)))
    FigureCanvasAgg(figure)
    axes = figure.subplots(len(zones), 1, sharex=True, squeeze=False)[:, 0]
    for ax, zone in zip(axes, zones, strict=True):
        ax.plot(
            predictions.index, predictions[f"measured_{zone}_degc"], "k-", lw=1.0, label="measured"
        )
        ax.plot(
            predictions.index,
            predictions[f"predicted_24h_{zone}_degc"],
            "C0-",
            lw=1.0,
            label="24 h ahead",
        )
        ax.plot(
            predictions.index,
            predictions[f"predicted_1step_{zone}_degc"],
            "C1:",
            lw=1.0,
            label="one step",
        )
        ax.set_ylabel(f"{zone} [°C]")
    axes[0].legend(loc="upper right", ncol=3, fontsize="small")
    axes[0].set_title("Identified model on the test days (EnergyPlus or BMS data, 30-min means)")
    figure.tight_layout()
    path = Path(path)
    figure.savefig(path, dpi=DPI)
    return path
