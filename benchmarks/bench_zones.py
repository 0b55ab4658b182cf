"""How the rmpc (IL event model) LP grows with the zones: office5 (5 zones) vs office15 (15).

Run::

    python benchmarks/bench_zones.py                      # 2014-03-03, 24 steps each
    python benchmarks/bench_zones.py --start 2014-03-04 --steps 48

Records the problems the ``rmpc`` preset's controller builds on each building over
``--steps`` closed-loop steps (``hvacflex.sim.recording``), then solves both sequences warm
with :class:`~hvacflex.opt.RMPCSolver` (lazy event rows, the product's default), the two
buildings' steps interleaved in one run so that the machine's load affects both alike. It
prints one table with the two buildings side by side and their ratio:

* model size n (nodes), m (zone flows), ny (outputs), nd (disturbance channels);
* the full LP (:func:`hvacflex.opt.lp.build_lp`): rows, columns, nonzeros, and the nonzeros
  of the dynamics rows (``N·n²``: A is dense) and of the event rows (``≈ N²·ny/2`` rows of
  ``≤ D·m_r`` reserve terms each: H_l = −C A^l B_r is dense);
* rows and nonzeros HiGHS holds (lazy event rows), warm-step CPU median / p90 [ms] and the
  simplex iterations median;
* how sparse an *approximation* could make the model: the share of entries of A above
  1e-6 and of the reserve responses H_l above 1e-3 of their row's largest entry, and the
  nonzeros of the dynamics and event rows if the entries below were dropped (counted, not
  solved: such an LP is another model, docs/reference/performance.md "Zones").

Growth ≤ linear in zones means ratios ≤ 3 here. This is a script, not a timed test; quote the
load it prints with any figure.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from dataclasses import dataclass

import numpy as np

from hvacflex.config import preset
from hvacflex.opt import RMPCProblem, RMPCSolver
from hvacflex.opt.events import event_matrix, event_rows, reserve_responses
from hvacflex.opt.lp import build_lp
from hvacflex.sim.recording import recorded_problems

BUILDINGS = ("office5", "office15")
A_ENTRY_THRESHOLD = 1e-6
H_RELATIVE_THRESHOLD = 1e-3


@dataclass
class Sizes:
    """Sizes of one building's model and full LP."""

    n: int
    m: int
    ny: int
    nd: int
    rows: int
    cols: int
    nonzeros: int
    dynamics_nonzeros: int
    event_nonzeros: int
    a_share_above: float
    h_share_above: float
    thresholded_dynamics_nonzeros: int
    thresholded_event_nonzeros: int


def lp_sizes(problem: RMPCProblem) -> Sizes:
    """The full LP's size and its nonzeros by family (dynamics rows come first in build_lp)."""
    program, layout = build_lp(problem, np.zeros((problem.horizon, problem.ny)))
    assert program.constant is not None
    rows = np.concatenate([program.constant.rows, program.varying.rows])
    values = np.concatenate([program.constant.values, program.varying.values])
    rows = rows[values != 0.0]
    dynamics = int(np.count_nonzero(rows < problem.horizon * problem.n))
    events = int(np.count_nonzero(np.isin(rows, layout.event_rows)))
    mask = np.asarray(problem.reserve_mask, dtype=bool)
    h = reserve_responses(
        problem.a_matrix, problem.b_matrix[:, mask], problem.c_matrix, problem.horizon
    )
    largest = h.max(axis=2, keepdims=True)
    kept_a = np.abs(problem.a_matrix) > A_ENTRY_THRESHOLD
    kept_h = h > H_RELATIVE_THRESHOLD * largest
    # dynamics: identity + kept A entries (k ≥ 1) + B per step
    thresholded_dynamics = int(
        problem.horizon * problem.n
        + (problem.horizon - 1) * np.count_nonzero(kept_a)
        + problem.horizon * np.count_nonzero(problem.b_matrix)
    )
    event_model = problem.events
    assert event_model is not None, "the product LP has the event model"
    rows_of_events = event_rows(
        problem.horizon, problem.ny, event_model.max_steps, event_model.recovery_steps
    )
    plan = layout.plan
    thresholded_events = event_matrix(
        rows_of_events,
        np.where(kept_h, h, 0.0),
        problem.c_matrix,
        col_x=plan.x,
        col_r=plan.r,
        col_eps=plan.eps,
        num_cols=program.num_cols,
    ).nnz
    return Sizes(
        n=problem.n,
        m=problem.m,
        ny=problem.ny,
        nd=problem.nd,
        rows=program.num_rows,
        cols=program.num_cols,
        nonzeros=int(rows.size),
        dynamics_nonzeros=dynamics,
        event_nonzeros=events,
        a_share_above=float(np.mean(np.abs(problem.a_matrix) > A_ENTRY_THRESHOLD)),
        h_share_above=float(np.mean(kept_h)),
        thresholded_dynamics_nonzeros=thresholded_dynamics,
        thresholded_event_nonzeros=int(thresholded_events),
    )


