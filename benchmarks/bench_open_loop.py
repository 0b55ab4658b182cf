"""Benchmark one warm open-loop RMPC step: where the time goes, and is it exact (issue 16).

Run::

    python benchmarks/bench_open_loop.py                      # office5, rmpc, 96 steps
    python benchmarks/bench_open_loop.py --steps 336 --cold   # a week, with cold solves

Records the problems the ``rmpc`` preset's controller builds in a closed loop on office5
(the product LP: IL event model, ``linearisation = "fixed"``), then solves the sequence with
one warm-started :class:`~hvacflex.opt.solve.RMPCSolver` whose methods are wrapped with
timers, and prints one markdown table of the per-step split (median / p90 / mean [ms]):

* coefficients: δ (robust margins) and the LP's costs, bounds and varying coefficients
  rebuilt from the problem (``build_lp(constants=False)``);
* push: the diff against the previous LP and the highspy calls (costs, bounds; ``changeCoeff``
  only where the moving rows are not replaced as a block);
* basis: rotating the previous basis, choosing the lazy event rows, replacing the moving rows
  with them (one ``deleteRows`` and one ``addRows``), ``setBasis``;
* ``run()``: HiGHS itself, every run of the step (lazy rounds included);
* lazy rounds: the event-row activities, the most violated rows and ``addRows`` (no run);
* read: ``getSolution``, the optimal basis from ``getBasicVariables``;
* plan: the :class:`RMPCSolution` (plan arrays, costs, worst event output);
* overhead = step − ``run()``.

Then the slowest steps (iterations, lazy rounds, rows added) and, with ``--cold``, the
largest relative difference between each warm objective and a cold solve with every event row
(``event_rows="full"``) of the same problem. This is a script, not a timed test.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

from hvacflex.config import preset
from hvacflex.opt import solve as solve_module
from hvacflex.opt.problem import RMPCProblem
from hvacflex.opt.solve import RMPCSolver
from hvacflex.sim.recording import recorded_problems

Timings = dict[str, float]

clock: Callable[[], float] = time.process_time
"""The timer of every part: process CPU time by default (the machine is shared), or wall."""


def timed(
    owner: Any, name: str, label: str, timings: Timings, *, exclude: str | None = None
) -> None:
    """Wrap ``owner.name`` so that each call adds its wall time [s] to ``timings[label]``
    (minus what ``timings[exclude]`` grew by during the call, for nested timers)."""
    inner: Callable[..., Any] = getattr(owner, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        before = timings[exclude] if exclude else 0.0
        tick = clock()
        try:
            return inner(*args, **kwargs)
        finally:
            elapsed = clock() - tick
            if exclude:
                elapsed -= timings[exclude] - before
            timings[label] += elapsed

    setattr(owner, name, wrapper)


class TimedHighs:
    """A proxy of the HiGHS handle that times ``run``, ``getSolution`` and
    ``getBasicVariables`` into ``timings`` (everything else passes through)."""

    def __init__(self, highs: Any, timings: Timings) -> None:
        self._highs = highs
        self._timings = timings

    def __getattr__(self, name: str) -> Any:
        return getattr(self._highs, name)

    def _timed(self, label: str, call: Callable[[], Any]) -> Any:
        tick = clock()
        result = call()
        self._timings[label] += clock() - tick
        return result

    def run(self) -> Any:
        self._timings["runs"] += 1
        return self._timed("run()", self._highs.run)

    def getSolution(self) -> Any:
        return self._timed("read", self._highs.getSolution)

    def getBasicVariables(self) -> Any:
        return self._timed("read", self._highs.getBasicVariables)


def instrumented_solver(problem: RMPCProblem, timings: Timings) -> RMPCSolver:
    """An :class:`RMPCSolver` whose parts add their wall time [s] to ``timings``."""
    solver = RMPCSolver(problem)
    session = solver._session  # the one HiGHS session: time its handle's calls
    session.highs = TimedHighs(session.highs, timings)
    timed(solve_module, "build_lp", "coefficients", timings)
    timed(solver, "_delta", "coefficients", timings)
    timed(solver, "_update", "push", timings, exclude="coefficients")
    timed(solver, "_start_from", "basis", timings)
    timed(solver, "_generate_rows", "lazy rounds", timings, exclude="run()")
    timed(solver, "_optimal_basis", "read", timings, exclude="read")
    timed(solver, "_solution", "plan", timings)
    return solver


def machine() -> str:
    """CPU, cores and the load average (the machine is shared)."""
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {load}"


def percentile(values: list[float], q: float) -> float:
    """The ``q`` quantile (0..1) of ``values``, nearest rank."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


WARM_COLD_REL_TOL = 1e-6  # a warm and a cold solve must reach the same optimum (relative)
PARTS = ("coefficients", "push", "basis", "run()", "lazy rounds", "read", "plan")


