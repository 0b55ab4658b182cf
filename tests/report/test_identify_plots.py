"""The identified fit's figure: a PNG with one panel per zone."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.image import imread

from hvacflex.report.identify_plots import DPI, PANEL_HEIGHT_IN, plot_identified_fit


def test_one_panel_per_zone_in_a_png(tmp_path: Path) -> None:
    index = pd.date_range("2014-03-18", periods=96, freq="30min", tz="Asia/Singapore")
    wave = 24 + np.sin(np.arange(96) / 48 * 2 * np.pi)
    frame = pd.DataFrame(
        {
            f"{kind}_{zone}_degc": wave + shift
            for zone, shift in (("SPACE1-1", 0.0), ("core", 0.5))
            for kind in ("measured", "predicted_1step", "predicted_24h")
        },
        index=index,
    )
    path = plot_identified_fit(frame, tmp_path / "fit.png")
    image = imread(path)
    assert image.shape[0] == round(2 * PANEL_HEIGHT_IN * DPI)  # two zones, two panels
    assert image.std() > 0.01  # something is drawn
