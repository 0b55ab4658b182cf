"""The ``hvacflex`` command line.

Each command imports what it needs inside its body, so ``hvacflex --help`` stays fast.
"""

from __future__ import annotations

import typer

app = typer.Typer(
    name="hvacflex",
    help="Robust predictive control of building HVAC in electricity markets.",
    no_args_is_help=True,
    add_completion=False,
)


@app.callback()
def main() -> None:
    """Robust predictive control of building HVAC in electricity markets."""


@app.command()
def version() -> None:
    """Print the hvacflex version."""
    from hvacflex import __version__

    typer.echo(__version__)


if __name__ == "__main__":
    app()
