"""office15, the shipped 3-storey 15-zone office: hand checks as for office5
(docs/explanation/buildings.md).

It is a resource, not a module; these tests check the numbers docs/explanation/buildings.md gives
for it: envelope UA by hand, the steady-state energy balance across the slabs, the design load per
m² and flows against office5's, the discrete model's sign conditions and the plant against an
ODE solver.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hvacflex.building.discretize import linearize
from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.building.rc import build_network, envelope_ua_w_per_k
from hvacflex.building.summary import design_disturbance, summarize

R_SI, R_SE = 0.13, 0.04  # inside / outside films [m²K/W] (ISO 6946)
R_WALL = R_SE + 0.015 / 0.72 + 0.15 / 1.4 + 0.025 / 0.04 + 0.0125 / 0.16 + R_SI
R_ROOF = R_SE + 0.05 / 1.0 + 0.075 / 0.034 + 0.15 / 1.4 + 0.01 / 0.06 + R_SI
R_GROUND = 0.3 / 1.2 + 0.15 / 1.4 + 0.01 / 0.06 + R_SI  # no film on the ground side
PLATE_M2 = 1296.0


@pytest.fixture(scope="module")
def office15(shipped_buildings_dir: Path) -> Building:
    return load_building(shipped_buildings_dir / "office15.toml")


@pytest.fixture(scope="module")
def office5(shipped_buildings_dir: Path) -> Building:
    return load_building(shipped_buildings_dir / "office5.toml")


def test_geometry_three_office5_floors(office15: Building, office5: Building) -> None:
    assert len(office15.zones) == 15 and office15.floor_area_m2 == pytest.approx(3 * PLATE_M2)
    for storey in (1, 2, 3):
        names = [f"{z.name}_{storey}" for z in office5.zones]
        areas = {z.name: z.floor_area_m2 for z in office15.zones}
        assert [areas[n] for n in names] == [z.floor_area_m2 for z in office5.zones]
    assert 1 / R_ROOF <= 0.5  # docs/explanation/model.md §1: roof U ≤ 0.5 W/m²K


def test_envelope_ua_by_hand(office15: Building) -> None:
    ua = envelope_ua_w_per_k(office15)
    facades = 3 * 4 * 64.8 / R_WALL
    assert ua["walls"] == pytest.approx(facades + PLATE_M2 / R_ROOF, rel=1e-3)
    assert ua["windows"] == pytest.approx(3 * 4 * 64.8 * 3.0)
    assert ua["ground"] == pytest.approx(PLATE_M2 / R_GROUND, rel=1e-3)


def test_steady_state_energy_balance_through_the_slabs(office15: Building) -> None:
    """Zones at 24 °C, outdoor 34 °C, ground 24 °C: the load is the façade, window and roof
    UA × 10 K, carried by the top storey's roof on top of the per-storey façade load; the
    intermediate slabs carry nothing between zones at one temperature."""
    net = build_network(office15)
    kinds = [ch.kind for ch in net.channels]
    d = np.zeros(len(net.channels))
    d[kinds.index("outdoor_temp")] = 34.0
    d[kinds.index("ground_temp")] = 24.0
    load = net.zone_heat_extraction_w(d, 24.0)
    ua = envelope_ua_w_per_k(office15)
    assert load.sum() == pytest.approx((ua["walls"] + ua["windows"]) * 10.0, rel=1e-9)
    per_storey = load.reshape(3, 5)
    np.testing.assert_allclose(per_storey[0], per_storey[1], rtol=1e-9)  # no roof below
    roof_share = (per_storey[2] - per_storey[1]).sum()
    assert roof_share == pytest.approx(PLATE_M2 / R_ROOF * 10.0, rel=1e-3)
    d[kinds.index("ground_temp")] = 34.0  # now the ground slab adds its UA × 10 K
    ground_load = net.zone_heat_extraction_w(d, 24.0).sum() - load.sum()
    assert ground_load == pytest.approx(ua["ground"] * 10.0, rel=1e-9)


def test_sized_like_office5_per_m2(office15: Building, office5: Building) -> None:
    big, small = summarize(office15), summarize(office5)
    assert all(z.design_flow_kg_s <= z.flow_max_kg_s for z in big.zones)
    ratio = (big.design_zone_load_kw / big.floor_area_m2) / (
        small.design_zone_load_kw / small.floor_area_m2
    )
    assert 1.0 < ratio < 1.15  # the roof adds load, the floors are office5's
    assert big.outdoor_air_at_ventilation_flow_l_s >= big.ventilation_need_l_s
    # one fan over 3 × office5's flows costs 3 × office5's fan power
    flows = np.asarray(office5.hvac.flow_max_kg_s)
    fan5 = office5.hvac.fan_coeff_kw * flows.sum() ** office5.hvac.fan_exponent
    fan15 = office15.hvac.fan_coeff_kw * (3 * flows.sum()) ** office15.hvac.fan_exponent
    assert fan15 == pytest.approx(3 * fan5, rel=1e-4)


def test_discrete_model_meets_the_sign_conditions(office15: Building) -> None:
    lm = linearize(office15)
    assert lm.a.min() >= -1e-12
    assert np.max(np.abs(np.linalg.eigvals(lm.a))) < 1.0
    assert lm.b[:, np.asarray(office15.reserve_mask)].max() <= 0.0
    # storeys are coupled: a zone's air responds to the zone above it within one step
    north_1, north_2 = lm.node_names.index("north_1"), lm.node_names.index("north_2")
    assert lm.a[north_2, north_1] > 1e-4


def test_plant_step_matches_ode_solver(office15: Building) -> None:
    plant = NonlinearPlant(office15)
    rng = np.random.default_rng(7)
    d = design_disturbance(office15) * rng.uniform(0.3, 1.0, size=plant.nd)
    x0 = 20.0 + 10.0 * rng.uniform(size=plant.n)
    low = np.asarray(office15.hvac.flow_min_kg_s)
    flow = low + rng.uniform(size=plant.m) * (np.asarray(office15.hvac.flow_max_kg_s) - low)
    sol = solve_ivp(
        lambda _t, y: plant.derivative(y, flow, d), (0.0, 1800.0), x0, rtol=1e-11, atol=1e-11
    )
    np.testing.assert_allclose(plant.step(x0, flow, d), sol.y[:, -1], atol=1e-7)


DOCS_BUILDINGS = Path(__file__).parents[2] / "docs" / "explanation" / "buildings.md"


def test_docs_figures_match_building_show(office15: Building) -> None:
    """The numbers docs/explanation/buildings.md quotes for office15 are the ones `building show`
    prints."""
    text = DOCS_BUILDINGS.read_text(encoding="utf-8").split("## `office15`")[1]
    s = summarize(office15)

    def number(pattern: str) -> float:
        match = re.search(pattern, text)
        assert match is not None, f"docs/explanation/buildings.md no longer says {pattern!r}"
        return float(match.group(1).replace(",", ""))

    assert number(r"zone sensible \*\*([\d.]+) kW") == round(s.design_zone_load_kw, 1)
    assert number(r"coil \*\*([\d.]+) kW") == round(s.design_coil_load_kw, 1)
    assert number(r"electric ([\d.]+) kW") == round(s.design_power_kw, 1)
    assert number(r"Slowest mode (\d+) h") == round(s.time_constants_h[-1])
    assert number(r"ventilation flow ([\d,]+) L/s ≥") == round(
        s.outdoor_air_at_ventilation_flow_l_s
    )
    assert number(r"≥ the ([\d,]+) L/s needed") == round(s.ventilation_need_l_s)


def test_cli_building_show_office15() -> None:
    from typer.testing import CliRunner

    from hvacflex.cli import app

    result = CliRunner().invoke(app, ["building", "show", "office15"])
    assert result.exit_code == 0, result.output
    assert "15 zones, 59 nodes" in result.output and "A ≥ 0 elementwise" in result.output
