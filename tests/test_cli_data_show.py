"""``hvacflex data show``: summary text and the Fig. 2 PNG."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from hvacflex.cli import app


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
