"""The reproduction on EnergyPlus (``hvacflex reproduce --energyplus``): (a) NMPC, (b) RMPC,
(c) RMPC + PPP, the 24 °C thermostat and ``thermostat-25.5`` (the strongest rule-based
baseline without reserve) on EnergyPlus office5 (the year; ``--quick``: one week) — the
building's own IDF export (``[plant] kind = "energyplus"``, ``idf = "generated"``, setpoint
actuation, the product presets' IL event model) — side by side with the same period on
hvacflex's RC plant.

EnergyPlus is the judge here: the controllers plan with hvacflex's RC model and never see
EnergyPlus's, so cost, peak and comfort on that plant are graded by an engine the controller
does not assume (docs/guide/energyplus.md). :func:`energyplus_jobs` makes the runs;
:func:`plant_comparison` tabulates them (``energyplus_vs_rc.csv``), :func:`plot_plant_week`
draws them, and :func:`energyplus_section` writes the report's section with the verdicts of
:mod:`hvacflex.report.verdicts` computed on EnergyPlus.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hvacflex import kpi
from hvacflex import results as schema
from hvacflex.config import PAPER_SCENARIOS, ScenarioConfig, preset
from hvacflex.config.model import PlantConfig
from hvacflex.errors import HvacflexError

if TYPE_CHECKING:
    from hvacflex.sim.sweep import JobOutcome

ENERGYPLUS_SCENARIOS: tuple[str, ...] = (
    "a",
    "b",
    "c",
    "thermostat",
    "thermostat-25.5",
    "thermostat-25.5-float",
    "gta-dr",
)
"""Scenario keys run on EnergyPlus office5: (a), (b), (c), the 24 °C thermostat,
``thermostat-25.5`` (25.5 °C with optimal start), the same with a 0.25 K night float
(``thermostat-25.5-float``) and ``gta-dr`` (the grid operator's demand-response rule)."""

ENERGYPLUS_PREFIX = "energyplus-"
"""Run-name prefix of the runs on EnergyPlus (``energyplus-rmpc``, …)."""

RC_WEEK_PREFIX = "week-"
"""Run-name prefix of the RC-plant week beside the EnergyPlus week when the scenario runs
cover another period (the full year): ``week-rmpc``, …"""

PLANTS = {"rc": "RC plant (hvacflex)", "energyplus": "EnergyPlus 25.2"}
"""Plant kind → its name in the report."""

COMPARISON_CSV = "energyplus_vs_rc.csv"
"""The comparison table's file in the reproduction's output folder."""

TABLE1_CSV = "table1_energyplus.csv"
"""Table 1 of the runs on each plant (:func:`plant_table1`) in the output folder."""

COMPARISON_COLUMNS: tuple[str, ...] = (
    "scenario",
    "plant",
    "energy_kwh",
    "facility_energy_kwh",
    "energy_cost_sgd",
    "peak_power_kw",
    "ppp_charge_sgd",
    "reserve_revenue_settled_sgd",
    "tariff_cost_sgd",
    "reserve_revenue_unsettled_sgd",
    "reserve_offered_mean_kw",
    "discomfort_kelvin_hours",
    "discomfort_occupied_kelvin_hours",
    "discomfort_unoccupied_kelvin_hours",
    "max_violation_k",
    "tracking_rmse_k",
    "fallback_count",
)
"""Columns of :func:`plant_comparison` (module docstring of :func:`plant_comparison`)."""

Jobs = list[tuple[dict[str, Any], ScenarioConfig]]


def scenario_preset(key: str) -> str:
    """The preset of a scenario key (``"a"`` → ``"nmpc"``, ``"thermostat"`` → itself)."""
    return PAPER_SCENARIOS.get(key, key)


def on_energyplus(cfg: ScenarioConfig) -> ScenarioConfig:
    """``cfg`` on EnergyPlus office5 (the generated IDF, setpoint actuation), named
    ``energyplus-<name>``: how the reproduction moves a run to EnergyPlus."""
    return replace(
        cfg,
        name=f"{ENERGYPLUS_PREFIX}{cfg.name}",
        plant=PlantConfig(kind="energyplus", idf="generated"),
    )


def energyplus_jobs(start: str, days: float, *, with_rc_week: bool) -> Jobs:
    """:data:`ENERGYPLUS_SCENARIOS` on EnergyPlus office5 over ``days`` from ``start``
    (names ``energyplus-<preset>``, parameters ``scenario`` and ``plant``) and, with
    ``with_rc_week``, the same scenarios on the RC plant over that week (``week-<preset>``;
    leave it out when the scenario runs already cover exactly that week)."""
    jobs: Jobs = []
    for key in ENERGYPLUS_SCENARIOS:
        name = scenario_preset(key)
        cfg = preset(name, start=start, days=days)
        jobs.append(({"scenario": key, "plant": "energyplus"}, on_energyplus(cfg)))
        if with_rc_week:
            rc = replace(cfg, name=f"{RC_WEEK_PREFIX}{name}")
            jobs.append(({"scenario": key, "plant": "rc"}, rc))
    return jobs


def tracking_rmse_k(results: pd.DataFrame) -> float:
    """RMS [K] over zones and planned periods of the realised end-of-period zone temperature
    minus the plan's served prediction (``temp_end − temp_served``): how closely the plant
    follows what the controller planned (on EnergyPlus: its own loops tracking the
    setpoints; for a setpoint-emitting baseline such as the thermostat, its setpoints); NaN
    for a run without those predictions."""
    zones = kpi.zone_names(results)
    served = [schema.TEMP_SERVED.name(zone) for zone in zones]
    if not all(col in results.columns for col in served):
        return float("nan")
    realised = results[[schema.TEMP_END.name(zone) for zone in zones]].to_numpy(float)
    error = realised - results[served].to_numpy(float)
    if not np.isfinite(error).any():
        return float("nan")
    return float(np.sqrt(np.nanmean(error**2)))


def plant_comparison(
    runs: Mapping[tuple[str, str], pd.DataFrame], peak_price_sgd_per_kw: float
) -> pd.DataFrame:
    """One row per (scenario label, plant kind) of ``runs``, columns
    :data:`COMPARISON_COLUMNS`: energy [kWh] (HVAC: ``power_kw``; the facility meter
    ``facility_power_kw`` where the plant has one, else NaN), energy cost [SGD], peak [kW]
    and its charge at the one tariff's φ = ``peak_price_sgd_per_kw`` [SGD/kW] prorated to the
    days the run covers, reserve revenue settled against the meter (activated periods) [SGD],
    ``tariff_cost_sgd`` = energy + billed peak + IL penalty − settled reserve over the run
    [SGD], the unsettled availability payments beside it [SGD], mean reserve offered [kW],
    discomfort [K·h] (all, occupied, unoccupied) and the largest violation [K] measured on the
    plant's own zone temperatures, :func:`tracking_rmse_k` [K], and the number of fallback
    steps."""
    rows = []
    for (label, plant), frame in runs.items():
        summary = kpi.summary(frame, peak_price_sgd_per_kw)
        facility = (
            float(frame["facility_power_kw"].sum() * kpi.step_hours(frame))
            if "facility_power_kw" in frame.columns and frame["facility_power_kw"].notna().any()
            else float("nan")
        )
        tariff = (
            summary["energy_cost_sgd"]
            + summary["ppp_charge_sgd"]
            + summary["il_penalty_sgd"]
            - summary["reserve_revenue_settled_sgd"]
        )
        rows.append(
            {
                "scenario": label,
                "plant": PLANTS.get(plant, plant),
                "facility_energy_kwh": facility,
                "tariff_cost_sgd": tariff,
                "tracking_rmse_k": tracking_rmse_k(frame),
                "fallback_count": int(summary["fallback_count"]),
            }
            | {
                name: summary[name]
                for name in COMPARISON_COLUMNS
                if name in summary and name != "fallback_count"
            }
        )
    return pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS))


