"""Warm dual pricing per LP family: Dantzig vs Devex, side by side (issue 63 item 2).

Run::

    python benchmarks/bench_pricing.py [--steps 48] [--start 2014-05-05] [--families event]

For each LP family — the event model (``rmpc``, the product LP), the whole-horizon model
(``paper-rmpc``) and the affine-feedback LP (``rmpc-feedback``) — records the problems the
preset's controller builds over ``--steps`` closed-loop periods on office5 — and the
whole-horizon LP on ``bench_rmpc.py``'s sequence (``--synthetic-steps``, office5, random
disturbances in the box, x0 following the Dantzig solver's plan) — then solves them
with two warm solvers (:func:`hvacflex.opt.solve.make_solver`), one whose warm runs price with
Dantzig (``simplex_dual_edge_weight_strategy`` 0) and one with Devex (1), alternating step by
step in one process. Prints per family and pricing the median simplex iterations and the
median / p90 process CPU of a warm step [ms], and their means (what a long run's time
follows: a few steps of thousands of iterations weigh in the mean, not in the median); fails
when the two disagree on a step's objective by more than 1e-6 relative. ``--families``: a
comma-separated subset (``event``, ``whole-horizon``, ``feedback``, ``synthetic``).
``--quick``: 4 steps (the smoke run).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
from bench_rmpc import HORIZON, building_model, exogenous_series, problem_at

from hvacflex.config import preset
from hvacflex.opt import highs_lp
from hvacflex.opt.factory import make_solver
from hvacflex.paths import resolve_building
from hvacflex.sim.recording import recorded_problems

FAMILIES = {"event": "rmpc", "whole-horizon": "paper-rmpc", "feedback": "rmpc-feedback"}
SYNTHETIC = "whole-horizon, bench_rmpc's sequence"
"""bench_rmpc.py's 200-step receding horizon on office5 (random disturbances in the box)."""
PRICINGS = {"Dantzig": 0, "Devex": 1}
REL_TOL = 1e-6
OFFICE5 = "office5"
"""The shipped building (load_building takes its name)."""


@contextlib.contextmanager
def warm_pricing(strategy: int) -> Iterator[None]:
    """Every HighsSession built inside prices its warm runs with ``strategy``."""
    original = highs_lp.HighsSession.__init__

    def init(self: Any, *args: Any, **kwargs: Any) -> None:
        original(self, *args, **{**kwargs, "warm_pricing": strategy})

    highs_lp.HighsSession.__init__ = init  # type: ignore[method-assign]
    try:
        yield
    finally:
        highs_lp.HighsSession.__init__ = original  # type: ignore[method-assign]


def p90(values: list[float]) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(0.9 * (len(ordered) - 1)))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=48)
    parser.add_argument("--start", default="2014-05-05")
    parser.add_argument("--synthetic-steps", type=int, default=200)
    parser.add_argument("--families", default=",".join([*FAMILIES, "synthetic"]))
    parser.add_argument("--quick", action="store_true", help="4 steps (the smoke run)")
    args = parser.parse_args()
    names = args.families.split(",")
    wanted = list(dict.fromkeys(SYNTHETIC if name == "synthetic" else name for name in names))
    unknown = sorted(set(wanted) - {*FAMILIES, SYNTHETIC})
    if unknown:
        parser.error(f"--families: unknown {unknown}; choose from {[*FAMILIES, 'synthetic']}")
    if args.quick:
        args.steps = args.synthetic_steps = 4
    rows: list[dict[str, Any]] = []
    print(
        f"office5, {args.steps} steps from {args.start}; load average "
        f"{' / '.join(f'{x:.1f}' for x in os.getloadavg())}"
    )
    print("| family | warm pricing | iterations median / mean | CPU median / p90 / mean [ms] |")
    print("|---|---|---:|---:|")
    for family in [name for name in [*FAMILIES, SYNTHETIC] if name in wanted]:
        if family == SYNTHETIC:
            model = building_model(str(resolve_building(OFFICE5)))
            series = exogenous_series(model, args.synthetic_steps + HORIZON, 0)
            noise = np.random.default_rng(1)
            x0 = np.full(model.a.shape[0], 24.0)
            count = args.synthetic_steps
        else:
            cfg = preset(FAMILIES[family], start=args.start, days=args.steps // 48 + 2)
            problems = recorded_problems(cfg, args.steps)
            count = len(problems)
        solvers: dict[str, Any] = {}
        cpu: dict[str, list[float]] = {name: [] for name in PRICINGS}
        iterations: dict[str, list[int]] = {name: [] for name in PRICINGS}
        for index in range(count):
            problem = (
                problem_at(model, series, index, x0) if family == SYNTHETIC else problems[index]
            )
            if not solvers:
                for name, strategy in PRICINGS.items():
                    with warm_pricing(strategy):
                        solvers[name] = make_solver(problem)
            objectives, solutions = [], []
            for name, solver in solvers.items():
                tick = time.process_time()
                solution = solver.solve(problem)
                elapsed = 1e3 * (time.process_time() - tick)
                if not solution.ok:
                    raise RuntimeError(f"{family} {name} step {index}: {solution.message}")
                objectives.append(solution.objective_sgd)
                solutions.append(solution)
                if index > 0:  # the first solve is cold
                    cpu[name].append(elapsed)
                    iterations[name].append(solution.simplex_iterations)
            if family == SYNTHETIC:  # the closed loop follows the Dantzig solver's plan
                w0 = noise.uniform(-1, 1, problem.nd) * problem.d_sigma[0]
                u0 = solutions[0].u[0]
                x0 = model.a @ x0 + model.b @ u0 + model.e @ (problem.d_forecast[0] + w0) + model.g
            gap = abs(objectives[0] - objectives[1]) / max(1.0, abs(objectives[1]))
            if gap > REL_TOL:
                raise RuntimeError(f"{family} step {index}: the pricings disagree ({gap:.1e})")
        for name in PRICINGS:
            median_it = statistics.median(iterations[name])
            print(
                f"| {family} | {name} | {median_it:g} / {statistics.fmean(iterations[name]):.1f}"
                f" | {statistics.median(cpu[name]):.1f} / {p90(cpu[name]):.1f} / "
                f"{statistics.fmean(cpu[name]):.1f} |"
            )
            rows.append(
                {
                    "method": f"{family} LP, warm step, {name} pricing",
                    "median": statistics.median(cpu[name]),
                    "p90": p90(cpu[name]),
                    "mean": statistics.fmean(cpu[name]),
                    "iterations": median_it,
                    "unit": "ms CPU",
                }
            )
    print("RESULT " + json.dumps({"rows": rows}))
    print(f"checks passed: Dantzig = Devex on every step of {len(wanted)} sequences")


if __name__ == "__main__":
    main()
