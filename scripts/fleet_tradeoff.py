"""The fleet's least discomfort against its energy, on the controllers' model: the
trade-off curve behind issue 60's "discomfort ≤ bound + 0.5 K·h and energy ≤ +10 %".

python scripts/fleet_tradeoff.py --fleet F [--start 2014-03-03] [--days 1]
    [--budgets 0 5 10 15 20 30] [--max-excursion 1.0] [--unlimited-kwh E]

Builds the run model of `fleet bound` (`hvacflex.fleet.bound.run_model`: every building
from the closed loop's initial state, one horizon over the run, perfect foresight, no
margins, the limits in force), measures the unlimited plan's energy E₀ (the centralised LP
of the controllers' objective without any limit, `unlimited_energy_kwh`), then for each
budget x [% over E₀] solves the bound's LP with the fleet's energy ≤ (1 + x/100)·E₀
(`budgeted_bound`), without and with every zone's slack capped at ``--max-excursion`` [K];
last the bound itself (no budget; ``--unlimited-kwh`` gives E₀ instead of solving for it:
it does not depend on the limits); and the least energy of a plan meeting issue 60's
comfort criteria (`least_energy_for_comfort`: each building's discomfort ≤ its bound +
0.5 K·h per day, without and with the slack cap). Prints per case: the plan's energy [kWh,
% over E₀], split 00–07 / 07–10 / 10–17 / 17–24 (of the run's days together), the
discomfort per building-day (fleet mean and the largest building; on runs of several days
also by day) and the largest zone slack [K].
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from hvacflex.fleet.bound import (
    BudgetedBound,
    budgeted_bound,
    least_energy_for_comfort,
    run_model,
    unlimited_energy_kwh,
)
from hvacflex.fleet.schema import load_fleet_document

BLOCKS = (("00-07", 0, 14), ("07-10", 14, 20), ("10-17", 20, 34), ("17-24", 34, 48))
"""(label, first period, end period) of the day's blocks [30-min periods from 00:00]."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleet", required=True)
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--days", type=float, default=1.0)
    parser.add_argument("--budgets", type=float, nargs="*", default=[0, 5, 10, 15, 20, 30])
    parser.add_argument("--max-excursion", type=float, default=None)
    parser.add_argument("--unlimited-kwh", type=float, default=None)
    args = parser.parse_args()
    fleet, document = load_fleet_document(args.fleet)
    model = run_model(fleet, document, args.start, args.days)
    tick = time.perf_counter()
    free = args.unlimited_kwh if args.unlimited_kwh else unlimited_energy_kwh(model)
    print(f"unlimited plan: {free:.0f} kWh ({time.perf_counter() - tick:.0f} s)", flush=True)
    caps = [None] if args.max_excursion is None else [None, args.max_excursion]
    days = model.p_min_kw.shape[1] / 48
    bound = None
    for cap in caps:
        for pct in [*args.budgets, np.inf]:
            tick = time.perf_counter()
            point = budgeted_bound(model, (1 + pct / 100) * free, max_excursion_k=cap)
            _show(f"budget +{pct:g} %, slack cap {cap} K", point, free, days, tick)
            if cap is None and np.isinf(pct):
                bound = point.bound.discomfort_kelvin_hours
    assert bound is not None
    for cap in caps:
        tick = time.perf_counter()
        point = least_energy_for_comfort(model, bound + 0.5 * days, max_excursion_k=cap)
        _show(
            f"least energy, each building ≤ bound + 0.5, slack cap {cap} K", point, free, days, tick
        )


def _show(label: str, point: BudgetedBound, free: float, days: float, tick: float) -> None:
    if not point.solved:
        print(f"{label}: no solution ({time.perf_counter() - tick:.0f} s)", flush=True)
        return
    daily = point.power_kw.reshape(-1, 48)
    blocks = " / ".join(f"{0.5 * daily[:, a:b].sum():.0f}" for _, a, b in BLOCKS)
    per_day = point.bound.discomfort_kelvin_hours / days
    print(
        f"{label}: energy {point.energy_kwh:.0f} kWh "
        f"({100 * (point.energy_kwh / free - 1):+.1f} %; {blocks} kWh), discomfort "
        f"{per_day.mean():.2f} K·h per building-day (largest {per_day.max():.2f}), "
        f"largest slack {point.largest_slack_k:.2f} K ({time.perf_counter() - tick:.0f} s)",
        flush=True,
    )
    if days > 1:
        by_day = point.bound.per_period_kelvin_hours.reshape(len(per_day), -1, 48).sum(axis=2)
        print("  by day [K·h per building]:", np.round(by_day.mean(axis=0), 2).tolist())


if __name__ == "__main__":
    main()
