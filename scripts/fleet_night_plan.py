"""The first step's centralised LP of a windowed fleet, with and without robust margins.

python scripts/fleet_night_plan.py --fleet F [--start 2014-03-03]

Builds every building's step problem at ``--start`` from the closed loop's initial state,
stacks them (`hvacflex.fleet.centralised`) under the fleet's planning limit (its windows)
and without a limit, each with the controllers' robust margins and with `robust = "none"`,
solves each cold and prints the energy it plans over 00:00–07:00, 07:00–10:00 and the
horizon, and the peak before 10:00 (docs/guide/fleet.md, "Issue 60 re-measured").
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.centralised import solve_centralised
from hvacflex.fleet.compare import reference_limit_kw
from hvacflex.fleet.run import _feeder_timeline
from hvacflex.fleet.schema import load_fleet_document


def first_step(fleet_path: str, start: str) -> tuple[BuildingGroup, int, np.ndarray]:
    """Every building of the fleet file set up for its first step at ``start`` (its problems
    built from the closed loop's initial state), the horizon N and the fleet's planning limit
    over it (N,) [kW] (its windows; inf outside them)."""
    fleet, doc = load_fleet_document(fleet_path)
    settings = FleetSettings.of(fleet, start, 1)
    group = BuildingGroup(doc, list(range(len(fleet.buildings))), settings)
    p_min, _, _ = group.begin_step()
    horizon = p_min.shape[1]
    _, _, planning = _feeder_timeline(fleet, start, 1, horizon)
    return group, horizon, reference_limit_kw(planning[:horizon], p_min)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleet", required=True)
    parser.add_argument("--start", default="2014-03-03")
    args = parser.parse_args()
    group, horizon, window = first_step(args.fleet, args.start)
    margins = group.problems()
    exact = [dataclasses.replace(p, robust="none") for p in margins]
    for label, problems in (("robust margins", margins), ("no margins", exact)):
        for limit_label, limit in (("window", window), ("no window", np.full(horizon, np.inf))):
            tick = time.perf_counter()
            power = solve_centralised(problems, limit).power_kw.sum(axis=0)
            print(
                f"{label}, {limit_label}: 00:00-07:00 {0.5 * power[:14].sum():.1f} kWh, "
                f"07:00-10:00 {0.5 * power[14:20].sum():.1f} kWh, horizon "
                f"{0.5 * power.sum():.1f} kWh, peak before 10:00 {power[:20].max():.1f} kW "
                f"({time.perf_counter() - tick:.0f} s)"
            )
            print("  00:00-07:00 plan [kW]:", np.round(power[:14]).tolist())


if __name__ == "__main__":
    main()
