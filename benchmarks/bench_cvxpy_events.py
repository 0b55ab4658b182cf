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
period. The CVXPY model is written here from the event model's definition
(docs/il_events.md: an allowance row per (t, s ≥ t − D − R) with the longest event, a strict
row per (t, s ≤ t − R − 2)), not from hvacflex's LP builder; its objective must equal HiGHS's
(tie-break included) to 1e-6 relative.

Prints the per-step process CPU time (median / p90 / mean [ms]) of both, the ratio of the
medians, the per-step ratios of the paired steps, and the machine's load. Target (issue 32):
CVXPY / warm ≥ 60× in one interleaved run. This is a script, not a timed test.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from typing import Any

import numpy as np
from scipy import sparse

from hvacflex.config import preset
from hvacflex.opt.options import RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR
from hvacflex.opt.problem import FloatArray, RMPCProblem
from hvacflex.opt.solve import RMPCSolver
from hvacflex.sim.recording import recorded_problems

KWH_PER_MWH = 1000.0


def margins(prob: RMPCProblem) -> FloatArray:
    """(N, ny) δ_k = Σ_{j<k} |C A^{k−1−j} E| σ_j [K] (impulse responses by repeated products)."""
    horizon = prob.horizon
    responses = np.empty((horizon, prob.ny, prob.nd))
    propagated = prob.e_matrix.copy()
    for lag in range(horizon):
        responses[lag] = np.abs(prob.c_matrix @ propagated)
        propagated = prob.a_matrix @ propagated
    delta = np.zeros((horizon, prob.ny))
    for k in range(horizon):
        delta[k] = np.einsum("lij,lj->i", responses[k::-1], prob.d_sigma[: k + 1])
    return delta


def event_rows_of(prob: RMPCProblem) -> tuple[Any, ...]:
    """Per event row: output step k = t − 1, first curtailed input s, curtailed inputs L,
    allowance (True) or strict (False), for every (t, s) of the event model (zones apart)."""
    d, r = prob.il_event_max_steps, prob.il_event_recovery_steps
    assert d is not None
    steps, starts, lengths, allowance = [], [], [], []
    for t in range(1, prob.horizon + 1):
        for s in range(t):
            lag = t - s
            if lag <= d + r:  # some event (s, L ≤ D) still allows α at t: the longest one
                steps.append(t - 1), starts.append(s), lengths.append(min(d, lag))
                allowance.append(True)
            if lag >= r + 2:  # some event ended more than R steps before t: the longest one
                steps.append(t - 1), starts.append(s), lengths.append(min(d, lag - r - 1))
                allowance.append(False)
    return tuple(np.array(a) for a in (steps, starts, lengths, allowance))


