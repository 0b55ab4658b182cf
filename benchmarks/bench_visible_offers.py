"""What paying the plan only for the offers its baselines see costs a period.

With ``[reserve] plan_visible_offers`` (the default) the event-model LP carries 2N offer
columns and N·(D + 2) rows more (:func:`hvacflex.opt.lp.add_visible_offers`; N = 48, D = 4:
96 columns, 288 rows). Measured side by side in one run, interleaved: a whole warm
closed-loop period of ``rmpc`` (office5, RC plant, stress activations; the decision, the
plant step and the recording included) with the setting on and off. Prints per-period
times (median, p90) in ms, their ratio and the machine's load.

    python benchmarks/bench_visible_offers.py [--periods 96] [--rounds 2]
"""

from __future__ import annotations

import argparse

from bench_loop_parts import machine_line  # beside this script: on sys.path when run
from bench_meter_response import warm_period_us


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--periods", type=int, default=96)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.periods, args.rounds = 2, 1
    times: dict[bool, list[tuple[float, float]]] = {True: [], False: []}
    for _ in range(args.rounds):  # interleaved: the machine's load hits both alike
        for visible in (True, False):
            overrides = {"reserve.plan_visible_offers": visible, "activation.mode": "stress"}
            times[visible].append(warm_period_us(overrides, args.periods))
    print(machine_line())
    print(f"{'warm rmpc period':32}  median ms   p90 ms")
    for visible, label in (
        (True, "plan paid what is seen (default)"),
        (False, "plan paid q·r, offers cut after"),
    ):
        median = min(t[0] for t in times[visible]) / 1000.0
        p90 = min(t[1] for t in times[visible]) / 1000.0
        print(f"{label:32}  {median:9.1f}  {p90:7.1f}")
    ratio = min(t[0] for t in times[True]) / min(t[0] for t in times[False])
    print(f"ratio of the medians (on / off): {ratio:.2f}")
    print("checks passed: both closed loops ran (the LP's offers: tests/opt/test_reference.py)")


if __name__ == "__main__":
    main()
