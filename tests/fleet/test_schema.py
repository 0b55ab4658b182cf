from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from hvacflex.config.presets import PRODUCT_RESERVE
from hvacflex.errors import BuildingConfigError
from hvacflex.fleet.agent import BuildingAgent, FleetSettings
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
    # the chiller is sized to the floor like the air flows (office5: 180 kW for 1,296 m²)
    for b in fleet.buildings:
        chiller, area = b.building.hvac.chiller, b.building.floor_area_m2
        assert chiller is not None
        assert chiller.capacity_kw / area == pytest.approx(180.0 / 1296.0, rel=0.01)
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


def test_reserve_defaults_to_the_product_event_model(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    del doc["reserve"]  # a fleet file without [reserve] gets the product's contract
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    config = fleet.spec.reserve.config()
    assert config.event_max_steps == PRODUCT_RESERVE["event_max_steps"]
    assert config.event_allowance_k == PRODUCT_RESERVE["event_allowance_k"]
    assert config.event_recovery_steps == PRODUCT_RESERVE["event_recovery_steps"]
    settings = FleetSettings.of(fleet, "2014-03-03", 1)
    assert settings.il_events == config
    # every building's controller builds event-model problems with these settings
    agent = BuildingAgent(fleet.buildings[0], 0, settings)
    agent.begin_step()
    assert agent.problem.il_event_max_steps == config.event_max_steps
    assert agent.problem.il_event_allowance_kelvin == config.event_allowance_k
    assert agent.problem.il_event_recovery_steps == config.event_recovery_steps
    assert agent.control.allowance_carry_steps == 0


def test_whole_horizon_reserve_and_its_errors(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    doc["reserve"] = {"enabled": True, "event_max_steps": 0}
    with pytest.raises(FleetConfigError, match=r"reserve.*allowance"):
        load_fleet(write_fleet(doc, tmp_path / "a.toml"))
    doc["reserve"].update(event_allowance_k=0.0, event_recovery_steps=0)
    config = load_fleet(write_fleet(doc, tmp_path / "b.toml")).spec.reserve.config()
    assert config.event_max_steps is None and config.event_allowance_k == 0.0
    doc["reserve"] = {"event_max_steps": -1}
    with pytest.raises(FleetConfigError, match=r"reserve\.event_max_steps"):
        load_fleet(write_fleet(doc, tmp_path / "c.toml"))


@pytest.mark.parametrize(
    ("key", "value", "field"),
    [
        ("initial_temp_degc", -500.0, "initial_temp_degc"),
        ("comfort_occupied_degc", [200.0, 300.0], "comfort_occupied_degc"),
    ],
)
def test_impossible_temperatures_are_refused(
    tmp_path: Path, key: str, value: object, field: str
) -> None:
    doc = generate_fleet(2, 1)
    doc["buildings"][1][key] = value
    path = write_fleet(doc, tmp_path / "f.toml")
    with pytest.raises(FleetConfigError, match=rf"buildings\[1\]\.{field}"):
        load_fleet(path)


def test_generate_caps_the_number_of_buildings() -> None:
    from hvacflex.errors import ConfigError
    from hvacflex.fleet.generate import MAX_FLEET_BUILDINGS

    with pytest.raises(ConfigError, match=r"field 'buildings'.*1 … 1000"):
        generate_fleet(MAX_FLEET_BUILDINGS + 1, 1)
