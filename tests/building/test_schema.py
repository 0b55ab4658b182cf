"""The building file's schema: the power model's table is derived from its dataclass (one home
for its fields), and a bad table is refused naming the field, the value and the fix."""

from __future__ import annotations

import copy
import dataclasses
import tomllib
from typing import Any

import pytest

from hvacflex.building import schema
from hvacflex.building.identified import MIN_RUNNING_PERIODS, IdentifiedPower
from hvacflex.building.io import building_from_dict
from hvacflex.errors import BuildingConfigError
from hvacflex.paths import resources_dir

FITTED = {"base_kw": 1.0, "kw_per_kw_cooling": 0.3, "kw_per_k_outdoor": 0.04}


@pytest.fixture(scope="module")
def office5() -> dict[str, Any]:
    return tomllib.loads((resources_dir() / "buildings" / "office5.toml").read_text())


def _with_power_model(office5: dict[str, Any], table: object) -> dict[str, Any]:
    document = copy.deepcopy(office5)
    document["power_models"] = {"rc": table}
    return document


def test_the_power_table_has_the_dataclass_s_fields_and_defaults() -> None:
    spec_fields = schema.IdentifiedPowerSpec.model_fields
    data_fields = dataclasses.fields(IdentifiedPower)
    assert list(spec_fields) == [f.name for f in data_fields]
    for field in data_fields:
        required = field.default is dataclasses.MISSING
        assert spec_fields[field.name].is_required() == required, field.name
        if not required:
            assert spec_fields[field.name].default == field.default, field.name
    assert [n for n, f in spec_fields.items() if f.is_required()] == [
        "base_kw",
        "kw_per_kw_cooling",
        "kw_per_k_outdoor",
    ]


def test_a_valid_table_becomes_the_dataclass(office5: dict[str, Any]) -> None:
    table = {**FITTED, "kw_per_kw2_cooling": 2, "running_periods": float(MIN_RUNNING_PERIODS)}
    building = building_from_dict(_with_power_model(office5, table))
    power = building.with_power_model_for("rc").metered_power
    assert power == IdentifiedPower(**{**table, "kw_per_kw2_cooling": 2.0})
    assert isinstance(power, IdentifiedPower) and power.kw_per_kw2_cooling == 2.0


@pytest.mark.parametrize(
    ("table", "expected"),
    [
        ({**FITTED, "base_kw": "1.0"}, "'power_models.rc.base_kw': expected a finite number"),
        ({**FITTED, "occupied_kw": True}, "'power_models.rc.occupied_kw': expected a finite"),
        ({**FITTED, "running_kw": float("inf")}, "running_kw': expected a finite number (got inf)"),
        ({**FITTED, "base_kW": 2.0}, "'power_models.rc.base_kW': unknown key (got 'base_kW')"),
        ({"base_kw": 1.0, "kw_per_kw_cooling": 0.3}, "kw_per_k_outdoor': missing required field"),
        ({**FITTED, "running_periods": 20}, "running_periods': must be ≥ 96 (got 20)"),
        (3.0, "'power_models.rc': expected a table (got 3.0)"),
    ],
)
def test_a_bad_power_table_is_refused_naming_field_and_value(
    office5: dict[str, Any], table: object, expected: str
) -> None:
    with pytest.raises(BuildingConfigError) as caught:
        building_from_dict(_with_power_model(office5, table))
    assert expected in str(caught.value)


def test_an_unknown_key_is_answered_with_the_dataclass_s_keys(office5: dict[str, Any]) -> None:
    with pytest.raises(BuildingConfigError) as caught:
        building_from_dict(_with_power_model(office5, {**FITTED, "fan_kw": 1.0}))
    for field in dataclasses.fields(IdentifiedPower):
        assert f"'{field.name}'" in str(caught.value)


def test_a_field_of_another_type_is_refused_when_the_schema_is_derived(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    @dataclasses.dataclass(frozen=True)
    class WithText:
        base_kw: float
        label: str = ""

    monkeypatch.setattr(schema, "IdentifiedPower", WithText)
    with pytest.raises(TypeError, match=r"IdentifiedPower\.label"):
        schema.identified_power_fields()
