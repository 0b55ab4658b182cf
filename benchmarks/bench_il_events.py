"""Benchmark the IL event model's LP: all event rows ("full") vs lazy row generation ("lazy").

Run::

    python benchmarks/bench_il_events.py                  # office5, 2014-03-03, 40 steps

Records the problems the ``rmpc`` preset's controller builds on office5 over ``--steps``
receding-horizon steps (N = 48) and solves the sequence with one warm-started
:class:`~hvacflex.opt.solve.RMPCSolver` per model — the whole-horizon model and the event
model with D = 1, 2, 4 (R = 2, α = 1 K, flat reserve price ``--price``) — once with
``event_rows="full"`` and once with ``event_rows="lazy"``. Prints one markdown table: rows in
HiGHS (mean), per-step warm solve time median / p90 / max [ms], HiGHS ``run()`` median,
simplex iterations median, re-solve rounds, and the largest relative objective difference
between the two modes (they must agree). This is a script, not a timed test.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import statistics
from typing import Any

import numpy as np

from hvacflex.config import preset
from hvacflex.opt import ILEventModel
from hvacflex.opt.problem import RMPCProblem
from hvacflex.opt.solve import RMPCSolver
from hvacflex.sim import recording

LAZY_REL_TOL = 1e-6  # lazy and full event rows must reach the same optimum (relative)


def recorded_problems(start: str, steps: int) -> list[RMPCProblem]:
    """The problems the ``rmpc`` controller builds over the first ``steps`` periods."""
    return recording.recorded_problems(preset("rmpc", start=start, days=1), steps)


def with_events(problem: RMPCProblem, max_steps: int | None, price: float) -> RMPCProblem:
    """``problem`` with a flat reserve price and D = ``max_steps`` (R = 2, α = 1 K)."""
    prices = np.full(problem.horizon, price)
    if max_steps is None:
        return dataclasses.replace(problem, reserve_price_sgd_per_mwh=prices)
    return dataclasses.replace(
        problem,
        reserve_price_sgd_per_mwh=prices,
        events=ILEventModel(max_steps=max_steps, allowance_kelvin=1.0, recovery_steps=2),
    )


def run(sequence: list[RMPCProblem], mode: str) -> dict[str, Any]:
    """Solve ``sequence`` warm with ``event_rows=mode``; per-step figures of the warm steps."""
    solver = RMPCSolver(sequence[0], event_rows=mode)  # type: ignore[arg-type]
    times, highs, iterations, rows, objectives = [], [], [], [], []
    for index, problem in enumerate(sequence):
        solution = solver.solve(problem)
        if not solution.ok:
            raise RuntimeError(f"step {index}: {solution.message}")
        objectives.append(solution.objective_sgd + solution.tie_break_sgd)
        if index:
            times.append(solution.solve_time_s * 1e3)
            highs.append(solution.highs_time_s * 1e3)
            iterations.append(solution.simplex_iterations)
            rows.append(solver.num_model_rows)
    return {
        "times": times,
        "highs": highs,
        "iterations": iterations,
        "rows": rows,
        "objectives": np.array(objectives),
        "full_rows": solver.num_rows,
    }


def machine() -> str:
    """CPU, cores and the load average (the machine is shared)."""
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {load}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--price", type=float, default=40.0, help="flat SGD/MWh")
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.steps = 2
    worst = 0.0
    problems = recorded_problems(args.start, args.steps)
    print(f"office5, N = {problems[0].horizon}, {len(problems) - 1} warm steps; {machine()}\n")
    print(
        "| model | rows (all) | mode | rows in HiGHS (mean) | warm median / p90 / max [ms] | "
        "run() median [ms] | iterations median | max rel. objective diff |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for label, d in (("whole horizon", None), ("D = 1", 1), ("D = 2", 2), ("D = 4", 4)):
        sequence = [with_events(p, d, args.price) for p in problems]
        results = {mode: run(sequence, mode) for mode in ("full", "lazy")}
        full = results["full"]["objectives"]
        diff = np.max(np.abs(results["lazy"]["objectives"] - full) / np.maximum(1.0, abs(full)))
        worst = max(worst, float(diff))
        for mode, result in results.items():
            times = sorted(result["times"])
            p90 = times[int(0.9 * (len(times) - 1))]
            print(
                f"| {label} | {result['full_rows']} | {mode} | "
                f"{statistics.mean(result['rows']):.0f} | {statistics.median(times):.1f} / "
                f"{p90:.1f} / {max(times):.1f} | {statistics.median(result['highs']):.1f} | "
                f"{statistics.median(result['iterations']):.0f} | {diff:.1e} |"
            )
    if not worst <= LAZY_REL_TOL:
        raise RuntimeError(f"lazy and full event rows disagree on the optimum ({worst:.1e})")
    print(f"checks passed: every solve optimal, lazy = full event rows ({worst:.1e})")


if __name__ == "__main__":
    main()