def interleaved_warm_steps(
    sequences: dict[str, list[RMPCProblem]],
) -> dict[str, dict[str, list[float]]]:
    """Solve every sequence warm, step i of each building in turn; per warm step CPU [ms],
    simplex iterations and rows/nonzeros HiGHS holds."""
    solvers = {name: RMPCSolver(problems[0]) for name, problems in sequences.items()}
    out: dict[str, dict[str, list[float]]] = {
        name: {"cpu_ms": [], "iterations": [], "rows": []} for name in sequences
    }
    steps = min(len(problems) for problems in sequences.values())
    for index in range(steps):
        for name, problems in sequences.items():
            start = time.process_time()
            solution = solvers[name].solve(problems[index])
            cpu_ms = (time.process_time() - start) * 1e3
            if not solution.ok:
                raise RuntimeError(f"{name} step {index}: {solution.message}")
            if index:  # step 0 is the cold start
                out[name]["cpu_ms"].append(cpu_ms)
                out[name]["iterations"].append(float(solution.simplex_iterations))
                out[name]["rows"].append(float(solvers[name].num_model_rows))
    return out


def machine() -> str:
    """CPU, cores and the load average (the machine is shared)."""
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {load}"


def _p90(values: list[float]) -> float:
    ordered = sorted(values)
    return ordered[int(0.9 * (len(ordered) - 1))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--steps", type=int, default=24)
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.steps = 2
    days = args.steps / 48.0 + 1.0
    sequences = {
        name: recorded_problems(
            preset("rmpc", start=args.start, days=days, building=name), args.steps
        )
        for name in BUILDINGS
    }
    sizes = {name: lp_sizes(problems[0]) for name, problems in sequences.items()}
    print(f"rmpc preset from {args.start}, {args.steps - 1} warm steps each, interleaved")
    print(f"before: {machine()}")
    warm = interleaved_warm_steps(sequences)
    print(f"after:  {machine()}\n")
    rows: list[tuple[str, float, float]] = []
    for field in ("n", "m", "ny", "nd", "rows", "cols", "nonzeros"):
        rows.append(
            (
                f"full LP {field}" if field in ("rows", "cols", "nonzeros") else field,
                getattr(sizes["office5"], field),
                getattr(sizes["office15"], field),
            )
        )
    rows.append(
        (
            "dynamics nonzeros (N·n²)",
            sizes["office5"].dynamics_nonzeros,
            sizes["office15"].dynamics_nonzeros,
        )
    )
    rows.append(
        ("event-row nonzeros", sizes["office5"].event_nonzeros, sizes["office15"].event_nonzeros)
    )
    for label, key, stat in (
        ("rows in HiGHS (lazy, mean)", "rows", statistics.mean),
        ("warm-step CPU median [ms]", "cpu_ms", statistics.median),
        ("warm-step CPU p90 [ms]", "cpu_ms", _p90),
        ("simplex iterations median", "iterations", statistics.median),
    ):
        rows.append((label, stat(warm["office5"][key]), stat(warm["office15"][key])))
    rows.append(
        (
            f"share of A entries > {A_ENTRY_THRESHOLD:g}",
            sizes["office5"].a_share_above,
            sizes["office15"].a_share_above,
        )
    )
    rows.append(
        (
            f"share of H_l entries > {H_RELATIVE_THRESHOLD:g} × row max",
            sizes["office5"].h_share_above,
            sizes["office15"].h_share_above,
        )
    )
    rows.append(
        (
            "dynamics nonzeros, A entries ≤ 1e-6 dropped",
            sizes["office5"].thresholded_dynamics_nonzeros,
            sizes["office15"].thresholded_dynamics_nonzeros,
        )
    )
    rows.append(
        (
            "event-row nonzeros, H entries ≤ 1e-3 × row max dropped",
            sizes["office5"].thresholded_event_nonzeros,
            sizes["office15"].thresholded_event_nonzeros,
        )
    )
    print("| quantity | office5 | office15 | ratio |")
    print("|---|---:|---:|---:|")
    for label, small, big in rows:
        ratio = big / small if small else float("nan")
        print(f"| {label} | {_number(small)} | {_number(big)} | {ratio:.2f} |")
    if not sizes["office15"].ny == 3 * sizes["office5"].ny:
        raise RuntimeError("office15 does not have three times office5's zones")
    print("checks passed: every warm solve optimal on both buildings, 3× the zones")


def _number(value: float) -> str:
    """Thousands separators for counts and milliseconds ≥ 100, three digits below."""
    return f"{value:,.0f}" if abs(value) >= 100 else f"{value:.3g}"


if __name__ == "__main__":
    main()
