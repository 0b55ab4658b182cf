"""RC network: hand-computed UA, layer model, energy balance, channel order."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from building_fixtures import MINIMAL_TOML, write_building

from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.rc import build_network, envelope_ua_w_per_k


def test_office5_envelope_ua_by_hand(office5: Building) -> None:
    # exterior wall: R_se 0.04 + render 0.015/0.72 + concrete 0.15/1.4 + wool 0.025/0.04
    # + gypsum 0.0125/0.16 + R_si 0.13
    r_wall = 0.04 + 0.015 / 0.72 + 0.15 / 1.4 + 0.025 / 0.04 + 0.0125 / 0.16 + 0.13
    ua_walls = 4 * 64.8 / r_wall
    ua_windows = 4 * 64.8 * 3.0
    ua = envelope_ua_w_per_k(office5)
    assert ua["walls"] == pytest.approx(ua_walls, rel=1e-3)
    assert ua["windows"] == pytest.approx(ua_windows)
    assert ua["total"] == pytest.approx(ua_walls + ua_windows, rel=1e-3)
    assert ua["total"] == pytest.approx(1036.5, abs=0.5)


def test_steady_state_conduction_load_equals_ua_times_delta_t(office5: Building) -> None:
    net = build_network(office5)
    d = np.zeros(len(net.channels))
    d[0] = 34.0  # outdoor 34 °C, no sun, no gains; zones held at 24 °C
    load = net.zone_heat_extraction_w(d, 24.0)
    assert load.sum() == pytest.approx(envelope_ua_w_per_k(office5)["total"] * 10.0, rel=1e-9)
    assert np.all(load[:4] > 0)


LAYERED = """
[constructions.layered]
nodes_per_layer = 3
inside_film_w_per_m2k = 8.0
outside_film_w_per_m2k = 20.0
[[constructions.layered.layers]]
thickness_m = 0.02
conductivity_w_per_mk = 0.8
density_kg_per_m3 = 1800.0
specific_heat_j_per_kgk = 840.0

[[constructions.layered.layers]]
thickness_m = 0.05
conductivity_w_per_mk = 0.035
density_kg_per_m3 = 25.0
specific_heat_j_per_kgk = 1400.0

