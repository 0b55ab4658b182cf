"""Benchmark the product LP (IL event model) warm-started against a CVXPY rebuild (issue 32).

Run::

    python benchmarks/bench_cvxpy_events.py                  # office5, rmpc, 48 steps
    python benchmarks/bench_cvxpy_events.py --steps 96 --every 4 --scenario rmpc-ppp

Records the problems the ``--scenario`` preset's controller builds in a closed loop on office5
(the product LP: IL event model D = 4, R = 2, α = 1 K), then solves them in **one interleaved
run**: every step with one warm-started :class:`~hvacflex.opt.solve.RMPCSolver` (the path the
controller takes: time-shifted basis, lazy event rows), and every ``--every``-th step, right
after its warm solve, the same LP written in CVXPY from the problem's arrays (vectorised,
every event row, HiGHS backend), built and solved from scratch as a CVXPY user would each
period. The CVXPY model is :func:`hvacflex.opt.reference.solve_reference`, written from the
event model's definition (docs/explanation/il_events.md: an allowance row per (t, s ≥ t − D − R)
with the longest event, a strict row per (t, s ≤ t − R − 2), the offers paid for what the settlement
baselines see, the committed reserve), not from hvacflex's LP builder; its objective must
equal HiGHS's (tie-breaks included) to 1e-6 relative, or the script fails (exit 1). The same
reference is checked against every LP family in the default suite
(``tests/opt/test_reference.py``), so it cannot drift from the LP unnoticed.

Prints the per-step process CPU time (median / p90 / mean [ms]) of both, the ratio of the
medians, the per-step ratios of the paired steps, and the machine's load. Target (issue 32):
CVXPY / warm ≥ 60× in one interleaved run. This is a script, not a timed test.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from typing import Any

import highspy

from hvacflex.config import preset
from hvacflex.opt.reference import solve_reference
from hvacflex.opt.solve import RMPCSolver
from hvacflex.sim.recording import recorded_problems


def machine() -> str:
    """CPU, cores, Python/HiGHS/CVXPY versions and the load average (the machine is shared)."""
    import cvxpy

    from hvacflex.opt.highs_lp import quiet_highs

    load = " / ".join(f"{x:.1f}" for x in os.getloadavg())
    return (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}, HiGHS {quiet_highs().version()}, CVXPY "
        f"{cvxpy.__version__}; load average {load}"
    )


def stats(values: list[float]) -> str:
    """median / p90 / mean of ``values`` [ms]."""
    ordered = sorted(values)
    p90 = ordered[min(len(ordered) - 1, round(0.9 * (len(ordered) - 1)))]
    return f"{statistics.median(ordered):.1f} / {p90:.1f} / {statistics.mean(ordered):.1f}"


class RunClock:
    """Process CPU [s] spent inside HiGHS ``run()`` (every handle), so a step's overhead is
    its CPU less this."""

    def __init__(self) -> None:
        self.cpu_s = 0.0
        core = getattr(highspy, "_Highs", highspy.Highs)  # the class hvacflex's handles are
        run = core.run

        def timed(handle: Any) -> Any:
            tick = time.process_time()
            try:
                return run(handle)
            finally:
                self.cpu_s += time.process_time() - tick

        core.run = timed


def p90(values: list[float]) -> float:
    """The 90th percentile (nearest rank) of ``values``."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(0.9 * (len(ordered) - 1)))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="rmpc")
    parser.add_argument("--start", default="2014-05-05")
    parser.add_argument("--steps", type=int, default=48)
    parser.add_argument("--every", type=int, default=3, help="CVXPY on every k-th step")
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.every = 4, 2
    problems = recorded_problems(
        preset(args.scenario, start=args.start, days=args.steps // 48 + 2), args.steps
    )
    assert problems[0].events is not None, "the product LP has the event model"
    print(f"office5, {args.scenario} from {args.start}, {len(problems)} steps; {machine()}")
    clock = RunClock()
    solver = RMPCSolver(problems[0])
    warm_ms: list[float] = []
    overhead_ms: list[float] = []
    iterations: list[int] = []
    cvx_ms: list[float] = []
    paired: list[float] = []
    worst = 0.0
    for index, problem in enumerate(problems):
        tick, in_run = time.process_time(), clock.cpu_s
        solution = solver.solve(problem)
        elapsed = 1e3 * (time.process_time() - tick)
        run_ms = 1e3 * (clock.cpu_s - in_run)
        if not solution.ok:
            raise RuntimeError(f"step {index}: {solution.message}")
        if index == 0:
            continue  # the first solve is cold
        warm_ms.append(elapsed)
        overhead_ms.append(elapsed - run_ms)
        iterations.append(solution.simplex_iterations)
        if index % args.every == 0:
            tick = time.process_time()
            reference = solve_reference(problem)
            cvx_ms.append(1e3 * (time.process_time() - tick))
            if reference.status != "optimal":
                raise RuntimeError(f"step {index}: CVXPY {reference.status}")
            ours = solver.highs_objective_sgd()
            worst = max(worst, abs(reference.objective_sgd - ours) / max(1.0, abs(ours)))
            paired.append(cvx_ms[-1] / elapsed)
    ratio = statistics.median(cvx_ms) / statistics.median(warm_ms)
    print(f"load average at the end: {' / '.join(f'{x:.1f}' for x in os.getloadavg())}\n")
    print("| per step, process CPU [ms] | steps | median / p90 / mean |")
    print("|---|---:|---|")
    print(f"| warm `RMPCSolver.solve` | {len(warm_ms)} | {stats(warm_ms)} |")
    print(f"| CVXPY rebuild + HiGHS (every event row) | {len(cvx_ms)} | {stats(cvx_ms)} |")
    print(
        f"\nCVXPY / warm (medians) = {ratio:.1f}× (target ≥ 60); per paired step: median "
        f"{statistics.median(paired):.1f}×, min {min(paired):.1f}×; "
        f"max rel. objective difference {worst:.1e}"
    )
    if worst > 1e-6:
        raise RuntimeError("CVXPY and hvacflex disagree on the optimum")
    print(
        f"overhead (step − HiGHS run(), CPU): median {statistics.median(overhead_ms):.2f} ms, "
        f"p90 {p90(overhead_ms):.2f} ms; simplex iterations median "
        f"{statistics.median(iterations):g}"
    )
    rows = [
        {
            "method": "office5 event LP, warm RMPCSolver.solve",
            "median": statistics.median(warm_ms),
            "p90": p90(warm_ms),
            "mean": statistics.fmean(warm_ms),
            "iterations": statistics.median(iterations),
            "unit": "ms CPU",
        },
        {
            "method": "office5 event LP, warm step overhead (step − HiGHS run())",
            "median": statistics.median(overhead_ms),
            "p90": p90(overhead_ms),
            "mean": statistics.fmean(overhead_ms),
            "unit": "ms CPU",
        },
        {
            "method": "office5 event LP, CVXPY rebuild + HiGHS",
            "median": statistics.median(cvx_ms),
            "p90": p90(cvx_ms),
            "mean": statistics.fmean(cvx_ms),
            "ratio": ratio,
            "unit": "ms CPU",
        },
    ]
    summary = {
        "warm_overhead_ms_median": statistics.median(overhead_ms),
        "office5_event_cvxpy_ratio": ratio,
        "office5_event_warm_ms_median": statistics.median(warm_ms),
        "office5_event_iterations_median": statistics.median(iterations),
    }
    print("RESULT " + json.dumps({"rows": rows, "summary": summary}))
    print(f"checks passed: CVXPY = hvacflex on {len(cvx_ms)} paired steps ({worst:.1e})")


if __name__ == "__main__":
    main()
