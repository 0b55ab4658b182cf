"""The ``hvacflex`` command line.

Each command imports what it needs inside its body, so ``hvacflex --help`` stays fast. Bad
input of any kind (an option, a file, an output path) exits 2 with a message naming the option
or field, the value and a fix, and is checked before any long work starts.
"""

from __future__ import annotations

import hvacflex.cli_threads  # noqa: F401  (first: the BLAS thread count, before numpy loads)

# isort: split
import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
import typer.core

from hvacflex.cli_config import config_app
from hvacflex.cli_help import (
    DAYS_HELP,
    PRESET_EPILOG,
    PRESET_HELP,
    START_HELP,
    fail,
    use_readable_metavars,
)
from hvacflex.cli_help import check_days as _check_days
from hvacflex.cli_help import run_summary_line as _run_summary_line
from hvacflex.cli_help import scenario_config as _scenario_config
from hvacflex.cli_model import identify_app, validate_app
from hvacflex.cli_serve import serve_app
from hvacflex.constants import DEFAULT_START, PERIODS_PER_DAY, RUN_DIR
from hvacflex.dates import ISO_START_FORMS, START_EXAMPLE

if TYPE_CHECKING:
    from hvacflex.config import ScenarioConfig

use_readable_metavars()

app = typer.Typer(
    rich_markup_mode=None,
    name="hvacflex",
    help="Robust predictive control of building HVAC in electricity markets.",
    no_args_is_help=True,
    add_completion=False,
)


def _print_version(value: bool) -> None:
    """Callback of ``--version``: print the version and stop."""
    if value:
        from hvacflex import __version__

        typer.echo(f"hvacflex {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: bool = typer.Option(
        False,
        "--version",
        help="Print the version and exit.",
        callback=_print_version,
        is_eager=True,
    ),
) -> None:
    """Robust predictive control of building HVAC in electricity markets."""


def _check_start(value: str | None) -> str | None:
    """Callback of ``--start``: an ISO 8601 date on a 30-min period start, normalised.

    Raises ``typer.BadParameter`` (exit code 2, the message names ``--start``).
    """
    from hvacflex.dates import StartDateError, normalise_start

    if value is None:
        return None
    try:
        return normalise_start(value)
    except StartDateError as exc:
        raise typer.BadParameter(f"{exc.problem} (got {value!r}); e.g. {START_EXAMPLE}") from None


def _check_finite(value: float | None) -> float | None:
    """Callback of a number option that must be finite (not nan or inf)."""

    if value is not None and not math.isfinite(value):
        raise typer.BadParameter(f"must be a finite number (got {value!r})")
    return value


def _peak_price_option(help_text: str) -> Any:
    """``--peak-price`` [SGD/kW]: a finite number ≥ 0 (``kpi`` and ``report`` alike)."""
    return typer.Option(None, "--peak-price", min=0.0, callback=_check_finite, help=help_text)


DATA_SHOW_MAX_DAYS = 366
"""Longest span ``data show`` summarises [days]: the shipped prices cover one year."""

data_app = typer.Typer(
    rich_markup_mode=None, help="Inspect prices, weather, gains and the uncertainty box."
)
app.add_typer(data_app, name="data")