def split_table(rows: list[Timings]) -> None:
    """Print the per-step split (median / p90 / mean [ms]) of the warm steps ``rows``."""
    print("| part | median [ms] | p90 [ms] | mean [ms] |")
    print("|---|---:|---:|---:|")
    for part in (*PARTS, "overhead (step − run())", "step"):
        values = [1e3 * row[part] for row in rows]
        print(
            f"| {part} | {statistics.median(values):.3f} | {percentile(values, 0.9):.3f} | "
            f"{statistics.mean(values):.3f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--start", default="2014-05-05")
    parser.add_argument("--steps", type=int, default=96)
    parser.add_argument("--scenario", default="rmpc")
    parser.add_argument("--cold", action="store_true", help="also cold-solve every step")
    parser.add_argument(
        "--clock", choices=("cpu", "wall"), default="cpu", help="CPU time: the machine is shared"
    )
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.cold = 3, True
    config = preset(args.scenario, start=args.start, days=args.steps // 48 + 2)
    problems = recorded_problems(config, args.steps)
    global clock
    clock = time.perf_counter if args.clock == "wall" else time.process_time
    timings: Timings = defaultdict(float)
    solver = instrumented_solver(problems[0], timings)
    rows: list[Timings] = []
    steps: list[tuple[float, int, int, int]] = []  # step ms, iterations, rounds, rows added
    objectives = []
    for index, problem in enumerate(problems):
        timings.clear()
        rows_before = solver.num_model_rows
        tick = clock()
        solution = solver.solve(problem)
        step_s = clock() - tick
        if not solution.ok:
            raise RuntimeError(f"step {index}: {solution.message}")
        objectives.append(solver.highs_objective_sgd())
        if index == 0:
            continue
        row = {part: timings[part] for part in PARTS}
        row["step"] = step_s
        row["overhead (step − run())"] = step_s - timings["run()"]
        rows.append(row)
        added = solver.num_model_rows - rows_before
        steps.append((1e3 * step_s, solution.simplex_iterations, int(timings["runs"]) - 1, added))
    print(
        f"office5, {args.scenario}, {args.start}, {len(rows)} warm steps, {args.clock} time; "
        f"{machine()}\n"
    )
    split_table(rows)
    iterations = [s[1] for s in steps]
    print(
        f"\nsimplex iterations: median {statistics.median(iterations):.0f}, "
        f"p90 {percentile(iterations, 0.9):.0f}, max {max(iterations)}; "
        f"lazy rounds: median {statistics.median(s[2] for s in steps):.0f}, "
        f"max {max(s[2] for s in steps)}"
    )
    print("\nslowest steps: (step ms, iterations, lazy rounds, event rows added/removed)")
    for step in sorted(steps, reverse=True)[:8]:
        print(f"  {step[0]:.1f} ms, {step[1]} it, {step[2]} rounds, {step[3]:+d} rows")
    checked = "every warm solve optimal"
    if args.cold:
        cold_table(problems, objectives, [s[0] for s in steps])
        checked += ", warm = cold (lazy and every row)"
    print(f"checks passed: {checked}")


def cold_table(
    problems: list[RMPCProblem], warm_objectives: list[float], warm_ms: list[float]
) -> None:
    """Cold solves of every problem (lazy rows as ``solve_rmpc``, and every event row): their
    step times beside the warm ones, and the largest relative objective difference."""
    cold_ms: dict[str, list[float]] = {"lazy": [], "full": []}
    worst = {"lazy": 0.0, "full": 0.0}
    for problem, warm in zip(problems, warm_objectives, strict=True):
        for mode in ("lazy", "full"):
            tick = clock()
            cold = RMPCSolver(problem, event_rows=mode)  # type: ignore[arg-type]
            if not cold.solve(problem).ok:
                raise RuntimeError("a cold solve failed")
            cold_ms[mode].append(1e3 * (clock() - tick))
            reference = cold.highs_objective_sgd()
            difference = abs(warm - reference) / max(1.0, abs(reference))
            worst[mode] = max(worst[mode], difference)
            if difference > WARM_COLD_REL_TOL:
                raise RuntimeError(f"warm and cold ({mode}) disagree ({difference:.1e})")
    warm_median = statistics.median(warm_ms)
    print("\n| solve | median [ms] | p90 [ms] | / warm (medians) | max rel. objective diff |")
    print("|---|---:|---:|---:|---:|")
    print(f"| warm (RMPCSolver) | {warm_median:.1f} | {percentile(warm_ms, 0.9):.1f} | 1 | – |")
    for mode, label in (("lazy", "cold, lazy rows (solve_rmpc)"), ("full", "cold, every row")):
        median = statistics.median(cold_ms[mode])
        print(
            f"| {label} | {median:.1f} | {percentile(cold_ms[mode], 0.9):.1f} | "
            f"{median / warm_median:.1f} | {worst[mode]:.1e} |"
        )


if __name__ == "__main__":
    main()
