"""Error messages name where, what and how to fix it; the family is catchable as one."""

from __future__ import annotations

from pathlib import Path

import pytest

from hvacflex.errors import (
    EXTRA_MODULES,
    BuildingConfigError,
    ConfigError,
    DataError,
    HvacflexError,
    InputError,
    MissingExtraError,
    ProblemError,
    StoredStateError,
    has_extra,
    require_extra,
)

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def test_the_message_names_file_line_field_value_and_hint() -> None:
    error = InputError(
        "must be > 0",
        source=Path("b.toml"),
        line=3,
        field="walls[0].area_m2",
        value=-1.0,
        hint="give the area in m²",
    )
    assert (
        str(error)
        == "b.toml:3: field 'walls[0].area_m2': must be > 0 (got -1.0). Give the area in m²"
    )
    assert (error.source, error.line, error.field, error.value) == (
        "b.toml",
        3,
        "walls[0].area_m2",
        -1.0,
    )


@pytest.mark.parametrize(
    ("kwargs", "text"),
    [
        ({}, "bad"),
        ({"line": 7}, "line 7: bad"),
        ({"field": "days"}, "field 'days': bad"),
        ({"value": "x"}, "bad (got 'x')"),
        ({"value": 0}, "bad (got 0)"),  # a falsy value is still shown
        ({"hint": "use 2"}, "bad. Use 2"),
    ],
)
def test_parts_not_given_are_left_out(kwargs: dict[str, object], text: str) -> None:
    assert str(InputError("bad", **kwargs)) == text  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "kind", [ConfigError, BuildingConfigError, DataError, ProblemError, StoredStateError]
)
def test_every_input_error_is_a_value_error_and_an_hvacflex_error(
    kind: type[InputError],
) -> None:
    with pytest.raises(HvacflexError):
        raise kind("bad")
    assert issubclass(kind, ValueError) and issubclass(kind, InputError)


def test_did_you_mean_suggests_the_closest_valid_name_only_when_close() -> None:
    from hvacflex.errors import did_you_mean

    names = ["rmpc", "rmpc-ppp", "nmpc", "thermostat-25.5"]
    assert did_you_mean("rmpc-pp", names, "use one of …") == "did you mean 'rmpc-ppp'? Use one of …"
    assert did_you_mean("thermostat25.5", names, "x") == "did you mean 'thermostat-25.5'? X"
    assert did_you_mean("zzzz", names, "use one of …") == "use one of …"


def test_a_missing_extra_is_one_line_with_its_pip_install(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "uvicorn" else real(name)
    )
    assert not has_extra("service")
    with pytest.raises(MissingExtraError) as err:
        require_extra("service", "hvacflex serve")
    assert isinstance(err.value, HvacflexError) and isinstance(err.value, ImportError)
    assert str(err.value) == (
        "hvacflex serve needs the 'service' extra of hvacflex (uvicorn is not installed): "
        'pip install -e ".[service]" in the hvacflex clone'
    )
    assert (err.value.extra, err.value.missing) == ("service", "uvicorn")


def test_every_extra_named_here_is_an_extra_of_the_package_and_dev_holds_them() -> None:
    import tomllib

    extras = tomllib.loads(PYPROJECT.read_text())["project"]["optional-dependencies"]
    assert set(EXTRA_MODULES) <= set(extras)
    (in_dev,) = [r for r in extras["dev"] if r.startswith("hvacflex[")]
    held = set(in_dev.removeprefix("hvacflex[").removesuffix("]").split(","))
    assert held == set(extras) - {"dev"}  # the dev extra includes every other extra
