"""What ``hvacflex data show`` prints, draws and writes: a text summary of the exogenous data,
the paper's Fig. 2 (energy and reserve price) and the summarised 30-min series as CSV, from an
:class:`hvacflex.data.forecast.Exogenous`.

Pure functions of loaded data; the command itself (options, loading, exit codes) lives in
:mod:`hvacflex.cli`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hvacflex.building.discretize import LinearModel
from hvacflex.constants import HORIZON_STEPS
from hvacflex.data.forecast import Exogenous
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.errors import InputError
from hvacflex.opt.robust import impulse_responses, margin_operator, robust_margins

FIG2_DPI = 120
"""Resolution of the Fig. 2 PNG [dots per inch]."""


def _stats(values: np.ndarray) -> str:
    return (
        f"mean {np.mean(values):8.2f}  median {np.median(values):8.2f}  "
        f"min {np.min(values):8.2f}  max {np.max(values):8.2f}"
    )


def margin_lines(
    exo: Exogenous,
    steps: int,
    model: LinearModel,
    boxes: Mapping[str, UncertaintyBox],
    horizon_steps: int = HORIZON_STEPS,
) -> list[str]:
    """max over steps and horizon of δ_k per zone, for each box, against the half-band.

    Parameters
    ----------
    exo : exogenous data over at least ``steps + horizon_steps`` periods.
    steps : number of MPC steps (each with its own horizon window).
    model : the building's linear model (its ``a``, ``e``, ``c`` and zone names).
    boxes : label → uncertainty box.
    horizon_steps : prediction horizon N.
    """
    a, e, c = np.asarray(model.a), np.asarray(model.e), np.asarray(model.c)
    operator = margin_operator(impulse_responses(a, e, c, horizon_steps))
    half_band = float(np.min(exo.comfort_upper_degc - exo.comfort_lower_degc)) / 2.0
    lines = [f"  occupied comfort half-band: {half_band:.2f} K"]
    for label, box in boxes.items():
        worst = np.zeros(len(model.zone_names))
        for k in range(steps):
            d = exo.disturbances[k : k + horizon_steps]
            delta = robust_margins(operator, box.sigma(d, exo.channels))
            worst = np.maximum(worst, delta.max(axis=0))
        per_zone = "  ".join(f"{z} {v:.2f}" for z, v in zip(model.zone_names, worst, strict=True))
        verdict = "OK" if worst.max() < half_band else "EXCEEDS half-band"
        lines.append(f"  {label} box ({box.describe()}):")
        lines.append(f"    max δ [K]  {per_zone}   → {verdict}")
    return lines


def exogenous_summary_text(
    exo: Exogenous,
    steps: int,
    days: int,
    building_name: str,
    model: LinearModel,
    boxes: Mapping[str, UncertaintyBox],
) -> str:
    """Prices, disturbance channels, humidity, occupancy and the robust margins, as text.

    Parameters
    ----------
    exo : exogenous data over at least ``steps + HORIZON_STEPS`` periods.
    steps : summarised periods (``days`` × 48).
    days : the number of days, for the heading.
    building_name : for the heading.
    model : the building's linear model (for δ).
    boxes : label → uncertainty box whose δ is reported.
    """
    n = steps
    energy = exo.energy_price_sgd_per_mwh[:n]
    reserve = exo.reserve_price_sgd_per_mwh[:n]
    width = max([33] + [len(ch.name) for ch in exo.channels])  # the label column

    def row(label: str, values: np.ndarray, unit: str = "") -> str:
        return f"{label:<{width}} {_stats(values)}" + (f"  [{unit}]" if unit else "")

    source = "SYNTHETIC" if exo.reserve_price_synthetic else "user data"
    out = [
        f"Exogenous data {exo.index[0]:%Y-%m-%d %H:%M} … {exo.index[n - 1]:%Y-%m-%d %H:%M} SGT "
        f"({days} days, {n} periods), building '{building_name}'",
        "",
        row("energy price USEP [SGD/MWh]", energy),
        f"  zero periods {int(np.sum(energy == 0))}, negative {int(np.sum(energy < 0))}, "
        f"copied from nearest day with data {int(exo.energy_price_extrapolated[:n].sum())}",
        row(f"reserve price [SGD/MWh] {source}", reserve),
    ]
    for i, ch in enumerate(exo.channels):
        out.append(row(ch.name, exo.disturbances[:n, i], ch.unit))
    out.append(
        row("outdoor humidity ratio [g/kg]", exo.outdoor_humidity_ratio_kg_per_kg[:n] * 1000.0)
    )
    out.append(
        f"occupied periods {int(exo.occupied[:n].sum())} of {n}; comfort band occupied "
        f"{exo.comfort_lower_degc[exo.occupied].min():.1f}–"
        f"{exo.comfort_upper_degc[exo.occupied].max():.1f} °C"
        if exo.occupied[:n].any()
        else f"occupied periods 0 of {n}"
    )
    out.append("")
    out.append(
        f"worst-case margin δ over a {HORIZON_STEPS}-step horizon (docs/explanation/model.md §3):"
    )
    out += margin_lines(exo, n, model, boxes)
    return "\n".join(out)


def write_fig2(exo: Exogenous, path: Path, steps: int) -> None:
    """Fig. 2 of the paper: energy (USEP) and reserve price over the first ``steps`` periods,
    as a PNG at ``path``."""
    index = exo.index[:steps]
    fig = Figure(figsize=(9, 4))
    FigureCanvasAgg(fig)
    ax_energy = fig.subplots()
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
    fig.savefig(path, dpi=FIG2_DPI)


def exogenous_frame(exo: Exogenous, steps: int, zone_names: Sequence[str]) -> pd.DataFrame:
    """The first ``steps`` periods of the exogenous data, one column per series, named as in
    the results file (docs/explanation/architecture.md, Results).

    Parameters
    ----------
    exo : exogenous data over at least ``steps`` periods.
    steps : number of 30-min periods.
    zone_names : (m,) the building's zones, for the comfort-band columns.

    Returns
    -------
    (steps rows) DataFrame on the tz-aware index ``time`` of period starts:
    ``energy_price_sgd_per_mwh``, ``reserve_price_sgd_per_mwh`` [SGD/MWh], one column per
    disturbance channel under its channel name (``outdoor_temp_degc``,
    ``solar_az90_tilt90_w_per_m2``, ``internal_gain_<zone>_w``, …: the ``<channel>`` of the
    results file's ``d_<channel>``; channel units), ``outdoor_humidity_ratio_kg_per_kg``
    [kg/kg], ``occupied`` [bool], ``comfort_lower_<zone>_degc``, ``comfort_upper_<zone>_degc``
    [°C].
    """
    columns: dict[str, np.ndarray] = {
        "energy_price_sgd_per_mwh": exo.energy_price_sgd_per_mwh[:steps],
        "reserve_price_sgd_per_mwh": exo.reserve_price_sgd_per_mwh[:steps],
    }
    for i, channel in enumerate(exo.channels):
        columns[channel.name] = exo.disturbances[:steps, i]
    columns["outdoor_humidity_ratio_kg_per_kg"] = exo.outdoor_humidity_ratio_kg_per_kg[:steps]
    columns["occupied"] = exo.occupied[:steps]
    for j, zone in enumerate(zone_names):
        columns[f"comfort_lower_{zone}_degc"] = exo.comfort_lower_degc[:steps, j]
        columns[f"comfort_upper_{zone}_degc"] = exo.comfort_upper_degc[:steps, j]
    return pd.DataFrame(columns, index=pd.DatetimeIndex(exo.index[:steps], name="time"))


def write_exogenous_csv(
    exo: Exogenous, steps: int, zone_names: Sequence[str], path: Path
) -> pd.DataFrame:
    """Write :func:`exogenous_frame` to ``path`` as CSV (times with their UTC offset)
    and return it.

    Raises
    ------
    InputError
        if ``path`` cannot be written (a folder, a missing parent that cannot be created, no
        permission).
    """
    frame = exogenous_frame(exo, steps, zone_names)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(path)
    except OSError as exc:
        raise InputError(
            f"cannot write the CSV file: {exc.strerror or exc}",
            source=path,
            field="--csv",
            hint="give a writable file path",
        ) from None
    return frame