def plant_table1(runs: Mapping[tuple[str, str], pd.DataFrame]) -> pd.DataFrame:
    """Table 1 (:func:`hvacflex.report.tables.table1`: averages per month, % against the
    plant's first scenario) of each plant's runs, one block per plant (index ``plant``,
    ``scenario``). ``runs``: (scenario label, plant kind) → results frame."""
    from hvacflex.report import tables

    by_plant: dict[str, dict[str, pd.DataFrame]] = {}
    for (label, plant), frame in runs.items():
        by_plant.setdefault(PLANTS.get(plant, plant), {})[label] = kpi.monthly_table(frame)
    blocks = [
        tables.table1(monthly).assign(plant=plant).set_index("plant", append=True)
        for plant, monthly in by_plant.items()
    ]
    return pd.concat(blocks).reorder_levels(["plant", "scenario"])


def mean_zone_temp_degc(results: pd.DataFrame) -> np.ndarray:
    """(T,) the mean over zones of the realised end-of-period temperature [°C]."""
    zones = kpi.zone_names(results)
    return np.asarray(
        results[[schema.TEMP_END.name(zone) for zone in zones]].to_numpy(float).mean(axis=1)
    )


DISPLAY_WEEK_START = "2014-03-03"
"""First day of the week :func:`plot_plant_week` draws when a run is longer than
:data:`DISPLAY_MAX_DAYS` (the EnergyPlus week of ``--quick``)."""

