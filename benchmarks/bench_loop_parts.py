"""The closed loop's parts outside the LP: one nonlinear plant step and one forecast.

Replaces the timing assertions that used to live in the tests (performance is measured
here, not asserted there). Prints a table of per-call times (median, p90) in µs.

    python benchmarks/bench_loop_parts.py [--calls 2000]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Callable

import numpy as np

from hvacflex.building.summary import design_disturbance
from hvacflex.config import preset
from hvacflex.sim.setup import prepare


def per_call_us(call: Callable[[int], object], calls: int) -> tuple[float, float]:
    """Median and 90th percentile of ``call(i)`` for i < calls [µs]."""
    times_us = np.empty(calls)
    for i in range(calls):
        start = time.perf_counter()
        call(i)
        times_us[i] = (time.perf_counter() - start) * 1e6
    return float(np.median(times_us)), float(np.percentile(times_us, 90.0))


def machine_line(detail: str = "") -> str:
    """The machine, its cores and load average (what every benchmark prints first)."""
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    line = f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
    return line + f"load {load}" + (f"; {detail}" if detail else "")


def print_us_rows(rows: dict[str, tuple[float, float]]) -> None:
    """Rows of (median, p90) [µs] under a header, names padded to one width."""
    width = max(len(name) for name in rows)
    print(f"{'':{width}}  median µs     p90 µs")
    for name, (median, p90) in rows.items():
        print(f"{name:{width}}  {median:9.1f}  {p90:9.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.calls = 5
    setup = prepare(preset("rmpc", start="2014-03-17", days=7))
    plant, building = setup.plant, setup.building
    low = np.asarray(building.hvac.flow_min_kg_s)
    high = np.asarray(building.hvac.flow_max_kg_s)
    rng = np.random.default_rng(0)
    flows = low + rng.uniform(size=(args.calls, plant.m)) * (high - low)  # distinct: no cache
    d = design_disturbance(building)
    state = {"x": plant.initial_state(25.0)}

    def plant_step(i: int) -> None:
        state["x"] = plant.step(state["x"], flows[i], d)

    steps = setup.exogenous.steps - setup.config.controller.horizon_steps - 1
    horizon = setup.config.controller.horizon_steps + 1
    rows = {
        "nonlinear plant step (distinct flows)": per_call_us(plant_step, args.calls),
        "perfect forecast (N + 1 steps)": per_call_us(
            lambda i: setup.forecaster.forecast(i % steps, horizon), args.calls
        ),
    }
    print(machine_line(f"{args.calls} calls each"))
    print("| part | median [µs] | p90 [µs] |")
    print("|---|---:|---:|")
    for name, (median, p90) in rows.items():
        print(f"| {name} | {median:.1f} | {p90:.1f} |")
    if not np.isfinite(np.asarray(state["x"], dtype=float)).all():
        raise RuntimeError("the plant's state is not finite after the steps")
    print(f"checks passed: the plant's state finite after {args.calls} steps")


if __name__ == "__main__":
    main()
