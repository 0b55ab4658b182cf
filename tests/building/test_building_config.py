"""Loading and validating building TOML files."""

from __future__ import annotations

from pathlib import Path

import pytest
from building_fixtures import MINIMAL_TOML, write_building

from hvacflex.building.config import Building, load_building
from hvacflex.errors import BuildingConfigError


def test_minimal_building_loads(two_zone: Building) -> None:
    assert two_zone.zone_names == ("a", "b")
    assert two_zone.hvac.flow_min_kg_s == (0.05, 0.05)
    assert two_zone.hvac.reserve_zones == ("a", "b")
    assert two_zone.floor_area_m2 == pytest.approx(50.0)
    assert two_zone.source_path is not None and two_zone.source_path.name == "building.toml"


def test_office5_contract_names(office5: Building) -> None:
    assert office5.name == "office5"
    assert office5.zone_names == ("north", "east", "south", "west", "core")
    assert 1100 <= office5.floor_area_m2 <= 1500
    assert len(office5.hvac.flow_max_kg_s) == 5
    assert office5.gains.occupancy_m2_per_person == pytest.approx(10.0)
    assert office5.latitude_deg == pytest.approx(1.37)
    assert all(z.height_m > 0 for z in office5.zones)


def test_office5_ventilation_met_at_minimum_flow(office5: Building) -> None:
    # 5.5 L/s per person + 0.3 L/s/m² (DESIGN §1), air at 1.2 kg/m³
    need_kg_s = 1.2e-3 * (5.5 * office5.floor_area_m2 / 10.0 + 0.3 * office5.floor_area_m2)
    supplied = office5.hvac.outdoor_air_fraction * sum(office5.hvac.ventilation_flow_kg_s)
    assert supplied >= need_kg_s


def _replace(old: str, new: str) -> str:
    assert old in MINIMAL_TOML, old
    return MINIMAL_TOML.replace(old, new, 1)


BAD_CASES = {
    "negative capacitance": (
        _replace("capacitance_j_per_m2k = 100000.0", "capacitance_j_per_m2k = -5.0"),
        "constructions.wall.capacitance_j_per_m2k",
        "-5.0",
    ),
    "zero R": (
        _replace("r_value_m2k_per_w = 2.0", "r_value_m2k_per_w = 0.0"),
        "constructions.wall.r_value_m2k_per_w",
        "0.0",
    ),
    "zero area": (
        _replace("area_m2 = 15.0", "area_m2 = 0.0"),
        "walls[0].area_m2",
        "0.0",
    ),
    "unknown zone in adjacency": (
        _replace('adjacent = "b"', 'adjacent = "kitchen"'),
        "walls[1].adjacent",
        "'kitchen'",
    ),
    "unknown zone of a window": (
        _replace('zone = "a"\narea_m2 = 5.0', 'zone = "c"\narea_m2 = 5.0'),
        "windows[0].zone",
        "'c'",
    ),
    "disconnected zone": (
        _replace('adjacent = "b"', 'adjacent = "adiabatic"'),
        "zones[1]",
        "'b'",
    ),
    "min flow above max flow": (
        _replace("flow_min_kg_s = { a = 0.05, b = 0.05 }", "flow_min_kg_s = { a = 0.5, b = 0.05 }"),
        "hvac.flow_min_kg_s.a",
        "0.5",
    ),
    "missing field": (
        _replace("height_m = 3.0\n", ""),
        "zones[0].height_m",
        None,
    ),
    "unknown key": (
        _replace("height_m = 3.0\n", "height_m = 3.0\nheigth_m = 3.0\n"),
        "zones[0].heigth_m",
        "'heigth_m'",
    ),
    "supply air not below comfort": (
        _replace("supply_temp_degc = 13.0", "supply_temp_degc = 24.0"),
        "hvac.supply_temp_degc",
        "24.0",
    ),
    "unknown construction": (
        _replace('construction = "partition"', 'construction = "glass_brick"'),
        "walls[1].construction",
        "'glass_brick'",
    ),
    "unknown reserve zone": (
        _replace("fan_exponent = 2.5", 'fan_exponent = 2.5\nreserve_zones = ["z"]'),
        "hvac.reserve_zones",
        "'z'",
    ),
    "missing flow for a zone": (
        _replace("flow_max_kg_s = { a = 0.3, b = 0.3 }", "flow_max_kg_s = { a = 0.3 }"),
        "hvac.flow_max_kg_s.b",
        None,
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_bad_file_names_file_field_and_value(tmp_path: Path, case: str) -> None:
    text, field, value = BAD_CASES[case]
    path = write_building(tmp_path, text, name="bad_building.toml")
    with pytest.raises(BuildingConfigError) as info:
        load_building(path)
    message = str(info.value)
    assert "bad_building.toml" in message
    assert field in message
    assert info.value.field == field
    if value is not None:
        assert value in message


def test_invalid_toml_syntax_names_the_file(tmp_path: Path) -> None:
    path = write_building(tmp_path, "name = \n", name="broken.toml")
    with pytest.raises(BuildingConfigError, match=r"broken\.toml"):
        load_building(path)


def test_layered_and_rc_forms_are_exclusive(tmp_path: Path) -> None:
    text = _replace(
        "capacitance_j_per_m2k = 100000.0",
        "capacitance_j_per_m2k = 100000.0\nlayers = [{ thickness_m = 0.1, "
        "conductivity_w_per_mk = 1.0, density_kg_per_m3 = 2000.0, "
        "specific_heat_j_per_kgk = 900.0 }]",
    )
    with pytest.raises(BuildingConfigError, match=r"constructions\.wall"):
        load_building(write_building(tmp_path, text))


def test_roof_azimuth_is_normalised(tmp_path: Path) -> None:
    text = MINIMAL_TOML + (
        '\n[[walls]]\nname = "roof"\nzone = "b"\nadjacent = "outside"\nconstruction = "wall"\n'
        "area_m2 = 30.0\ntilt_deg = 0.0\nazimuth_deg = 123.0\n"
    )
    b = load_building(write_building(tmp_path, text))
    roof = b.walls[-1]
    assert (roof.azimuth_deg, roof.tilt_deg) == (0.0, 0.0)
