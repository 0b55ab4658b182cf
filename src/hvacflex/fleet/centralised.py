"""The centralised LP of a whole fleet step, the reference for the coordination.

The buildings' open-loop LPs (as :class:`~hvacflex.opt.RMPCSolver` builds them: robust
margins in the comfort rows) are stacked block-diagonally and coupled by the feeder rows
``Σ_b P_b,k ≤ F_k``; the whole LP is solved once, cold, by
:func:`hvacflex.opt.solve.solve_lp`. Practical for small fleets (≤ 10 buildings).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import sparse

from hvacflex.control.base import FloatArray
from hvacflex.opt import RMPCProblem, SolveStatus
from hvacflex.opt import robust as robust_mod
from hvacflex.opt.lp import build_lp, sparse_matrix
from hvacflex.opt.solve import solve_lp


@dataclass(frozen=True)
class CentralisedResult:
    """status, objective [SGD] (reserve tie-break included), (B, N) plan powers [kW]."""

    status: SolveStatus
    objective_sgd: float
    power_kw: FloatArray


def centralised_lp(problems: Sequence[RMPCProblem], limit_kw: FloatArray) -> tuple[Any, ...]:
    """The stacked LP: cost, A (CSR), row bounds, column bounds, each building's power
    columns (N,) in the stacked numbering, and each building's (first column, layout) for
    reading any other of its columns from a solution."""
    costs, blocks, row_lo, row_hi, col_lo, col_hi, power_cols = [], [], [], [], [], [], []
    layouts: list[tuple[int, Any]] = []
    offset = 0
    for problem in problems:
        responses = robust_mod.impulse_responses(
            problem.a_matrix, problem.e_matrix, problem.c_matrix, problem.horizon
        )
        if problem.robust == "none":
            margin = np.zeros((problem.horizon, problem.ny))
        else:
            margin = robust_mod.robust_margins(
                robust_mod.margin_operator(responses), problem.d_sigma
            )
        lp, layout = build_lp(problem, margin, responses=responses)
        assert lp.constant is not None
        blocks.append(sparse_matrix(lp, lp.constant, keep_varying_zeros=False, csc=False))
        costs.append(lp.cost)
        row_lo.append(lp.row_lower)
        row_hi.append(lp.row_upper)
        col_lo.append(lp.col_lower)
        col_hi.append(lp.col_upper)
        power_cols.append(np.asarray(layout.plan.power, dtype=np.int64) + offset)
        layouts.append((offset, layout))
        offset += lp.num_cols
    horizon = problems[0].horizon
    coupling = sparse.lil_matrix((horizon, offset))
    for cols in power_cols:
        for k in range(horizon):
            coupling[k, int(cols[k])] = 1.0
    finite = np.isfinite(limit_kw)
    matrix = sparse.vstack([sparse.block_diag(blocks), coupling.tocsr()[finite]]).tocsr()
    lower = np.concatenate([*row_lo, np.full(int(finite.sum()), -np.inf)])
    upper = np.concatenate([*row_hi, limit_kw[finite]])
    return (
        np.concatenate(costs),
        matrix,
        lower,
        upper,
        np.concatenate(col_lo),
        np.concatenate(col_hi),
        power_cols,
        layouts,
    )


def solve_centralised(problems: Sequence[RMPCProblem], limit_kw: FloatArray) -> CentralisedResult:
    """Solve the fleet step's centralised LP (see the module docstring)."""
    cost, matrix, lower, upper, col_lo, col_hi, power_cols, _ = centralised_lp(problems, limit_kw)
    result = solve_lp(cost, matrix, lower, upper, col_lo, col_hi)
    if not result.status.ok:
        nan = np.full((len(problems), problems[0].horizon), np.nan)
        return CentralisedResult(result.status, float("nan"), nan)
    power = np.array([result.x[cols] for cols in power_cols])
    return CentralisedResult(result.status, float(cost @ result.x), power)
