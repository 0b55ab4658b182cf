"""How the ``hvacflex`` command line describes its options: the shared help texts and
click's names of value types (TEXT, INTEGER, PATH) in ``--help``."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any

import typer
import typer.core

from hvacflex.constants import DEFAULT_START
from hvacflex.dates import ISO_START_FORMS, START_EXAMPLE

if TYPE_CHECKING:
    from hvacflex.errors import HvacflexError

PRESET_HELP = (
    "Preset: nmpc, rmpc, rmpc-ppp, nmpc-no-reserve, thermostat, thermostat-25.5, "
    "trim-respond, demand-limit, gta-dr, plant-baseline, rmpc-feedback, rmpc-feedback-ppp, "
    "rmpc-output-feedback, paper-nmpc, paper-rmpc, paper-rmpc-ppp."
)
"""The presets, spelled out so that ``--help`` need not import the configuration
(``tests/test_cli.py`` checks it against ``hvacflex.config.PRESET_NAMES``)."""

START_HELP = (
    f"First day (Singapore local time), {ISO_START_FORMS}, e.g. {START_EXAMPLE}. "
    f"Default: the scenario's start ({DEFAULT_START} unless the scenario file sets one)."
)
"""Help of ``--start`` where the scenario supplies the default (``simulate``, ``sweep``)."""

_METAVARS = {
    "str": "TEXT",
    "int": "INTEGER",
    "float": "FLOAT",
    "Path": "PATH",
    "path": "PATH",
    "file": "FILE",
    "directory": "DIRECTORY",
    "bool": "BOOLEAN",
}
"""click's names of the value types, which ``--help`` shows instead of typer's ``<str>``."""
_TYPE_NAMES = re.compile(rf"\b({'|'.join(_METAVARS)})\b")


def use_readable_metavars() -> None:
    """Show value types in ``--help`` as click names them (TEXT, INTEGER, FLOAT, PATH;
    ``PATH...`` for a list) and flags without any (typer 0.2x shows ``<str>``, ``<list[Path]>``
    and ``--quick <bool>``, which reads as if the flag took a value)."""
    typer_display_type = typer.core._TyperParameter.display_type

    def display_type(self: typer.core._TyperParameter, ctx: Any) -> str:
        label = typer_display_type(self, ctx).removeprefix("<").removesuffix(">")
        label = re.sub(r"^list\[(.*)\]$", r"\1...", label)
        label = _TYPE_NAMES.sub(lambda m: _METAVARS[m[1]], label)
        return label.replace(" range", " RANGE")

    def display_type_rich(self: typer.core.TyperOption, ctx: Any) -> str | None:
        if self.metavar is not None:
            return self.metavar
        return None if self.is_flag else display_type(self, ctx)

    typer.core._TyperParameter.display_type = display_type  # type: ignore[method-assign]
    typer.core.TyperOption.display_type_rich = display_type_rich  # type: ignore[method-assign]


def fail(exc: HvacflexError) -> typer.Exit:
    """Print a bad-input error (no traceback) and return the exit of code 2 to raise."""
    from rich.console import Console
    from rich.markup import escape

    Console(stderr=True).print(f"[red]error:[/red] {escape(str(exc))}", soft_wrap=True)
    return typer.Exit(code=2)


def exit_on_error(exc: Exception) -> typer.Exit:
    """Print ``exc`` as an error line and return the exit of code 2 to raise."""
    typer.echo(f"error: {exc}", err=True)
    return typer.Exit(2)