def cvxpy_event_lp(prob: RMPCProblem) -> tuple[float, str]:
    """Build the event-model LP of ``prob`` in CVXPY and solve it with HiGHS:
    (objective [SGD], CVXPY status)."""
    import cvxpy as cp

    horizon, n, m, ny = prob.horizon, prob.n, prob.m, prob.ny
    inputs = np.flatnonzero(prob.reserve_mask)
    m_r = inputs.size
    alpha, carry_steps = prob.il_event_allowance_kelvin, prob.il_allowance_carry_steps
    recovery = prob.il_event_recovery_steps
    delta = margins(prob)
    # the recovery's decaying allowance on outputs 1..c (served and strict rows)
    t = np.arange(1, horizon + 1)
    share = np.clip((carry_steps - t + 1) / (recovery + 1), 0.0, 1.0) * (t <= carry_steps)
    carry = alpha * share[:, None] * np.ones(ny)
    # warming responses H_l = −C A^l B_r and the event rows' r-coefficients
    b_reserve = prob.b_matrix[:, inputs]
    warming = np.empty((horizon, ny, m_r))
    propagated = -b_reserve
    for lag in range(horizon):
        warming[lag] = prob.c_matrix @ propagated
        propagated = prob.a_matrix @ propagated
    step, start, length, allowance = event_rows_of(prob)
    rows = np.arange(step.size)
    entries_r, entries_c, entries_v = [], [], []
    for offset in range(int(length.max())):
        take = length > offset
        j = start[take] + offset
        for zone in range(ny):
            entries_r.append(rows[take] * ny + zone)
            entries_c.append(j)
            entries_v.append(warming[step[take] - j, zone])
    row_of = np.concatenate([np.repeat(e, m_r) for e in entries_r])
    col_of = np.concatenate([(c[:, None] * m_r + np.arange(m_r)).ravel() for c in entries_c])
    warming_rows = sparse.csr_matrix(
        (np.concatenate([v.ravel() for v in entries_v]), (row_of, col_of)),
        shape=(step.size * ny, horizon * m_r),
    )
    out_index = (step[:, None] * ny + np.arange(ny)).ravel()  # (rows·ny,) into (N, ny).ravel()
    widen = np.where(allowance[:, None], alpha, carry[step]).ravel()
    event_upper = (prob.y_max - delta)[step].ravel() + widen

    u = cp.Variable((horizon, m))
    r = cp.Variable((horizon, m_r))
    x = cp.Variable((horizon, n))
    eps = cp.Variable((horizon, ny))
    power = cp.Variable(horizon)
    beta = cp.Variable()
    drift = prob.d_forecast @ prob.e_matrix.T + prob.g
    x_prev = cp.vstack([prob.x0[None, :], x[:-1]])
    y = x @ prob.c_matrix.T
    slack_max = np.inf if prob.slack_max_kelvin is None else prob.slack_max_kelvin
    cons = [
        x == x_prev @ prob.a_matrix.T + u @ prob.b_matrix.T + drift,
        y - eps <= prob.y_max - delta + carry,
        y + eps >= prob.y_min + delta,
        u >= prob.u_min,
        u <= prob.u_max,
        r >= 0,
        r <= (prob.u_max - prob.u_min)[:, inputs],
        u[:, inputs] - r >= prob.u_min[:, inputs],
        eps >= 0,
        power == prob.power_offset_kw + cp.sum(cp.multiply(prob.power_coeff_kw_per_kg_s, u), 1),
        cp.multiply(prob.phi, power) <= beta,
        beta >= float(prob.phi[0]) * prob.peak_floor_kw,
        cp.vec(y, order="C")[out_index]
        + warming_rows @ cp.vec(r, order="C")
        - cp.vec(eps, order="C")[out_index]
        <= event_upper,
    ]
    if np.isfinite(slack_max):
        cons.append(eps <= slack_max)
    if np.isfinite(prob.power_max_kw).any():
        cons.append(power <= prob.power_max_kw)
    dt = prob.dt_h
    reserve_kw = cp.sum(cp.multiply(prob.reserve_kw_per_kg_s[:, inputs], r), axis=1)
    objective = (
        dt * (prob.energy_price_sgd_per_mwh @ power) / KWH_PER_MWH
        - dt * (prob.reserve_price_sgd_per_mwh @ reserve_kw) / KWH_PER_MWH
        + dt * RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR * cp.sum(r)
        + prob.comfort_penalty_sgd_per_kelvin_hour * dt * cp.sum(eps)
        + beta
    )
    model = cp.Problem(cp.Minimize(objective), cons)
    model.solve(solver=cp.HIGHS)
    return float(model.value), str(model.status)


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="rmpc")
    parser.add_argument("--start", default="2014-05-05")
    parser.add_argument("--steps", type=int, default=48)
    parser.add_argument("--every", type=int, default=3, help="CVXPY on every k-th step")
    args = parser.parse_args()
    problems = recorded_problems(
        preset(args.scenario, start=args.start, days=args.steps // 48 + 2), args.steps
    )
    assert problems[0].il_event_max_steps is not None, "the product LP has the event model"
    print(f"office5, {args.scenario} from {args.start}, {len(problems)} steps; {machine()}")
    solver = RMPCSolver(problems[0])
    warm_ms: list[float] = []
    cvx_ms: list[float] = []
    paired: list[float] = []
    worst = 0.0
    for index, problem in enumerate(problems):
        tick = time.process_time()
        solution = solver.solve(problem)
        elapsed = 1e3 * (time.process_time() - tick)
        if not solution.ok:
            raise RuntimeError(f"step {index}: {solution.message}")
        if index == 0:
            continue  # the first solve is cold
        warm_ms.append(elapsed)
        if index % args.every == 0:
            tick = time.process_time()
            value, status = cvxpy_event_lp(problem)
            cvx_ms.append(1e3 * (time.process_time() - tick))
            if status != "optimal":
                raise RuntimeError(f"step {index}: CVXPY {status}")
            ours = solver.highs_objective_sgd()
            worst = max(worst, abs(value - ours) / max(1.0, abs(ours)))
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


if __name__ == "__main__":
    main()
