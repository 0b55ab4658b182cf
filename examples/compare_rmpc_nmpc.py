"""One day of the robust MPC (rmpc) against the nominal one (nmpc), side by side.

Run from any folder: ``python compare_rmpc_nmpc.py``; each run's files go to
``results/examples/<preset>`` there (a second call re-uses the finished runs).
"""

from __future__ import annotations

import hvacflex

START = "2014-03-03"
"""A Monday in the price data (Singapore time)."""

KPIS = (
    "energy_kwh",
    "energy_cost_sgd",
    "reserve_revenue_sgd",
    "net_cost_sgd",
    "peak_power_kw",
    "reserve_offered_mean_kw",
    "discomfort_kelvin_hours",
    "max_violation_k",
)


def main() -> None:
    runs = {
        name: hvacflex.simulate(name, f"results/examples/{name}", quiet=True, start=START, days=1)
        for name in ("nmpc", "rmpc")
    }
    print(f"{'kpi':<26}" + "".join(f"{name:>12}" for name in runs))
    for kpi in KPIS:
        print(f"{kpi:<26}" + "".join(f"{run.summary[kpi]:>12.2f}" for run in runs.values()))
    for name, run in runs.items():
        hours_offered = (run.results["reserve_kw"] > 0).sum() / 2  # 30-min periods
        print(f"{name}: reserve offered in {hours_offered:g} h; files in {run.out_dir}")


if __name__ == "__main__":
    main()
