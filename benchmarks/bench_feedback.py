"""Benchmark the feedback RMPC step: warm-started vs cold, next to the open-loop step (issue 16).

Run::

    python benchmarks/bench_feedback.py                 # office5, 2014-03-03, 48 steps
    python benchmarks/bench_feedback.py --steps 96 --cold-every 8

It records the LPs of two closed loops of the shipped office5 (``hvacflex`` presets
``rmpc-feedback`` and ``rmpc``, from ``--start``, ``--steps`` steps of 30 min), then solves
each recorded sequence again, in this one process, and prints one table of per-step wall and
CPU times (median, p90, max) and simplex iterations:

1. open-loop warm, event model: :class:`RMPCSolver` on the ``rmpc`` preset's problems (the
   product's open-loop RMPC);
2. open-loop warm, whole-horizon model: :class:`RMPCSolver` on the feedback problems with
   ``robust="tightening"`` (the same building, σ and reserve model as the feedback LP);
3. feedback warm: :class:`FeedbackSolver` (one HiGHS handle, time-shifted basis);
4. feedback cold: ``FeedbackSolver(..., warm_start=False)``, the LP rebuilt and solved from
   scratch (every ``--cold-every``-th step, ≈ 2 s each), with the largest relative objective
   difference between (3) and (4) on those steps;

and the CPU split of a feedback warm step (LP build, ``passModel``, basis, HiGHS ``run()``,
reading, the solution's realised margins).

Step 0 of every warm sequence is a cold solve; it is in max, not in median/p90 (a 1-day
closed loop of 48 steps carries it in its mean). Times are wall (``perf_counter``) and CPU
(``process_time``) in ms; on a shared machine CPU time is the steadier figure. This is a
script, not a timed test.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hvacflex.config import preset
from hvacflex.opt import FeedbackSolver, RMPCProblem, RMPCSolver, feedback_solve
from hvacflex.sim.recording import recorded_problems

WARM_COLD_REL_TOL = 1e-6  # warm and cold feedback optima must agree to this (relative)


def record(name: str, start: str, steps: int) -> list[RMPCProblem]:
    """The problems the controller of preset ``name`` solved in a closed loop of ``steps``."""
    return recorded_problems(preset(name, start=start, days=steps / 48.0 + 1.0), steps)


def warm_split(problems: list[RMPCProblem]) -> dict[str, float]:
    """Mean CPU time [ms] of each part of a warm :class:`FeedbackSolver` step (steps 1..):
    the LP build, ``passModel``, setting the rotated basis, HiGHS ``run()``, reading the
    solution and basis, and building the :class:`RMPCSolution` (realised margins)."""
    parts: dict[str, float] = {}
    patched: list[tuple[Any, str, Any]] = []

    def timing(owner: Any, attribute: str, part: str) -> None:
        original = getattr(owner, attribute)

        def timed_call(*args: Any, **kwargs: Any) -> Any:
            tick = time.process_time()
            try:
                return original(*args, **kwargs)
            finally:
                parts[part] = parts.get(part, 0.0) + time.process_time() - tick

        patched.append((owner, attribute, original))
        setattr(owner, attribute, timed_call)

    solver = FeedbackSolver(problems[0])
    solver.solve(problems[0])
    timing(feedback_solve, "build_feedback_lp", "LP build (no constants)")
    timing(feedback_solve, "pass_csc_model", "passModel")
    timing(FeedbackSolver, "_start_from", "basis: rotate + setBasis")
    timing(FeedbackSolver, "_run_with_retries", "run + read solution/basis")
    timing(type(solver._session.highs), "run", "HiGHS run()")
    timing(FeedbackSolver, "_solution", "solution (margins, plan)")
    tick = time.process_time()
    try:
        for problem in problems[1:]:
            solver.solve(problem)
    finally:
        for owner, attribute, original in reversed(patched):
            setattr(owner, attribute, original)
    parts["step"] = time.process_time() - tick
    # the basis is set and HiGHS runs inside the session's retry ladder
    parts["run + read solution/basis"] -= parts["HiGHS run()"] + parts["basis: rotate + setBasis"]
    parts["rest (matrix data, checks)"] = 2 * parts["step"] - sum(parts.values())
    return {part: 1e3 * total / (len(problems) - 1) for part, total in parts.items()}


def timed(solve: Callable[[RMPCProblem], Any], problems: list[RMPCProblem]) -> dict[str, Any]:
    """Per-step wall and CPU times [ms] and iterations of ``solve`` over ``problems``."""
    wall, cpu, iterations, objectives = [], [], [], []
    for problem in problems:
        tick, cpu_tick = time.perf_counter(), time.process_time()
        solution = solve(problem)
        wall.append((time.perf_counter() - tick) * 1e3)
        cpu.append((time.process_time() - cpu_tick) * 1e3)
        iterations.append(solution.simplex_iterations)
        objectives.append(solution.objective_sgd)
        assert solution.ok, solution.message
    return {"wall": wall, "cpu": cpu, "iterations": iterations, "objective": objectives}


def row(name: str, result: dict[str, Any], skip_first: bool) -> str:
    """One line of the table: median, p90 (without step 0 if ``skip_first``), max."""
    first = 1 if skip_first else 0
    wall, cpu = np.array(result["wall"]), np.array(result["cpu"])
    its = np.array(result["iterations"])
    return (
        f"{name:<36} {np.median(wall[first:]):8.1f} {np.percentile(wall[first:], 90):8.1f} "
        f"{wall.max():8.1f} {np.median(cpu[first:]):8.1f} {np.percentile(cpu[first:], 90):8.1f} "
        f"{wall.mean():8.1f} {int(np.median(its[first:])) if its.any() else '-':>6}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--steps", type=int, default=48)
    parser.add_argument("--cold-every", type=int, default=4)
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.cold_every = 2, 1
    feedback = record("rmpc-feedback", args.start, args.steps)
    open_loop = record("rmpc", args.start, args.steps)
    whole_horizon = [dataclasses.replace(p, robust="tightening", feedback=None) for p in feedback]
    warm_open = RMPCSolver(open_loop[0])
    warm_whole = RMPCSolver(whole_horizon[0])
    warm_feedback = FeedbackSolver(feedback[0])
    cold_steps = feedback[:: args.cold_every]
    results = {
        "open-loop warm (rmpc, event model)": timed(warm_open.solve, open_loop),
        "open-loop warm (whole-horizon)": timed(warm_whole.solve, whole_horizon),
        "feedback warm (zone-local, L=4)": timed(warm_feedback.solve, feedback),
        "feedback cold (rebuild each step)": timed(
            lambda p: FeedbackSolver(p, warm_start=False).solve(p), cold_steps
        ),
    }
    load = os.getloadavg()
    print(
        f"machine: {platform.machine()} {platform.processor() or ''} {os.cpu_count()} CPUs, "
        f"load {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; python {platform.python_version()}"
    )
    print(f"office5 from {args.start}, {args.steps} steps; cold every {args.cold_every}th step")
    print(
        f"{'per step':<36} {'wall med':>8} {'wall p90':>8} {'wall max':>8} {'cpu med':>8} "
        f"{'cpu p90':>8} {'wall mean':>8} {'iters':>6}"
    )
    for name, result in results.items():
        print(row(name, result, skip_first="cold" not in name))
    warm = results["feedback warm (zone-local, L=4)"]
    cold = results["feedback cold (rebuild each step)"]
    warm_at_cold = np.array(warm["objective"][:: args.cold_every])
    worst = np.max(np.abs(warm_at_cold - cold["objective"]) / np.abs(cold["objective"]))
    median = {name: float(np.median(r["cpu"][1:])) for name, r in results.items()}
    median["feedback cold (rebuild each step)"] = float(np.median(cold["cpu"]))
    fb = median["feedback warm (zone-local, L=4)"]
    print(
        f"ratios (CPU medians): feedback warm / open-loop warm event model "
        f"{fb / median['open-loop warm (rmpc, event model)']:.1f}x, / whole-horizon "
        f"{fb / median['open-loop warm (whole-horizon)']:.1f}x; feedback cold / warm "
        f"{median['feedback cold (rebuild each step)'] / fb:.0f}x"
    )
    print(f"warm vs cold objective, worst relative difference: {worst:.1e}")
    if not worst <= WARM_COLD_REL_TOL:
        raise RuntimeError(f"warm and cold feedback solves disagree ({worst:.1e})")
    split = warm_split(feedback)
    print("CPU split of a feedback warm step, mean over steps 1.. [ms]:")
    for part, value in split.items():
        print(f"  {part:<36} {value:7.1f}")
    print(f"checks passed: every solve optimal, feedback warm = cold ({worst:.1e})")


if __name__ == "__main__":
    main()
