"""Grade a windowed fleet run against issue 60's criteria (docs/guide/fleet.md, "Issue 60").

python scripts/fleet_window_grade.py --run runs/window --unlimited runs/unlimited
    [--bound runs/bound/bound.csv] [--by-hour]

Both runs are `hvacflex fleet simulate` folders over the same days, the second with
`feeder_limit_kw = inf` and no windows. Prints, on the RC plants' meters: whether the windows
bind, the planned and realised over-limit in the window periods, discomfort per building-day
against the bound (+0.5 K·h), the largest zone violation per building, the peak outside the
windows against the unlimited peak, and the energy against the unlimited days, split by
block of the day (00:00–07:00, 07:00–10:00, 10:00–17:00, 17:00–24:00; `--by-hour`: by hour),
planned and metered; the building-periods whose applied action the fleet's guard cut
(`solve_status` ending in "+capped") with their share of the discomfort; and the discomfort
below and above the band.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex import kpi as kpis
from hvacflex import results as schema
from hvacflex.results import read_results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, required=True)
    parser.add_argument("--unlimited", type=Path, required=True)
    parser.add_argument("--bound", type=Path)
    parser.add_argument("--by-hour", action="store_true")
    args = parser.parse_args()
    run, _ = read_results(args.run / "results.parquet")
    free, _ = read_results(args.unlimited / "results.parquet")
    free = free.loc[run.index]
    inside = np.isfinite(run["feeder_limit_kw"].to_numpy())
    limit = run["feeder_limit_kw"].to_numpy()[inside]
    days = len(run) / 48
    print(f"{len(run)} periods ({days:g} days), {int(inside.sum())} in windows")
    above = free["fleet_power_kw"].to_numpy()[inside] - limit
    print(
        f"binds: unlimited above the limit in {int((above > 0).sum())} window periods "
        f"(by up to {above.max():.2f} kW)"
    )
    planned = run["planned_fleet_power_kw"].to_numpy()[inside] - limit
    realised = 100 * (run["fleet_power_kw"].to_numpy()[inside] / limit - 1)
    flagged = run["feeder_infeasible"].to_numpy()[inside]
    print(
        f"planned over-limit max {planned.max():.3g} kW; realised over-limit max "
        f"{realised.max():+.2f} %; {int(flagged.sum())} window periods flagged infeasible"
    )
    outside = run["fleet_power_kw"].to_numpy()[~inside]
    peak_free = free["fleet_power_kw"].max()
    worst = run.index[~inside][int(np.argmax(outside))]
    print(
        f"peak outside the windows {outside.max():.2f} kW at {worst:%m-%d %H:%M} "
        f"against the unlimited peak {peak_free:.2f} kW"
    )
    energy = 0.5 * run["fleet_power_kw"].sum()
    energy_free = 0.5 * free["fleet_power_kw"].sum()
    print(
        f"energy {energy:,.0f} kWh against {energy_free:,.0f} kWh: "
        f"{100 * (energy / energy_free - 1):+.1f} %"
    )
    if days > 1:
        for day, metered in run["fleet_power_kw"].groupby(run.index.date):
            unlimited = 0.5 * free["fleet_power_kw"][free.index.date == day].sum()
            print(
                f"  {day}: {0.5 * metered.sum():,.0f} kWh against {unlimited:,.0f} kWh: "
                f"{100 * (0.5 * metered.sum() / unlimited - 1):+.1f} %"
            )
    night = run.index.hour < 7
    print(
        f"00:00-07:00: planned {run['planned_fleet_power_kw'][night].min():.0f}-"
        f"{run['planned_fleet_power_kw'][night].max():.0f} kW, metered "
        f"{run['fleet_power_kw'][night].min():.0f}-{run['fleet_power_kw'][night].max():.0f} kW "
        f"(unlimited {free['fleet_power_kw'][night].min():.0f}-"
        f"{free['fleet_power_kw'][night].max():.0f} kW)"
    )
    print(energy_table(run, free, args.by_hour).round(1).to_string())
    long = pd.read_parquet(args.run / "buildings.parquet")
    cut, in_cut, total = 0, 0.0, 0.0
    for _, frame in long.groupby("building"):
        step = kpis.step_discomfort_kelvin_hours(frame).to_numpy()
        capped = frame["solve_status"].astype(str).str.endswith("+capped").to_numpy()
        cut += int(capped.sum())
        in_cut, total = in_cut + step[capped].sum(), total + step.sum()
    print(
        f"guard-cut building-periods: {cut}, holding {in_cut:.2f} of {total:.2f} K·h of discomfort"
    )
    below, above = band_sides_kelvin_hours(long)
    print(f"of which below the band {below:.2f} K·h, above it {above:.2f} K·h")
    rows = []
    for name, frame in long.groupby("building"):
        rows.append(
            (
                name,
                kpis.total_discomfort_kelvin_hours(frame) / days,
                float(kpis.max_violation_k(frame).max()),
            )
        )
    table = pd.DataFrame(rows, columns=["building", "discomfort_per_day", "max_violation_k"])
    if args.bound is not None:
        bound = pd.read_csv(args.bound).set_index("building")["discomfort_kelvin_hours"]
        table["bound_per_day"] = table["building"].map(bound) / days
        table["within"] = table["discomfort_per_day"] <= table["bound_per_day"] + 0.5
    print(table.round(3).to_string(index=False))
    if days > 1:
        by_day = long.assign(day=pd.DatetimeIndex(long.index).date)
        for day, frame in by_day.groupby("day"):
            per_building = [
                kpis.total_discomfort_kelvin_hours(f) for _, f in frame.groupby("building")
            ]
            print(f"  {day}: {np.mean(per_building):.3f} K·h per building")
    print(
        f"fleet mean per building-day {table['discomfort_per_day'].mean():.3f} K·h"
        + (f" against bound {table['bound_per_day'].mean():.3f}" if args.bound else "")
    )


def band_sides_kelvin_hours(long: pd.DataFrame) -> tuple[float, float]:
    """Discomfort [K·h] below and above the band, summed over buildings and zones: each
    building's period-end temperatures against the band the KPIs grade (``temp_end_*``
    against ``comfort_lower_*`` and ``comfort_upper_*``), × its periods' hours; their sum
    is the guard line's total."""
    below = above = 0.0
    for _, frame in long.groupby("building"):
        hours = kpis.step_hours(frame)
        for zone in kpis.zone_names(frame):
            end = frame[schema.TEMP_END.name(zone)].to_numpy()
            lower = frame[schema.COMFORT_LOWER.name(zone)].to_numpy()
            upper = frame[schema.COMFORT_UPPER.name(zone)].to_numpy()
            below += hours * float(np.maximum(lower - end, 0.0).sum())
            above += hours * float(np.maximum(end - upper, 0.0).sum())
    return below, above


BLOCKS = ((0, 7), (7, 10), (10, 17), (17, 24))
"""The day's blocks [hours]: night, morning, the office window, evening."""


def energy_table(run: pd.DataFrame, free: pd.DataFrame, by_hour: bool) -> pd.DataFrame:
    """Energy [kWh] by block of the day (or by hour), summed over the days: the run's
    planned and metered, the unlimited run's metered, and the difference."""
    hours = run.index.hour
    edges = [(h, h + 1) for h in range(24)] if by_hour else BLOCKS
    rows = {}
    for a, b in edges:
        inside = (hours >= a) & (hours < b)
        rows[f"{a:02d}-{b:02d}"] = {
            "planned_kwh": 0.5 * run["planned_fleet_power_kw"][inside].sum(),
            "metered_kwh": 0.5 * run["fleet_power_kw"][inside].sum(),
            "unlimited_kwh": 0.5 * free["fleet_power_kw"][inside].sum(),
        }
    table = pd.DataFrame(rows).T
    table["extra_kwh"] = table["metered_kwh"] - table["unlimited_kwh"]
    return table


if __name__ == "__main__":
    main()