@data_app.command("show")
def data_show(
    start: str = typer.Option(
        DEFAULT_START,
        help=f"First day (Singapore local time), {ISO_START_FORMS}.",
        callback=_check_start,
    ),
    days: int = typer.Option(7, min=1, max=DATA_SHOW_MAX_DAYS, help="Number of days."),
    building_file: str = typer.Option(
        "office5", "--building-file", help="Building: a TOML file or a shipped name (office5)."
    ),
    weather: Path | None = typer.Option(None, help="EPW file (default: TMYx Singapore Changi)."),  # noqa: B008
    fig2: Path | None = typer.Option(None, help="Write Fig. 2 (energy & reserve price) PNG."),  # noqa: B008
    csv: Path | None = typer.Option(  # noqa: B008
        None, help="Write the summarised 30-min series as CSV (results-file column names)."
    ),
) -> None:
    """Summarise prices, reserve prices (synthetic), weather, gains and the uncertainty box."""
    from hvacflex.building.discretize import linearize
    from hvacflex.building.io import load_building
    from hvacflex.constants import HORIZON_STEPS
    from hvacflex.data.forecast import load_exogenous
    from hvacflex.data.uncertainty import DEFAULT_UNCERTAINTY, paper_uncertainty
    from hvacflex.errors import HvacflexError
    from hvacflex.paths import check_output_file, resolve_building
    from hvacflex.report.data_summary import (
        exogenous_summary_text,
        write_exogenous_csv,
        write_fig2,
    )

    steps = days * PERIODS_PER_DAY
    try:
        if fig2 is not None:
            check_output_file(fig2, "--fig2")
        b = load_building(resolve_building(building_file))
        model = linearize(b)
        exo = load_exogenous(
            model.channels,
            b.gain_floor_areas_m2,
            b.gains,
            start=start,
            steps=steps,
            horizon_steps=HORIZON_STEPS,
            weather_file=weather,
        )
    except HvacflexError as exc:
        raise fail(exc) from None
    boxes = {"default": DEFAULT_UNCERTAINTY, "paper": paper_uncertainty()}
    typer.echo(exogenous_summary_text(exo, steps, days, b.name, model, boxes))
    if fig2 is not None:
        write_fig2(exo, fig2, steps)
        typer.echo(f"\nwrote {fig2}")
    if csv is not None:
        try:
            write_exogenous_csv(exo, steps, model.zone_names, csv)
        except HvacflexError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(code=2) from None
        typer.echo(f"\nwrote {csv} ({steps} periods)")


def _fleet_group() -> typer.Typer:
    from hvacflex.fleet.cli import fleet_app

    return fleet_app


app.add_typer(_fleet_group(), name="fleet")

building_app = typer.Typer(
    rich_markup_mode=None, help="Inspect building descriptions.", no_args_is_help=True
)
app.add_typer(building_app, name="building")


@building_app.command("show")
def building_show(
    building: str = typer.Argument(..., help="A building TOML file or a shipped name (office5)."),
) -> None:
    """Print zones, nodes, time constants, UA, design load and model checks of a building."""
    from hvacflex.building.io import load_building
    from hvacflex.building.summary import building_summary_text, format_comfort_band
    from hvacflex.config import ScenarioConfig
    from hvacflex.data.gains import DEFAULT_OFFICE_SCHEDULE
    from hvacflex.errors import HvacflexError
    from hvacflex.paths import resolve_building

    try:
        text = building_summary_text(load_building(resolve_building(building)))
    except HvacflexError as exc:
        raise fail(exc) from None
    comfort = ScenarioConfig().comfort
    band = format_comfort_band(
        comfort.occupied_degc,
        comfort.unoccupied_degc,
        DEFAULT_OFFICE_SCHEDULE.occupied_hours,
        "default scenario",
    )
    typer.echo(f"{text}\n{band}")


@building_app.command("export-idf")
def building_export_idf(
    building: str = typer.Argument(..., help="A building TOML file or a shipped name (office5)."),
    out: Path = typer.Option(..., "--out", help="The IDF file to write."),  # noqa: B008
    hvac: str = typer.Option(
        "vav", help="HVAC: vav (air loop + chiller), ideal (ideal loads) or none (free float)."
    ),
    weather: Path | None = typer.Option(None, help="EPW for the site (default: Singapore TMYx)."),  # noqa: B008
    surfaces: str = typer.Option(
        "energyplus",
        help="Surface heat transfer: energyplus (its own convection, long-wave and rain) or "
        "hvacflex (the building's constant films; docs/explanation/validation.md).",
    ),
) -> None:
    """Write an EnergyPlus 25.2 model (IDF) of a building; run it with `energyplus -x`."""
    from hvacflex.building.io import load_building
    from hvacflex.energyplus.export import export_idf
    from hvacflex.errors import HvacflexError
    from hvacflex.paths import resolve_building
    from hvacflex.version import atomic_write_text

    try:
        text = export_idf(
            load_building(resolve_building(building)),
            hvac=hvac,
            epw_path=weather,
            surfaces=surfaces,
        )
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    try:
        atomic_write_text(out, text)
    except OSError as exc:
        typer.echo(f"error: {out}: cannot write the IDF ({exc.strerror})", err=True)
        raise typer.Exit(2) from None
    typer.echo(
        f"wrote {out} (EnergyPlus 25.2, hvac {hvac}); run: energyplus -x -w WEATHER.epw {out}"
    )


