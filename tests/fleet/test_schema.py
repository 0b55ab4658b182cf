from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from hvacflex.errors import BuildingConfigError
from hvacflex.fleet.generate import generate_fleet, to_toml, write_fleet
from hvacflex.fleet.schema import FleetConfigError, load_fleet
from hvacflex.paths import resources_dir


def test_generate_is_heterogeneous_valid_and_seeded(tmp_path: Path) -> None:
    doc = generate_fleet(6, 11)
    assert doc == generate_fleet(6, 11)
    assert doc != generate_fleet(6, 12)
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert len(fleet.buildings) == 6
    cops = {b.building.hvac.cop for b in fleet.buildings}
    areas = {round(sum(z.floor_area_m2 for z in b.building.zones)) for b in fleet.buildings}
    assert len(cops) > 1 and len(areas) > 1
    text = (tmp_path / "f.toml").read_text()
    for key in ("feeder_limit_kw", "min_bid_mw", "[reserve]", "[ppp]"):
        assert key in text
    assert tomllib.loads(to_toml(doc)) == doc


def test_infinite_limit_round_trips(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1, feeder_limit_kw=float("inf"))
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert fleet.spec.feeder_limit_kw == float("inf")


def test_example_fleet_ships() -> None:
    fleet = load_fleet(resources_dir() / "fleets" / "example.toml")
    assert len(fleet.buildings) == 3 and fleet.spec.min_bid_mw == 0.1


def test_unknown_key_names_file_and_field(tmp_path: Path) -> None:
    path = write_fleet(generate_fleet(1, 1), tmp_path / "f.toml")
    path.write_text(path.read_text().replace("min_bid_mw", "min_bid_MW"))
    with pytest.raises(FleetConfigError, match=r"f\.toml.*min_bid_MW.*unknown key"):
        load_fleet(path)


def test_bad_building_names_the_building(tmp_path: Path) -> None:
    doc = generate_fleet(2, 1)
    doc["buildings"][1]["building"]["zones"][0]["floor_area_m2"] = -1.0
    path = write_fleet(doc, tmp_path / "f.toml")
    with pytest.raises(BuildingConfigError, match=r"buildings\[1\]\.building.*floor_area_m2"):
        load_fleet(path)


def test_limit_needs_exactly_one_form(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    doc["feeder_limit_csv"] = "limit.csv"
    path = write_fleet(doc, tmp_path / "f.toml")
    with pytest.raises(FleetConfigError, match="exactly one"):
        load_fleet(path)
