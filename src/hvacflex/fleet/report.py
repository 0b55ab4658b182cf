"""The fleet report (``report.html`` in the run folder): fleet power against the feeder
limit, the aggregate bid against the minimum, the flexibility envelope next to the limit
windows and the offers, per-building cost and comfort distributions."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from hvacflex.fleet.envelope import ENVELOPE_FILE
from hvacflex.report.html import Section, write_report
from hvacflex.results import RESULTS_FILENAME, read_results


def write_fleet_report(run_dir: str | Path, min_bid_mw: float | None = None) -> Path:
    """Render ``report.html`` from a fleet run's files (see :mod:`hvacflex.fleet.run`)."""
    out = Path(run_dir)
    results, _ = read_results(out / RESULTS_FILENAME)
    table = pd.read_csv(out / "buildings_summary.csv", index_col="building")
    summary = pd.read_json(out / "summary.json", typ="series")
    figures = []
    fig, ax = plt.subplots(figsize=(10, 3.5))
    ax.plot(results.index, results["fleet_power_kw"], label="realised fleet power")
    ax.plot(results.index, results["planned_fleet_power_kw"], "--", label="planned")
    ax.plot(results.index, results["feeder_limit_kw"], "k:", label="feeder limit")
    ax.set_ylabel("kW")
    ax.legend()
    fig.tight_layout()
    figures.append(out / "fleet_power.png")
    fig.savefig(figures[-1], dpi=90)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(10, 3.0))
    ax.step(results.index, results["fleet_bid_kw"], where="post", label="the fleet's bid")
    ax.step(results.index, results["fleet_reserve_kw"], where="post", label="Σ buildings' offers")
    ax.step(results.index, results["settled_reserve_kw"], where="post", label="settled")
    if min_bid_mw is not None:
        ax.axhline(1000 * min_bid_mw, color="k", ls=":", label="minimum bid")
    ax.set_ylabel("kW")
    ax.legend()
    fig.tight_layout()
    figures.append(out / "fleet_bid.png")
    fig.savefig(figures[-1], dpi=90)
    plt.close(fig)
    envelope_figure = _envelope_figure(out, results, min_bid_mw, len(table))
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.0))
    for ax, column, label in (
        (axes[0], "net_cost_sgd", "net cost per building [SGD]"),
        (axes[1], "discomfort_kelvin_hours", "discomfort per building [K·h]"),
    ):
        if column in table:
            ax.hist(table[column].to_numpy(float), bins=min(20, max(len(table), 2)))
        ax.set_xlabel(label)
    fig.tight_layout()
    figures.append(out / "fleet_buildings.png")
    fig.savefig(figures[-1], dpi=90)
    plt.close(fig)
    sections = [
        Section("Fleet KPIs", tables=[summary.to_frame("value")]),
        Section(
            "Fleet power and the feeder limit, aggregate bid",
            figures=figures[:2],
            figure_captions=["fleet power (planned, realised) and the limit", "aggregate bid"],
        ),
        *envelope_figure,
        Section(
            "Buildings",
            figures=figures[2:],
            tables=[table],
            figure_captions=["per-building cost and comfort"],
        ),
    ]
    return write_report(out, title="hvacflex fleet run", sections=sections)


def whole_fleet_rows(envelope: pd.DataFrame, fleet_size: int) -> pd.DataFrame:
    """``envelope.csv``'s rows with the power of those summing fewer than ``fleet_size``
    buildings blanked (NaN): their sum omits the buildings without a comfort-keeping hold."""
    whole = envelope.copy()
    whole.loc[whole["buildings"] < fleet_size, ["min_power_kw", "max_power_kw"]] = np.nan
    return whole


def _envelope_figure(
    out: Path, results: pd.DataFrame, min_bid_mw: float | None, fleet_size: int
) -> list[Section]:
    """The flexibility envelope (``envelope.csv``: the least and the most power the fleet
    holds for 30, 60 and 120 min from each period's start) as bands around the fleet's
    power, with the limit windows, and the fleet's offer below it; none without the file.
    Rows summing fewer than ``fleet_size`` buildings (some building has no comfort-keeping
    hold) are left blank: their power omits those buildings'."""
    path = out / ENVELOPE_FILE
    if not path.is_file():
        return []
    envelope = whole_fleet_rows(pd.read_csv(path), fleet_size)
    envelope["time"] = pd.to_datetime(envelope["time"])
    fig, (top, bottom) = plt.subplots(
        2, 1, figsize=(10, 5.0), sharex=True, gridspec_kw={"height_ratios": [3, 1.2]}
    )
    times = results.index
    shades = (0.15, 0.25, 0.35)
    for (minutes, rows), alpha in zip(envelope.groupby("duration_min"), shades, strict=False):
        top.fill_between(
            times[: len(rows)],
            rows["min_power_kw"].to_numpy(float),
            rows["max_power_kw"].to_numpy(float),
            step="post",
            alpha=alpha,
            label=f"envelope, {minutes} min hold",
        )
    top.step(
        times, results["fleet_power_kw"], "k", where="post", lw=1, label="realised fleet power"
    )
    top.step(times, results["feeder_limit_kw"], "r:", where="post", label="limit in force")
    top.set_ylabel("kW")
    top.legend(fontsize=7, ncol=3)
    bottom.step(times, results["fleet_bid_kw"], where="post", label="the fleet's offer")
    bottom.step(times, results["settled_reserve_kw"], where="post", label="settled")
    if min_bid_mw is not None:
        bottom.axhline(1000 * min_bid_mw, color="k", ls=":", label="minimum bid")
    bottom.set_ylabel("kW")
    bottom.legend(fontsize=7)
    fig.tight_layout()
    figure = out / "fleet_envelope.png"
    fig.savefig(figure, dpi=90)
    plt.close(fig)
    return [
        Section(
            "Flexibility envelope",
            figures=[figure],
            figure_captions=[
                "the least and the most power the fleet can hold for 30, 60 and 120 min from "
                "each period (envelope.csv; blank where some building has no comfort-keeping "
                "hold), the limit in force and the fleet's offer"
            ],
        )
    ]
