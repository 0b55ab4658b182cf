"""``hvacflex data …`` commands: inspect the loaded exogenous data and draw the paper's Fig. 2.

Registered on the main CLI as the ``data`` group. Heavy imports stay inside the commands.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

if TYPE_CHECKING:
    import numpy as np

    from hvacflex.data.forecast import Exogenous
    from hvacflex.data.uncertainty import UncertaintyBox

data_app = typer.Typer(help="Inspect prices, weather, gains and the uncertainty box.")

HORIZON_STEPS = 48


def _stats(values: np.ndarray) -> str:
    import numpy as np

    return (
        f"mean {np.mean(values):8.2f}  median {np.median(values):8.2f}  "
        f"min {np.min(values):8.2f}  max {np.max(values):8.2f}"
    )


def _margin_lines(
    exo: Exogenous,
    steps: int,
    a: np.ndarray,
    e: np.ndarray,
    c: np.ndarray,
    zone_names: tuple[str, ...],
    boxes: dict[str, UncertaintyBox],
) -> list[str]:
    """max over steps and horizon of δ_k per zone, for each box, against the half-band."""
    import numpy as np

    from hvacflex.opt.robust import impulse_responses, margin_operator, robust_margins

    operator = margin_operator(impulse_responses(a, e, c, HORIZON_STEPS))
    half_band = float(np.min(exo.comfort_upper_degc - exo.comfort_lower_degc)) / 2.0
    lines = [f"  occupied comfort half-band: {half_band:.2f} K"]
    for label, box in boxes.items():
        worst = np.zeros(len(zone_names))
        for k in range(steps):
            d = exo.disturbances[k : k + HORIZON_STEPS]
            delta = robust_margins(operator, box.sigma(d, exo.channels))
            worst = np.maximum(worst, delta.max(axis=0))
        per_zone = "  ".join(f"{z} {v:.2f}" for z, v in zip(zone_names, worst, strict=True))
        verdict = "OK" if worst.max() < half_band else "EXCEEDS half-band"
        lines.append(f"  {label} box ({box.describe()}):")
        lines.append(f"    max δ [K]  {per_zone}   → {verdict}")
    return lines


def write_fig2(exo: Exogenous, path: Path, steps: int) -> None:
    """Fig. 2 of the paper: energy (USEP) and reserve price over the chosen days, PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    index = exo.index[:steps]
    fig, ax_energy = plt.subplots(figsize=(9, 4))
    ax_energy.step(index, exo.energy_price_sgd_per_mwh[:steps], where="post", color="C0")
    ax_energy.set_ylabel("energy price USEP [SGD/MWh]", color="C0")
    ax_reserve = ax_energy.twinx()
    reserve_label = "reserve price [SGD/MWh]" + (
        " — SYNTHETIC" if exo.reserve_price_synthetic else ""
    )
    ax_reserve.step(index, exo.reserve_price_sgd_per_mwh[:steps], where="post", color="C3")
    ax_reserve.set_ylabel(reserve_label, color="C3")
    title = f"NEMS energy and reserve prices, {index[0]:%d %b %Y} – {index[-1]:%d %b %Y}"
    if exo.reserve_price_synthetic:
        title += "\n(reserve price synthetic: no public NEMS reserve-price history)"
    ax_energy.set_title(title, fontsize=10)
    ax_energy.set_xlabel("time (SGT)")
    fig.autofmt_xdate()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


@data_app.command("show")
def show(
    start: str = typer.Option("2014-01-01", help="First day (Singapore time)."),
    days: int = typer.Option(7, min=1, help="Number of days."),
    building: str = typer.Option("office5", help="Building (shipped name or TOML path)."),
    weather: Path | None = typer.Option(None, help="EPW file (default: TMYx Singapore Changi)."),  # noqa: B008
    fig2: Path | None = typer.Option(None, help="Write Fig. 2 (energy & reserve price) PNG."),  # noqa: B008
) -> None:
    """Summarise prices, reserve prices (synthetic), weather, gains and the uncertainty box."""
    import numpy as np

    from hvacflex.building.discretize import linearize
    from hvacflex.building.io import load_building
    from hvacflex.data.forecast import load_exogenous
    from hvacflex.data.uncertainty import DEFAULT_UNCERTAINTY, paper_uncertainty
    from hvacflex.errors import HvacflexError
    from hvacflex.paths import resolve_building

    steps = days * 48
    try:
        b = load_building(resolve_building(building))
        lm = linearize(b)
        exo = load_exogenous(
            lm.channels,
            [z.floor_area_m2 for z in b.zones],
            b.gains,
            start=start,
            steps=steps,
            horizon_steps=HORIZON_STEPS,
            weather_file=weather,
        )
    except HvacflexError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(code=2) from None
    n = steps
    energy = exo.energy_price_sgd_per_mwh[:n]
    reserve = exo.reserve_price_sgd_per_mwh[:n]
    out = [
        f"Exogenous data {exo.index[0]:%Y-%m-%d %H:%M} … {exo.index[n - 1]:%Y-%m-%d %H:%M} SGT "
        f"({days} days, {n} periods), building '{b.name}'",
        "",
        f"energy price USEP [SGD/MWh]      {_stats(energy)}",
        f"  zero periods {int(np.sum(energy == 0))}, negative {int(np.sum(energy < 0))}, "
        f"copied from nearest day with data {int(exo.energy_price_extrapolated[:n].sum())}",
        f"reserve price [SGD/MWh] {'SYNTHETIC' if exo.reserve_price_synthetic else 'user data'}"
        f" {_stats(reserve)}",
    ]
    for i, ch in enumerate(exo.channels):
        column = exo.disturbances[:n, i]
        out.append(f"{ch.name:<33} {_stats(column)}  [{ch.unit}]")
    out.append(
        "outdoor humidity ratio [g/kg]     "
        + _stats(exo.outdoor_humidity_ratio_kg_per_kg[:n] * 1000.0)
    )
    out.append(
        f"occupied periods {int(exo.occupied[:n].sum())} of {n}; comfort band occupied "
        f"{exo.comfort_lower_degc[exo.occupied].min():.1f}–"
        f"{exo.comfort_upper_degc[exo.occupied].max():.1f} °C"
        if exo.occupied[:n].any()
        else f"occupied periods 0 of {n}"
    )
    out.append("")
    out.append(f"worst-case margin δ over a {HORIZON_STEPS}-step horizon (DESIGN §3):")
    out += _margin_lines(
        exo,
        n,
        np.asarray(lm.a),
        np.asarray(lm.e),
        np.asarray(lm.c),
        tuple(lm.zone_names),
        {"default": DEFAULT_UNCERTAINTY, "paper": paper_uncertainty()},
    )
    typer.echo("\n".join(out))
    if fig2 is not None:
        write_fig2(exo, fig2, n)
        typer.echo(f"\nwrote {fig2}")
