"""The coordination schemes on one fleet step against the centralised LP (issue 31).

From the fleet file's initial states at ``--start``, every building builds its step problem
once; the centralised LP of the whole fleet is solved, then each ``SCHEME:ROUNDS`` argument
coordinates the same step (the same building agents, warm-started) and its cost is compared
with the centralised optimum. Prints a markdown table with the process CPU time of each
coordination per building:

    python scripts/fleet_scheme_table.py pd4.toml 2014-03-03T08:00 bundle:20 envelope:0 prices:10
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from hvacflex.fleet.agent import FleetSettings
from hvacflex.fleet.centralised import solve_centralised
from hvacflex.fleet.run import (
    DT_H,
    _coordination_options,
    _feeder_timeline,
    _Groups,
    coordinate_ranges,
)
from hvacflex.fleet.schema import load_fleet
from hvacflex.tomlio import read_toml


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("fleet")
    parser.add_argument("start")
    parser.add_argument("schemes", nargs="+", help="SCHEME:ROUNDS, e.g. bundle:20")
    args = parser.parse_args()
    fleet = load_fleet(args.fleet)
    days = DT_H / 24.0
    settings = FleetSettings.of(fleet, args.start, days)
    _, _, planning = _feeder_timeline(fleet, args.start, days, settings.horizon_steps)
    n = len(fleet.buildings)
    groups = _Groups(read_toml(args.fleet, what="fleet"), settings, n, None)
    ranges = groups.stacked("begin_step")
    limit = planning[: settings.horizon_steps]
    central = solve_centralised([a.problem for a in groups.groups[0].agents], limit)
    print(
        "| scheme | rounds | centralised [SGD] | coordinated [SGD] | gap | over limit [kW] | "
        "CPU-s per building |"
    )
    print("|---|---|---|---|---|---|---|")
    for item in args.schemes:
        scheme, rounds = item.split(":")
        options = dataclasses.replace(
            _coordination_options(fleet), scheme=scheme, max_iterations=max(int(rounds), 1)
        )
        tick = time.process_time()
        result = coordinate_ranges(groups, ranges, limit, options, np.zeros(limit.size))
        cpu = (time.process_time() - tick) / n
        cost = float(result.cost_sgd.sum())
        over = float(np.max(result.power_kw.sum(axis=0) - limit, initial=0.0))
        print(
            f"| {scheme} | {result.iterations} | {central.objective_sgd:.2f} | {cost:.2f} | "
            f"{100 * (cost / central.objective_sgd - 1):.2f} % | {max(over, 0.0):.2g} | "
            f"{cpu:.2f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