DISPLAY_MAX_DAYS = 14.0
"""Longest run drawn whole by :func:`plot_plant_week` [days]; a longer one (the year) is
drawn over the week from :data:`DISPLAY_WEEK_START`, its tables cover it all."""


def display_week(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` itself when it spans at most :data:`DISPLAY_MAX_DAYS`, else its seven days
    from :data:`DISPLAY_WEEK_START` (its first seven when that day is outside it)."""
    index = pd.DatetimeIndex(frame.index)
    if len(index) == 0 or index[-1] - index[0] <= pd.Timedelta(days=DISPLAY_MAX_DAYS):
        return frame
    start = pd.Timestamp(DISPLAY_WEEK_START, tz=index.tz)
    if not index[0] <= start <= index[-1]:
        start = index[0]
    return frame[(index >= start) & (index < start + pd.Timedelta(days=7))]


def plot_plant_week(
    runs: Mapping[str, Mapping[str, pd.DataFrame]], path: Path, *, title: str
) -> Path:
    """Per scenario a row of two panels: HVAC power [kW] on each plant, and the mean zone
    temperature [°C] on each plant over the comfort band (shaded; the first zone's, from the
    RC run), two lines a panel, over :func:`display_week` of each run. ``runs``: scenario
    label → plant kind → results frame. Writes the PNG and its CSV (``scenario``, ``plant``,
    ``time``, ``power_kw``, ``mean_zone_temp_degc``)."""
    from hvacflex.report import plots

    runs = {
        label: {plant: display_week(frame) for plant, frame in by_plant.items()}
        for label, by_plant in runs.items()
    }

    figure, axes = plots.new_figure(len(runs), 2, sharex=True, panel_height_in=2.2)
    colours = {"rc": "C0", "energyplus": "C3"}
    parts = []
    for row, (label, by_plant) in enumerate(runs.items()):
        ax_power, ax_temp = axes[2 * row], axes[2 * row + 1]
        first = next(iter(by_plant.values()))
        plots.shade_comfort_band(ax_temp, first, kpi.zone_names(first)[0])
        for plant, frame in by_plant.items():
            edges = plots.period_edges(frame)
            power = frame["power_kw"].to_numpy(float)
            temp = mean_zone_temp_degc(frame)
            name = PLANTS.get(plant, plant)
            ax_power.stairs(power, edges, baseline=None, color=colours.get(plant), label=name)
            ax_temp.plot(edges[1:], temp, color=colours.get(plant), linewidth=1.0, label=name)
            parts.append(
                pd.DataFrame(
                    {
                        "scenario": label,
                        "plant": plant,
                        "time": edges[:-1],
                        "power_kw": power,
                        "mean_zone_temp_degc": temp,
                    }
                )
            )
        ax_power.set_title(f"{label}: HVAC power", loc="left", fontsize="medium")
        ax_power.set_ylabel("power\n[kW]")
        ax_power.set_ylim(bottom=0.0)
        ax_temp.set_title(f"{label}: mean zone temperature", loc="left", fontsize="medium")
        ax_temp.set_ylabel("temperature\n[°C]")
        if row == 0:
            ax_power.legend(fontsize="x-small", loc="upper left")
            ax_temp.legend(fontsize="x-small", loc="upper left")
    for ax in axes[-2:]:
        plots.format_time_axis(ax)
        ax.set_xlabel("time (local)")
    shown = pd.Timestamp(parts[0]["time"].iloc[0]) if parts else None
    figure.suptitle(title if shown is None else f"{title}; the week from {shown:%Y-%m-%d} shown")
    return plots.save_figure(figure, pd.concat(parts, ignore_index=True), path)


def energyplus_section(
    eplus: Mapping[str, pd.DataFrame],
    rc: Mapping[str, pd.DataFrame],
    *,
    labels: Mapping[str, str],
    peak_price_sgd_per_kw: float,
    period: str,
    out: Path,
    figures: Path,
) -> Any:
    """The report's section on EnergyPlus office5; writes :data:`COMPARISON_CSV`,
    :data:`TABLE1_CSV` (Table 1, monthly averages, of the runs on each plant) and
    ``figures/energyplus_week.png`` (+ CSV).

    Parameters
    ----------
    eplus, rc : scenario key (:data:`ENERGYPLUS_SCENARIOS`) → results of the EnergyPlus and
        the RC-plant run of the same period.
    labels : scenario key → its label in the report.
    peak_price_sgd_per_kw : φ of the one tariff [SGD/kW].
    period : the period in words (e.g. "7 days from 2014-03-03").
    """
    from hvacflex.report import verdicts
    from hvacflex.report.html import Section

    keys = [key for key in ENERGYPLUS_SCENARIOS if key in eplus]
    runs = {
        (labels.get(key, key), plant): frames[key]
        for key in keys
        for plant, frames in (("rc", rc), ("energyplus", eplus))
        if key in frames
    }
    table = plant_comparison(runs, peak_price_sgd_per_kw)
    table.to_csv(out / COMPARISON_CSV, index=False)
    monthly = plant_table1(runs)
    monthly.to_csv(out / TABLE1_CSV)
    by_scenario: dict[str, dict[str, pd.DataFrame]] = {}
    for (label, plant), frame in runs.items():
        by_scenario.setdefault(label, {})[plant] = frame
    figure = plot_plant_week(
        by_scenario,
        figures / "energyplus_week.png",
        title=f"The same controllers on hvacflex's RC plant and on EnergyPlus ({period})",
    )
    basis = f"EnergyPlus office5 (generated IDF, setpoint actuation), {period}, not scaled"
    verdict_table = verdicts.verdict_table(
        verdicts.scenario_verdicts({key: kpi.summary(eplus[key]) for key in keys}, basis)
    )
    return Section(
        title="On EnergyPlus — the same controllers graded by an independent engine",
        paragraphs=[
            f"(a), (b), (c), the 24 °C thermostat and thermostat-25.5 over {period} on EnergyPlus "
            "25.2 running "
            "office5's own IDF export (VAV air loop with a chiller; hvacflex building "
            "export-idf office5), beside the same runs on hvacflex's RC plant. The controllers "
            "plan with hvacflex's RC model and send zone cooling setpoints (the planned "
            "end-of-period temperature clipped to the band, docs/guide/energyplus.md); "
            "EnergyPlus's own loops track them. Energy, cost, peak and comfort on EnergyPlus are "
            "measured on EnergyPlus's meters and zone temperatures; the HVAC energy is "
            "Electricity:HVAC + Electricity:Plant, the facility energy "
            "ElectricityPurchased:Facility. "
            f"tariff_cost_sgd prices every run alike: HVAC energy + φ = "
            f"{peak_price_sgd_per_kw:g} SGD/kW × the billed HVAC peak (prorated to the days "
            "covered) + IL penalties − reserve revenue settled against the meter (activated "
            "periods), over the period; reserve_revenue_unsettled_sgd beside it is the "
            "availability payments no activation tested (synthetic price). tracking_rmse_k: "
            "RMS of the realised minus the planned end-of-period zone temperature.",
            "The verdicts below repeat the paper's findings on the EnergyPlus runs; they are "
            "graded by EnergyPlus, not by hvacflex's model.",
        ],
        figures=[figure],
        figure_captions=[
            "Left: HVAC electric power of each run on each plant over a week of the period; "
            "right: the "
            "mean zone temperature over the shaded comfort band. Where the lines part, the RC "
            "plant and EnergyPlus disagree about the same controller's building."
        ],
        tables=[verdict_table, monthly, table],
        table_captions=[
            f"The paper's findings on EnergyPlus ({period}; the paper: the year 2014)",
            f"Table 1 on each plant: average per month, {period} (energy, billed peak at the "
            "one tariff, reserve offered / delivered against the metered baseline / "
            "shortfall, revenue, penalties, net; % against (a) on the same plant)",
            f"RC plant and EnergyPlus, {period}, totals over the period (not scaled)",
        ],
    )


# ---- Fig. 7 on EnergyPlus (issue 61 item 1) ---------------------------------------------

FIG7_ENERGYPLUS = "fig7_ppp_sweep_energyplus.png"
"""The figure of Fig. 7 on EnergyPlus in ``figures/``; its CSV,
``fig7_ppp_sweep_energyplus.csv``, holds :func:`fig7_energyplus_table`."""

FORECASTS: tuple[str, ...] = ("perfect", "realistic")
"""The ``forecast`` values of Fig. 7 on EnergyPlus: the presets' perfect foresight, and the
realistic forecast (``hvacflex.reproduce_plan.REALISTIC_FORECAST``)."""

FIG7_COLUMNS: tuple[str, ...] = (
    "peak_price_sgd_per_kw",
    "total_cost_sgd",
    "peak_power_kw",
    "net_cost_with_ppp_sgd",
    "normalised_total_cost_pct",
    "normalised_peak_power_pct",
    "forecast",
    "bound_peak_kw",
)
"""Columns of ``fig7_ppp_sweep_energyplus.csv``: those of ``fig7_ppp_sweep.csv`` (normalised
within each forecast) plus ``forecast`` and ``bound_peak_kw``."""

PEAK_KEEPS_PLAN = 1.05
"""Fig. 7 on EnergyPlus holds its plan when the realised peak ≤ this × the planned one."""

BOUND_SHARE_TARGET = 0.8
"""Perfect forecast: φ = 5's realised peak at least this share of the way from φ = 0.5's
peak down to ``bound_peak_kw``."""

NEAR_BOUND = 1.05
"""φ = 0.5's peak within this factor of the bound: nothing left to shave."""

LOW_PHI, HIGH_PHI = 0.5, 5.0
"""The φ [SGD/kW] of Fig. 7's verdict: φ = 5's way from φ = 0.5's peak to the bound."""

PHI_REL_TOLERANCE = 1e-6
"""Relative tolerance a sweep's φ matches :data:`LOW_PHI` / :data:`HIGH_PHI` with."""


def fig7_energyplus_table(sweep: pd.DataFrame, bound_peak_kw: Mapping[str, float]) -> pd.DataFrame:
    """Fig. 7 on EnergyPlus, columns :data:`FIG7_COLUMNS`, sorted by forecast then φ.

    Parameters
    ----------
    sweep : one row per run: ``forecast``, ``peak_price_sgd_per_kw`` [SGD/kW],
        ``net_cost_sgd`` (energy − reserve revenue, Fig. 7's total cost) [SGD],
        ``peak_power_kw`` (realised, EnergyPlus's meter) [kW], ``net_cost_with_ppp_sgd`` [SGD].
    bound_peak_kw : forecast → the least peak reachable with perfect foresight on the same
        days and band (:func:`hvacflex.sim.peak_bound.bound_peak_kw`) [kW].
    """
    from hvacflex.report.plots import normalise_ppp_sweep

    parts = []
    for forecast in [f for f in FORECASTS if f in set(sweep["forecast"])]:
        rows = sweep[sweep["forecast"] == forecast].rename(
            columns={"net_cost_sgd": "total_cost_sgd"}
        )
        data = normalise_ppp_sweep(rows)
        data["forecast"] = forecast
        data["bound_peak_kw"] = float(bound_peak_kw.get(forecast, np.nan))
        parts.append(data[list(FIG7_COLUMNS)])
    if not parts:
        return pd.DataFrame(columns=list(FIG7_COLUMNS))
    return pd.concat(parts, ignore_index=True)


def plot_fig7_energyplus(table: pd.DataFrame, path: Path) -> Path:
    """The realised peak [kW] against φ [SGD/kW], one line per forecast, each forecast's
    ``bound_peak_kw`` dashed; writes the PNG and ``table`` as its CSV."""
    from hvacflex.report import plots

    figure, (ax,) = plots.new_figure(1)
    for i, forecast in enumerate(FORECASTS):
        rows = table[table["forecast"] == forecast]
        if rows.empty:
            continue
        colour = f"C{i}"
        ax.plot(
            rows["peak_price_sgd_per_kw"],
            rows["peak_power_kw"],
            "o-",
            color=colour,
            label=f"realised peak, {forecast} forecast",
        )
        bound = float(rows["bound_peak_kw"].iloc[0])
        if np.isfinite(bound):  # NaN where the bound's LP failed (the section says why)
            ax.axhline(
                bound, color=colour, linestyle="--", label=f"bound, {forecast} forecast's days"
            )
    if len(table) and table["peak_price_sgd_per_kw"].min() > 0:
        ax.set_xscale("log")
    ax.set_xlabel("peak-power price φ [SGD/kW]")
    ax.set_ylabel("HVAC peak [kW]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="x-small")
    figure.suptitle("Fig. 7 on EnergyPlus office5: the realised peak and its bound")
    return plots.save_figure(figure, table, path)


def fig7_energyplus_verdict(
    table: pd.DataFrame, planned_peak_kw: Mapping[tuple[str, float], float]
) -> list[str]:
    """Sentences grading Fig. 7 on EnergyPlus (issue 61's "Done when"): each run's realised
    peak against :data:`PEAK_KEEPS_PLAN` × its planned one (``planned_peak_kw``: (forecast,
    φ) → the largest planned first-step power of the run [kW]); with the perfect forecast,
    φ = 5's share of the way from φ = 0.5's peak to the bound against
    :data:`BOUND_SHARE_TARGET` (or φ = 0.5 already within :data:`NEAR_BOUND` of it); with the
    realistic forecast, the distance to the bound."""
    sentences = []
    ratios = {
        key: float(row["peak_power_kw"]) / planned_peak_kw[key]
        for _, row in table.iterrows()
        if (key := (str(row["forecast"]), float(row["peak_price_sgd_per_kw"]))) in planned_peak_kw
        and planned_peak_kw[key] > 0
    }
    if ratios:
        worst = max(ratios, key=lambda k: ratios[k])
        held = sum(r <= PEAK_KEEPS_PLAN for r in ratios.values())
        sentences.append(
            f"Realised peak ≤ {PEAK_KEEPS_PLAN:g} × planned in {held} of {len(ratios)} runs "
            f"({'holds' if held == len(ratios) else 'does not hold'}; the largest ratio "
            f"{ratios[worst]:.3f} at φ = {worst[1]:g}, {worst[0]} forecast)."
        )
    for forecast in FORECASTS:
        rows = table[table["forecast"] == forecast]
        if not rows.empty:
            sentences.append(_bound_verdict(forecast, rows))
    return sentences


def _peak_at(rows: pd.DataFrame, phi: float) -> float | None:
    """The realised peak [kW] of the run at φ = ``phi`` (matched within
    :data:`PHI_REL_TOLERANCE`), None without one."""
    prices = rows["peak_price_sgd_per_kw"].astype(float).to_numpy()
    match = np.isclose(prices, phi, rtol=PHI_REL_TOLERANCE, atol=0.0)
    return float(rows["peak_power_kw"].to_numpy()[match][0]) if match.any() else None


def _bound_verdict(forecast: str, rows: pd.DataFrame) -> str:
    """One forecast's sentence against ``bound_peak_kw`` (:func:`fig7_energyplus_verdict`),
    or why there is none: no bound, no φ = 0.5 (or, perfect, φ = 5) run in the sweep."""
    name = f"{forecast.capitalize()} forecast"
    bound = float(rows["bound_peak_kw"].iloc[0])
    low, high = _peak_at(rows, LOW_PHI), _peak_at(rows, HIGH_PHI)
    if not np.isfinite(bound):
        return f"{name}: no bound_peak_kw (its LP failed, see above): no verdict against it."
    if low is None:
        return f"{name}: the sweep has no φ = {LOW_PHI:g} run: no verdict against the bound."
    if forecast == "realistic":
        best = float(rows["peak_power_kw"].min())
        gap = 100 * (best / bound - 1)
        side = "above" if gap >= 0 else "below (the bound is the LP model's optimum, not a plant's)"
        return (
            f"{name}: the lowest realised peak {best:.1f} kW is {abs(gap):.0f} % {side} the "
            f"bound {bound:.1f} kW of its days (φ = {LOW_PHI:g}: {low:.1f} kW)."
        )
    if low <= NEAR_BOUND * bound:
        return (
            f"{name}: φ = {LOW_PHI:g}'s peak {low:.1f} kW is already within "
            f"{100 * (NEAR_BOUND - 1):.0f} % of the bound {bound:.1f} kW: nothing left to shave."
        )
    if high is None:
        return f"{name}: the sweep has no φ = {HIGH_PHI:g} run: no share of the way to the bound."
    share = (low - high) / (low - bound)
    verdict = "holds" if share >= BOUND_SHARE_TARGET else "does not hold"
    beyond = (
        f"; φ = {HIGH_PHI:g}'s peak is below the bound, the LP model's perfect-foresight "
        "optimum, which is no lower bound on EnergyPlus"
        if share > 1
        else ""
    )
    return (
        f"{name}: φ = {HIGH_PHI:g} brings the peak from {low:.1f} kW (φ = {LOW_PHI:g}) to "
        f"{high:.1f} kW, {100 * share:.0f} % of the way to the bound {bound:.1f} kW "
        f"(target ≥ {100 * BOUND_SHARE_TARGET:.0f} %: {verdict}{beyond})."
    )


def fig7_energyplus_section(
    table: pd.DataFrame,
    planned_peak_kw: Mapping[tuple[str, float], float],
    *,
    period: str,
    figures: Path,
    bound_failures: Mapping[str, str] | None = None,
) -> Any:
    """The report's section on Fig. 7 on EnergyPlus: writes ``figures/``
    :data:`FIG7_ENERGYPLUS` and its CSV (``table``, :func:`fig7_energyplus_table`);
    ``bound_failures``: forecast → why its bound could not be computed (NaN in the table)."""
    from hvacflex.report.html import Section

    figure = plot_fig7_energyplus(table, figures / FIG7_ENERGYPLUS)
    return Section(
        title="Fig. 7 on EnergyPlus — the peak graded by EnergyPlus's meter, against its bound",
        paragraphs=[
            f"Scenario (c) (rmpc-ppp, its peak guard on) on EnergyPlus office5 (generated IDF, "
            f"setpoint actuation) over {period} at each φ, with the presets' perfect "
            "forecast and with the realistic one (statistical weather forecast, stochastic "
            "occupancy). peak_power_kw is the largest 30-min mean of EnergyPlus's HVAC meters "
            "(Electricity:HVAC + Electricity:Plant). bound_peak_kw is the perfect-foresight "
            "optimum of the controller's LP model (same comfort band, same days): one LP over "
            "the whole period on the controller's model and power rows "
            "(hvacflex.sim.peak_bound), graded by that model, not by EnergyPlus; a reference, "
            "not a proven lower bound on any plant (its power rows are secants, its start the "
            "configuration's initial state).",
            *(
                f"No bound_peak_kw for the {forecast} forecast (NaN): {why}"
                for forecast, why in sorted((bound_failures or {}).items())
            ),
            *fig7_energyplus_verdict(table, planned_peak_kw),
        ],
        figures=[figure],
        figure_captions=[
            "The realised HVAC peak on EnergyPlus against φ, per forecast; dashed: the bound of "
            "each forecast's days (perfect foresight on the controller's model)."
        ],
        tables=[table],
        table_captions=[f"Fig. 7 on EnergyPlus, {period}, totals over the period (not scaled)"],
    )


def fig7_energyplus_part(
    configs: Mapping[str, ScenarioConfig],
    outcomes: Sequence[JobOutcome],
    figures: Path,
    *,
    period: str,
    bound: Callable[[ScenarioConfig], float] | None = None,
) -> Any:
    """Fig. 7 on EnergyPlus (:func:`fig7_energyplus_section`) from the sweep's outcomes, or
    None without them. ``configs``: forecast → a run's configuration of that forecast (the
    bound does not depend on φ); ``bound``: a configuration → its ``bound_peak_kw`` [kW]
    (default :func:`hvacflex.sim.peak_bound.bound_peak_kw` on it: the same days, band and
    realised disturbances as the runs of that forecast). A bound that fails (a
    :class:`~hvacflex.errors.HvacflexError`) is NaN in the table and the section says why;
    the report goes on."""
    from hvacflex.results import load_results
    from hvacflex.sim.sweep import outcomes_table

    done = [o for o in outcomes if o.ok]
    if not done:
        return None
    if bound is None:
        from hvacflex.sim.peak_bound import bound_peak_kw

        def bound(cfg: ScenarioConfig) -> float:
            return bound_peak_kw(cfg).peak_kw

    forecasts = sorted({str(o.params["forecast"]) for o in done})
    bounds: dict[str, float] = {}
    failures: dict[str, str] = {}
    for forecast in (f for f in forecasts if f in configs):
        try:
            bounds[forecast] = bound(configs[forecast])
        except HvacflexError as exc:  # the report goes on without this bound
            bounds[forecast], failures[forecast] = float("nan"), str(exc)
    planned = {
        (str(o.params["forecast"]), float(o.params["peak_price_sgd_per_kw"])): float(
            load_results(o.out_dir)["planned_power_kw"].max()
        )
        for o in done
    }
    table = fig7_energyplus_table(outcomes_table(done), bounds)
    return fig7_energyplus_section(
        table,
        planned,
        period=period,
        figures=figures,
        bound_failures=failures,
    )