app.add_typer(validate_app, name="validate")
app.add_typer(identify_app, name="identify")
app.add_typer(config_app, name="config")
app.add_typer(serve_app, name="serve")


@app.command()
def version() -> None:
    """Print the hvacflex version."""
    from hvacflex import __version__

    typer.echo(__version__)


@app.command()
def kpi(
    paths: list[Path] = typer.Argument(  # noqa: B008
        ...,
        metavar="RUN",
        help="Run directories (holding results.parquet) or results Parquet files.",
    ),
    peak_price_sgd_per_kw: float | None = _peak_price_option(
        "Price the PPP charge of every run at this φ [SGD/kW] "
        "(default: each run's peak_price_sgd_per_kw column)."
    ),
    csv: Path | None = typer.Option(None, help="Also write the table to this CSV file."),  # noqa: B008
) -> None:
    """Print the KPIs of one or more closed-loop runs side by side (one column per run)."""
    import pandas as pd
    from rich.console import Console
    from rich.table import Table

    from hvacflex import kpi as kpis
    from hvacflex.errors import HvacflexError
    from hvacflex.fleet.kpi import fleet_summary, load_fleet_results
    from hvacflex.paths import check_output_file
    from hvacflex.report.tables import format_value
    from hvacflex.results import RESULTS_FILENAME, load_results
    from hvacflex.version import atomic_write_text

    if csv is not None:
        try:
            check_output_file(csv, "--csv")
        except HvacflexError as exc:
            raise fail(exc) from None
    columns: dict[str, dict[str, float]] = {}
    for path in paths:
        if path.is_dir():
            name = path.name
        else:
            name = path.parent.name if path.name == RESULTS_FILENAME else path.stem
        unique = name
        suffix = 2
        while unique in columns:
            unique = f"{name}#{suffix}"
            suffix += 1
        try:
            fleet_results = load_fleet_results(path)
            if fleet_results is not None:  # a fleet run (hvacflex fleet simulate)
                columns[unique] = fleet_summary(fleet_results)
            else:
                results = load_results(path)
                columns[unique] = kpis.summary(results, peak_price_sgd_per_kw)
        except HvacflexError as exc:
            where = "" if str(path) in str(exc) else f"{path}: "
            typer.echo(f"error: {where}{exc}", err=True)
            raise typer.Exit(2) from None
    # object columns: the counts stay int in the CSV and on screen (kpi.COUNT_KPIS)
    frame = pd.DataFrame({run: pd.Series(kpis_, dtype=object) for run, kpis_ in columns.items()})
    if csv is not None:
        atomic_write_text(csv, frame.to_csv(index_label="kpi"))
    table = Table(title="KPIs per run")
    table.add_column("kpi")
    for name in frame.columns:
        table.add_column(str(name), justify="right")
    for row_name, row in frame.iterrows():
        table.add_row(str(row_name), *(format_value(str(row_name), v) for v in row))
    Console().print(table)


PRICE_GAP_FILL_HELP = (
    "Missing periods in the price files: 'none' (an error) or 'previous-day' (copy "
    "the same period of the day before). Default: the scenario's data.price_gap_fill."
)
"""Help of ``--price-gap-fill`` (``simulate`` and ``sweep``)."""


MAX_WORKERS = 256
"""Most local worker processes ``sweep`` and ``reproduce`` start."""

SweepSchedulerOption = Annotated[
    str | None,
    typer.Option(
        help="dask.distributed scheduler address (the dask extra); default: a LocalCluster "
        "here, or local processes without the dask extra."
    ),
]
"""``--scheduler`` of ``sweep`` and ``reproduce``."""
SweepWorkersOption = Annotated[
    int,
    typer.Option(min=1, max=MAX_WORKERS, help="Local worker processes (without --scheduler)."),
]
"""``--workers`` of ``sweep`` and ``reproduce``."""
SweepFreshOption = Annotated[bool, typer.Option(help="Ignore existing results and checkpoints.")]
"""``--fresh`` of ``sweep`` and ``reproduce``."""


