"""LP sizes, warm solve times and offered reserve of the IL event model on office5 (issue 14).

Runs the ``rmpc`` preset's closed loop on 2014-03-03 from midnight and records the problems the
controller builds, then

1. solves the receding-horizon sequence (N = 48) with one warm-started :class:`RMPCSolver` per
   model — the whole-horizon model and the event model with D = 1, 2, 4 (R = 2, α = 1 K) —
   and prints LP sizes (rows, columns, nonzeros) and per-step warm solve times;
2. re-solves the problems at 10:00 and 13:00 with flat reserve prices 10, 40, 80 SGD/MWh for
   α ∈ {0, 0.5, 1} K and D ∈ {1, 2, 4} (R = 2) and prints the offered reserve.

The markdown tables go to stdout (they are copied into ``docs/explanation/il_events.md``):

    python scripts/il_event_table.py
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from typing import Any

import numpy as np

from hvacflex.config import preset
from hvacflex.opt import ILEventModel, RMPCProblem, RMPCSolver, solve_rmpc
from hvacflex.sim.recording import recorded_problems

STEPS_PER_HOUR = 2


def with_events(
    problem: RMPCProblem, max_steps: int | None, alpha_k: float, recovery: int, **extra: Any
) -> RMPCProblem:
    """``problem`` with the event fields (None: whole-horizon model)."""
    if max_steps is None:
        return dataclasses.replace(problem, **extra)
    return dataclasses.replace(
        problem,
        events=ILEventModel(max_steps=max_steps, allowance_kelvin=alpha_k, recovery_steps=recovery),
        **extra,
    )


def size_and_time_table(problems: list[RMPCProblem], price: float) -> str:
    lines = [
        "| model | rows | cols | nnz | event rows | warm solve median / max [ms] | "
        "iterations median | cold solve [ms] | reserve step 0 mean [kW] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for label, d in (("whole horizon", None), ("D = 1", 1), ("D = 2", 2), ("D = 4", 4)):
        sequence = [
            with_events(p, d, 1.0, 2, reserve_price_sgd_per_mwh=np.full(p.horizon, price))
            for p in problems
        ]
        solver = RMPCSolver(sequence[0])
        times, iterations, reserve = [], [], []
        for index, problem in enumerate(sequence):
            solution = solver.solve(problem)
            if not solution.ok:
                raise RuntimeError(f"{label} step {index}: {solution.message}")
            reserve.append(float(solution.reserve_kw[0]))
            if index:
                times.append(solution.solve_time_s * 1e3)
                iterations.append(solution.simplex_iterations)
        tick = time.perf_counter()
        solve_rmpc(sequence[0])
        cold_ms = (time.perf_counter() - tick) * 1e3
        event_rows = solver.layout.event_rows.size
        lines.append(
            f"| {label} | {solver.num_rows} | {solver.num_cols} | {solver.num_nonzeros} | "
            f"{event_rows} | {statistics.median(times):.1f} / {max(times):.1f} | "
            f"{statistics.median(iterations):.0f} | {cold_ms:.0f} | "
            f"{statistics.mean(reserve):.2f} |"
        )
    return "\n".join(lines)


def reserve_table(problems: dict[str, RMPCProblem], prices: list[float]) -> str:
    header = "| time | D | α [K] | " + " | ".join(f"{p:g} SGD/MWh" for p in prices) + " |"
    lines = [header, "|---|---|---|" + "---|" * len(prices)]
    for clock, problem in problems.items():
        cases: list[tuple[str, int | None, float]] = [("whole", None, 0.0)]
        cases += [(str(d), d, a) for d in (1, 2, 4) for a in (0.0, 0.5, 1.0)]
        for label, d, alpha in cases:
            cells = []
            for price in prices:
                solution = solve_rmpc(
                    with_events(
                        problem,
                        d,
                        alpha,
                        2,
                        reserve_price_sgd_per_mwh=np.full(problem.horizon, price),
                    )
                )
                if not solution.ok:
                    cells.append(solution.status.value)
                    continue
                cells.append(f"{solution.reserve_kw[0]:.2f} / {solution.reserve_kw.mean():.2f}")
            alpha_text = "–" if d is None else f"{alpha:g}"
            lines.append(f"| {clock} | {label} | {alpha_text} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--timing-price", type=float, default=40.0, help="flat SGD/MWh")
    args = parser.parse_args()
    steps = 13 * STEPS_PER_HOUR + 1
    problems = recorded_problems(preset("rmpc", start=args.start, days=1), steps)
    print(
        f"## LP sizes and warm solve times (N = {problems[0].horizon}, R = 2, α = 1 K, "
        f"flat reserve price {args.timing_price:g} SGD/MWh, {steps} receding steps)\n"
    )
    print(size_and_time_table(problems, args.timing_price))
    at = {"10:00": problems[10 * STEPS_PER_HOUR], "13:00": problems[13 * STEPS_PER_HOUR]}
    print("\n## Offered reserve, step 0 / horizon mean [kW] (R = 2)\n")
    print(reserve_table(at, [10.0, 40.0, 80.0]))


if __name__ == "__main__":
    main()
