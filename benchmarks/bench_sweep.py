"""Fig. 7's PPP sweep on Dask with 1 and with 2 local workers: wall time and speed-up.

    python benchmarks/bench_sweep.py [--days 2] [--values 0.5,1.5,5,30] [--workers 1 2]

Each configuration runs in a fresh temporary folder, so nothing is re-used from a cache.
Prints a table; record it in docs/reference/performance.md with the machine it ran on.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time

from hvacflex.config import preset
from hvacflex.sim.sweep import expand_grid, run_sweep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--days", type=float, default=2.0)
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--values", default="0.5,1.5,5,30")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.days, args.values, args.workers = 0.25, "1.5,5", [2]
    values = [float(v) for v in args.values.split(",")]
    jobs = expand_grid(
        preset("rmpc-ppp", start=args.start, days=args.days), {"peak_price_sgd_per_kw": values}
    )
    timings = {}
    for workers in args.workers:
        with tempfile.TemporaryDirectory() as out:
            t0 = time.perf_counter()
            outcomes = run_sweep(jobs, out, n_workers=workers)
            timings[workers] = time.perf_counter() - t0
            failed = [o for o in outcomes if not o.ok]
            if failed:
                raise SystemExit(f"{len(failed)} jobs failed: {failed[0].error}")
    cpu = platform.processor() or platform.machine()
    print(f"machine: {os.cpu_count()} cores, {cpu}, Python {platform.python_version()}")
    print(f"sweep: {len(jobs)} runs of {args.days:g} days from {args.start}, φ = {values}")
    print("| workers | wall [s] | speed-up |")
    print("|---:|---:|---:|")
    for workers, seconds in timings.items():
        speed_up = f"{timings[1] / seconds:.2f}×" if 1 in timings else "–"
        print(f"| {workers} | {seconds:.1f} | {speed_up} |")
    print(f"checks passed: every job of {len(jobs)} ran on {args.workers} workers")


if __name__ == "__main__":
    main()
