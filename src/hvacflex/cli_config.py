"""The ``hvacflex config`` commands: the scenario file's keys, generated from its schema.

Each command imports what it needs inside its body, so ``hvacflex --help`` stays fast."""

from __future__ import annotations

from pathlib import Path

import typer

from hvacflex.cli_help import fail

config_app = typer.Typer(
    rich_markup_mode=None, help="The scenario file's tables and keys.", no_args_is_help=True
)

REFERENCE_FILE = "docs/reference/scenario_reference.md"
"""Where the repository keeps the reference (``tests/config/test_reference.py`` checks it)."""


@config_app.command("reference")
def config_reference(
    out: Path | None = typer.Option(  # noqa: B008
        None, "--out", help=f"Write the Markdown to this file, e.g. {REFERENCE_FILE}."
    ),
    check: bool = typer.Option(
        False,
        "--check",
        help="Write nothing: exit 1 when the file given by --out differs from the schema.",
    ),
) -> None:
    """Every scenario key: type, default, unit, allowed values, description (Markdown).

    Generated from the scenario schema; printed, or written to --out.
    """
    from hvacflex.config.reference import reference_markdown
    from hvacflex.errors import HvacflexError, InputError
    from hvacflex.paths import check_output_file
    from hvacflex.version import atomic_write_text

    text = reference_markdown()
    if out is None:
        if check:
            raise fail(
                InputError(
                    "--check needs the file to compare",
                    field="--check",
                    hint=f"give --out {REFERENCE_FILE}",
                )
            )
        typer.echo(text, nl=False)
        return
    if check:
        current = out.read_text(encoding="utf-8") if out.is_file() else None
        if current != text:
            typer.echo(
                f"{out} is out of date with the scenario schema; regenerate it with "
                f"hvacflex config reference --out {out}",
                err=True,
            )
            raise typer.Exit(code=1)
        typer.echo(f"{out} is up to date")
        return
    try:
        atomic_write_text(check_output_file(out, "--out"), text)
    except HvacflexError as exc:
        raise fail(exc) from None
    typer.echo(f"wrote {out}")
