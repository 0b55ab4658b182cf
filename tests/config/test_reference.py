"""The scenario-key reference: generated from the schema, complete, and committed up to date."""

from __future__ import annotations

import tomllib
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Annotated, Literal, get_type_hints

import pytest
from pydantic import Field

from hvacflex.config import PRESET_NAMES, model, schema
from hvacflex.config.reference import (
    describe_type,
    plain_text,
    reference_markdown,
    table_docs,
    unit_of,
)

REFERENCE = Path(__file__).resolve().parents[2] / "docs" / "reference" / "scenario_reference.md"


def test_the_committed_reference_is_up_to_date() -> None:
    committed = REFERENCE.read_text(encoding="utf-8")
    assert committed == reference_markdown(), (
        "docs/reference/scenario_reference.md is out of date with the scenario schema: "
        "regenerate it with `hvacflex config reference --out docs/reference/scenario_reference.md`"
    )


def _domain_keys(cls: type, prefix: str = "") -> set[str]:
    """Every leaf key of the domain dataclasses, walked from their type hints (not from the
    schema the reference is generated from)."""
    out: set[str] = set()
    hints = get_type_hints(cls, vars(model))
    for f in fields(cls):
        dotted = f"{prefix}.{f.name}" if prefix else f.name
        nested = [
            t for t in (hints[f.name], *getattr(hints[f.name], "__args__", ())) if is_dataclass(t)
        ]
        if nested:
            out |= _domain_keys(nested[0], dotted)
        else:
            out.add(dotted)
    return out


def _documented_keys() -> set[str]:
    return {
        f"{table.path}.{key.key}" if table.path else key.key
        for table in table_docs()
        for key in table.keys
    }


def test_every_key_of_the_domain_objects_is_documented() -> None:
    assert _documented_keys() == _domain_keys(model.ScenarioConfig)


def test_every_key_has_a_description_and_a_unit_column() -> None:
    undocumented = [
        f"{table.path}.{key.key}"
        for table in table_docs()
        for key in table.keys
        if not key.description
    ]
    assert undocumented == [], "add an attribute docstring under these fields in schema.py"
    assert all(key.unit for table in table_docs() for key in table.keys)


def _default_document() -> dict[str, object]:
    """A scenario document that sets every key to the default the reference prints, parsed
    from the printed TOML literals."""
    lines: list[str] = []
    for table in table_docs():
        if table.path:
            lines.append(f"[{table.path}]")
        for key in table.keys:
            literal = key.default_toml
            if literal == "required":
                literal = '"2014-02-01..2014-02-07"'  # calibrate.train: no default
            if literal != "unset":
                lines.append(f"{key.key} = {literal}")
    return tomllib.loads("\n".join(lines))


def test_the_printed_defaults_are_valid_toml_and_the_schema_defaults() -> None:
    document = _default_document()
    calibrate = document["uncertainty"].pop("calibrate")  # type: ignore[union-attr]
    assert calibrate["quantile"] == 0.95  # type: ignore[index]
    parsed = schema.to_domain(schema.ScenarioSpec.model_validate(document))
    assert parsed == model.ScenarioConfig()


def test_units_come_from_the_key_names() -> None:
    assert unit_of("peak_price_sgd_per_kw") == "SGD/kW"
    assert unit_of("comfort_penalty_sgd_per_kelvin_hour") == "SGD/(K·h)"
    assert unit_of("event_allowance_k") == "K"
    assert unit_of("occupied_degc") == "°C"
    assert unit_of("horizon_steps") == "30-min periods"
    assert unit_of("time_limit_s") == "s"
    assert unit_of("relative") == "fraction"
    assert unit_of("seed") == "—"


def test_types_choices_and_ranges_are_read_from_the_annotations() -> None:
    choice = describe_type(Literal["a", "b"])
    assert (choice.text, choice.choices) == ("text", ('"a"', '"b"'))
    optional = describe_type(Annotated[int, Field(ge=1)] | None)
    assert (optional.text, optional.limits) == ("integer", ("≥ 1",))
    band = describe_type(tuple[Annotated[float, Field(gt=0, le=50)], float])
    assert band.text == "array [number, number]"
    assert band.limits == ("> 0", "≤ 50")
    table = describe_type(dict[Literal["solar"], Annotated[float, Field(ge=0)]])
    assert (table.choices, table.limits) == (('"solar"',), ("≥ 0",))


def test_docstrings_become_markdown_with_constants_filled_in() -> None:
    text = plain_text(
        "One of :data:`VALID_TIMESTEPS_PER_HOUR`, see :mod:`hvacflex.settlement`\n  and ``None``."
    )
    assert text == "One of 2, 4, 6, 10, 12, 20, 30, 60, see `hvacflex.settlement` and unset."


class _NewSpec(schema.Spec):
    """A table someone adds later."""

    commit_ahead_periods: schema.PositiveInt = 2
    """Reserve committed this many periods ahead."""
    market: Literal["nems", "other"] = "nems"
    """The market."""


class _ParentSpec(schema.Spec):
    seed: schema.NonNegativeInt = 1
    """A seed."""
    timing: _NewSpec = _NewSpec()


def test_a_new_key_or_table_is_picked_up_without_changes_to_the_generator() -> None:
    tables = {table.path: table for table in table_docs(_ParentSpec)}
    assert list(tables) == ["", "timing"]
    assert tables["timing"].description == "A table someone adds later."
    commit, market = tables["timing"].keys
    assert commit.key == "commit_ahead_periods"
    assert (commit.type_text, commit.default_toml, commit.unit) == (
        "integer",
        "2",
        "30-min periods",
    )
    assert commit.allowed == "≥ 1"
    assert commit.description == "Reserve committed this many periods ahead."
    assert market.allowed == '`"nems"`, `"other"`'


@pytest.mark.parametrize(
    "table", ["controller", "reserve", "comfort", "plant", "uncertainty.calibrate"]
)
def test_every_table_has_a_section(table: str) -> None:
    assert f"## `[{table}]`" in reference_markdown()


def test_presets_are_listed_with_their_settings() -> None:
    text = reference_markdown()
    assert (
        '| `rmpc-ppp` | `controller.robust = "tightening"`, '
        "`controller.peak_price_sgd_per_kw = 1.5`" in text
    )
    listed = [
        line.split("`")[1]
        for line in text.split("## Presets")[1].splitlines()
        if line.startswith("| `")
    ]
    assert listed == list(PRESET_NAMES)
