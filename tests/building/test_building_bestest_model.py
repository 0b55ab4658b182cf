"""BESTEST model extensions: layers → RC against SPEC.md, infiltration, massless layers,
radiant star, sky long-wave and angle-dependent windows (checked by hand)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from hvacflex.building.io import building_from_dict, load_building
from hvacflex.building.model import DOUBLE_CLEAR_ANGLE_MODIFIER, Building
from hvacflex.building.rc import build_network, envelope_ua_w_per_k
from hvacflex.errors import BuildingConfigError

# SPEC.md: surface-to-surface U [W/m²K] and Σ ρ c d [J/(m²K)] from its layer table
# (inside → outside: thickness, k, ρ, c).
SPEC_LAYERS = {
    ("bestest600", "wall"): [
        (0.012, 0.16, 950, 840),
        (0.066, 0.040, 12, 840),
        (0.009, 0.14, 530, 900),
    ],
    ("bestest600", "roof"): [
        (0.010, 0.16, 950, 840),
        (0.1118, 0.040, 12, 840),
        (0.019, 0.14, 530, 900),
    ],
    ("bestest600", "floor"): [(0.025, 0.14, 650, 1200), (1.003, 0.040, 0, 0)],
    ("bestest900", "wall"): [
        (0.100, 0.51, 1400, 1000),
        (0.0615, 0.040, 10, 1400),
        (0.009, 0.14, 530, 900),
    ],
    ("bestest900", "roof"): [
        (0.010, 0.16, 950, 840),
        (0.1118, 0.040, 12, 840),
        (0.019, 0.14, 530, 900),
    ],
    ("bestest900", "floor"): [(0.080, 1.13, 1400, 1000), (1.007, 0.040, 0, 0)],
}
SPEC_U_SURFACE = {"wall": 0.559, "roof": 0.334, "floor": 0.040}  # Case 600 (SPEC.md)
SPEC_FILMS = {"wall": (21.6, 1.8), "roof": (21.8, 1.7), "floor": (5.2, 3.7)}  # (out, in)
SPEC_AREAS = {"wall": 63.6, "roof": 48.0, "floor": 48.0}
SPEC_ENVELOPE_C_MJ_PER_K = {"bestest600": 2.73, "bestest900": 15.48}


@pytest.fixture(scope="module", params=["bestest600", "bestest900"])
def bestest(request: pytest.FixtureRequest, shipped_buildings_dir: Path) -> Building:
    return load_building(shipped_buildings_dir / f"{request.param}.toml")


def _load(shipped_buildings_dir: Path, name: str) -> Building:
    return load_building(shipped_buildings_dir / f"{name}.toml")


@pytest.mark.parametrize(("building", "construction"), sorted(SPEC_LAYERS))
def test_layers_to_rc_match_spec(
    shipped_buildings_dir: Path, building: str, construction: str
) -> None:
    b = _load(shipped_buildings_dir, building)
    c = b.constructions[construction]
    layers = SPEC_LAYERS[(building, construction)]
    r_layers = sum(d / k for d, k, _, _ in layers)
    c_layers = sum(d * rho * cp for d, _, rho, cp in layers)
    h_out, h_in = SPEC_FILMS[construction]
    assert c.r_material_m2k_per_w == pytest.approx(r_layers, rel=1e-12)
    assert c.u_value_w_per_m2k() == pytest.approx(1 / (1 / h_in + r_layers + 1 / h_out))
    assert c.capacitance_j_per_m2k == pytest.approx(c_layers)
    if building == "bestest600":
        assert 1 / r_layers == pytest.approx(SPEC_U_SURFACE[construction], abs=6e-4)
    # the finite-volume chain keeps Σ R and Σ C; massless insulation has no node
    capacitances, links = c.chain()
    assert sum(links) == pytest.approx(r_layers, rel=1e-12)
    assert sum(capacitances) == pytest.approx(c_layers)
    assert all(cap > 0 for cap in capacitances)


def test_network_capacitance_and_conduction_match_spec(bestest: Building) -> None:
    net = build_network(bestest)
    envelope = net.capacitance_j_per_k[1:].sum() / 1e6
    assert envelope == pytest.approx(SPEC_ENVELOPE_C_MJ_PER_K[bestest.name], abs=0.01)
    # steady state, no sun/sky/gains, without the radiant star (which lets the warm, well
    # insulated floor radiate to the walls, a little more loss): the heat to hold 20 °C at
    # 0 °C outside is UA·20 K
    zone = dataclasses.replace(bestest.zones[0], interior_radiation_w_per_m2k=None)
    no_star = build_network(dataclasses.replace(bestest, zones=(zone,)))
    d = np.zeros(len(net.channels))
    load = no_star.zone_heat_extraction_w(d, 20.0)
    with_star = net.zone_heat_extraction_w(d, 20.0)
    assert 1.0 < with_star.sum() / load.sum() < 1.05
    ua = envelope_ua_w_per_k(bestest)
    assert -load.sum() == pytest.approx(ua["total"] * 20.0, rel=1e-9)
    by_hand = sum(
        SPEC_AREAS[name]
        / (
            1 / SPEC_FILMS[name][1]
            + bestest.constructions[name].r_material_m2k_per_w
            + 1 / SPEC_FILMS[name][0]
        )
        for name in SPEC_AREAS
    )
    by_hand += 12.0 * 2.10 + 1.2 * 1006.0 * 129.6 * 0.427 / 3600
    assert ua["total"] == pytest.approx(by_hand, rel=1e-9)


def test_infiltration_conductance_by_hand(bestest: Building) -> None:
    zone = bestest.zones[0]
    # ρ c_p V ACH / 3600 = 1.2 · 1006 · (48 · 2.7) · 0.427 / 3600 = 18.55 W/K (SPEC: 18.55)
    assert zone.infiltration_w_per_k == pytest.approx(1.2 * 1006 * 129.6 * 0.427 / 3600)
    assert zone.infiltration_w_per_k == pytest.approx(18.55, abs=0.01)
    net = build_network(bestest)
    windows = 12.0 * 2.10
    assert net.outdoor_conductance_w_per_k[0] == pytest.approx(windows + zone.infiltration_w_per_k)


def test_gains_and_solar_are_conserved(bestest: Building) -> None:
    """At steady state every watt injected leaves through the boundaries: the internal gain
    fully; window solar except the lost share; surface sky loss exactly as emitted."""
    net = build_network(bestest)
    names = net.channel_names
    for channel, injected_w in (
        ("internal_gain_zone_w", 200.0),
        ("window_solar_gain_south_window_w_per_m2", 100.0 * 12.0 * (1 - 0.04454)),
    ):
        d = np.zeros(len(names))
        d[names.index(channel)] = 200.0 if channel.startswith("internal") else 100.0
        x = net.steady_state_degc(d)
        out = (net.outdoor_conductance_w_per_k * x).sum()  # outdoor air at 0 °C
        assert out == pytest.approx(injected_w, rel=1e-9)
    # radiative gains reach the surfaces: the zone-air input share is below 1 - 0.6 + ...
    gain_col = names.index("internal_gain_zone_w")
    assert net.input_w[0, gain_col] < 1.0
    assert net.input_w[:, gain_col].sum() == pytest.approx(1.0)


def test_matrices_stay_metzler_and_stable(bestest: Building) -> None:
    net = build_network(bestest)
    off = net.a_cont - np.diag(np.diag(net.a_cont))
    assert off.min() >= -1e-12
    assert np.max(np.linalg.eigvals(net.a_cont).real) < 0
    np.testing.assert_allclose(net.conductance_w_per_k, net.conductance_w_per_k.T, atol=1e-9)


def test_sky_longwave_and_roof_channels(bestest: Building) -> None:
    net = build_network(bestest)
    names = net.channel_names
    assert "solar_az0_tilt0_w_per_m2" in names  # the roof
    assert names[-2:] == ("sky_longwave_w_per_m2", "window_solar_gain_south_window_w_per_m2")
    assert not any("tilt180" in n for n in names)  # shaded raised floor: no channel
    # the south window has its own channel, so the south plane channel serves the wall only
    sky = names.index("sky_longwave_w_per_m2")
    assert np.all(net.input_w[:, sky] <= 0)
    roof = bestest.walls[[w.name for w in bestest.walls].index("roof")]
    assert roof.sky_view_factor == pytest.approx(1.0)
    floor = bestest.walls[[w.name for w in bestest.walls].index("floor")]
    assert floor.sky_view_factor == pytest.approx(0.0, abs=1e-12)


def test_angle_dependent_window_gain(bestest: Building) -> None:
    window = bestest.windows[0]
    beam = np.array([100.0, 100.0, 100.0, 0.0])
    diffuse = np.array([0.0, 0.0, 0.0, 100.0])
    angle = np.array([0.0, 60.0, 95.0, 30.0])
    gain = window.solar_gain_w_per_m2(beam, diffuse, angle)
    assert gain[0] == pytest.approx(76.9)
    assert gain[1] == pytest.approx(76.9 * 0.64 / 0.76)
    assert gain[2] == pytest.approx(0.0)
    assert gain[3] == pytest.approx(67.0)
    assert DOUBLE_CLEAR_ANGLE_MODIFIER[0] == (0.0, 1.0)


def _one_zone(**extra_zone: object) -> dict[str, object]:
    return {
        "name": "box",
        "zones": [{"name": "z", "floor_area_m2": 10.0, "height_m": 3.0, **extra_zone}],
        "constructions": {
            "wall": {
                "layers": [
                    {
                        "thickness_m": 0.1,
                        "conductivity_w_per_mk": 0.04,
                        "density_kg_per_m3": 0.0,
                        "specific_heat_j_per_kgk": 0.0,
                    },
                    {
                        "thickness_m": 0.1,
                        "conductivity_w_per_mk": 1.0,
                        "density_kg_per_m3": 2000.0,
                        "specific_heat_j_per_kgk": 1000.0,
                    },
                ],
                "inside_film_w_per_m2k": 2.0,
                "outside_film_w_per_m2k": 20.0,
                "nodes_per_layer": 1,
            }
        },
        "walls": [
            {
                "name": "w1",
                "zone": "z",
                "adjacent": "outside",
                "construction": "wall",
                "area_m2": 10.0,
                "azimuth_deg": 180.0,
            },
            {
                "name": "w2",
                "zone": "z",
                "adjacent": "adiabatic",
                "construction": "wall",
                "area_m2": 30.0,
            },
        ],
        "gains": {
            "occupancy_m2_per_person": 10.0,
            "sensible_w_per_person": 75.0,
            "latent_w_per_person": 0.0,
            "lighting_w_per_m2": 0.0,
            "equipment_w_per_m2": 0.0,
        },
        "hvac": {
            "supply_temp_degc": 13.0,
            "flow_min_kg_s": [0.0],
            "flow_max_kg_s": [1.0],
            "outdoor_air_fraction": 0.2,
            "cop": 3.0,
            "fan_coeff_kw": 0.1,
            "fan_exponent": 2.0,
        },
    }


def test_massless_layer_joins_the_link_and_u_is_kept() -> None:
    b = building_from_dict(_one_zone())
    net = build_network(b)
    assert net.n_nodes == 3  # air + one node per wall (the insulation is massless)
    # exterior wall: outside → node = 1/20 + 0.1/0.04 + 0.05; node → air = 0.05 + 1/2
    k = net.conductance_w_per_k
    assert net.outdoor_conductance_w_per_k[1] == pytest.approx(10.0 / (0.05 + 2.5 + 0.05))
    assert k[0, 1] == pytest.approx(10.0 / (0.05 + 0.5))


def test_radiant_star_exchanges_between_surfaces_only() -> None:
    plain = build_network(building_from_dict(_one_zone()))
    star = build_network(building_from_dict(_one_zone(interior_radiation_w_per_m2k=5.0)))
    # the star adds surface-to-surface coupling (w1 ↔ w2 nodes) and keeps the air films
    assert plain.conductance_w_per_k[1, 2] == 0.0
    assert star.conductance_w_per_k[1, 2] > 0.0
    assert star.conductance_w_per_k.sum(axis=1) + star.outdoor_conductance_w_per_k == pytest.approx(
        0.0, abs=1e-9
    )
    # steady state, air 20 °C, outdoor 0 °C, by hand. Plain: 10 m² / (0.05 + 2.5 + 0.05 +
    # 0.05 + 1/2). Star: the exterior wall's surface reaches the air directly (h_c A = 20 W/K)
    # and through the star (h_r A: 50 and 150 W/K in series = 37.5) and the adiabatic wall's
    # surface (h_c A = 60 W/K): 20 + 1/(1/37.5 + 1/60) W/K; in series with the wall's
    # outside → node 10/2.6 and node → surface 10/0.05 W/K.
    d = np.zeros(len(star.channels))
    plain_ua = 10.0 / (0.05 + 2.5 + 0.05 + 0.05 + 0.5)
    surface_to_air = 20.0 + 1.0 / (1 / 37.5 + 1 / 60.0)
    star_ua = 1.0 / (2.6 / 10.0 + 0.05 / 10.0 + 1.0 / surface_to_air)
    assert plain.zone_heat_extraction_w(d, 20.0)[0] == pytest.approx(-plain_ua * 20.0)
    assert star.zone_heat_extraction_w(d, 20.0)[0] == pytest.approx(-star_ua * 20.0)


@pytest.mark.parametrize(
    ("zone_extra", "wall_extra", "message"),
    [
        ({"solar_lost_fraction": 0.5}, {"interior_solar_fraction": 0.6}, "add up to"),
        ({"internal_gain_radiative_fraction": 1.5}, {}, "must be ≤ 1"),
        ({"infiltration_ach": -1.0}, {}, "must be ≥ 0"),
    ],
)
def test_bad_extension_values_are_refused(
    zone_extra: dict[str, object], wall_extra: dict[str, object], message: str
) -> None:
    data = _one_zone(**zone_extra)
    walls = data["walls"]
    assert isinstance(walls, list)
    walls[0].update(wall_extra)
    with pytest.raises(BuildingConfigError, match=message):
        building_from_dict(data)


def test_all_massless_construction_is_refused() -> None:
    data = _one_zone()
    constructions = data["constructions"]
    assert isinstance(constructions, dict)
    constructions["wall"]["layers"] = constructions["wall"]["layers"][:1]
    with pytest.raises(BuildingConfigError, match="massless"):
        building_from_dict(data)


def test_sky_view_factor_by_tilt() -> None:
    for tilt, expected in ((0.0, 1.0), (90.0, 0.5), (180.0, 0.0)):
        assert (1 + math.cos(math.radians(tilt))) / 2 == pytest.approx(expected, abs=1e-12)
