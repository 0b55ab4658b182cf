"""The controllers' objective under a limit window with a comfort penalty that grows with
the excursion, on the controllers' model with perfect foresight.

python scripts/fleet_convex_penalty.py --fleet F [--start 2014-03-03] [--days 1]
    [--cases 100:100:1 10:1000:0.5 3:300:0.5]

Each case ρ₁:ρ₂:δ prices every zone's slack ε at ρ₁ [SGD per K·h] up to δ [K] and at
ρ₂ ≥ ρ₁ beyond (the controllers' comfort knee, `hvacflex.opt.ComfortKnee`: fleet keys
``comfort_penalty_sgd_per_kelvin_hour``, ``comfort_knee_k`` and
``comfort_penalty_beyond_knee_sgd_per_kelvin_hour``); 100:100:δ is the product's linear
penalty. Builds the run model of `fleet bound` (every building from the closed loop's
initial state, one horizon over the run, the limits in force, no robust margins, no
reserve: `hvacflex.fleet.bound.priced_only`), stacks the buildings' LPs under the limits
(`hvacflex.fleet.centralised.stacked_lp`), solves cold and prints the plan's energy [kWh,
% over the unlimited plan's], split 00–07 / 07–10 / 10–17 / 17–24, its discomfort per
building-day (fleet mean and the largest building) and its largest zone slack [K].
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from hvacflex.fleet.bound import priced_only, run_model, unlimited_energy_kwh
from hvacflex.fleet.centralised import stacked_lp
from hvacflex.fleet.compare import reference_limit_kw
from hvacflex.fleet.schema import load_fleet_document
from hvacflex.opt import ComfortKnee

BLOCKS = (("00-07", 0, 14), ("07-10", 14, 20), ("10-17", 20, 34), ("17-24", 34, 48))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleet", required=True)
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--days", type=float, default=1.0)
    parser.add_argument("--cases", nargs="+", default=["100:100:1", "10:1000:0.5", "3:300:0.5"])
    parser.add_argument("--unlimited-kwh", type=float, default=None)
    args = parser.parse_args()
    fleet, document = load_fleet_document(args.fleet)
    model = run_model(fleet, document, args.start, args.days)
    free = args.unlimited_kwh or unlimited_energy_kwh(model)
    print(f"unlimited plan: {free:.0f} kWh", flush=True)
    limit = reference_limit_kw(model.planning_kw, model.p_min_kw)
    days = model.p_min_kw.shape[1] / 48
    for case in args.cases:
        rho1, rho2, knee_k = (float(v) for v in case.split(":"))
        tick = time.perf_counter()
        knee = ComfortKnee(knee_kelvin=knee_k, penalty_beyond_sgd_per_kelvin_hour=rho2)
        problems = [
            dataclasses.replace(
                priced_only(p), comfort_penalty_sgd_per_kelvin_hour=rho1, comfort_knee=knee
            )
            for p in model.problems
        ]
        stacked = stacked_lp(problems, limit)
        dt = problems[0].dt_h
        result = stacked.solve()
        if not result.status.ok:
            print(f"{case}: no solution ({result.status})", flush=True)
            continue
        power = np.sum([result.x[cols] for cols in stacked.power_cols], axis=0)
        slack = [result.x[np.asarray(lay.plan.eps) + first] for first, lay in stacked.layouts]
        per_day = np.array([s.sum() * dt for s in slack]) / days
        daily = power.reshape(-1, 48)
        blocks = " / ".join(f"{0.5 * daily[:, a:b].sum():.0f}" for _, a, b in BLOCKS)
        energy = 0.5 * power.sum()
        print(
            f"rho {rho1:g} up to {knee_k:g} K, {rho2:g} beyond: energy {energy:.0f} kWh "
            f"({100 * (energy / free - 1):+.1f} %; {blocks} kWh), discomfort "
            f"{per_day.mean():.2f} K·h per building-day (largest {per_day.max():.2f}), "
            f"largest slack {max(s.max() for s in slack):.2f} K "
            f"({time.perf_counter() - tick:.0f} s)",
            flush=True,
        )


if __name__ == "__main__":
    main()
