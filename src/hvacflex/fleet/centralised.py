"""The centralised LP of a whole fleet step, the reference for the coordination.

The buildings' open-loop LPs (as :class:`~hvacflex.opt.RMPCSolver` builds them: robust
margins in the comfort rows) are stacked block-diagonally and coupled by the feeder rows
``Σ_b P_b,k ≤ F_k``. :func:`solve_centralised` solves one such LP cold
(:func:`hvacflex.opt.solve.solve_lp`); :class:`CentralisedSolver` solves one per step of a
run on one HiGHS session, each step from the previous step's optimal basis rotated by one
step (every building's block as its own solver rotates it, :func:`hvacflex.opt.basis.rotation`;
the feeder rows shifted alike). Practical for small fleets (≤ 20 buildings).

:func:`objective_split` splits a building's plan cost into energy + peak, reserve and
comfort penalty [SGD], by the formulas of :class:`~hvacflex.opt.RMPCSolution` (the reserve
tie-break excluded), for a centralised solution and a building's own alike.
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
from hvacflex.opt.basis import bounded_start, nonbasic_status, rotation
from hvacflex.opt.highs_lp import HighsSession, SessionOptions, pass_csc_model
from hvacflex.opt.lp import LinearProgram, LPLayout, build_lp, sparse_matrix
from hvacflex.opt.solution import comfort_penalty_sgd
from hvacflex.opt.solve import LPResult, solve_lp
from hvacflex.units import KWH_PER_MWH


@dataclass(frozen=True)
class CentralisedResult:
    """status, objective [SGD] (reserve tie-break included), (B, N) plan powers [kW], and
    (B, 3) each building's :func:`objective_split` [SGD] (NaN unless solved); the simplex
    iterations and whether the solve started from a basis (:class:`CentralisedSolver`)."""

    status: SolveStatus
    objective_sgd: float
    power_kw: FloatArray
    split_sgd: FloatArray | None = None
    iterations: int = 0
    warm_start: bool = False


def objective_split(
    problem: RMPCProblem, u: FloatArray, r: FloatArray, slack: FloatArray, peak_sgd: float
) -> FloatArray:
    """(3,) a plan's cost [SGD]: energy + peak, reserve (−revenue, ≤ 0) and comfort penalty.

    Parameters
    ----------
    problem : the building's step problem (N periods, m inputs, ny outputs).
    u, r : (N, m) flows and reserve flows [kg/s] (r = 0 on inputs without reserve).
    slack : (N, ny) comfort slack ε [K].
    peak_sgd : the peak charge β [SGD].
    """
    dt = problem.dt_h
    power = problem.power_offset_kw + np.einsum("km,km->k", problem.power_coeff_kw_per_kg_s, u)
    reserve = np.einsum("km,km->k", problem.reserve_kw_per_kg_s, r)
    energy = float(dt * problem.energy_price_sgd_per_mwh @ power / KWH_PER_MWH)
    revenue = float(dt * problem.reserve_price_sgd_per_mwh @ reserve / KWH_PER_MWH)
    comfort = comfort_penalty_sgd(problem, slack)
    return np.array([energy + peak_sgd, -revenue, comfort])


def _split_of(problem: RMPCProblem, layout: LPLayout, x: FloatArray) -> FloatArray:
    """:func:`objective_split` of one building's block ``x`` of a centralised solution."""
    plan = layout.plan
    r = np.zeros_like(problem.u_min)
    r[:, np.asarray(plan.reserve_inputs, dtype=np.int64)] = x[np.asarray(plan.r, dtype=np.int64)]
    u = x[np.asarray(plan.u, dtype=np.int64)]
    return objective_split(problem, u, r, x[np.asarray(plan.eps, dtype=np.int64)], x[plan.beta])


def centralised_lp(problems: Sequence[RMPCProblem], limit_kw: FloatArray) -> tuple[Any, ...]:
    """The stacked LP: cost, A (CSR), row bounds, column bounds, each building's power
    columns (N,) in the stacked numbering, and each building's (first column, layout) for
    reading any other of its columns from a solution."""
    return stacked_lp(problems, limit_kw).as_tuple()


@dataclass(frozen=True, eq=False)
class StackedLP:
    """The centralised LP's parts (:func:`centralised_lp` returns them as a tuple): cost,
    A (CSR: every building's rows, then one feeder row per period, free where the limit is
    inf), row and column bounds, each building's power columns (N,), each building's (first
    column, layout), each building's LP and first row, and the feeder rows' periods."""

    cost: FloatArray
    matrix: Any
    row_lower: FloatArray
    row_upper: FloatArray
    col_lower: FloatArray
    col_upper: FloatArray
    power_cols: list[Any]
    layouts: list[tuple[int, LPLayout]]
    lps: list[tuple[int, LinearProgram]]
    feeder_periods: Any

    def as_tuple(self) -> tuple[Any, ...]:
        return (
            self.cost,
            self.matrix,
            self.row_lower,
            self.row_upper,
            self.col_lower,
            self.col_upper,
            self.power_cols,
            self.layouts,
        )

    def solve(self) -> LPResult:
        """This LP solved cold (:func:`hvacflex.opt.solve.solve_lp`)."""
        return solve_lp(
            self.cost, self.matrix, self.row_lower, self.row_upper, self.col_lower, self.col_upper
        )

    def rotation(self) -> tuple[Any, Any]:
        """Column and row maps (``new = old[map]``) rotating a basis of this LP by a step."""
        col_map, row_map = [], []
        for (first_col, _), (first_row, lp) in zip(self.layouts, self.lps, strict=True):
            cols, rows = rotation(lp)
            col_map.append(cols + first_col)
            row_map.append(rows + first_row)
        first = sum(lp.num_rows for _, lp in self.lps)
        # the feeder row of period k takes that of period k + 1, the last that of the first
        # (a permutation, as every time block's: the count of basic variables is kept)
        row_map.append(np.roll(np.arange(len(self.feeder_periods)), -1) + first)
        return np.concatenate(col_map), np.concatenate(row_map)


