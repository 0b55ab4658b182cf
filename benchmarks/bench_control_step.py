"""CPU per period of the control step (``ControlStep.decide``: the period's inputs built,
the MPC's problem built and solved warm, offers sized) over a closed-loop run, and of the
whole period (plant and recording included).

Run it against two checkouts side by side (same machine, same load, interleaved) to compare
code versions::

    for i in 1 2 3; do
      PYTHONPATH=old/src python benchmarks/bench_control_step.py --days 3
      PYTHONPATH=new/src python benchmarks/bench_control_step.py --days 3
    done

Prints the scenario, the median and p90 CPU per decided period [ms] and the whole period's
median [ms]; fails when a period was not planned optimally. ``--quick``: a quarter of a day.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from hvacflex.config import preset, with_overrides
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.setup import prepare


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", default="rmpc")
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--days", type=float, default=3.0)
    parser.add_argument("--activation", default="stress", help="[activation] mode")
    parser.add_argument("--quick", action="store_true", help="a quarter of a day (smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.days = 0.25
    cfg = with_overrides(
        preset(args.scenario, start=args.start, days=args.days),
        {"activation.mode": args.activation},
    )
    loop = ClosedLoop(prepare(cfg))
    decide = loop.control.decide
    decide_s: list[float] = []

    def timed(*a: Any, **kw: Any) -> Any:
        tick = time.process_time()
        try:
            return decide(*a, **kw)
        finally:
            decide_s.append(time.process_time() - tick)

    loop.control.decide = timed  # type: ignore[method-assign]
    period_s: list[float] = []
    while loop.k < loop.steps:
        tick = time.process_time()
        loop.step()
        period_s.append(time.process_time() - tick)
    frame = loop.frame()
    if frame["fallback"].any() or len(decide_s) != loop.steps:
        raise RuntimeError("a period was not planned optimally, or not decided once")
    decide_ms = 1e3 * np.asarray(decide_s[1:])  # the first builds the solver
    period_ms = 1e3 * np.asarray(period_s[1:])
    print(
        f"{args.scenario} {args.days:g} d: decide median {np.median(decide_ms):.2f} ms, "
        f"p90 {np.percentile(decide_ms, 90):.2f} ms; period median {np.median(period_ms):.2f} ms"
    )
    print(f"checks passed: {loop.steps} periods, each decided once, none by a fallback")


if __name__ == "__main__":
    main()
