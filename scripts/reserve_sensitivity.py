"""Sensitivity of the offered reserve and its revenue to the reserve price, D and α.

Runs scenario (a) (the product preset ``nmpc``, event model) in closed loop, varying one
setting at a time around the product defaults: the synthetic reserve-price scale, the
event length D (``reserve.event_max_steps``) and the allowance α (``reserve.event_allowance_k``).
Prints a Markdown table (one row per run) for ``docs/explanation/il_events.md``.

    python scripts/reserve_sensitivity.py --start 2014-03-03 --days 3
    python scripts/reserve_sensitivity.py --prices 2.5 40 --events 1 2 4 --allowances 0 0.5 1
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from hvacflex import kpi
from hvacflex.config import preset, with_overrides
from hvacflex.data.market import RESERVE_PRICE_SCALE
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.setup import prepare

COLUMNS = (
    "reserve_offered_mean_kw",
    "reserve_period_share",
    "reserve_revenue_sgd",
    "energy_cost_sgd",
    "discomfort_kelvin_hours",
)


def run(overrides: dict[str, Any], start: str, days: float, scenario: str) -> dict[str, float]:
    """KPIs of one closed-loop run of ``scenario`` with ``overrides``, plus its ms/step."""
    cfg = with_overrides(preset(scenario, start=start, days=days), overrides)
    loop = ClosedLoop(prepare(cfg))
    t0 = time.perf_counter()
    while loop.k < loop.steps:
        loop.step()
    out = kpi.summary(loop.frame())
    out["ms_per_step"] = 1e3 * (time.perf_counter() - t0) / loop.steps
    return out


def variations(args: argparse.Namespace) -> list[tuple[str, dict[str, Any]]]:
    """One setting at a time around the defaults (price scale, D, α)."""
    runs: list[tuple[str, dict[str, Any]]] = []
    for scale in args.prices:
        runs.append((f"price scale {scale:g}", {"data.reserve_price_scale": scale}))
    for steps in args.events:
        runs.append((f"D = {steps}", {"reserve.event_max_steps": steps}))
    for allowance in args.allowances:
        runs.append((f"α = {allowance:g} K", {"reserve.event_allowance_k": allowance}))
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--start", default="2014-03-03", help="first day (local date)")
    parser.add_argument("--days", type=float, default=3.0)
    parser.add_argument("--scenario", default="nmpc")
    parser.add_argument("--prices", type=float, nargs="*", default=[2.5, RESERVE_PRICE_SCALE, 40.0])
    parser.add_argument("--events", type=int, nargs="*", default=[1, 2, 4])
    parser.add_argument("--allowances", type=float, nargs="*", default=[0.0, 0.5, 1.0])
    args = parser.parse_args()
    seen: dict[str, dict[str, float]] = {}
    print("| run | " + " | ".join(COLUMNS) + " | revenue / cost | ms/step |")
    print("|---" * (len(COLUMNS) + 3) + "|")
    for label, overrides in variations(args):
        key = repr(sorted(with_overrides(preset(args.scenario), overrides).to_dict().items()))
        out = seen.get(key) or run(overrides, args.start, args.days, args.scenario)
        seen[key] = out
        share = out["reserve_revenue_sgd"] / out["energy_cost_sgd"]
        cells = " | ".join(f"{out[c]:.3g}" for c in COLUMNS)
        print(f"| {label} | {cells} | {100 * share:.2f} % | {out['ms_per_step']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
