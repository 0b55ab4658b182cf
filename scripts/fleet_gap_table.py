"""Coordination gap of one fleet step against the centralised LP (issue 17, docs/guide/fleet.md).

For each case, ``B`` generated buildings (seed 3) run with no feeder limit up to the case's
hour on 2014-03-03; the step is then coordinated under a limit of 0.9 × the uncoordinated
peak over the horizon, with ``I`` price iterations and 0 (the averaged-request caps alone)
or ``R`` cap-reallocation rounds, and compared with the centralised LP of the whole fleet
(:func:`hvacflex.fleet.centralised.solve_centralised`). The markdown table goes to stdout:

    python scripts/fleet_gap_table.py [--rounds 0 4 8]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.centralised import solve_centralised
from hvacflex.fleet.coordinate import CoordinationOptions, coordinate
from hvacflex.fleet.generate import generate_fleet
from hvacflex.fleet.schema import fleet_from_dict

CASES = ((5, 20, "10:00"), (4, 16, "08:00 pull-down"))
"""(buildings, steps from midnight, label)."""


def group_at(buildings: int, steps: int) -> BuildingGroup:
    """A fleet of ``buildings`` (seed 3) advanced ``steps`` periods without a limit."""
    doc = generate_fleet(buildings, 3)
    fleet = fleet_from_dict(doc)
    group = BuildingGroup(doc, list(range(buildings)), FleetSettings.of(fleet, "2014-03-03", 1))
    free = np.full((buildings, 48), np.inf)
    for _ in range(steps):
        group.begin_step()
        group.solve(np.zeros(48))
        group.finalize(np.zeros(48), free)
        group.advance()
    return group


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--iterations", type=int, nargs="+", default=[5, 15])
    parser.add_argument("--rounds", type=int, nargs="+", default=[0, 4, 8])
    parser.add_argument("--step-share", type=float, default=0.25, help="cap_step_share")
    parser.add_argument("--cases", type=int, nargs="+", default=[0, 1], help="indices of CASES")
    args = parser.parse_args()
    print(
        "| case | iterations | cap rounds | centralised [SGD] | coordinated [SGD] | gap | "
        "feasible | time [s] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for buildings, steps, label in (CASES[i] for i in args.cases):
        group = group_at(buildings, steps)
        p_min, p_max, price = group.begin_step()
        free_power, _, _ = group.solve(np.zeros(48))
        limit = np.full(48, 0.9 * free_power.sum(axis=0).max())
        central = solve_centralised([a.problem for a in group.agents], limit)
        for iterations in args.iterations:
            for rounds in args.rounds:
                start = time.perf_counter()
                result = coordinate(
                    group.solve,
                    group.finalize,
                    limit,
                    p_min,
                    p_max,
                    price,
                    0.5,
                    CoordinationOptions(
                        max_iterations=iterations,
                        cap_rounds=rounds,
                        cap_step_share=args.step_share,
                    ),
                    cap_values_all=group.cap_values,
                )
                elapsed = time.perf_counter() - start
                cost = float(np.sum(result.cost_sgd))
                gap = (cost - central.objective_sgd) / abs(central.objective_sgd)
                feasible = bool(np.all(result.power_kw.sum(axis=0) <= limit + 1e-6))
                print(
                    f"| {label} ({buildings} buildings) | {iterations} | {result.cap_rounds} | "
                    f"{central.objective_sgd:.2f} | {cost:.2f} | {100 * gap:.1f} % | "
                    f"{feasible} | {elapsed:.1f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