def stacked_lp(problems: Sequence[RMPCProblem], limit_kw: FloatArray) -> StackedLP:
    """The centralised LP's parts (see :class:`StackedLP`)."""
    costs, blocks, row_lo, row_hi, col_lo, col_hi, power_cols = [], [], [], [], [], [], []
    layouts: list[tuple[int, Any]] = []
    lps: list[tuple[int, LinearProgram]] = []
    rows = 0
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
        lps.append((rows, lp))
        offset += lp.num_cols
        rows += lp.num_rows
    horizon = problems[0].horizon
    coupling = sparse.lil_matrix((horizon, offset))
    for cols in power_cols:
        for k in range(horizon):
            coupling[k, int(cols[k])] = 1.0
    # one feeder row per period, free where there is no limit: the same rows every step
    matrix = sparse.vstack([sparse.block_diag(blocks), coupling.tocsr()]).tocsr()
    lower = np.concatenate([*row_lo, np.full(horizon, -np.inf)])
    upper = np.concatenate([*row_hi, np.asarray(limit_kw, dtype=float)])
    return StackedLP(
        np.concatenate(costs),
        matrix,
        lower,
        upper,
        np.concatenate(col_lo),
        np.concatenate(col_hi),
        power_cols,
        layouts,
        lps,
        np.arange(horizon),
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


class CentralisedSolver:
    """The centralised LP of every step of a run on one HiGHS session (see the module
    docstring): a step's solve starts from the previous step's optimal basis rotated by one
    step and made consistent with the new bounds; cold when there is none or the LP's size
    changed (a warm start that fails falls back to a cold run)."""

    def __init__(self) -> None:
        self.session = HighsSession("CentralisedSolver", "centralised", SessionOptions())
        self._basis: tuple[Any, Any] | None = None
        self._size: tuple[int, int] | None = None

    def solve(self, problems: Sequence[RMPCProblem], limit_kw: FloatArray) -> CentralisedResult:
        """Solve the step's centralised LP under the feeder limit (N,) [kW]."""
        stacked = stacked_lp(problems, limit_kw)
        csc = stacked.matrix.tocsc()
        matrix = (csc.indptr.astype(np.int32), csc.indices.astype(np.int32), csc.data)
        session = self.session
        if not pass_csc_model(
            session.highs,
            stacked.cost,
            stacked.col_lower,
            stacked.col_upper,
            stacked.row_lower,
            stacked.row_upper,
            matrix,
        ):
            return self._failed(problems, SolveStatus.ERROR)
        size = (stacked.cost.size, stacked.row_lower.size)
        warm = False
        if self._basis is not None and self._size == size:
            col_map, row_map = stacked.rotation()
            col_status, row_status = bounded_start(
                self._basis[0][col_map],
                self._basis[1][row_map],
                stacked.col_lower,
                stacked.col_upper,
                nonbasic_status(stacked.col_lower, stacked.col_upper),
                nonbasic_status(stacked.row_lower, stacked.row_upper),
            )
            warm = session.set_start(col_status, row_status)
        else:
            session.highs.clearSolver()
        outcome = session.run_with_retries(warm, lambda: False)
        if not outcome.status.ok:
            self._basis = None
            return self._failed(problems, outcome.status)
        held = session.highs.getBasis()
        self._basis = (
            np.array([int(v) for v in held.col_status], dtype=np.int8),
            np.array([int(v) for v in held.row_status], dtype=np.int8),
        )
        self._size = size
        x = session.values()
        power = np.array([x[cols] for cols in stacked.power_cols])
        split = np.array(
            [
                _split_of(problem, layout, x[first : first + layout.num_cols])
                for problem, (first, layout) in zip(problems, stacked.layouts, strict=True)
            ]
        )
        return CentralisedResult(
            outcome.status,
            float(stacked.cost @ x),
            power,
            split,
            outcome.iterations,
            outcome.warm,
        )

    @staticmethod
    def _failed(problems: Sequence[RMPCProblem], status: SolveStatus) -> CentralisedResult:
        nan = np.full((len(problems), problems[0].horizon), np.nan)
        return CentralisedResult(status, float("nan"), nan, np.full((len(problems), 3), np.nan))
