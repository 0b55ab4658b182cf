"""Fig. 7's peak-price sweep on EnergyPlus office5 (docs/explanation/reproduction.md, the findings
table).

Scenario (c) (``rmpc-ppp``, billed per month, the full plan's realistic forecast) over Fig. 7's
28 days from 2014-03-03 at each φ, on EnergyPlus office5 (the generated IDF, setpoint
actuation; the plan's EnergyPlus runs, with φ varied), on Dask, cached by inputs and code.
Prints per φ the realised peak (EnergyPlus's meters), the largest planned first-period power
and (energy − reserve revenue), and writes ``OUT/energyplus_ppp_sweep.csv``.

    python scripts/energyplus_ppp_sweep.py OUT [φ ...]     # default φ: 0.5 1.5 5 15 30
"""

import sys
import time
from dataclasses import replace
from pathlib import Path

import pandas as pd

from hvacflex import kpi
from hvacflex.config import with_overrides
from hvacflex.reproduce_energyplus import on_energyplus
from hvacflex.reproduce_plan import REALISTIC_FORECAST, Plan, ppp_jobs
from hvacflex.results import load_results
from hvacflex.sim.sweep import run_sweep


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "results/energyplus_ppp")
    values = tuple(float(v) for v in sys.argv[2:]) or (0.5, 1.5, 5.0, 15.0, 30.0)
    plan = replace(Plan.full(), ppp_values=values)
    jobs = [
        (params, with_overrides(on_energyplus(cfg), REALISTIC_FORECAST))
        for params, cfg in ppp_jobs(plan)
    ]
    t0 = time.time()
    outcomes = run_sweep(jobs, out, n_workers=2, progress=True)
    rows = []
    for o in outcomes:
        if not o.ok:
            print(f"{o.label}: FAILED {o.error}")
            continue
        frame = load_results(Path(o.out_dir) / "results.parquet")
        summary = kpi.summary(frame)
        rows.append(
            {
                "peak_price_sgd_per_kw": o.params["peak_price_sgd_per_kw"],
                "realised_peak_kw": summary["peak_power_kw"],
                "planned_peak_kw": float(frame["planned_power_kw"].max()),
                "energy_cost_sgd": summary["energy_cost_sgd"],
                "reserve_revenue_sgd": summary["reserve_revenue_sgd"],
                "total_cost_sgd": summary["energy_cost_sgd"] - summary["reserve_revenue_sgd"],
                "discomfort_kelvin_hours": summary["discomfort_kelvin_hours"],
                "peak_time": str(frame["power_kw"].idxmax()),
            }
        )
    table = pd.DataFrame(rows)
    table.to_csv(out / "energyplus_ppp_sweep.csv", index=False)
    print(table.to_string(index=False))
    print(f"{len(outcomes)} runs, {time.time() - t0:.0f} s wall")


if __name__ == "__main__":
    main()
