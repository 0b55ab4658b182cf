"""The fleet report (``report.html`` in the run folder): fleet power against the feeder
limit, the aggregate bid against the minimum, per-building cost and comfort distributions."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pandas as pd

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
        Section(
            "Buildings",
            figures=figures[2:],
            tables=[table],
            figure_captions=["per-building cost and comfort"],
        ),
    ]
    return write_report(out, title="hvacflex fleet run", sections=sections)
