"""Fleet scale: set-up, cold and warm step times, iterations and memory (issues 17, 31).

For each fleet size B (generated, seed 17, default feeder limit) and each worker count W,
runs ``--steps`` steps from ``--start`` on a ``LocalCluster`` of W single-threaded workers
(:func:`hvacflex.fleet.run.run_fleet`) and prints one markdown row:

* set-up: wall time from the call to the first step (cluster start + agents), and the
  groups' own agent-building time (wall, and CPU summed over the workers);
* the cold first step (every building's first, cold solve) and the mean of the warm steps
  after it: wall time, and CPU time summed over the workers (on a loaded machine the CPU
  time is the measure of work; wall time depends on the load); the busiest worker's CPU and
  the coordinator's (this process: coordination, Dask client and scheduler) per warm step —
  on an idle machine a warm step cannot take less than the busiest worker's CPU time;
* coordination rounds per step (bundle rounds; price iterations for ``scheme = "prices"``),
  the largest certified gap of a step (``coordination_gap``: the issue-31 targets hold at
  gap ≤ 2 %) and the warm step's CPU per building (the issue-31 target: ≤ 0.05 CPU-s);
* the workers' resident memory after the run (memory per building = the slope between fleet
  sizes at the same W).

    python benchmarks/bench_fleet_scale.py --buildings 10 100 --workers 1 2 --steps 3

The aggregator's product (issue 62): ``--limit inf`` (no feeder limit) and ``--activations``
(the grid operator activates IL for 30 min at every full hour from 08:00 to 17:00, a file
schedule) add the fleet's offer in office hours (mean kW per building, the periods
bid at the 0.1 MW minimum of those run), the delivery ratio on the buildings' meters, the
coordinator's share of the CPU and the workers' memory per building:

    python benchmarks/bench_fleet_scale.py --buildings 50 200 --workers 2 --steps 48 \
        --start "2014-03-03 00:00" --limit inf --activations

Measured 2026-12-03 (``--buildings 10 40 100 1000 --workers 0 --steps 3``, idle machine):
0.082 / 0.047 / 0.046 / 0.046 CPU-s per building and warm dispatch, 1,000 buildings 46.4
CPU-s per warm dispatch at a largest gap of 0.06 %; docs/guide/fleet.md, "Scale".

Measured 2026-12-02 (issue 31, bundle scheme, ``--workers 0 --steps 4 --start "2014-03-03
08:00"``, shared 2-core machine, load 16–23): warm step CPU 7.30 s for 10 buildings (20
rounds per step), 19.61 s for 40 (15.5 rounds) → 0.73 and 0.49 CPU-s per building and warm
dispatch; docs/guide/fleet.md, "Scale".
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.constants import TIMEZONE
from hvacflex.fleet.generate import generate_fleet, write_fleet
from hvacflex.fleet.run import run_fleet

MIB = 2**20
MAX_GAP = 0.02  # the largest certified coordination gap of a step (issue 31's targets hold)


def _worker_rss_bytes() -> int:
    import psutil

    return int(psutil.Process(os.getpid()).memory_info().rss)


def _group_timings(groups: Any) -> np.ndarray:
    """(G, 3) set-up wall, set-up CPU and CPU so far [s] of every group."""
    return np.array(groups.broadcast("timings"), dtype=float)


ACTIVATION_STARTS_H = tuple(float(h) for h in range(8, 18))
"""``--activations``: the grid operator's IL activations start at these hours each day (every
full office hour: ten events a day, each its own first period, so each is bid apart)."""
ACTIVATION_HOURS = 0.5
"""Each ``--activations`` event lasts one 30-min period."""


def _write_activations(folder: Path, start: str, steps: int) -> str:
    """``activations.csv`` beside the fleet file: :data:`ACTIVATION_STARTS_H`, each
    :data:`ACTIVATION_HOURS` long."""
    index = pd.date_range(start, periods=steps, freq="30min", tz=TIMEZONE)
    hours = index.hour + index.minute / 60.0
    on = np.zeros(steps, dtype=bool)
    for first in ACTIVATION_STARTS_H:
        on |= (hours >= first) & (hours < first + ACTIVATION_HOURS)
    frame = pd.DataFrame({"time": [t.isoformat() for t in index], "activated": on.astype(int)})
    frame.to_csv(folder / "activations.csv", index=False)
    return "activations.csv"


def measure(
    buildings: int, workers: int, steps: int, start: str, options: argparse.Namespace
) -> dict[str, Any]:
    """One run; its timings, iterations, the workers' memory and the fleet's offer."""
    kwargs = {} if options.limit is None else {"feeder_limit_kw": options.limit}
    doc = generate_fleet(buildings, 17, **kwargs)
    if options.iterations:
        doc["coordination"]["max_iterations"] = options.iterations
    if options.cap_rounds >= 0:
        doc["coordination"]["cap_rounds"] = options.cap_rounds
    with tempfile.TemporaryDirectory() as tmp:
        if options.activations:
            doc["activation"] = {
                "mode": "file",
                "file": _write_activations(Path(tmp), start, steps),
            }
        path = write_fleet(doc, Path(tmp) / "fleet.toml")
        memory: list[int] = []
        marks: list[float] = []
        timings: list[np.ndarray] = []

        coordinator_cpu: list[float] = []

        def on_step(k: int, groups: Any) -> None:
            marks.append(time.perf_counter())
            coordinator_cpu.append(time.process_time())
            timings.append(_group_timings(groups))
            print(f"  step {k}: {marks[-1] - t0:.1f} s since start", flush=True)
            if k == steps and groups.client is not None:
                memory.extend(groups.client.run(_worker_rss_bytes).values())

        t0 = time.perf_counter()
        result = run_fleet(
            path,
            Path(tmp) / "out" if options.out is None else options.out / f"b{buildings}w{workers}",
            start=start,
            days=steps / 48,
            workers=workers,
            scheduler=options.scheduler,
            checkpoint_every=10**6,
            resume=False,
            on_step=on_step,
        )
    frame, summary = result.frame, result.summary
    _check_bids(frame)
    step_s = frame["step_time_s"].to_numpy(float)
    first = timings[0]
    group_cpu = np.diff(np.array([t[:, 2] for t in timings]), axis=0)  # (steps - 1, G)
    return {
        "setup_s": marks[0] - t0 - step_s[0],
        "agents_wall_s": float(first[:, 0].max()),
        "agents_cpu_s": float(first[:, 1].sum()),
        "cold_s": float(step_s[0]),
        "warm_s": float(np.mean(step_s[1:])) if steps > 1 else float("nan"),
        "warm_cpu_s": float(np.mean(group_cpu.sum(axis=1))) if steps > 1 else float("nan"),
        "warm_group_cpu_max_s": float(np.mean(group_cpu.max(axis=1))) if steps > 1 else np.nan,
        "warm_coordinator_cpu_s": float(np.mean(np.diff(coordinator_cpu))) if steps > 1 else np.nan,
        "iterations": float(frame["coordination_iterations"].mean()),
        "max_gap": float(np.nanmax(frame["coordination_gap"].to_numpy(float), initial=0.0)),
        "rss_mib": sum(memory) / MIB,
        "offer": {key: float(summary.get(key, np.nan)) for key in OFFER_KEYS},
    }


OFFER_KEYS = (
    "office_periods",
    "office_periods_bid",
    "offer_per_building_office_kw_mean",
    "fleet_offer_office_kw_max",
    "delivery_ratio",
    "il_dispatched_kwh",
)


def _check_bids(frame: pd.DataFrame) -> None:
    """Bids only at or above the minimum (the fleet file's 0.1 MW), and never a delivery
    above what was dispatched (capped on each building's meter)."""
    bid = frame["fleet_bid_kw"].to_numpy(float)
    if np.any((bid > 0) & (bid < 100.0)) or np.any((bid > 0) & (bid != frame["fleet_offer_kw"])):
        raise RuntimeError("a bid below the 0.1 MW minimum, or not the fleet's offer")
    over = frame["il_delivered_buildings_kw"] - frame["il_dispatched_kw"]
    if np.any(over.to_numpy(float) > 1e-9):
        raise RuntimeError("a delivery above the dispatched reserve")


def _print_offer(buildings: int, workers: int, r: dict[str, Any]) -> None:
    """The aggregator's figures of one run, and the CPU and memory split (on workers: the
    workers' CPU and the coordinator's, this process's; in process they are one)."""
    offer = r["offer"]
    if workers:
        cpu = r["warm_cpu_s"] + r["warm_coordinator_cpu_s"]
        split = f"coordinator's share {r['warm_coordinator_cpu_s'] / cpu:.1%}"
    else:
        cpu, split = r["warm_cpu_s"], "coordinator's share not separable in process"
    print(
        f"  offer: {offer['office_periods_bid']:.0f} of {offer['office_periods']:.0f} "
        f"office-hour periods bid (≥ 0.1 MW), {offer['offer_per_building_office_kw_mean']:.3f} "
        f"kW per building on average, largest {offer['fleet_offer_office_kw_max']:.1f} kW; "
        f"dispatched {offer['il_dispatched_kwh']:.1f} kWh, delivery ratio "
        f"{offer['delivery_ratio']:.3f}; warm CPU per building-dispatch "
        f"{cpu / buildings:.3f} s, {split}; "
        f"worker memory per building {r['rss_mib'] / buildings:.2f} MiB",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--buildings", type=int, nargs="+", default=[10, 100])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--steps", type=int, default=3)
    parser.add_argument("--start", default="2014-03-03 08:00")
    parser.add_argument("--iterations", type=int, default=0, help="0 = the fleet's (30)")
    parser.add_argument("--cap-rounds", type=int, default=-1, help="-1 = the fleet's (4)")
    parser.add_argument(
        "--limit",
        type=float,
        default=None,
        help="feeder limit [kW] (inf: none); default: generate's",
    )
    parser.add_argument("--activations", action="store_true", help="2-h IL activations (above)")
    parser.add_argument("--scheduler", default=None, help="a Dask scheduler address (tcp://…)")
    parser.add_argument("--out", type=Path, default=None, help="keep each run's folder here")
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.buildings, args.workers, args.steps = [2], [0], 2
        args.start, args.limit, args.activations = "2014-03-03 08:30", float("inf"), True
    print(f"load average at start: {os.getloadavg()}", flush=True)
    header = (
        "| buildings | workers | set-up [s] | agents wall / CPU [s] | cold step [s] | "
        "warm step wall / CPU [s] | busiest worker / coordinator CPU [s] | iterations/step | "
        "largest gap | worker memory [MiB] | warm CPU per building [s] |"
    )
    print(header)
    print("|---|---|---|---|---|---|---|---|---|---|---|", flush=True)
    for buildings in args.buildings:
        for workers in args.workers:
            r = measure(buildings, workers, args.steps, args.start, args)
            print(
                f"| {buildings} | {workers} | {r['setup_s']:.1f} | {r['agents_wall_s']:.1f} / "
                f"{r['agents_cpu_s']:.1f} | {r['cold_s']:.2f} | {r['warm_s']:.2f} / "
                f"{r['warm_cpu_s']:.2f} | {r['warm_group_cpu_max_s']:.2f} / "
                f"{r['warm_coordinator_cpu_s']:.2f} | {r['iterations']:.1f} | {r['max_gap']:.2%} | "
                f"{r['rss_mib']:.0f} | "
                f"{r['warm_cpu_s'] / buildings:.3f} |",
                flush=True,
            )
            _print_offer(buildings, workers, r)
            print(f"load average now: {os.getloadavg()}", flush=True)
            if not r["max_gap"] <= MAX_GAP:
                raise RuntimeError(f"coordination gap {r['max_gap']:.2%} > {MAX_GAP:.0%}")
    print(f"load average at end: {os.getloadavg()}")
    print(f"checks passed: every run's steps done, coordination gap ≤ {MAX_GAP:.0%}")


if __name__ == "__main__":
    main()
