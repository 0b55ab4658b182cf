"""The three paper years (``nmpc``, ``rmpc``, ``rmpc-ppp`` from 2014-01-01) on 2 local
workers: wall time, and the CPU per period (issue 63 item 3).

Run::

    python benchmarks/bench_years.py                 # 365 days each (goal: ≤ 8 min wall)
    python benchmarks/bench_years.py --days 28       # a shorter run; the year extrapolated

The three runs go through :func:`hvacflex.sim.sweep.run_sweep` (Dask ``LocalCluster`` with the
``dask`` extra, else a process pool) into a fresh temporary folder (nothing re-used), on the RC
plant (no EnergyPlus). Prints the wall time, the CPU the workers spent (their processes'
CPU once they ended, ``RUSAGE_CHILDREN``) per period of the three runs, each run's own CPU per
period (its worker's process CPU over the job, ``JobOutcome.cpu_s``), and, for fewer than 365
days, the wall time scaled to 365 days (labelled as extrapolated). Fails when a run fails.
``--quick``: a quarter of a day each (the smoke run).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time

from hvacflex.config import preset
from hvacflex.constants import PERIODS_PER_DAY
from hvacflex.sim.sweep import run_sweep

SCENARIOS = ("nmpc", "rmpc", "rmpc-ppp")
YEAR_DAYS = 365
MIN_EXTRAPOLATED_DAYS = 7
"""Shortest run whose wall time is scaled to the year (below it, start-up dominates)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--days", type=float, default=float(YEAR_DAYS))
    parser.add_argument("--start", default="2014-01-01")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--quick", action="store_true", help="a quarter of a day (smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.days = 0.25
    jobs = [({"scenario": s}, preset(s, start=args.start, days=args.days)) for s in SCENARIOS]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as out:
        tick = time.perf_counter()
        outcomes = run_sweep(jobs, out, n_workers=args.workers, fresh=True)
        wall_s = time.perf_counter() - tick
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    failed = [o for o in outcomes if not o.ok]
    if failed:
        raise SystemExit(f"{len(failed)} runs failed: {failed[0].label}: {failed[0].error}")
    cpu_s = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    run_periods = round(args.days * PERIODS_PER_DAY)
    periods = run_periods * len(SCENARIOS)
    load = " / ".join(f"{x:.1f}" for x in os.getloadavg())
    print(
        f"{', '.join(SCENARIOS)} from {args.start}, {args.days:g} days each, "
        f"{args.workers} workers; load average {load}"
    )
    print(
        f"wall {wall_s:.1f} s; workers' CPU {cpu_s:.1f} s = "
        f"{1e3 * cpu_s / periods:.1f} ms per period ({periods} periods)"
    )
    summary: dict[str, float] = {"years_cpu_ms_per_period": 1e3 * cpu_s / periods}
    rows: list[dict[str, object]] = [
        {
            "method": f"three years on {args.workers} workers ({args.days:g} d each), wall",
            "median": wall_s,
            "unit": "s",
        }
    ]
    for name, outcome in zip(SCENARIOS, outcomes, strict=True):
        assert outcome.cpu_s is not None  # the run finished
        per_period_ms = 1e3 * outcome.cpu_s / run_periods
        print(f"{name}: {outcome.cpu_s:.1f} CPU-s = {per_period_ms:.1f} ms per period")
        rows.append({"method": f"{name}, CPU per period", "median": per_period_ms, "unit": "ms"})
    if args.days >= YEAR_DAYS:
        summary["years_x3_wall_s"] = wall_s
    elif args.days >= MIN_EXTRAPOLATED_DAYS:
        extrapolated = wall_s * YEAR_DAYS / args.days
        summary["years_x3_wall_s_extrapolated"] = extrapolated
        print(f"the year extrapolated from {args.days:g} days: {extrapolated / 60:.1f} min wall")
    print("RESULT " + json.dumps({"rows": rows, "summary": summary}))
    print(f"checks passed: the {len(SCENARIOS)} runs finished")


if __name__ == "__main__":
    main()
