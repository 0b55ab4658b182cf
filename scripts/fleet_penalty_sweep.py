"""Energy against discomfort in the first step's centralised LP of a windowed fleet, by the
weight of the comfort penalty.

python scripts/fleet_penalty_sweep.py --fleet F [--start 2014-03-03] [--penalties 100 30 10]
    [--robust none]

Builds every building's step problem at ``--start`` from the closed loop's initial state
and stacks them (`hvacflex.fleet.centralised`) under the fleet's planning limit (its
windows), once without a limit (the unlimited plan, at the problems' own penalty), then
under the limit with each comfort penalty ρ [SGD per K·h]; solves each cold and prints the
energy it plans over 00:00–07:00, 07:00–10:00, 10:00–17:00, 17:00–24:00 and the horizon
(against the unlimited plan; blocks by clock hour, so ``--start 2014-03-03T17:00`` grades
the evening step: its 17:00–24:00 is cold stored for the next day's window), and the
discomfort it plans [K·h per building over the horizon: the comfort penalty / ρ].
``--robust none`` (default) drops the robust margins (perfect foresight on the controllers'
model, as `fleet bound`); ``tightening`` keeps the controllers' (several times slower).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
import pandas as pd
from fleet_night_plan import first_step  # scripts/ is the script's own folder on sys.path

from hvacflex.fleet.centralised import CentralisedSolver

BLOCKS = (("00-07", 0, 7), ("07-10", 7, 10), ("10-17", 10, 17), ("17-24", 17, 24))
"""(label, first hour, end hour) of the day's blocks [local clock hours]; a horizon that does
not start at midnight (``--start 2014-03-03T17:00``: the evening step) sums each block by the
clock hour of its periods."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleet", required=True)
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--penalties", type=float, nargs="+", default=[100.0, 30.0, 10.0])
    parser.add_argument("--robust", choices=["none", "tightening"], default="none")
    args = parser.parse_args()
    group, horizon, window = first_step(args.fleet, args.start)
    start = pd.Timestamp(args.start)
    hours = np.asarray([(start + pd.Timedelta(minutes=30 * k)).hour for k in range(horizon)])
    base = [dataclasses.replace(p, robust=args.robust) for p in group.problems()]
    buildings = len(base)
    free_energy = float("nan")
    cases = [("no window", base[0].comfort_penalty_sgd_per_kelvin_hour, np.full(horizon, np.inf))]
    cases += [("window", rho, window) for rho in args.penalties]
    for label, rho, limit in cases:
        problems = [  # the linear penalty alone (fleet_convex_penalty.py sweeps the knee)
            dataclasses.replace(p, comfort_penalty_sgd_per_kelvin_hour=rho, comfort_knee=None)
            for p in base
        ]
        tick = time.perf_counter()
        result = CentralisedSolver().solve(problems, limit)
        power = result.power_kw.sum(axis=0)
        energy = 0.5 * float(power.sum())
        if label == "no window":
            free_energy = energy
        assert result.split_sgd is not None
        discomfort = float(result.split_sgd[:, 2].sum()) / rho / buildings
        blocks = ", ".join(
            f"{name} {0.5 * power[(hours >= a) & (hours < b)].sum():.0f}" for name, a, b in BLOCKS
        )
        print(
            f"{label}, rho {rho:g} SGD/K·h: energy {energy:.0f} kWh "
            f"({100 * (energy / free_energy - 1):+.1f} %; {blocks} kWh), discomfort "
            f"{discomfort:.2f} K·h per building, peak {power.max():.1f} kW "
            f"({time.perf_counter() - tick:.0f} s)",
            flush=True,
        )


if __name__ == "__main__":
    main()
