"""What measuring the meter's response to the plan (ρ) costs a building's period.

``ControlStep`` keeps each building's last 240 periods of planned and metered power and
computes ρ before every decision (:mod:`hvacflex.control.meter_response`). Measured side by
side in one run: one ρ over a full window (lags 1 … 4), one ``advance`` + ``open`` of the
history, and a whole warm closed-loop period of ``rmpc`` (office5, RC plant, the decision,
the plant step and the recording included) with ρ measured (the default) and without
(``[reserve] meter_calibrated_offers = false``). Prints per-call times (median, p90) in µs
and the machine's load.

    python benchmarks/bench_meter_response.py [--calls 2000] [--periods 96]
"""

from __future__ import annotations

import argparse

import numpy as np
from bench_loop_parts import (  # beside this script: on sys.path when run
    machine_line,
    per_call_us,
    print_us_rows,
)

from hvacflex.config import preset, with_overrides
from hvacflex.control.meter_response import WINDOW_PERIODS, MeterHistory
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.setup import prepare


def _full_history() -> MeterHistory:
    """A history whose window is full: the meter moves 0.6 kW per kW of a varying plan."""
    history = MeterHistory()
    rng = np.random.default_rng(1)
    for k in range(WINDOW_PERIODS + 1):
        history.advance(k, None if k == 0 else 3.0 + 0.6 * history.open_planned_kw)
        history.open(k, float(20.0 + 5.0 * np.sin(k / 3.0) + rng.normal()))
    return history


def warm_period_us(overrides: dict[str, object], periods: int) -> tuple[float, float]:
    """Per-period wall time [µs] (median, p90) of a warm ``rmpc`` closed loop from
    2014-03-03 with the scenario ``overrides`` (the first 12 periods, the cold start among
    them, not counted)."""
    config = with_overrides(preset("rmpc", start="2014-03-03", days=3.0), overrides)
    loop = ClosedLoop(prepare(config))
    for _ in range(12):
        loop.step()
    return per_call_us(lambda i: loop.step(), periods)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument("--periods", type=int, default=96)
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.calls, args.periods = 5, 2
    history = _full_history()
    ratio = history.ratio(4)

    def advance_open(i: int) -> None:
        period = history.next_period + 1
        history.advance(period, 15.0)
        history.open(period, 20.0 + (i % 7))

    rows = {
        f"one ρ, full window ({WINDOW_PERIODS} periods, lags 1…4)": per_call_us(
            lambda i: history.ratio(4), args.calls
        ),
        "advance + open of the history": per_call_us(advance_open, args.calls),
        "warm rmpc period, ρ measured": warm_period_us(
            {"reserve.meter_calibrated_offers": True}, args.periods
        ),
        "warm rmpc period, ρ not measured": warm_period_us(
            {"reserve.meter_calibrated_offers": False}, args.periods
        ),
    }
    print(machine_line(f"ρ of the full window {ratio:.3f}"))
    print_us_rows(rows)
    if not 0.0 <= ratio <= 1.0:
        raise RuntimeError(f"ρ = {ratio} outside [0, 1]")
    print("checks passed: ρ of the full window in [0, 1], both closed loops ran")


if __name__ == "__main__":
    main()