@app.command(epilog=PRESET_EPILOG)
def simulate(
    scenario: str = typer.Option(
        "rmpc",
        help=PRESET_HELP,
    ),
    config: Path | None = typer.Option(None, help="Scenario TOML file (overrides --scenario)."),  # noqa: B008
    start: str | None = typer.Option(None, help=START_HELP, callback=_check_start),
    days: float | None = typer.Option(None, help=DAYS_HELP, callback=_check_days),
    price_gap_fill: str | None = typer.Option(
        None,
        "--price-gap-fill",
        help=PRICE_GAP_FILL_HELP,
    ),
    out: Path = typer.Option(  # noqa: B008
        Path(RUN_DIR),
        help="Output folder. A folder holding another configuration's run is refused "
        "(--fresh replaces it); the same configuration resumes or re-uses its results.",
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    fresh: bool = typer.Option(
        False, help="Ignore existing results and checkpoints (and replace another run's)."
    ),
    checkpoint_every: int = typer.Option(
        336, min=1, help="Steps between checkpoints (336 = one week)."
    ),
    no_report: bool = typer.Option(False, "--no-report", help="Write no report.html in OUT."),
) -> None:
    """Run a closed-loop simulation (resumes from a checkpoint in OUT if there is one)."""
    from rich.console import Console

    from hvacflex.errors import HvacflexError
    from hvacflex.paths import check_output_dir
    from hvacflex.sim.run import RunInterrupted, run_simulation
    from hvacflex.sim.run_files import check_linearisation, check_out_dir

    console = Console()
    try:
        cfg = _scenario_config(scenario, config, start, days, price_gap_fill)
        check_linearisation(cfg, config if config is not None else "preset")
        check_output_dir(out, "--out")
        check_out_dir(out, cfg, fresh)
        result = run_simulation(
            cfg,
            out,
            progress=not quiet,
            resume=not fresh,
            checkpoint_every=checkpoint_every,
            on_resume=lambda k: console.print(f"resumed from period {k}"),
        )
        if not no_report:
            from hvacflex.report.run_report import report_for_run_dir

            report_for_run_dir(result.out_dir)
    except HvacflexError as exc:
        raise fail(exc) from None
    except RunInterrupted as stopped:
        console.print(stopped.message(), soft_wrap=True, markup=False, highlight=False)
        raise typer.Exit(130) from None
    if result.cached:
        console.print(f"re-used finished results in {result.out_dir}")
    summary = _run_summary_line(run_label(cfg), result.summary, result.results_path)
    console.print(summary, soft_wrap=True, markup=False, highlight=False)


def console_line(text: str) -> None:
    """Print a line of plain text on rich's shared console: above a progress bar while one
    is live (so bar and lines stay apart), at once otherwise (also when piped)."""
    from rich import get_console

    get_console().print(text, markup=False, highlight=False, soft_wrap=True)


def run_label(cfg: ScenarioConfig) -> str:
    """What ran: ``"scenario rmpc, building office5, plant rc, 2014-03-04 to
    2014-03-04T12:00"`` (the plant graded on: ``rc``, or ``energyplus`` with its IDF; the first
    period's start and the last period's end, Singapore local time)."""
    import pandas as pd

    from hvacflex.dates import normalise_start

    end = cfg.start_timestamp + pd.Timedelta(seconds=cfg.steps * cfg.dt_s)
    end_text = normalise_start(end.strftime("%Y-%m-%dT%H:%M"))
    plant: str = cfg.plant.kind
    if cfg.plant.kind == "energyplus":
        idf = cfg.plant.idf
        plant += f" ({'generated IDF' if idf == 'generated' else Path(idf).name})"
    return f"scenario {cfg.name}, building {cfg.building}, plant {plant}, {cfg.start} to {end_text}"


@app.command()
def report(
    runs: list[Path] = typer.Argument(  # noqa: B008
        ..., help="Run folders (holding results.parquet) or results Parquet files."
    ),
    out: Path = typer.Option(..., "--out", help="The HTML file to write."),  # noqa: B008
    baseline: Path | None = typer.Option(  # noqa: B008
        None, help="A run to compare against (shown too; Δ columns in the KPI table)."
    ),
    peak_price_sgd_per_kw: float | None = _peak_price_option(
        "φ of the one tariff every run is billed at [SGD/kW] (default: the largest "
        "any run recorded)."
    ),
) -> None:
    """Write one self-contained HTML page for runs: temperatures, power and reserve, prices,
    the cost under one tariff and the KPIs (per run, per m², against a baseline)."""
    from hvacflex.errors import HvacflexError
    from hvacflex.paths import check_output_file
    from hvacflex.report.run_report import write_run_report

    try:
        check_output_file(out, "--out")
        path = write_run_report(
            runs, out, baseline=baseline, peak_price_sgd_per_kw=peak_price_sgd_per_kw
        )
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    typer.echo(f"report → {path}")


@app.command(epilog=PRESET_EPILOG)
def sweep(
    param: list[str] = typer.Option(  # noqa: B008
        ..., help="NAME=V1,V2,... (repeatable; the grid is their product)."
    ),
    scenario: str = typer.Option(
        "rmpc-ppp", help="The preset the sweep starts from (the presets are listed below)."
    ),
    config: Path | None = typer.Option(None, help="Scenario TOML file (overrides --scenario)."),  # noqa: B008
    start: str | None = typer.Option(None, help=START_HELP, callback=_check_start),
    days: float | None = typer.Option(
        None, help=DAYS_HELP.replace("to simulate", "per run"), callback=_check_days
    ),
    price_gap_fill: str | None = typer.Option(
        None,
        "--price-gap-fill",
        help=PRICE_GAP_FILL_HELP,
    ),
    out: Path = typer.Option(Path("results/sweep"), help="Output folder."),  # noqa: B008
    scheduler: SweepSchedulerOption = None,
    workers: SweepWorkersOption = 2,
    fresh: SweepFreshOption = False,
) -> None:
    """Run independent closed-loop simulations over a parameter grid (on Dask with the dask
    extra, else on local processes).

    Exits 1 when any run fails (the table still lists every run, with its error).
    """
    from rich import get_console
    from rich.markup import escape

    from hvacflex.errors import HvacflexError
    from hvacflex.paths import check_output_dir
    from hvacflex.sim.sweep import (
        JobOutcome,
        check_scheduler,
        expand_grid,
        outcomes_table,
        parse_param,
        run_sweep,
    )
    from hvacflex.version import atomic_write_text

    console = get_console()  # the progress bar's: its lines print above the bar
    try:
        cfg = _scenario_config(scenario, config, start, days, price_gap_fill)
        grid = dict(parse_param(p) for p in param)
        jobs = expand_grid(cfg, grid)
        check_output_dir(out, "--out")
        if scheduler is not None:
            check_scheduler(scheduler)
    except HvacflexError as exc:
        raise fail(exc) from None
    done = 0

    def report(outcome: JobOutcome) -> None:
        nonlocal done
        done += 1
        state = (
            "[green]ok[/green]"
            if outcome.ok
            else f"[red]failed[/red]: {escape(str(outcome.error))}"
        )
        console.print(f"{escape(f'[{done}/{len(jobs)}] {outcome.params}')} {state}")

    outcomes = run_sweep(
        jobs,
        out,
        scheduler=scheduler,
        n_workers=workers,
        on_done=report,
        fresh=fresh,
        progress=True,
    )
    table = outcomes_table(outcomes)
    atomic_write_text(out / "sweep.csv", table.to_csv(index=False))
    failed = sum(not o.ok for o in outcomes)
    console.print(f"{len(outcomes) - failed} ok, {failed} failed → {out / 'sweep.csv'}")
    if failed:
        console.print(f"[red]error:[/red] {failed} of {len(outcomes)} runs failed")
        raise typer.Exit(1)


@app.command()
def reproduce(
    quick: bool = typer.Option(
        False,
        "--quick",
        help="One week and 4 PPP values (a few minutes) instead of the year; with "
        "--sensitivity / --seeds their reduced grids.",
    ),
    energyplus: bool = typer.Option(
        False,
        "--energyplus",
        help="Add the section on EnergyPlus office5: (a), (b), (c), the 24 °C thermostat and "
        "thermostat-25.5 over the year (--quick: the week) beside the same runs on the RC "
        "plant (needs the energyplus extra of hvacflex).",
    ),
    feedback: bool = typer.Option(
        True,
        "--feedback/--no-feedback",
        help="Run (b) and (c) with affine disturbance feedback over the period too; "
        "--no-feedback leaves these two runs out (the full run's longest: each takes several "
        "times an open-loop year; the robustness sweep keeps its short feedback runs).",
    ),
    out: Path = typer.Option(  # noqa: B008
        Path("results/reproduce"),
        help="Output folder; every run is kept in OUT/runs/<run name> and updated in place.",
    ),
    scheduler: SweepSchedulerOption = None,
    workers: SweepWorkersOption = 2,
    fresh: SweepFreshOption = False,
    sensitivity: bool = typer.Option(
        False,
        "--sensitivity",
        help="Only the sweep of the synthetic reserve price's scale × correlation with USEP "
        "for (a), (b), (c) (--quick: 3 × 2 points over two days), into OUT/sensitivity.",
    ),
    seeds: bool = typer.Option(
        False,
        "--seeds",
        help="Only the findings' robustness: (a), (b), (c) over four representative weeks × "
        "5 occupancy seeds (--quick: two days of each week × 2 seeds), into OUT/seeds.",
    ),
) -> None:
    """Regenerate the paper's Fig. 2, 5, 6, 7 and Table 1 (+ comfort and robustness) as HTML.

    With --sensitivity and/or --seeds, run only those studies (CSV + PNG;
    docs/explanation/reproduction.md). Exits 1 when any run fails; the report is still written,
    marked incomplete at its top.
    """
    from hvacflex.errors import HvacflexError
    from hvacflex.paths import check_output_dir
    from hvacflex.reproduce import reproduce as run_reproduction
    from hvacflex.sim.sweep import check_scheduler

    try:
        check_output_dir(out, "--out")
        if scheduler is not None:
            check_scheduler(scheduler)
        if sensitivity or seeds:
            _reproduce_studies(out, quick, scheduler, workers, fresh, sensitivity, seeds)
            return
        result = run_reproduction(
            out,
            quick=quick,
            energyplus=energyplus,
            feedback=feedback,
            scheduler=scheduler,
            workers=workers,
            log=console_line,
            fresh=fresh,
        )
    except HvacflexError as exc:
        raise fail(exc) from None
    if not result.complete:
        typer.echo(
            f"error: {len(result.failed)} of {len(result.outcomes)} runs failed; the report "
            f"{result.report} is INCOMPLETE",
            err=True,
        )
        raise typer.Exit(1)


def _reproduce_studies(
    out: Path,
    quick: bool,
    scheduler: str | None,
    workers: int,
    fresh: bool,
    sensitivity: bool,
    seeds: bool,
) -> None:
    """``reproduce --sensitivity`` / ``--seeds``: run the studies, print where their files
    are and the machine time; exit 1 when a run failed (the tables hold the others)."""
    from hvacflex.robustness import SeedPlan, run_seed_study
    from hvacflex.sensitivity import SensitivityGrid, run_sensitivity

    studies: list[tuple[str, Any, Any]] = []
    if sensitivity:
        grid = SensitivityGrid.quick() if quick else SensitivityGrid.full()
        studies.append(("sensitivity", run_sensitivity, grid))
    if seeds:
        studies.append(("seeds", run_seed_study, SeedPlan.quick() if quick else SeedPlan.full()))
    failed: list[str] = []
    for name, run_study, plan in studies:
        study = run_study(
            out / name, plan, scheduler=scheduler, workers=workers, fresh=fresh, log=console_line
        )
        typer.echo(f"{name}: {study.out_dir} ({study.elapsed_s:.0f} s)")
        failed += [f"{o.label}: {o.error}" for o in study.failed]
    if failed:
        typer.echo(f"error: {len(failed)} runs failed:\n" + "\n".join(failed), err=True)
        raise typer.Exit(1)


if __name__ == "__main__":
    app()
