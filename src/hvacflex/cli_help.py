"""What the ``hvacflex`` command groups share: the help texts, click's names of value types
(TEXT, INTEGER, PATH) in ``--help``, the exit on a bad input, the ``--days`` check, the
scenario from a preset or file, and the line printed after a run."""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
import typer.core

from hvacflex.constants import DEFAULT_DAYS, DEFAULT_START, PRESET_NAMES
from hvacflex.dates import ISO_START_FORMS, START_EXAMPLE

if TYPE_CHECKING:
    from hvacflex.config import ScenarioConfig
    from hvacflex.errors import HvacflexError

PRESET_HELP = "A preset (the presets are listed below the options)."
"""Help of ``--scenario``; the names follow the options in full (:data:`PRESET_EPILOG`)."""

HELP_WIDTH = 80
"""The terminal width ``--help`` is laid out for (every line fits; click wraps the rest)."""


def preset_epilog(names: tuple[str, ...] = PRESET_NAMES, width: int = HELP_WIDTH) -> str:
    """The presets in full, in aligned columns that fit ``width`` with click's 2-space
    indent of an epilog; ``\\b`` keeps click from rewrapping (and splitting names at their
    hyphens)."""
    cell = max(len(n) for n in names) + 2
    per_row = max(1, (width - 4) // cell)
    rows = [
        "  " + "".join(n.ljust(cell) for n in names[i : i + per_row]).rstrip()
        for i in range(0, len(names), per_row)
    ]
    return "\b\nPresets (--scenario NAME; docs/explanation/baselines.md):\n" + "\n".join(rows)


PRESET_EPILOG = preset_epilog()
"""What follows the options of a command with ``--scenario``: every preset's name."""

DAYS_HELP = (
    f"Number of days to simulate. Default: the scenario's days ({DEFAULT_DAYS:g} unless the "
    "scenario file sets them)."
)
"""Help of ``--days`` where the scenario supplies the default (``simulate``, ``sweep``)."""

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


def check_days(value: float | None) -> float | None:
    """Callback of ``--days``: a finite, positive whole number of 30-min periods, ≤ ten years
    (:func:`hvacflex.config.schema.whole_periods_problem`, the scenario file's rule).

    Raises ``typer.BadParameter`` (exit code 2, the message names ``--days``).
    """
    from hvacflex.config.schema import whole_periods_problem

    if value is None:
        return None
    problem = whole_periods_problem(value)
    if problem is None:
        return value
    raise typer.BadParameter(f"{problem} (got {value!r}); e.g. --days 0.5, --days 7 or --days 365")


def scenario_config(
    scenario: str | None,
    config: Path | None,
    start: str | None,
    days: float | None,
    price_gap_fill: str | None = None,
) -> ScenarioConfig:
    """A ScenarioConfig from a preset name or a TOML file, with --start/--days and
    --price-gap-fill applied (as overrides of ``start``, ``days``, ``data.price_gap_fill``).

    The options given become the overrides of :func:`hvacflex.config.resolve_scenario`, the
    one path ``hvacflex.simulate`` takes too."""
    from hvacflex.config import resolve_scenario

    given = {"start": start, "days": days, "price_gap_fill": price_gap_fill}
    overrides = {key: value for key, value in given.items() if value is not None}
    return resolve_scenario(config if config is not None else scenario or "rmpc", overrides)


def run_summary_line(name: str, s: dict[str, float], results_path: Path) -> str:
    """The one line printed after ``simulate``: HVAC energy, cost, reserve, HVAC peak (the
    facility's energy and peak beside them where the plant meters it) and discomfort (the
    occupied part in brackets); names the fallback steps when there were any."""
    facility = (
        f" (facility {s['facility_energy_kwh']:.0f} kWh)" if "facility_energy_kwh" in s else ""
    )
    facility_peak = (
        f" (facility {s['facility_peak_power_kw']:.1f} kW)" if "facility_peak_power_kw" in s else ""
    )
    occupied = (
        f" ({s['discomfort_occupied_kelvin_hours']:.2f} occupied)"
        if "discomfort_occupied_kelvin_hours" in s
        else ""
    )
    line = (
        f"{name}: {s['days']:.1f} days, HVAC energy {s['energy_kwh']:.0f} kWh{facility}, "
        f"cost {s['energy_cost_sgd']:.2f} SGD, reserve revenue {s['reserve_revenue_sgd']:.2f} "
        f"SGD, HVAC peak {s['peak_power_kw']:.1f} kW{facility_peak}, discomfort "
        f"{s['discomfort_kelvin_hours']:.2f} K·h{occupied}"
    )
    fallbacks = int(s.get("fallback_count", 0.0))
    if fallbacks > 0:
        steps = int(s.get("steps", 0.0))
        line += (
            f", {fallbacks} fallback step{'s' if fallbacks != 1 else ''} of {steps} "
            "(the solver gave no plan; see the fallback column)"
        )
    return f"{line} → {results_path}"
