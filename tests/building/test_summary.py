"""``building show``: summary numbers and text."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hvacflex.building.discretize import continuous_affine_model
from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.rc import build_network
from hvacflex.building.summary import format_summary, summarize, ventilation_warning


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


KW_PER_TON_REFRIGERATION = 3.51685
"""1 refrigeration ton (12,000 BTU/h) [kW] (ASHRAE Handbook, Fundamentals: units)."""

DOCS_BUILDINGS = Path(__file__).parents[2] / "docs" / "explanation" / "buildings.md"


def _doc_number(pattern: str) -> float:
    """The number captured by ``pattern`` in docs/explanation/buildings.md (thousands commas
    dropped)."""
    match = re.search(pattern, DOCS_BUILDINGS.read_text(encoding="utf-8"))
    assert match is not None, f"docs/explanation/buildings.md no longer says {pattern!r}"
    return float(match.group(1).replace(",", ""))


def test_docs_figures_match_building_show(office5: Building) -> None:
    """The numbers docs/explanation/buildings.md quotes for office5 are the ones `building show`
    prints."""
    s = summarize(office5)
    assert _doc_number(r"electric \*\*([\d.]+) kW\*\*") == round(s.design_power_kw, 1)
    assert _doc_number(r"zone sensible ([\d.]+) kW") == round(s.design_zone_load_kw, 1)
    per_m2 = s.design_coil_load_kw * 1000 / s.floor_area_m2
    assert _doc_number(r"\(\*\*(\d+) W/m²\*\*, design range") == round(per_m2)
    assert _doc_number(r"eigen-analysis \*\*(\d+) h\*\*") == round(s.time_constants_h[-1])
    assert _doc_number(r"`building show`: \*\*(\d+) h\*\*") == round(
        s.time_constants_min_flow_h[-1]
    )
    air = _doc_number(r"outdoor air ([\d,]+) L/s ≥")
    assert air == round(s.outdoor_air_at_ventilation_flow_l_s)
    assert _doc_number(r"L/s ≥ ([\d,]+) L/s") == round(s.ventilation_need_l_s)
    net = build_network(office5)
    ventilation = np.asarray(office5.hvac.ventilation_flow_kg_s)
    a_vent, *_ = continuous_affine_model(office5, net, ventilation, 23.0)
    slowest_h = float(np.max(-1.0 / np.linalg.eigvals(a_vent).real)) / 3600.0
    assert _doc_number(r"slowest mode drops to (\d+) h") == round(slowest_h)


def test_office5_comments_match_its_values(office5: Building) -> None:
    assert office5.source_path is not None
    text = Path(office5.source_path).read_text(encoding="utf-8")
    chiller = office5.hvac.chiller
    assert chiller is not None
    capacity = re.search(r"→ ([\d.]+) kW\s*#\s*\((\d+) RT, (\d+) W/m²\)", text)
    assert capacity is not None
    assert float(capacity.group(1)) == chiller.capacity_kw
    assert int(capacity.group(2)) == round(chiller.capacity_kw / KW_PER_TON_REFRIGERATION)
    assert int(capacity.group(3)) == round(chiller.capacity_kw * 1000 / office5.floor_area_m2)
    # the pump: EnergyPlus's template pump scaled from its 292 kW chiller to this one
    pump = re.search(r"draws ([\d.]+) kW per ([\d.]+) kW of chiller →\s*#?\s*([\d.]+) kW", text)
    assert pump is not None
    scaled = float(pump.group(1)) * chiller.capacity_kw / float(pump.group(2))
    assert float(pump.group(3)) == chiller.pump_design_kw == round(scaled, 2)
    need = re.search(r"= ([\d,]+) L/s \(", text)
    assert need is not None
    assert float(need.group(1).replace(",", "")) == round(summarize(office5).ventilation_need_l_s)
    air = re.search(r"outdoor\s*#?\s*air ([\d,]+) L/s", text)
    assert air is not None
    assert float(air.group(1).replace(",", "")) == round(
        summarize(office5).outdoor_air_at_ventilation_flow_l_s
    )
    assert "40 %" not in text and max(office5.hvac.flow_min_kg_s) == 0.0


def test_ventilation_below_requirement_is_warned(office5: Building) -> None:
    assert ventilation_warning(summarize(office5)) is None
    starved = replace(
        office5, hvac=replace(office5.hvac, outdoor_air_fraction=0.2, outdoor_air_kg_s=1.0)
    )
    s = summarize(starved)
    assert s.outdoor_air_at_ventilation_flow_l_s < s.ventilation_need_l_s
    assert "WARNING: ventilation below requirement" in format_summary(s)


def test_cli_building_show_prints_the_comfort_band() -> None:
    from typer.testing import CliRunner

    from hvacflex.cli import app
    from hvacflex.config import ScenarioConfig

    result = CliRunner().invoke(app, ["building", "show", "office5"])
    assert result.exit_code == 0, result.output
    lower, upper = ScenarioConfig().comfort.occupied_degc
    assert f"Comfort band (default scenario): {lower:g}–{upper:g} °C occupied" in result.output
    assert "WARNING" not in result.output


def test_building_show_flags_a_zone_whose_design_load_needs_more_than_its_maximum_flow(
    tmp_path: Path,
) -> None:
    from typer.testing import CliRunner

    from hvacflex.cli import app
    from hvacflex.paths import resolve_building

    shipped = resolve_building("room1").read_text(encoding="utf-8")
    assert "flow_max_kg_s = { room = 1.4 }" in shipped
    small = tmp_path / "small_room.toml"
    small.write_text(shipped.replace("{ room = 1.4 }", "{ room = 0.6 }"), encoding="utf-8")
    room = summarize(load_building(small)).zones[0]
    # the design load at 24 °C in the zone, over c_p (24 °C − supply), is more than 0.6 kg/s
    assert room.design_flow_kg_s == pytest.approx(room.design_load_kw * 1000 / (1006 * 11), 0.05)
    assert room.design_flow_kg_s > room.flow_max_kg_s == 0.6
    result = CliRunner().invoke(app, ["building", "show", str(small)], env={"COLUMNS": "120"})
    assert result.exit_code == 0, result.output
    warning = f"WARNING: zone 'room' is under-sized: its design load {room.design_load_kw:.1f} kW"
    assert warning in result.output and "maximum flow is 0.60 kg/s" in result.output
    as_shipped = CliRunner().invoke(app, ["building", "show", "room1"])
    assert "under-sized" not in as_shipped.output
