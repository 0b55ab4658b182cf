"""Calibrate the synthetic reserve-price scale on scenario (a) (DESIGN §2).

Finds the scale of :func:`hvacflex.data.market.synthetic_reserve_prices` at which the nominal
MPC's reserve revenue is ``--target`` (default 1 %) of its energy cost over the chosen
period, by bisection on a log scale. The result is frozen by hand in
``hvacflex.data.market.RESERVE_PRICE_SCALE`` and recorded in ``docs/reference/data.md``.

    python scripts/calibrate_reserve.py --start 2014-01-01 --days 365
    python scripts/calibrate_reserve.py --start 2014-01-13 --start 2014-04-14 \
        --start 2014-07-14 --start 2014-10-13 --days 7     # four weeks, one per quarter
"""

from __future__ import annotations

import argparse
import math

from hvacflex import kpi
from hvacflex.config import preset, with_overrides
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.setup import prepare


def revenue_share(scale: float, starts: list[str], days: float) -> float:
    """Reserve revenue / energy cost of scenario (a) at reserve-price ``scale``, summed over
    the periods ``[start, start + days)``."""
    revenue = cost = 0.0
    for start in starts:
        cfg = with_overrides(
            preset("nmpc", start=start, days=days), {"data.reserve_price_scale": scale}
        )
        loop = ClosedLoop(prepare(cfg))
        while loop.k < loop.steps:
            loop.step()
        frame = loop.frame()
        revenue += kpi.reserve_revenue_sgd(frame)
        cost += kpi.energy_cost_sgd(frame)
    return revenue / cost


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--start", action="append", help="period start (repeatable; default 2014-01-01)"
    )
    parser.add_argument("--days", type=float, default=365.0, help="days per period")
    parser.add_argument("--target", type=float, default=0.01, help="revenue / energy cost")
    parser.add_argument("--low", type=float, default=10.0)
    parser.add_argument("--high", type=float, default=200.0)
    parser.add_argument("--iterations", type=int, default=8)
    args = parser.parse_args()
    low, high = args.low, args.high
    for _ in range(args.iterations):
        mid = math.sqrt(low * high)
        share = revenue_share(mid, args.start or ["2014-01-01"], args.days)
        print(f"scale {mid:8.3f} SGD/MWh → revenue {100 * share:6.3f} % of energy cost", flush=True)
        if share < args.target:
            low = mid
        else:
            high = mid
    print(f"calibrated scale ≈ {math.sqrt(low * high):.2f} (bracket {low:.2f} – {high:.2f})")


if __name__ == "__main__":
    main()
