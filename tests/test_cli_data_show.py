"""``hvacflex data show``: summary text, the Fig. 2 PNG and the CSV of the series."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.building.discretize import linearize
from hvacflex.building.io import load_building
from hvacflex.cli import app
from hvacflex.constants import HORIZON_STEPS, TIMEZONE
from hvacflex.data.forecast import load_exogenous
from hvacflex.paths import resolve_building


def test_data_show_prints_summary_and_writes_fig2(tmp_path: Path) -> None:
    png = tmp_path / "fig2.png"
    result = CliRunner().invoke(
        app, ["data", "show", "--start", "2014-03-20", "--days", "1", "--fig2", str(png)]
    )
    assert result.exit_code == 0, result.output
    assert "SYNTHETIC" in result.output
    assert "energy price USEP" in result.output and "outdoor_temp_degc" in result.output
    assert "max δ" in result.output and "half-band" in result.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_data_show_reports_bad_input() -> None:
    result = CliRunner().invoke(
        app, ["data", "show", "--start", "2014-01-01T00:10"], env={"COLUMNS": "300"}
    )
    assert result.exit_code == 2
    assert "'--start'" in result.output and "must start a 30-min period" in result.output


def _csv(tmp_path: Path, start: str, days: int) -> tuple[pd.DataFrame, str]:
    path = tmp_path / "series.csv"
    result = CliRunner().invoke(
        app, ["data", "show", "--start", start, "--days", str(days), "--csv", str(path)]
    )
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(path, index_col="time")
    frame.index = pd.DatetimeIndex(pd.to_datetime(frame.index)).tz_convert(TIMEZONE)
    return frame, result.output


def test_data_show_csv_writes_the_summarised_series(tmp_path: Path) -> None:
    """One column per channel under its results-file name; the values are the ones
    load_exogenous gives the simulation (rounding of the CSV aside)."""
    frame, output = _csv(tmp_path, "2014-03-20", 1)
    assert "wrote" in output and "48 periods" in output
    b = load_building(resolve_building("office5"))
    model = linearize(b)
    exo = load_exogenous(
        model.channels,
        [z.floor_area_m2 for z in b.zones],
        b.gains,
        start="2014-03-20",
        steps=48,
        horizon_steps=HORIZON_STEPS,
    )
    assert len(frame) == 48 and frame.index[0] == pd.Timestamp("2014-03-20", tz=TIMEZONE)
    for i, channel in enumerate(model.channels):
        np.testing.assert_allclose(frame[channel.name], exo.disturbances[:48, i], rtol=1e-9)
    np.testing.assert_allclose(frame["energy_price_sgd_per_mwh"], exo.energy_price_sgd_per_mwh[:48])
    assert frame["occupied"].sum() == 20  # a Thursday, 08:00–18:00
    assert {f"comfort_upper_{z}_degc" for z in b.zone_names} <= set(frame.columns)


def test_data_show_csv_refuses_an_unwritable_path(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app,
        ["data", "show", "--days", "1", "--csv", str(tmp_path)],  # a folder
    )
    assert result.exit_code == 2
    assert "--csv" in result.output and "Traceback" not in result.output


@pytest.mark.slow
def test_data_show_csv_of_the_shipped_year_has_no_wall_above_1100(tmp_path: Path) -> None:
    """Issue 26: ``data show --start 2014-01-01 --days 365 --csv F``, every solar_*_tilt90*
    column ≤ 1,100 W/m² (≈ 30 s: the summary's margins run over every step)."""
    frame, _ = _csv(tmp_path, "2014-01-01", 365)
    walls = [c for c in frame.columns if c.startswith("solar_") and "_tilt90_" in c]
    assert len(frame) == 17_520 and len(walls) == 4
    assert frame[walls].to_numpy().max() <= 1100.0


def test_long_channel_names_keep_the_columns_aligned() -> None:
    """An angle-dependent window's channel name is longer than the default label column:
    every row's statistics start in the same column."""
    from pathlib import Path

    from typer.testing import CliRunner

    from hvacflex.cli import app

    example = Path(__file__).resolve().parents[1] / "examples" / "office5_sky_angular.toml"
    result = CliRunner().invoke(
        app, ["data", "show", "--building-file", str(example), "--days", "1"]
    )
    assert result.exit_code == 0, result.output
    rows = [line for line in result.output.splitlines() if " mean " in line]
    assert any(line.startswith("window_solar_gain_") for line in rows)
    assert len({line.index(" mean ") for line in rows}) == 1
