"""The sensitivity and seed-spread figures: written with the data behind them."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hvacflex.errors import DataError
from hvacflex.report.plots import csv_path
from hvacflex.report.sensitivity_plots import (
    SPREAD_PANELS,
    plot_reserve_sensitivity,
    plot_seed_spread,
)


def test_reserve_sensitivity_figure_and_its_csv(tmp_path: Path) -> None:
    points = pd.DataFrame(
        [
            {
                "scenario": letter,
                "reserve_price_scale": scale,
                "reserve_price_correlation": rho,
                "revenue_share": 0.001 * scale * (1 + rho),
            }
            for letter in ("a", "b", "c")
            for scale in (7.5, 15.0, 30.0)
            for rho in (0.0, 1.0)
        ]
    )
    png = plot_reserve_sensitivity(points, tmp_path / "sensitivity.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = pd.read_csv(csv_path(png))
    assert len(data) == len(points)
    pd.testing.assert_series_equal(data["revenue_share"], points["revenue_share"])


def test_seed_spread_figure_and_its_csv(tmp_path: Path) -> None:
    runs = pd.DataFrame(
        [
            {"scenario": letter}
            | {key: float(i + seed) for i, (key, _) in enumerate(SPREAD_PANELS)}
            for letter in ("a", "b", "c")
            for seed in range(5)
        ]
    )
    png = plot_seed_spread(runs, tmp_path / "spread.png")
    assert png.stat().st_size > 0
    assert list(pd.read_csv(csv_path(png)).columns) == ["scenario", *(k for k, _ in SPREAD_PANELS)]


def test_missing_columns_are_named() -> None:
    with pytest.raises(DataError, match="lacks required columns") as info:
        plot_reserve_sensitivity(pd.DataFrame({"scenario": ["a"]}), "unused.png")
    assert "revenue_share" in str(info.value.field)
