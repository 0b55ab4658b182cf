"""The identified-model file: written, read back equal, refused when invalid."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hvacflex.building.identified import IdentifiedIdleAir, IdentifiedValidity
from hvacflex.building.io import load_building
from hvacflex.building.rc import build_network
from hvacflex.errors import BuildingConfigError, ConfigError
from hvacflex.identify.model_file import (
    IdentifiedModel,
    identifier,
    load_identified_model,
    write_identified_model,
)


def test_a_written_model_reads_back_equal(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    model = identified_model
    loaded = load_identified_model(write_identified_model(model, tmp_path / "model.toml"))
    assert loaded.zones == model.zones and loaded.energyplus_zones == model.energyplus_zones
    np.testing.assert_array_equal(loaded.parameters.zone, model.parameters.zone)
    np.testing.assert_array_equal(loaded.parameters.couplings, model.parameters.couplings)
    assert loaded.boundaries == ("PLENUM-1",) and loaded.parameters.boundaries == 1
    np.testing.assert_array_equal(
        loaded.parameters.boundary_ua_kw_per_k, model.parameters.boundary_ua_kw_per_k
    )
    np.testing.assert_array_equal(
        loaded.parameters.boundary_couplings, model.parameters.boundary_couplings
    )
    assert loaded.power == model.power and loaded.provenance == model.provenance
    assert loaded.air == model.air and loaded.boundary_nodes == model.boundary_nodes


def test_the_model_is_a_building_file_with_the_fitted_network(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    model = identified_model
    building = load_building(write_identified_model(model, tmp_path / "model.toml"))
    assert building.zone_names == ("space1_1", "space2_1")
    assert [z.energyplus_zone for z in building.zones] == ["SPACE1-1", "Space2-1"]
    assert building.hvac.flow_max_kg_s == (0.6, 0.9) and building.hvac.supply_temp_degc == 13.5
    network = build_network(building)
    # air, mass and the plenum's node; capacitances in J/K from the file's kJ/K
    np.testing.assert_allclose(
        network.capacitance_j_per_k, [8.0e5, 1.2e6, 3.0e7, 6.0e7, 3.0e5], rtol=1e-12
    )
    # the plenum's node couples to both zones with the fitted conductances [W/K]
    np.testing.assert_allclose(network.conductance_w_per_k[4, :2], [500.0, 250.0])


def test_zone_names_become_lower_case_identifiers() -> None:
    assert identifier("SPACE1-1") == "space1_1"
    assert identifier("Core Zone") == "core_zone"
    assert identifier("1st floor") == "zone_1st_floor"


def test_a_negative_capacitance_is_refused_naming_the_field(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    path = write_identified_model(identified_model, tmp_path / "model.toml")
    text = path.read_text(encoding="utf-8").replace(
        "c_air_kj_per_k = 800.0", "c_air_kj_per_k = -8.0"
    )
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as caught:
        load_identified_model(path)
    assert caught.value.field == "identified.zones.space1_1.c_air_kj_per_k"
    assert caught.value.value == -8.0


def test_a_coupling_to_an_unknown_zone_is_refused(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    path = write_identified_model(identified_model, tmp_path / "model.toml")
    text = path.read_text(encoding="utf-8").replace('["space1_1", "space2_1"]', '["space1_1", "x"]')
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match="unknown zone"):
        load_identified_model(path)


def test_floor_areas_are_written_per_zone_and_read_back(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    model = replace(identified_model, floor_areas_m2=(99.16, 42.73))
    path = write_identified_model(model, tmp_path / "model.toml")
    text = path.read_text(encoding="utf-8")
    assert text.count("floor_area_m2 = ") == 2  # the zones' only: the plenum carries none
    assert load_identified_model(path).floor_areas_m2 == (99.16, 42.73)
    building = load_building(path)
    assert building.floor_area_m2 == pytest.approx(99.16 + 42.73)
    assert [z.floor_area_m2 for z in building.zones] == [99.16, 42.73]


def test_a_model_without_floor_areas_has_a_floor_area_that_is_not_a_number(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    path = write_identified_model(identified_model, tmp_path / "model.toml")
    assert "floor_area_m2" not in path.read_text(encoding="utf-8")
    assert load_identified_model(path).floor_areas_m2 is None
    assert np.isnan(load_building(path).floor_area_m2)  # not 2 m² of nominal zones


def test_a_floor_area_on_some_zones_only_is_refused_naming_the_zone(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    path = write_identified_model(
        replace(identified_model, floor_areas_m2=(99.16, 42.73)), tmp_path / "model.toml"
    )
    text = path.read_text(encoding="utf-8").replace("floor_area_m2 = 42.73\n", "", 1)
    path.write_text(text, encoding="utf-8")
    with pytest.raises(BuildingConfigError) as caught:
        load_building(path)
    assert caught.value.field == "zones[1].floor_area_m2"


def test_the_validity_range_is_written_and_read_back(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    validity = IdentifiedValidity((23.1, 22.8), (29.5, 30.2), 24.0, 33.5)
    path = write_identified_model(replace(identified_model, validity=validity), tmp_path / "m.toml")
    assert "[identified.validity]" in path.read_text(encoding="utf-8")
    assert load_identified_model(path).validity == validity
    rc = load_building(path).identified
    assert rc is not None and rc.validity == validity
    text = path.read_text(encoding="utf-8").replace(
        "outdoor_temp_min_degc = 24.0", "outdoor_temp_min_degc = 40.0"
    )
    path.write_text(text, encoding="utf-8")
    with pytest.raises(BuildingConfigError) as caught:
        load_building(path)
    assert caught.value.field == "identified.validity.outdoor_temp_min_degc"


def test_the_idle_air_is_written_and_read_back_and_bad_hours_are_refused(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    night = tuple(p < 12 or p >= 40 for p in range(48))
    fan_only = (night,) * 5 + ((True,) * 48,) * 2
    idle = IdentifiedIdleAir(fan_only=fan_only, fan_only_difference_k=(-0.8, -0.9))
    path = write_identified_model(replace(identified_model, idle_air=idle), tmp_path / "m.toml")
    text = path.read_text(encoding="utf-8")
    assert '"monday" = ["00:00-06:00", "20:00-24:00"]' in text
    assert '"sunday" = ["00:00-24:00"]' in text
    assert load_identified_model(path).idle_air == idle
    rc = load_building(path).identified
    assert rc is not None and rc.idle_air == idle
    for old, new, field in (
        ('"monday" = ', '"mondays" = ', "identified.idle_air.fan_only_hours.mondays"),
        ('"00:00-06:00"', '"06:00-00:00"', "identified.idle_air.fan_only_hours.monday"),
        ('"00:00-06:00"', '"00:00-06:15"', "identified.idle_air.fan_only_hours.monday"),
        ('"space2_1" = -0.9', '"space3_1" = -0.9', "identified.idle_air.fan_only_difference_k"),
    ):
        path.write_text(text.replace(old, new, 1), encoding="utf-8")
        with pytest.raises(BuildingConfigError) as caught:
            load_building(path)
        assert caught.value.field.startswith(field), caught.value.field


def test_a_units_per_zone_fan_only_flow_is_written_and_read_back_and_checked(
    identified_model: IdentifiedModel, tmp_path: Path
) -> None:
    """``fan_only_flow_kg_s``: optional, every zone when given, non-negative."""
    day = tuple(12 <= p < 44 for p in range(48))
    idle = IdentifiedIdleAir(
        fan_only=(day,) * 5 + ((False,) * 48,) * 2,
        fan_only_difference_k=(-0.8, -0.7),
        fan_only_flow_kg_s=(0.72, 0.5),
    )
    path = write_identified_model(replace(identified_model, idle_air=idle), tmp_path / "m.toml")
    text = path.read_text(encoding="utf-8")
    assert '"saturday" = []' in text and "fan_only_flow_kg_s" in text
    assert load_identified_model(path).idle_air == idle
    rc = load_building(path).identified
    assert rc is not None and rc.idle_air == idle
    for old, new, field in (
        ('"space2_1" = 0.5', '"space3_1" = 0.5', "identified.idle_air.fan_only_flow_kg_s"),
        ('"space2_1" = 0.5', '"space2_1" = -0.5', "identified.idle_air.fan_only_flow_kg_s"),
    ):
        assert old in text
        path.write_text(text.replace(old, new, 1), encoding="utf-8")
        with pytest.raises(BuildingConfigError) as caught:
            load_building(path)
        assert caught.value.field.startswith(field), caught.value.field
