"""The fleet report (``report.html`` in the run folder): fleet power against the feeder
limit, the aggregate bid against the minimum, the flexibility envelope next to the limit
windows and the offers, the aggregator's offer per building and its delivery
(:mod:`hvacflex.fleet.aggregation`), per-building cost and comfort distributions."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from hvacflex.fleet.aggregation import office_hours
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
        *_offer_section(out, results, summary, min_bid_mw),
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


OFFER_KPIS = (
    "office_periods",
    "office_periods_bid",
    "fleet_offer_office_kw_mean",
    "fleet_offer_office_kw_max",
    "offer_per_building_office_kw_mean",
    "offer_per_building_office_kw_min",
    "offer_per_building_office_kw_max",
    "buildings_for_min_bid",
    "il_dispatched_kwh",
    "il_delivered_buildings_kwh",
    "delivery_ratio",
)
"""The summary keys of the aggregator's section (:func:`hvacflex.fleet.aggregation.offer_kpis`)."""


def _offer_section(
    out: Path, results: pd.DataFrame, summary: pd.Series, min_bid_mw: float | None
) -> list[Section]:
    """The aggregator's offer: the fleet's offer (Σ of the buildings' metered-visible offers)
    against the minimum bid, the offer per building in office hours (what sizes a fleet),
    and the dispatched and delivered reserve; none for a run without offers (older runs)."""
    if "fleet_offer_kw" not in results.columns:
        return []
    buildings = float(summary.get("buildings", np.nan))
    per_building = results["fleet_offer_kw"] / buildings if buildings > 0 else None
    office = office_hours(pd.DatetimeIndex(results.index))
    fig, axes = plt.subplots(2, 1, figsize=(10, 5.0), sharex=True)
    axes[0].step(results.index, results["fleet_offer_kw"], where="post", label="the fleet's offer")
    axes[0].step(results.index, results["il_dispatched_kw"], where="post", label="dispatched")
    axes[0].step(
        results.index,
        results["il_delivered_buildings_kw"],
        where="post",
        label="delivered (buildings' meters, capped)",
    )
    if min_bid_mw is not None:
        axes[0].axhline(1000 * min_bid_mw, color="k", ls=":", label="minimum bid")
    axes[0].set_ylabel("kW")
    axes[0].legend()
    if per_building is not None:
        axes[1].step(results.index, per_building, where="post", label="offer per building")
        axes[1].fill_between(
            results.index,
            0,
            per_building.max(),
            where=office,
            step="post",
            alpha=0.15,
            label="office hours",
        )
        axes[1].set_ylabel("kW per building")
        axes[1].legend()
    fig.tight_layout()
    figure = out / "fleet_offer.png"
    fig.savefig(figure, dpi=90)
    plt.close(fig)
    kpis = summary.reindex([k for k in OFFER_KPIS if k in summary.index]).to_frame("value")
    return [
        Section(
            "The aggregator's offer, dispatch and delivery",
            paragraphs=[
                "The fleet offers the sum of its buildings' metered-visible offers (each cut "
                "to what its own meter would show) and bids it at or above the minimum bid; "
                "an activated bid is dispatched to the buildings by their offers and settled "
                "on each building's meter, its delivery capped at its share (offers.csv)."
            ],
            figures=[figure],
            figure_captions=["the fleet's offer, dispatch and delivery; offer per building"],
            tables=[kpis],
        )
    ]
