"""The ``hvacflex`` commands about the building model: ``validate`` it against outside
references (ASHRAE 140, EnergyPlus) and ``identify`` it from measured data. Each command
imports what it needs inside its body, so ``hvacflex --help`` stays fast."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from hvacflex.cli_help import exit_on_error, fail
from hvacflex.constants import MAX_VALIDATION_SPINUP_DAYS, VALIDATION_SPINUP_DAYS

validate_app = typer.Typer(
    rich_markup_mode=None, help="Validate the building model.", no_args_is_help=True
)


@validate_app.command("bestest")
def validate_bestest(
    out: Path = typer.Option(  # noqa: B008
        Path("bestest_results"), "--out", help="Folder for the table, CSV and PNG figures."
    ),
) -> None:
    """ASHRAE Standard 140 Cases 600, 900, 600FF, 900FF against the six example programs."""
    from hvacflex.errors import HvacflexError
    from hvacflex.paths import buildings_dir, check_output_dir, data_dir
    from hvacflex.report.validation_plots import write_bestest_outputs
    from hvacflex.sim.progress import task_progress
    from hvacflex.validation.bestest import run_bestest, stage_count, table_markdown

    try:
        check_output_dir(out, "--out")
        with task_progress(True, "bestest", stage_count()) as bar:
            result = run_bestest(data_dir() / "bestest", buildings_dir(), progress=bar.stage)
        paths = write_bestest_outputs(result, out)
    except HvacflexError as exc:
        raise fail(exc) from None
    typer.echo(table_markdown(result.table))
    for path in paths:
        typer.echo(f"wrote {path}")


@validate_app.command("energyplus")
def validate_energyplus(
    building: str = typer.Argument("office5", help="A shipped building name or a TOML file."),
    start: list[str] = typer.Option(  # noqa: B008
        ["2014-03-03", "2014-05-05"],
        "--start",
        help="First compared day, YYYY-MM-DD (repeat for several weeks).",
    ),
    days: int = typer.Option(7, "--days", min=1, max=31, help="Days compared per start."),
    spinup_days: int = typer.Option(
        VALIDATION_SPINUP_DAYS,
        "--spinup-days",
        min=0,
        max=MAX_VALIDATION_SPINUP_DAYS,
        help="Days simulated before and discarded (office5 needs ≈ 42 to forget its start).",
    ),
    out: Path = typer.Option(  # noqa: B008
        Path("energyplus_validation"), "--out", help="Folder for the CSV tables and figures."
    ),
    surfaces: str = typer.Option(
        "energyplus",
        "--surfaces",
        help="EnergyPlus's surface heat transfer: energyplus (its own convection, long-wave and "
        "rain: the model check) or hvacflex (the building's constant films: the "
        "implementation check).",
    ),
) -> None:
    """hvacflex's RC plant against EnergyPlus on the building's IDF export: free-float, and
    for office5 and office15 fixed-flow and thermostat (zone air RMSE, cooling energy, HVAC
    electricity)."""
    from datetime import date

    from hvacflex.building.io import load_building
    from hvacflex.energyplus.export import SURFACE_MODELS, check_choice
    from hvacflex.errors import HvacflexError, InputError
    from hvacflex.paths import resolve_building
    from hvacflex.report.tables import to_markdown
    from hvacflex.report.validation_plots import write_energyplus_outputs
    from hvacflex.sim.progress import task_progress
    from hvacflex.validation.energyplus import run_energyplus_validation, stage_count

    try:
        starts = []
        for text in start:
            try:
                starts.append(date.fromisoformat(text))
            except ValueError:
                raise InputError(
                    "not a date", field="--start", value=text, hint="write YYYY-MM-DD"
                ) from None
        if out.exists() and not out.is_dir():
            raise InputError("is a file, not a folder", field="--out", value=str(out))
        check_choice(surfaces, SURFACE_MODELS, what="surface model", field="--surfaces")
        model = load_building(resolve_building(building))
        with task_progress(True, "energyplus", stage_count(model, starts)) as bar:
            result = run_energyplus_validation(
                model,
                starts=starts,
                days=days,
                spinup_days=spinup_days,
                workdir=out,
                surfaces=surfaces,
                progress=bar.stage,
            )
        paths = write_energyplus_outputs(result, out)
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    typer.echo(to_markdown(result.temperatures.set_index("case").round(2)))
    if not result.energy.empty:
        typer.echo(to_markdown(result.energy.set_index("case").round(1)))
    for path in paths:
        typer.echo(f"wrote {path}")


identify_app = typer.Typer(
    rich_markup_mode=None,
    help="Identify a controller model from measured trend data (docs/guide/identify.md).",
    no_args_is_help=True,
)


@identify_app.command("collect")
def identify_collect(
    idf: Path = typer.Option(  # noqa: B008
        ...,
        "--idf",
        help="The EnergyPlus 25.2 model: a path, or a shipped model's name (5ZoneAirCooled, "
        "RefBldgSmallOfficeNew2004_Chicago, packaged_shops).",
    ),
    start: str = typer.Option(..., "--start", help="First day, YYYY-MM-DD."),
    days: int = typer.Option(..., "--days", min=1, max=366, help="Number of days."),
    out: Path = typer.Option(..., "--out", help="The trend CSV to write."),  # noqa: B008
    weather: Path | None = typer.Option(  # noqa: B008
        None, "--weather", help="EPW file (default: the shipped Singapore TMYx)."
    ),
    excitation: str = typer.Option(
        "range",
        "--excitation",
        help="Setpoint excitation: range (the operating range: PRBS in office hours, "
        "float-ups and pull-downs outside), prbs, steps or none.",
    ),
    zones: str | None = typer.Option(
        None, "--zones", help="IDF zones, comma-separated (default: every zone with a thermostat)."
    ),
    seed: int = typer.Option(0, "--seed", help="Seed of the PRBS."),
) -> None:
    """Run the IDF under its own control plus a seeded setpoint excitation; write trend data."""
    from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
    from hvacflex.errors import HvacflexError
    from hvacflex.identify.collect import collect_trend
    from hvacflex.identify.trend import write_trend
    from hvacflex.paths import check_output_file, data_dir
    from hvacflex.sim.progress import task_progress

    epw = weather if weather is not None else data_dir() / "weather" / DEFAULT_WEATHER_FILE
    names = None if zones is None else tuple(z.strip() for z in zones.split(",") if z.strip())
    try:
        check_output_file(out, "--out")  # before EnergyPlus runs
        with task_progress(True, "identify collect", days) as bar:

            def day_done() -> None:
                bar()
                bar.beat(f"day {bar.completed} of {days}")

            frame = collect_trend(
                idf,
                start=start,
                days=days,
                epw_path=epw,
                excitation=excitation,
                zones=names,
                seed=seed,
                on_day=day_done,
            )
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    typer.echo(f"wrote {write_trend(frame, out)} ({len(frame)} periods)")


@identify_app.command("fit")
def identify_fit(
    data: Path = typer.Option(..., "--data", help="The trend CSV."),  # noqa: B008
    out: Path = typer.Option(..., "--out", help="The model TOML to write."),  # noqa: B008
    template: str | None = typer.Option(
        None, "--template", help="A building file: its zones and the walls between them."
    ),
    zones: str | None = typer.Option(None, "--zones", help="The data's zones, comma-separated."),
    adjacency: str | None = typer.Option(
        None, "--adjacency", help='Coupled zones, "Z1-Z2,Z1-Z3" (default: every pair).'
    ),
    train: str | None = typer.Option(None, "--train", help="YYYY-MM-DD..YYYY-MM-DD"),
    test: str | None = typer.Option(None, "--test", help="YYYY-MM-DD..YYYY-MM-DD"),
    idf: Path | None = typer.Option(  # noqa: B008
        None,
        "--idf",
        help="The EnergyPlus model the data came from (a path or a shipped model's name): "
        "the plant of scenario.toml and baseline.toml.",
    ),
    weather: Path | None = typer.Option(  # noqa: B008
        None,
        "--weather",
        help="EPW of the site: where the walls' irradiance is computed, scenario.toml's "
        "weather (default: the shipped Singapore TMYx).",
    ),
    floor_area: str | None = typer.Option(
        None,
        "--floor-area",
        help="The fitted zones' floor areas, \"Z1=M2,Z2=M2\" (default: the --idf's zone "
        "floors, else the --template's zones; without any, per-m² figures are not available).",
    ),
    strict: bool = typer.Option(
        False, "--strict", help="Exit 2 when a plausibility check fails (checks.csv)."
    ),
) -> None:
    """Fit a grey-box RC model to trend data; write it (a building file), fit_report.csv,
    the parameters, the calibrated model-error box, scenario.toml and (with --idf)
    baseline.toml."""
    import warnings

    from hvacflex.errors import HvacflexError
    from hvacflex.identify.workflow import FIT_STAGES, identify
    from hvacflex.paths import resolve_building
    from hvacflex.sim.progress import task_progress

    try:
        building = None if template is None else resolve_building(template)
        with (
            warnings.catch_warnings(),
            task_progress(True, "identify fit", len(FIT_STAGES)) as bar,
        ):
            warnings.simplefilter("ignore")  # they are in the fit report's warnings column
            outcome = identify(
                data,
                out,
                zones=zones,
                adjacency=adjacency,
                template=building,
                train=train,
                test=test,
                idf=idf,
                weather=weather,
                floor_areas=floor_area,
                progress=bar.stage,
                heartbeat=bar.beat,
            )
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    _print_fit(outcome)
    failed = outcome.failed_checks
    if not failed:
        typer.echo("plausibility checks: all ok")
        return
    typer.echo(f"plausibility checks: {len(failed)} failed ({outcome.checks_path}):", err=True)
    for line in failed:
        typer.echo(f"  {line}", err=True)
    if strict:
        typer.echo(
            "error: --strict: the fitted model fails the checks above; fix the data or the "
            "zones' description (--idf, --floor-area), or leave --strict out to keep it",
            err=True,
        )
        raise typer.Exit(2)


@identify_app.command("power")
def identify_power_command(
    data: Path = typer.Option(  # noqa: B008
        ...,
        "--data",
        help="A trend CSV with hvac_power_kw (identify collect), or a run's folder or "
        "results.parquet (hvacflex simulate; with --building).",
    ),
    plant: str = typer.Option(
        ..., "--plant", help="The plant whose meter it is: rc or energyplus."
    ),
    out: Path = typer.Option(  # noqa: B008
        ..., "--out", help="The TOML to write: a [power_models.<plant>] table."
    ),
    building: str | None = typer.Option(
        None, "--building", help="The building (file or shipped name) a run's results are of."
    ),
    train: str | None = typer.Option(None, "--train", help="YYYY-MM-DD..YYYY-MM-DD"),
    test: str | None = typer.Option(None, "--test", help="YYYY-MM-DD..YYYY-MM-DD"),
) -> None:
    """Fit a power model to a plant's meter for a designed building; write its
    [power_models.<plant>] table and power_report.csv (docs/guide/identify.md)."""
    from hvacflex.building.io import load_building
    from hvacflex.errors import HvacflexError
    from hvacflex.identify.power_file import identify_power
    from hvacflex.paths import resolve_building

    try:
        described = None if building is None else load_building(resolve_building(building))
        outcome = identify_power(data, plant, out, building=described, train=train, test=test)
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    typer.echo(outcome.report.to_string(index=False, float_format=lambda v: f"{v:.2f}"))
    typer.echo(f"wrote {outcome.model_path}")
    typer.echo(f"wrote {outcome.report_path}")


def _print_fit(outcome: Any) -> None:
    """The fit's tables (report, box, power) and the files ``identify fit`` wrote."""
    shown = outcome.report.drop(columns=["warnings"])  # they are the checks printed below
    typer.echo(shown.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    typer.echo(outcome.box.frame().to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if outcome.power is not None:
        typer.echo(outcome.power.to_string(index=False, float_format=lambda v: f"{v:.1f}"))
    from hvacflex.report.identify_plots import plot_identified_fit

    figure = plot_identified_fit(outcome.predictions, outcome.model_path.parent / "fit.png")
    for path in (
        outcome.model_path,
        outcome.report_path,
        outcome.parameters_path,
        outcome.checks_path,
        outcome.power_path,
        outcome.model_path.parent / "fit_predictions.csv",
        outcome.model_path.parent / "box_report.csv",
        outcome.scenario_path,
        outcome.baseline_path,
        figure,
    ):
        if path is not None:
            typer.echo(f"wrote {path}")
