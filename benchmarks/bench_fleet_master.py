"""The bundle's coordinator LPs at fleet scale (issue 31): CPU of one restricted master and
one dual model for B buildings with J plans each over 48 periods (synthetic plans: powers
drawn around a base profile, one cheap-enough feasible plan per building), as they are
solved now (cold, :func:`hvacflex.opt.solve.solve_lp`). They run on the coordinator once per
round, so their sum over a step's rounds is the serial part of a fleet dispatch.

    python benchmarks/bench_fleet_master.py --buildings 100 1000 --plans 5 20

Measured 2026-12-02 on the shared 2-core machine (load 21.7–22.4): master / dual model CPU
0.05 / 0.03 s (100 buildings, 5 plans), 0.22 / 0.10 s (100, 20), 1.00 / 0.26 s (1,000, 5),
5.55 / 1.04 s (1,000, 20); docs/guide/fleet.md, "Scale".
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from hvacflex.fleet.bundle import _Columns, solve_dual_model, solve_restricted_master

PERIODS = 48


def measure(buildings: int, plans: int, seed: int = 0) -> tuple[float, float]:
    """(master CPU [s], dual-model CPU [s]) for ``buildings`` × ``plans`` columns."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(5.0, 30.0, (buildings, PERIODS))
    columns = _Columns()
    for _ in range(plans):
        power = base * rng.uniform(0.5, 1.0, base.shape)
        columns.add(power, 1000.0 / power.mean(axis=1) * rng.uniform(0.9, 1.1, buildings))
    columns.add(0.55 * base, np.full(buildings, 5000.0))  # makes the master feasible
    total = 0.7 * base.sum(axis=0)
    tick = time.process_time()
    found = solve_restricted_master(columns, total)
    master = time.process_time() - tick
    if found is None:
        raise RuntimeError(f"the restricted master of {buildings} × {plans} is infeasible")
    tick = time.process_time()
    solve_dual_model(columns, total, np.zeros(PERIODS), np.full(PERIODS, 10.0))
    return master, time.process_time() - tick


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--buildings", type=int, nargs="+", default=[100, 1000])
    parser.add_argument("--plans", type=int, nargs="+", default=[5, 20])
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.buildings, args.plans = [5], [2]
    print(f"load average at start: {os.getloadavg()}")
    print("| buildings | plans per building | master CPU [s] | dual model CPU [s] |")
    print("|---|---|---|---|")
    for buildings in args.buildings:
        for plans in args.plans:
            master, dual = measure(buildings, plans)
            print(f"| {buildings} | {plans} | {master:.2f} | {dual:.2f} |", flush=True)
    print(f"load average at end: {os.getloadavg()}")
    print("checks passed: every restricted master feasible")


if __name__ == "__main__":
    main()
