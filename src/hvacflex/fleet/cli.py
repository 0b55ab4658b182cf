"""``hvacflex fleet generate`` and ``hvacflex fleet simulate``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from hvacflex.constants import DEFAULT_START, MAX_FLEET_BUILDINGS, PERIODS_PER_DAY
from hvacflex.dates import ISO_START_FORMS, START_EXAMPLE, StartDateError, normalise_start
from hvacflex.sim.progress import task_progress

if TYPE_CHECKING:
    from hvacflex.fleet.run import FleetStepProgress

MAX_WORKERS = 256
"""Most LocalCluster workers ``fleet simulate`` and ``fleet compare`` start."""
MAX_COMPARE_STEPS = 7 * PERIODS_PER_DAY
"""Most steps ``fleet compare`` runs (a week)."""


def _check_start(value: str) -> str:
    """Callback of ``--start``: ISO 8601 on a 30-min period start, normalised."""
    try:
        return normalise_start(value)
    except StartDateError as exc:
        raise typer.BadParameter(f"{exc.problem} (got {value!r}); e.g. {START_EXAMPLE}") from None


def _check_days(value: float) -> float:
    """Callback of ``--days``: a finite, positive whole number of 30-min periods (the
    scenario file's rule, :func:`hvacflex.config.schema.whole_periods_problem`)."""
    from hvacflex.config.schema import whole_periods_problem

    problem = whole_periods_problem(value)
    if problem is not None:
        raise typer.BadParameter(f"{problem} (got {value!r}); e.g. --days 0.5 or --days 7")
    return value


def _check_optional_number(value: float | None) -> float | None:
    """Callback of a number option: not nan (inf is allowed where it means 'none')."""
    if value is not None and math.isnan(value):
        raise typer.BadParameter("must be a number (got nan)")
    return value


def _start_option(first: str) -> Any:
    """``--start``: ``first`` (what the date starts: a day, a period), checked and normalised."""
    return typer.Option(
        "--start", help=f"{first} (Singapore local time), {ISO_START_FORMS}.", callback=_check_start
    )


def _out_option(help_text: str) -> Any:
    """``--out`` with the command's own help (what it writes there)."""
    return typer.Option("--out", help=help_text)


FleetFileOption = Annotated[Path, typer.Option("--fleet", help="Fleet TOML file.")]
"""``--fleet`` of ``simulate``, ``bound`` and ``compare``."""
PeriodStartOption = Annotated[str, _start_option("First period")]
"""``--start`` of ``bound`` and ``compare``."""
SchedulerOption = Annotated[str | None, typer.Option("--scheduler", help="Dask scheduler address.")]
"""``--scheduler`` of ``simulate`` and ``compare``."""
WorkersOption = Annotated[
    int,
    typer.Option("--workers", min=0, max=MAX_WORKERS, help="LocalCluster workers (0 = no Dask)."),
]
"""``--workers`` of ``simulate`` and ``compare`` (each command its own default)."""


fleet_app = typer.Typer(
    rich_markup_mode=None, help="Fleets of buildings under a feeder limit.", no_args_is_help=True
)


@fleet_app.command("generate")
def generate(
    buildings: int = typer.Option(
        ..., "--buildings", min=1, max=MAX_FLEET_BUILDINGS, help="Number of buildings."
    ),
    seed: int = typer.Option(2014, "--seed", min=0, help="Seed of the random choices."),
    out: Path = typer.Option(..., "--out", help="Fleet TOML file to write."),  # noqa: B008
    template: str = typer.Option("office5", "--template", help="Template building."),
    feeder_limit_kw: float | None = typer.Option(
        None,
        "--feeder-limit-kw",
        min=0.0,
        callback=_check_optional_number,
        help="Feeder limit [kW] (inf = none; default: a share of design power).",
    ),
    min_bid_mw: float = typer.Option(
        0.1,
        "--min-bid-mw",
        min=0.0,
        callback=_check_optional_number,
        help="Minimum reserve bid [MW].",
    ),
) -> None:
    """Write a heterogeneous fleet of buildings from the shipped templates."""
    from hvacflex.errors import HvacflexError
    from hvacflex.fleet.generate import generate_fleet, write_fleet
    from hvacflex.paths import check_output_file

    try:
        check_output_file(out, "--out")
        doc = generate_fleet(
            buildings,
            seed,
            template=template,
            feeder_limit_kw=feeder_limit_kw,
            min_bid_mw=min_bid_mw,
        )
        path = write_fleet(doc, out)
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    typer.echo(f"{path}: {buildings} buildings, feeder limit {doc['feeder_limit_kw']} kW")


@fleet_app.command("simulate")
def simulate(
    fleet: FleetFileOption,
    start: Annotated[str, _start_option("First day")] = DEFAULT_START,
    days: Annotated[
        float, typer.Option("--days", help="Days to simulate.", callback=_check_days)
    ] = 7.0,
    *,  # --out has no default: keyword-only, so --help keeps the options in this order
    out: Annotated[Path, _out_option("Output folder.")],
    scheduler: SchedulerOption = None,
    workers: WorkersOption = 2,
    fresh: bool = typer.Option(False, "--fresh", help="Ignore a checkpoint."),
    allow_infeasible_limits: bool = typer.Option(
        False,
        "--allow-infeasible-limits",
        help="Run even when a limit window is below the fleet's minimum power (flagged).",
    ),
) -> None:
    """Simulate a fleet under its feeder limit with coordinated RMPC (results.parquet)."""
    from hvacflex.errors import HvacflexError, require_extra
    from hvacflex.fleet.bound import check_limit_windows
    from hvacflex.fleet.report import write_fleet_report
    from hvacflex.fleet.run import minimum_power_warning, run_fleet
    from hvacflex.fleet.schema import load_fleet_document
    from hvacflex.paths import check_output_dir
    from hvacflex.results import RESULTS_FILENAME
    from hvacflex.sim.sweep import check_scheduler

    watch = CoordinationWatch()
    try:
        loaded, document = load_fleet_document(fleet)  # a bad file is said before --out is made
        check_output_dir(out, "--out")
        if scheduler is not None:
            check_scheduler(scheduler)
        elif workers > 0:
            require_extra(
                "dask", "hvacflex fleet simulate with --workers > 0 (--workers 0 runs without Dask)"
            )
        warning = minimum_power_warning(loaded, start, days)
        if warning is not None:
            typer.echo(f"warning: {warning}", err=True)
        for message in check_limit_windows(
            loaded, document, start, days, allow=allow_infeasible_limits
        ):
            typer.echo(f"warning: {message}", err=True)
        with task_progress(True, "fleet", round(days * PERIODS_PER_DAY)) as update:
            watch.update = update
            result = run_fleet(
                fleet,
                out,
                start=start,
                days=days,
                scheduler=scheduler,
                workers=workers,
                resume=not fresh,
                progress=watch,
                loaded=(loaded, document),
            )
        write_fleet_report(out, loaded.spec.min_bid_mw)
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    if watch.at_limit:
        typer.echo(f"warning: {watch.summary()}", err=True)
    s = result.summary
    flagged = int(s["feeder_infeasible_steps"])
    outside = ""
    if flagged and flagged == int(s["steps"]):
        outside = " (every period)"
    elif flagged:  # what the feeder guarantee is judged on
        outside = (
            f" (outside them: planned over limit max "
            f"{s['max_planned_over_limit_unflagged_kw']:.3g} kW, realised "
            f"{s['max_realised_over_limit_unflagged_pct']:.2f} %)"
        )
    typer.echo(
        f"{out / RESULTS_FILENAME}: {int(s['steps'])} steps, "
        f"peak {s['peak_fleet_power_kw']:.1f} kW, "
        f"planned over limit max {s['max_planned_over_limit_kw']:.3g} kW, realised over limit "
        f"max {s['max_realised_over_limit_pct']:.2f} %, "
        f"bid accepted {100 * s['bid_accepted_share']:.0f} %, "
        f"{s['coordination_iterations_mean']:.1f} iterations/step, "
        f"{s['step_time_s_mean']:.2f} s/step, "
        f"{flagged} periods flagged infeasible{outside}"
    )
    if "office_periods" in s:
        typer.echo(
            f"offer: {int(s['office_periods_bid'])} of {int(s['office_periods'])} office-hour "
            f"periods at or above the minimum bid ({s['min_bid_kw']:.0f} kW), "
            f"{s['offer_per_building_office_kw_mean']:.2f} kW per building on average "
            f"(max {s['fleet_offer_office_kw_max']:.1f} kW for the fleet), "
            f"delivery ratio {s['delivery_ratio']:.3f} "
            f"({s['il_delivered_buildings_kwh']:.1f} of {s['il_dispatched_kwh']:.1f} kWh, "
            "on the buildings' meters)"
        )


class CoordinationWatch:
    """The fleet's progress callback: the bar's step count and its text (iterations and gap
    of the last step), a warning above the bar the first time coordination stops at its
    iteration limit unconverged, and the count of such steps for the closing warning."""

    def __init__(self) -> None:
        self.update: task_progress | None = None
        self.at_limit = 0
        self.steps = 0
        self.worst_gap = 0.0
        self.last: FleetStepProgress | None = None

    def __call__(self, step: FleetStepProgress) -> None:
        self.steps += 1
        self.last = step
        if step.at_iteration_limit:
            self.at_limit += 1
            self.worst_gap = max(self.worst_gap, step.gap)
        if self.update is None:
            return
        limit = " [at limit]" if step.at_iteration_limit else ""
        self.update(
            completed=step.done,
            info=f"{step.iterations} iterations, gap {step.gap:.3g}{limit}",
        )
        if step.at_iteration_limit and self.at_limit == 1:
            self.update.warn(
                f"step {step.done}: coordination stopped at its iteration limit "
                f"({step.max_iterations}) with gap {step.gap:.3g} > tolerance "
                f"{step.gap_tolerance:g}; the plans keep the last prices and caps"
            )

    def summary(self) -> str:
        """The closing warning (call when :attr:`at_limit` > 0)."""
        assert self.last is not None
        return (
            f"coordination stopped at its iteration limit ({self.last.max_iterations}) in "
            f"{self.at_limit} of {self.steps} steps (largest gap {self.worst_gap:.3g}, "
            f"tolerance {self.last.gap_tolerance:g}); raise [coordination] max_iterations or "
            "gap_tolerance in the fleet file"
        )


@fleet_app.command("bound")
def bound(
    fleet: FleetFileOption,
    start: PeriodStartOption = DEFAULT_START,
    days: Annotated[
        float, typer.Option("--days", help="Days bounded (≤ 7).", callback=_check_days)
    ] = 1.0,
    *,  # --out has no default: keyword-only, so --help keeps the options in this order
    out: Annotated[Path, _out_option("Output folder (bound.csv).")],
    energy_budget_pct: Annotated[
        float | None,
        typer.Option(
            "--energy-budget-pct",
            min=0.0,
            callback=_check_optional_number,
            help="Energy at most this % over the unlimited plan's.",
        ),
    ] = None,
    max_excursion_k: Annotated[
        float | None,
        typer.Option(
            "--max-excursion-k",
            min=0.0,
            callback=_check_optional_number,
            help="No zone more than this [K] outside its band.",
        ),
    ] = None,
) -> None:
    """The least discomfort under the feeder limits on the controllers' model (bound.csv)."""
    from hvacflex.errors import HvacflexError
    from hvacflex.fleet.bound import BOUND_FILE, bound_fleet, budgeted_fleet_bound
    from hvacflex.paths import check_output_dir

    budget = None
    try:
        check_output_dir(out, "--out")
        if energy_budget_pct is None and max_excursion_k is None:
            result = bound_fleet(fleet, start, days, out)
        else:
            budget = budgeted_fleet_bound(
                fleet,
                start,
                days,
                out,
                energy_budget_pct=energy_budget_pct,
                max_excursion_k=max_excursion_k,
            )
            result = budget.bound
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    if budget is not None and not budget.solved:
        typer.echo(
            f"{out / BOUND_FILE}: no plan meets the limits within an energy budget of "
            f"{budget.budget_kwh:.1f} kWh and a zone excursion of at most "
            f"{budget.max_excursion_k if budget.max_excursion_k is not None else 'any'} K"
        )
        return
    typer.echo(result.frame().to_string(index=False, float_format="{:.3f}".format))
    raised = (
        ""
        if result.feasible
        else f" (not feasible as given: {result.raised_periods} periods raised to the "
        "buildings' minimum power)"
    )
    typer.echo(
        f"{out / BOUND_FILE}: {len(result.names)} buildings, "
        f"{float(result.discomfort_kelvin_hours.sum()):.3f} K·h in all{raised}"
    )
    if budget is not None:
        typer.echo(
            f"the plan's energy {budget.energy_kwh:.1f} kWh (budget {budget.budget_kwh:.1f} "
            f"kWh), largest zone slack {budget.largest_slack_k:.2f} K"
        )


@fleet_app.command("compare")
def compare(
    fleet: FleetFileOption,
    start: PeriodStartOption = DEFAULT_START,
    steps: Annotated[int, typer.Option("--steps", min=1, max=MAX_COMPARE_STEPS, help="Steps.")] = 1,
    *,  # --out has no default: keyword-only, so --help keeps the options in this order
    out: Annotated[Path, _out_option("Output folder (compare.csv).")],
    scheduler: SchedulerOption = None,
    workers: WorkersOption = 0,
) -> None:
    """Coordinated plans against the centralised LP from the same states (compare.csv)."""
    from hvacflex.errors import HvacflexError
    from hvacflex.fleet.compare import COMPARE_COLUMNS, COMPARE_FILE, compare_fleet
    from hvacflex.paths import check_output_dir
    from hvacflex.sim.sweep import check_scheduler

    try:
        check_output_dir(out, "--out")
        if scheduler is not None:
            check_scheduler(scheduler)
        frame = compare_fleet(fleet, start, steps, out, workers=workers, scheduler=scheduler)
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    typer.echo(frame[list(COMPARE_COLUMNS)].to_string(index=False, float_format="{:.6g}".format))
    typer.echo(
        f"{out / COMPARE_FILE}: {len(frame)} steps, largest gap {frame['gap'].max():.4g}, "
        f"largest energy + peak gap {frame['gap_energy_peak_pct'].max():.3g} %"
    )
