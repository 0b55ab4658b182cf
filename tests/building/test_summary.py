"""``building show``: summary numbers and text."""

from __future__ import annotations

import pytest

from hvacflex.building.model import Building
from hvacflex.building.summary import format_summary, summarize


def test_office5_summary_numbers(office5: Building) -> None:
    s = summarize(office5)
    assert s.ua_total_w_per_k == pytest.approx(1036.5, abs=0.5)
    assert s.a_nonnegative and s.b_reserve_nonpositive and s.spectral_radius < 1
    assert 100 <= s.design_coil_load_kw * 1000 / s.floor_area_m2 <= 150  # DESIGN §1 range
    assert all(z.design_flow_kg_s <= z.flow_max_kg_s for z in s.zones)
    assert s.outdoor_air_at_ventilation_flow_l_s >= s.ventilation_need_l_s
    # time constants: fastest is the zone air (minutes), slowest the core slab (days)
    assert 0.1 < s.time_constants_h[0] < 1.0 and s.time_constants_h[-1] > 24.0


def test_summary_text(room1: Building) -> None:
    text = format_summary(summarize(room1))
    for needle in ("room1", "Time constants", "Envelope UA", "A ≥ 0", "spectral radius", "wall4"):
        assert needle in text
    assert "NO" not in text


def test_cli_building_show() -> None:
    from typer.testing import CliRunner

    from hvacflex.cli import app

    result = CliRunner().invoke(app, ["building", "show", "office5"])
    assert result.exit_code == 0, result.output
    assert "office5" in result.output and "Envelope UA" in result.output
    missing = CliRunner().invoke(app, ["building", "show", "no_such_building"])
    assert missing.exit_code == 2
