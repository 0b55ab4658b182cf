"""The ``hvacflex`` command line.

Each command imports what it needs inside its body, so ``hvacflex --help`` stays fast.
"""

from __future__ import annotations

from pathlib import Path

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


def _data_group() -> typer.Typer:
    from hvacflex.data.show import data_app

    return data_app


app.add_typer(_data_group(), name="data")


building_app = typer.Typer(help="Inspect building descriptions.", no_args_is_help=True)
app.add_typer(building_app, name="building")


@building_app.command("show")
def building_show(
    building: str = typer.Argument(..., help="A building TOML file or a shipped name (office5)."),
) -> None:
    """Print zones, nodes, time constants, UA, design load and model checks of a building."""
    from hvacflex.building.config import load_building
    from hvacflex.building.summary import building_summary_text
    from hvacflex.errors import HvacflexError
    from hvacflex.paths import resolve_building

    try:
        text = building_summary_text(load_building(resolve_building(building)))
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    typer.echo(text)


@app.command()
def version() -> None:
    """Print the hvacflex version."""
    from hvacflex import __version__

    typer.echo(__version__)


@app.command()
def kpi(
    paths: list[Path] = typer.Argument(  # noqa: B008
        ..., help="Run directories (holding results.parquet) or results Parquet files."
    ),
    peak_price_sgd_per_kw: float | None = typer.Option(
        None,
        "--peak-price",
        help="Price the PPP charge of every run at this φ [SGD/kW] "
        "(default: each run's peak_price_sgd_per_kw column).",
    ),
    csv: Path | None = typer.Option(None, help="Also write the table to this CSV file."),  # noqa: B008
) -> None:
    """Print the KPIs of one or more closed-loop runs side by side (one column per run)."""
    import pandas as pd
    from rich.console import Console
    from rich.table import Table

    from hvacflex import kpi as kpis

    columns: dict[str, dict[str, float]] = {}
    for path in paths:
        if path.is_dir():
            name = path.name
        else:
            name = path.parent.name if path.name == kpis.RESULTS_FILENAME else path.stem
        unique = name
        suffix = 2
        while unique in columns:
            unique = f"{name}#{suffix}"
            suffix += 1
        columns[unique] = kpis.summary(kpis.load_results(path), peak_price_sgd_per_kw)
    frame = pd.DataFrame(columns)
    if csv is not None:
        frame.to_csv(csv, index_label="kpi")
    table = Table(title="KPIs per run")
    table.add_column("kpi")
    for name in frame.columns:
        table.add_column(str(name), justify="right")
    for row_name, row in frame.iterrows():
        table.add_row(str(row_name), *(_format_kpi(str(row_name), v) for v in row))
    Console().print(table)


def _format_kpi(name: str, value: float) -> str:
    """Human formatting of one KPI value by the unit in its name."""
    if value != value:  # NaN
        return "–"
    if name in ("steps", "fallback_count"):
        return f"{value:,.0f}"
    if name.endswith("_share"):
        return f"{100.0 * value:.2f} %"
    if name.endswith("_s") or name == "max_delta_vs_half_band":
        return f"{value:.4g}"
    return f"{value:,.2f}"


if __name__ == "__main__":
    app()
