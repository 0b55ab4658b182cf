"""Loading and validating building TOML files."""

from __future__ import annotations

from pathlib import Path

import pytest
from building_fixtures import MINIMAL_TOML, write_building

from hvacflex.building.io import load_building
from hvacflex.building.model import Building
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


UNREADABLE_FILES = {
    "not UTF-8": (b'name = "caf\xe9"\n', r"not UTF-8 text \(byte 0xe9 at offset 11\)"),
    "empty": (b"", "the building file is empty"),
    "blank lines only": (b"\n  \n", "the building file is empty"),
    "comments only": (b"# a building\n", r"the building file is empty \(only comments\)"),
    "not TOML": (b"\x00\x01 binary", "not valid TOML"),
}


@pytest.mark.parametrize("case", sorted(UNREADABLE_FILES))
def test_unreadable_file_names_the_file_and_the_problem(tmp_path: Path, case: str) -> None:
    content, problem = UNREADABLE_FILES[case]
    path = tmp_path / "odd.toml"
    path.write_bytes(content)
    with pytest.raises(BuildingConfigError, match=problem) as info:
        load_building(path)
    assert info.value.source == str(path)


def test_not_utf8_error_gives_the_line(tmp_path: Path) -> None:
    path = tmp_path / "latin1.toml"
    path.write_bytes(MINIMAL_TOML.replace('"two_zone"', '"zwei_räume"').encode("latin-1"))
    with pytest.raises(BuildingConfigError) as info:
        load_building(path)
    assert info.value.line == 2  # MINIMAL_TOML starts with a newline
    assert f"{path}:2:" in str(info.value)


def test_missing_file_is_a_building_config_error(tmp_path: Path) -> None:
    with pytest.raises(BuildingConfigError, match="building file not found"):
        load_building(tmp_path / "nowhere.toml")


@pytest.mark.parametrize(
    ("content", "problem"),
    [(b"name = '\xff'\n", "not UTF-8 text"), (b"", "empty"), (b"[zones\n", "not valid TOML")],
)
def test_cli_building_show_exits_2_on_unreadable_file(
    tmp_path: Path, content: bytes, problem: str
) -> None:
    from typer.testing import CliRunner

    from hvacflex.cli import app

    path = tmp_path / "odd.toml"
    path.write_bytes(content)
    result = CliRunner().invoke(app, ["building", "show", str(path)])
    assert result.exit_code == 2
    assert "odd.toml" in result.output
    assert problem in result.output
    assert "Traceback" not in result.output


def test_misspelt_key_is_reported_before_the_missing_one(tmp_path: Path) -> None:
    # renaming height_m makes it both unknown (heigth_m) and missing (height_m)
    text = _replace("height_m = 3.0\n", "heigth_m = 3.0\n")
    with pytest.raises(BuildingConfigError) as info:
        load_building(write_building(tmp_path, text))
    assert info.value.field == "zones[0].heigth_m"
    assert info.value.hint is not None and "height_m" in info.value.hint


def test_flows_as_arrays_in_zone_order(tmp_path: Path) -> None:
    text = _replace("flow_max_kg_s = { a = 0.3, b = 0.3 }", "flow_max_kg_s = [0.3, 0.4]")
    b = load_building(write_building(tmp_path, text))
    assert b.hvac.flow_max_kg_s == (0.3, 0.4)
    short = _replace("flow_max_kg_s = { a = 0.3, b = 0.3 }", "flow_max_kg_s = [0.3]")
    with pytest.raises(BuildingConfigError, match="expected 2 values") as info:
        load_building(write_building(tmp_path, short))
    assert info.value.field == "hvac.flow_max_kg_s"


@pytest.mark.parametrize(
    ("old", "new", "field", "message"),
    [
        ("area_m2 = 15.0", "area_m2 = true", "walls[0].area_m2", "expected a finite number"),
        ("area_m2 = 15.0", 'area_m2 = "15"', "walls[0].area_m2", "expected a finite number"),
        ("area_m2 = 15.0", "area_m2 = nan", "walls[0].area_m2", "expected a finite number"),
        ('name = "a"', 'name = "outside"', "zones[0].name", "invalid zone name"),
        ('name = "a"', 'name = "A"', "zones[0].name", "invalid zone name"),
        ("shgc = 0.4", "shgc = 1.4", "windows[0].shgc", "must be ≤ 1"),
        ("azimuth_deg = 180.0\n\n[gains]", "\n[gains]", "windows[0].azimuth_deg", "missing"),
    ],
)
def test_schema_errors_name_field_and_say_what_is_wrong(
    tmp_path: Path, old: str, new: str, field: str, message: str
) -> None:
    with pytest.raises(BuildingConfigError, match=message) as info:
        load_building(write_building(tmp_path, _replace(old, new)))
    assert info.value.field == field


def test_energyplus_zone_is_optional_and_read(tmp_path: Path) -> None:
    text = MINIMAL_TOML.replace('name = "b"\n', 'name = "b"\nenergyplus_zone = "SPACE2-1"\n', 1)
    building = load_building(write_building(tmp_path, text))
    assert [z.energyplus_zone for z in building.zones] == [None, "SPACE2-1"]
    empty = MINIMAL_TOML.replace('name = "b"\n', 'name = "b"\nenergyplus_zone = ""\n', 1)
    with pytest.raises(BuildingConfigError, match=r"zones\[1\]\.energyplus_zone"):
        load_building(write_building(tmp_path, empty, "empty.toml"))


def test_the_purge_is_read_in_whole_half_hours(tmp_path: Path) -> None:
    purge = _replace("[hvac]\n", "[hvac]\noutdoor_air_purge_h = 1.5\n")
    assert load_building(write_building(tmp_path, purge)).hvac.outdoor_air_purge_h == 1.5
    assert load_building(write_building(tmp_path, MINIMAL_TOML)).hvac.outdoor_air_purge_h == 0.0
    bad = _replace("[hvac]\n", "[hvac]\noutdoor_air_purge_h = 0.25\n")
    with pytest.raises(BuildingConfigError, match=r"multiple of 0\.5") as info:
        load_building(write_building(tmp_path, bad))
    assert info.value.field == "hvac.outdoor_air_purge_h"
