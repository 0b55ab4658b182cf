"""The affine-feedback rows of Table 1 on the four representative weeks
(docs/explanation/reproduction.md).

(b) and (c) with affine disturbance feedback (``rmpc-feedback``, ``rmpc-feedback-ppp``) beside
the same scenarios open loop under the same whole-horizon reserve model (``paper-rmpc``,
``paper-rmpc-ppp``), each representative week (:data:`hvacflex.robustness.REPRESENTATIVE_WEEKS`)
for 7 days, on Dask (cached by inputs and code, resumable); writes ``OUT/feedback_weeks.csv``
(one row per run) and prints the sums per preset.

    python scripts/feedback_weeks.py [OUT] [WORKERS]     # default results/feedback_weeks, 1
"""

import json
import sys
import time
from pathlib import Path

import pandas as pd

from hvacflex import kpi
from hvacflex.config import preset
from hvacflex.results import load_results
from hvacflex.robustness import REPRESENTATIVE_WEEKS, WEEK_DAYS
from hvacflex.sim.sweep import run_sweep

PRESETS = ("paper-rmpc", "rmpc-feedback", "paper-rmpc-ppp", "rmpc-feedback-ppp")


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "results/feedback_weeks")
    workers = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    jobs = []
    for week in REPRESENTATIVE_WEEKS:
        for name in PRESETS:
            cfg = preset(name, start=week.start, days=WEEK_DAYS)
            jobs.append(({"preset": name, "week": week.start}, cfg))
    t0 = time.time()
    outcomes = run_sweep(jobs, out, n_workers=workers, progress=True)
    rows = []
    for o in outcomes:
        if not o.ok:
            print("FAILED", o.label, o.error)
            continue
        s = kpi.summary(load_results(o.out_dir), 1.5)
        stored = json.loads((Path(o.out_dir) / "summary.json").read_text())
        rows.append(
            {
                **o.params,
                **{
                    k: s[k]
                    for k in (
                        "energy_cost_sgd",
                        "reserve_revenue_sgd",
                        "il_penalty_sgd",
                        "ppp_charge_sgd",
                        "peak_power_kw",
                        "discomfort_kelvin_hours",
                        "max_violation_k",
                        "fallback_count",
                        "solve_time_mean_s",
                    )
                },
                "time_controller_ms_per_step": stored["time_controller_ms_per_step"],
            }
        )
    table = pd.DataFrame(rows)
    table.to_csv(out / "feedback_weeks.csv", index=False)
    print(table.groupby("preset").sum(numeric_only=True).to_string())
    print(f"{len(outcomes)} runs, {time.time() - t0:.0f} s wall")


if __name__ == "__main__":
    main()