[[constructions.layered.layers]]
thickness_m = 0.2
conductivity_w_per_mk = 1.6
density_kg_per_m3 = 2400.0
specific_heat_j_per_kgk = 1000.0
"""


def test_layer_model_u_and_c(tmp_path: Path) -> None:
    text = MINIMAL_TOML.replace(
        "[constructions.partition]", LAYERED + "\n[constructions.partition]"
    )
    text = text.replace('construction = "wall"', 'construction = "layered"')
    b = load_building(write_building(tmp_path, text))
    wall = b.walls[0]
    r_total = 1 / 8.0 + 0.02 / 0.8 + 0.05 / 0.035 + 0.20 / 1.6 + 1 / 20.0
    c_total = 0.02 * 1800 * 840 + 0.05 * 25 * 1400 + 0.20 * 2400 * 1000
    assert wall.construction.u_value_w_per_m2k("outside") == pytest.approx(1 / r_total)
    assert wall.construction.capacitance_j_per_m2k == pytest.approx(c_total)

    net = build_network(b)
    wall_nodes = [i for i, name in enumerate(net.node_names) if name.startswith("a_ext_")]
    assert len(wall_nodes) == 9  # 3 layers × 3 nodes
    assert net.capacitance_j_per_k[wall_nodes].sum() == pytest.approx(c_total * wall.area_m2)

    # steady-state U of the discretised wall: only the wall and zone a to the outside
    d = np.zeros(len(net.channels))
    d[0] = 30.0
    # zone b coupled through the partition is held at the same temperature as zone a, so only
    # the exterior wall and the window carry heat
    load = net.zone_heat_extraction_w(d, 20.0)
    expected = (wall.area_m2 / r_total + 5.0 * 3.0) * 10.0
    assert load.sum() == pytest.approx(expected, rel=1e-10)


def test_energy_balance_at_steady_state(two_zone: Building) -> None:
    """Heat in (gains, transmitted and absorbed sun, supply air) = heat out to the outdoor
    air, computed from the node temperatures alone."""
    net = build_network(two_zone)
    names = [c.name for c in net.channels]
    assert names == [
        "outdoor_temp_degc",
        "solar_az180_tilt90_w_per_m2",
        "internal_gain_a_w",
        "internal_gain_b_w",
    ]
    t_out, sun, gain_a, gain_b = 31.0, 350.0, 800.0, 1200.0
    cooling = np.array([-1500.0, -900.0])  # supply air heat into the zones [W]
    x = net.steady_state_degc([t_out, sun, gain_a, gain_b], zone_heat_w=cooling)
    t_a, t_wall = x[0], x[net.node_names.index("a_ext")]

    heat_in = gain_a + gain_b + cooling.sum() + 0.4 * 5.0 * sun + 0.5 * 15.0 * sun
    # window: U·A (T_a − T_out)
    out_window = 3.0 * 5.0 * (t_a - t_out)
    # exterior wall: massless outer surface between the node (R/2 = 1.0) and the film (1/25)
    r_half, r_film, alpha = 1.0, 0.04, 0.5
    t_surface = (alpha * sun + t_wall / r_half + t_out / r_film) / (1 / r_half + 1 / r_film)
    out_wall = 15.0 * (t_surface - t_out) / r_film
    assert heat_in == pytest.approx(out_window + out_wall, rel=1e-10)


def test_conductance_matrix_symmetric_and_a_metzler(shipped: Building) -> None:
    net = build_network(shipped)
    k = net.conductance_w_per_k
    np.testing.assert_allclose(k, k.T, atol=1e-9)
    off = net.a_cont - np.diag(np.diag(net.a_cont))
    assert off.min() >= 0.0
    # every row of K + boundary conductances sums to zero (heat flows between nodes conserve)
    boundary = net.outdoor_conductance_w_per_k + net.ground_conductance_w_per_k
    np.testing.assert_allclose(k.sum(axis=1) + boundary, 0.0, atol=1e-8)


def test_ground_channel_last_when_a_wall_touches_ground(tmp_path: Path) -> None:
    text = MINIMAL_TOML + (
        '\n[[walls]]\nname = "b_slab"\nzone = "b"\nadjacent = "ground"\n'
        'construction = "wall"\narea_m2 = 30.0\n'
    )
    b = load_building(write_building(tmp_path, text))
    net = build_network(b)
    assert net.channels[-1].kind == "ground_temp"
    col = len(net.channels) - 1
    slab = net.node_names.index("b_slab")
    # no film on the ground side: conductance A / (R/2)
    assert net.input_w[slab, col] == pytest.approx(30.0 / 1.0)


def test_a_partition_face_joins_the_radiant_star_of_the_zone_it_faces(tmp_path: Path) -> None:
    """Zone b sees the partition ``ab`` only through that partition's far face; with explicit
    long-wave exchange in b that face radiates to b's other surfaces (here an adiabatic slab),
    so the reduced network links the partition node to the slab node directly; without it
    (or without the star) they meet only through b's air. Heat is conserved either way."""
    slab = """
[[walls]]
name = "b_slab"
zone = "b"
adjacent = "adiabatic"
construction = "wall"
area_m2 = 30.0
"""
    plain = MINIMAL_TOML.replace("[[windows]]", slab + "\n[[windows]]")
    starred = plain.replace(
        'name = "b"\nfloor_area_m2 = 30.0\nheight_m = 3.0',
        'name = "b"\nfloor_area_m2 = 30.0\nheight_m = 3.0\ninterior_radiation_w_per_m2k = 5.1\n'
        "internal_gain_radiative_fraction = 0.5",
    )
    assert starred != plain
    nets = []
    for name, text in (("plain", plain), ("starred", starred)):
        folder = tmp_path / name
        folder.mkdir()
        nets.append(build_network(load_building(write_building(folder, text))))
    for net, linked in zip(nets, (False, True), strict=True):
        k = net.conductance_w_per_k
        i, j = net.node_names.index("ab"), net.node_names.index("b_slab")
        assert bool(k[i, j] > 1e-9) is linked
        # steady state: every node balances, and the heat put in leaves to the outdoor air
        d = np.array([30.0, 200.0, 500.0, 900.0])
        x = net.steady_state_degc(d)
        forcing = net.input_w @ d
        assert np.allclose(k @ x + forcing, 0.0, atol=1e-6)
        out_w = float(net.outdoor_conductance_w_per_k @ (x - d[0]))
        absorbed_w = d[1] * (0.4 * 5.0 + 0.5 * 15.0) - d[1] * float(net.solar_direct_loss_m2[1])
        assert out_w == pytest.approx(d[2] + d[3] + absorbed_w, rel=1e-9)
