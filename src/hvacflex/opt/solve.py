"""Solve :class:`~hvacflex.opt.problem.RMPCProblem` with HiGHS; the only importer of highspy.

:class:`RMPCSolver` builds the sparse LP of :mod:`hvacflex.opt.problem` once per structure
(A, B, E, C, N, reserve mask, robust mode). Each :meth:`RMPCSolver.solve` pushes only what
changed since the previous solve — costs, column bounds, row bounds (x0, d̂, g, δ, bounds,
p0) and the step-varying coefficients (``p_k`` on the power rows, ``φ_k`` on the peak rows,
σ in the dual form, via ``changeCoeff``) — and re-solves with the dual simplex (warm start).
HiGHS runs single-threaded with its output silenced, so results are reproducible.
:func:`solve_rmpc` is the one-shot wrapper.

Warm start (see ``docs/performance.md``). Successive problems of a receding horizon are
shifted by one step, so the previous optimal basis is a poor start *position by position*,
but a good one once rotated: by default (``time_shift=True``) the statuses of step k + 1 of
every time-indexed block (x, z, u, r, ε, P and their rows) start step k, and those of step 0
start step N − 1 (a rotation keeps the number of basic variables, so HiGHS takes the basis
as is). The basis is read after each optimal solve from HiGHS's basic-variable list and the
primal values (every row of the LP is an equality or one-sided, so a nonbasic row's status
follows from its bounds), which costs ~0.1 ms where ``getBasis`` costs ~3 ms. HiGHS uses
Devex dual pricing: every step re-initialises the simplex (new basis; the power-row
coefficients p_k change), and dual steepest-edge weights would then be recomputed from
scratch, one BTRAN per row, which cost more than all the iterations. Warm solves run without
scaling (re-scaling cost more than it saved); cold solves keep HiGHS's default scaling and
presolve.

Failures are never silent: :class:`SolveStatus` says what happened, ``RMPCSolution.message``
says it in words, and every plan array (u, r, P, R, ε, trajectories, costs) is NaN unless the
status is :attr:`SolveStatus.OPTIMAL`. If a warm-started solve ends in a solver error, the
solve is retried once from scratch (cold) before the error is reported.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass
from typing import Any, NamedTuple, cast

import highspy
import numpy as np
from numpy.typing import NDArray

from hvacflex.errors import ProblemError
from hvacflex.opt import events as events_mod
from hvacflex.opt import robust as robust_mod
from hvacflex.opt.problem import (
    KW_PER_MW,
    RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR,
    FloatArray,
    IntArray,
    LPLayout,
    RMPCProblem,
    assemble_matrix,
    build_layout,
    dual_equality_rhs,
    lp_vectors,
)

__all__ = [
    "LPResult",
    "RMPCSolution",
    "RMPCSolver",
    "SolveStatus",
    "SolverBasis",
    "failed_solution",
    "plan_solution",
    "solve_lp",
    "solve_rmpc",
]


class SolveStatus(enum.Enum):
    """Outcome of one solve."""

    OPTIMAL = "optimal"
    INFEASIBLE = "infeasible"
    UNBOUNDED = "unbounded"
    TIME_LIMIT = "time_limit"
    ERROR = "error"  # numerical trouble, iteration limit or any other solver failure

    @property
    def ok(self) -> bool:
        """True only for :attr:`OPTIMAL`."""
        return self is SolveStatus.OPTIMAL


_STATUS_MAP = {
    highspy.HighsModelStatus.kOptimal: SolveStatus.OPTIMAL,
    highspy.HighsModelStatus.kInfeasible: SolveStatus.INFEASIBLE,
    # The LP is bounded by construction (bounded u, r; ε, β with non-negative costs), so
    # "unbounded or infeasible" can only mean infeasible.
    highspy.HighsModelStatus.kUnboundedOrInfeasible: SolveStatus.INFEASIBLE,
    highspy.HighsModelStatus.kUnbounded: SolveStatus.UNBOUNDED,
    highspy.HighsModelStatus.kTimeLimit: SolveStatus.TIME_LIMIT,
}


@dataclass(frozen=True, eq=False)
class RMPCSolution:
    """The plan and its cost split. Arrays are NaN unless ``status`` is OPTIMAL.

    Attributes
    ----------
    status, message : outcome and a human-readable explanation
    objective_sgd : energy_cost − reserve_revenue + comfort_penalty + peak_charge [SGD]
        (the reserve tie-break ``tie_break_sgd`` is excluded)
    u, r : (N, m) planned flows and reserve flows [kg/s] (r = 0 on masked inputs)
    power_kw : (N,) P_k = p0_k + p_k·u_k [kW];  reserve_kw : (N,) R_k = p_k·r_k [kW]
    peak_kw : max_k P_k [kW];  peak_charge_sgd : β [SGD]
    slack : (N, ny) ε_k for outputs at steps 1..N [K];  delta : (N, ny) robust margins δ_k [K]
        (zero for robust="none"; for robust="dual" the equivalent tightening, for reference)
    x_served, x_curtailed : (N+1, n) nominal (w = 0) trajectories from x0 [°C]; in the IL
        event model (``il_event_max_steps`` = D) ``x_curtailed`` is the trajectory under the
        event (s = 0, L = D), otherwise under curtailment for the whole horizon
    energy_cost_sgd, reserve_revenue_sgd, comfort_penalty_sgd : objective terms [SGD]
    tie_break_sgd : the reserve tie-break cost included in the LP but not in objective_sgd
    solve_time_s : wall time of the whole solve call (updates + HiGHS + extraction) [s]
    highs_time_s : wall time of HiGHS ``run()`` alone [s]
    simplex_iterations : simplex iterations of this solve
    warm_start : whether HiGHS started from a previous basis
    feedback_gains : (N, N, m, nd) for ``robust="feedback"``: ``[k, j]`` is the gain of input
        k on the disturbance error w_j (zero for j ≥ k; see :mod:`hvacflex.opt.feedback`);
        None otherwise
    y_event_worst : (N, ny) worst upper-side output over the event set × the box [°C]:
        ``max(C x_t, max over events of the event output) + δ_t`` (events (s, L ≤ D), or the
        whole-horizon curtailment when D is None; see
        :func:`hvacflex.opt.events.worst_event_output`)
    """

    status: SolveStatus
    message: str
    objective_sgd: float
    u: FloatArray
    r: FloatArray
    power_kw: FloatArray
    reserve_kw: FloatArray
    peak_kw: float
    peak_charge_sgd: float
    slack: FloatArray
    delta: FloatArray
    x_served: FloatArray
    x_curtailed: FloatArray
    energy_cost_sgd: float
    reserve_revenue_sgd: float
    comfort_penalty_sgd: float
    tie_break_sgd: float
    solve_time_s: float
    highs_time_s: float
    simplex_iterations: int
    warm_start: bool
    y_event_worst: FloatArray
    feedback_gains: FloatArray | None = None

    @property
    def ok(self) -> bool:
        """True when the plan is optimal (and its arrays are finite)."""
        return self.status.ok


@dataclass(frozen=True, eq=False)
class SolverBasis:
    """A picklable simplex basis of an :class:`RMPCSolver` (to resume a checkpoint warm).

    ``col_status`` and ``row_status`` hold HiGHS basis status codes (0 lower, 1 basic,
    2 upper, 3 zero, 4 nonbasic); ``fingerprint`` identifies the problem structure.
    """

    fingerprint: str
    col_status: NDArray[np.int8]
    row_status: NDArray[np.int8]


def _nan(shape: tuple[int, ...]) -> FloatArray:
    return np.full(shape, np.nan)


def failed_solution(
    problem: RMPCProblem,
    *,
    status: SolveStatus,
    message: str,
    delta: FloatArray,
    start: float,
    highs_time_s: float,
    simplex_iterations: int,
    warm_start: bool,
) -> RMPCSolution:
    """An :class:`RMPCSolution` without a plan: every plan array and cost is NaN.

    ``start`` is the ``time.perf_counter()`` reading when the solve call began.
    """
    horizon, m, n, ny = problem.horizon, problem.m, problem.n, problem.ny
    return RMPCSolution(
        status=status,
        message=message,
        objective_sgd=np.nan,
        u=_nan((horizon, m)),
        r=_nan((horizon, m)),
        power_kw=_nan((horizon,)),
        reserve_kw=_nan((horizon,)),
        peak_kw=np.nan,
        peak_charge_sgd=np.nan,
        slack=_nan((horizon, ny)),
        delta=delta,
        x_served=_nan((horizon + 1, n)),
        x_curtailed=_nan((horizon + 1, n)),
        energy_cost_sgd=np.nan,
        reserve_revenue_sgd=np.nan,
        comfort_penalty_sgd=np.nan,
        tie_break_sgd=np.nan,
        solve_time_s=time.perf_counter() - start,
        highs_time_s=highs_time_s,
        simplex_iterations=simplex_iterations,
        warm_start=warm_start,
        y_event_worst=_nan((horizon, ny)),
    )


def plan_solution(
    problem: RMPCProblem,
    *,
    status: SolveStatus,
    message: str,
    u: FloatArray,
    r: FloatArray,
    slack: FloatArray,
    peak_charge_sgd: float,
    x_served: FloatArray,
    x_curtailed: FloatArray,
    delta: FloatArray,
    start: float,
    highs_time_s: float,
    simplex_iterations: int,
    warm_start: bool,
    feedback_gains: FloatArray | None = None,
) -> RMPCSolution:
    """An :class:`RMPCSolution` from a plan: power, reserve and the cost split follow from
    ``u`` (N, m), ``r`` (N, m) [kg/s], ``slack`` (N, ny) [K] and β [SGD] as in the LP.

    ``start`` is the ``time.perf_counter()`` reading when the solve call began.
    """
    dt = problem.dt_h
    p = problem.power_coeff_kw_per_kg_s
    power = problem.power_offset_kw + np.einsum("km,km->k", p, u)
    reserve = np.einsum("km,km->k", p, r)
    energy = float(dt * problem.energy_price_sgd_per_mwh @ power / KW_PER_MW)
    revenue = float(dt * problem.reserve_price_sgd_per_mwh @ reserve / KW_PER_MW)
    comfort = float(problem.comfort_penalty_sgd_per_kelvin_hour * dt * slack.sum())
    return RMPCSolution(
        status=status,
        message=message,
        objective_sgd=energy - revenue + comfort + peak_charge_sgd,
        u=u,
        r=r,
        power_kw=power,
        reserve_kw=reserve,
        peak_kw=float(power.max()),
        peak_charge_sgd=peak_charge_sgd,
        slack=slack,
        delta=delta,
        x_served=x_served,
        x_curtailed=x_curtailed,
        energy_cost_sgd=energy,
        reserve_revenue_sgd=revenue,
        comfort_penalty_sgd=comfort,
        tie_break_sgd=float(RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR * dt * r.sum()),
        solve_time_s=time.perf_counter() - start,
        highs_time_s=highs_time_s,
        simplex_iterations=simplex_iterations,
        warm_start=warm_start,
        feedback_gains=feedback_gains,
        y_event_worst=events_mod.worst_event_output(problem, x_served, r, delta),
    )


#: HiGHS basis status codes (``HighsBasisStatus``) as stored in :class:`SolverBasis`.
_LOWER, _BASIC, _UPPER, _ZERO = 0, 1, 2, 3
_HIGHS_BASIS_STATUS = np.array([highspy.HighsBasisStatus(code) for code in range(5)], dtype=object)
#: Options of every solve: quiet, single-threaded (reproducible), Devex dual pricing (1).
_BASE_OPTIONS: dict[str, Any] = {
    "output_flag": False,
    "log_to_console": False,
    "threads": 1,
    "simplex_dual_edge_weight_strategy": 1,
}
#: ``simplex_scale_strategy`` of a warm solve (0: no scaling); cold solves use HiGHS's default.
_WARM_SCALE_STRATEGY = 0


def _rotation(layout: LPLayout) -> tuple[IntArray, IntArray]:
    """Index maps that rotate a basis by one time step: ``new = old[map]``.

    Step k of every time-indexed column and row block takes the status of step k + 1, step
    N − 1 that of step 0; β and the dual form's λ columns and rows keep theirs.
    """
    col_map = np.arange(layout.num_cols)
    row_map = np.arange(layout.num_rows)
    col_blocks = (
        layout.col_x,
        layout.col_z,
        layout.col_u,
        layout.col_r,
        layout.col_eps,
        layout.col_power,
    )
    row_blocks = (
        layout.row_dyn_x,
        layout.row_dyn_z,
        layout.row_hi_x,
        layout.row_lo_x,
        layout.row_hi_z,
        layout.row_lo_z,
        layout.row_flow,
        layout.row_power,
        layout.row_peak,
    )
    for index_map, blocks in ((col_map, col_blocks), (row_map, row_blocks)):
        for block in blocks:
            if block.size:
                index_map[block.ravel()] = np.roll(block, -1, axis=0).ravel()
    if layout.row_event.size:
        row_map[layout.row_event] = layout.row_event[events_mod.event_rotation(layout.events)]
    return col_map, row_map


def _nonbasic_status(lower: FloatArray, upper: FloatArray) -> NDArray[np.int8]:
    """Status of a nonbasic variable from its bounds alone: at the lower bound if finite,
    else at the upper bound if finite, else zero (free)."""
    status = np.where(np.isfinite(upper), _UPPER, _ZERO)
    status[np.isfinite(lower)] = _LOWER
    return status.astype(np.int8)


def check_time_limit(time_limit_s: float | None, *, source: str) -> None:
    """Refuse a per-solve time limit that is not a positive number of seconds (None = none)."""
    if time_limit_s is not None and not time_limit_s > 0:
        raise ProblemError(
            "time limit must be > 0 s or None",
            source=source,
            field="time_limit_s",
            value=time_limit_s,
        )


class RMPCSolver:
    """Warm-started HiGHS solver for a sequence of problems of one structure.

    Parameters
    ----------
    problem : the first problem; fixes the structure (A, B, E, C, N, reserve mask, robust)
    time_limit_s : wall-clock limit per solve [s] (each :meth:`solve`, not cumulative);
        None = no limit
    time_shift : each problem is the previous one a step later (receding horizon): start
        from the previous optimal basis rotated by one step (see the module docstring).
        False: start from the previous basis as is (e.g. re-solving one step's problem with
        other prices).

    Examples
    --------
    >>> solver = RMPCSolver(problem)                     # doctest: +SKIP
    >>> for step in range(steps):                        # doctest: +SKIP
    ...     sol = solver.solve(problem_at(step))
    """

    def __init__(
        self, problem: RMPCProblem, *, time_limit_s: float | None = None, time_shift: bool = True
    ) -> None:
        check_time_limit(time_limit_s, source="RMPCSolver")
        if problem.robust == "feedback":
            raise ProblemError(
                "RMPCSolver solves the open-loop problem only",
                source="RMPCSolver",
                field="robust",
                value=problem.robust,
                hint="use hvacflex.opt.feedback.FeedbackSolver (or solve_rmpc) for feedback",
            )
        self._structure = problem.structure
        self._fingerprint = self._structure.fingerprint()
        self._layout: LPLayout = build_layout(self._structure)
        responses = robust_mod.impulse_responses(
            problem.a_matrix, problem.e_matrix, problem.c_matrix, problem.horizon
        )
        self._margin_operator = robust_mod.margin_operator(responses)
        # highspy's Python wrapper is only partly typed; treat the handle as Any.
        self._highs: Any = cast(Any, highspy.Highs)()
        for option, value in _BASE_OPTIONS.items():
            self._highs.setOptionValue(option, value)
        _, self._cold_scale_strategy = self._highs.getOptionValue("simplex_scale_strategy")
        self._scale_strategy = self._cold_scale_strategy
        self._time_limit_s = float(time_limit_s) if time_limit_s is not None else None
        self._time_shift = time_shift
        self._build(problem)
        self._col_rotation, self._row_rotation = _rotation(self._layout)
        self._last_problem: RMPCProblem | None = problem
        self._has_basis = False
        # statuses of the last optimal basis (or of set_basis), to start the next solve from
        self._basis: tuple[NDArray[np.int8], NDArray[np.int8]] | None = None
        self._basis_given = False

    # ------------------------------------------------------------------ properties
    @property
    def layout(self) -> LPLayout:
        """Column/row indices of the LP."""
        return self._layout

    @property
    def num_cols(self) -> int:
        """Number of LP variables."""
        return self._layout.num_cols

    @property
    def num_rows(self) -> int:
        """Number of LP constraints."""
        return self._layout.num_rows

    @property
    def num_nonzeros(self) -> int:
        """Nonzeros of the constraint matrix as HiGHS holds it."""
        return int(self._highs.getNumNz())

    # ------------------------------------------------------------------ model
    def _build(self, problem: RMPCProblem) -> None:
        layout = self._layout
        delta = self._delta(problem)
        vectors = lp_vectors(problem, layout, self._tightening(problem, delta))
        matrix = assemble_matrix(
            self._structure,
            layout,
            problem.power_coeff_kw_per_kg_s,
            problem.phi,
            problem.d_sigma,
        )
        extra_cols = layout.num_cols - layout.num_core_cols
        extra_rhs = dual_equality_rhs(self._structure, layout)
        lp = highspy.HighsLp()
        lp.num_col_ = layout.num_cols
        lp.num_row_ = layout.num_rows
        lp.col_cost_ = np.concatenate([vectors.cost, np.zeros(extra_cols)])
        lp.col_lower_ = np.concatenate([vectors.col_lower, np.zeros(extra_cols)])
        lp.col_upper_ = np.concatenate([vectors.col_upper, np.full(extra_cols, np.inf)])
        lp.row_lower_ = np.concatenate([vectors.row_lower, extra_rhs])
        lp.row_upper_ = np.concatenate([vectors.row_upper, extra_rhs])
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.num_col_ = layout.num_cols
        lp.a_matrix_.num_row_ = layout.num_rows
        lp.a_matrix_.start_ = matrix.indptr.astype(np.int32)
        lp.a_matrix_.index_ = matrix.indices.astype(np.int32)
        lp.a_matrix_.value_ = matrix.data.astype(np.float64)
        status = self._highs.passModel(lp)
        if status == highspy.HighsStatus.kError:
            raise ProblemError(
                "HiGHS refused the assembled LP",
                source="RMPCSolver",
                hint="check the problem arrays for extreme magnitudes",
            )
        self._vectors = vectors
        self._bounds_changed()
        self._power_coeff = problem.power_coeff_kw_per_kg_s.copy()
        self._phi = problem.phi.copy()
        self._sigma = problem.d_sigma.copy()
        self._core_col_index = np.arange(layout.num_core_cols, dtype=np.int32)
        self._core_row_index = np.arange(layout.num_core_rows, dtype=np.int32)

    def _bounds_changed(self) -> None:
        """Refresh the bound data that basis statuses are derived from (after any update)."""
        layout, vectors = self._layout, self._vectors
        extra_cols = layout.num_cols - layout.num_core_cols
        extra_rows = layout.num_rows - layout.num_core_rows
        self._col_lower = np.concatenate([vectors.col_lower, np.zeros(extra_cols)])
        self._col_upper = np.concatenate([vectors.col_upper, np.full(extra_cols, np.inf)])
        self._col_nonbasic = _nonbasic_status(self._col_lower, self._col_upper)
        row_lower = np.concatenate([vectors.row_lower, np.zeros(extra_rows)])
        row_upper = np.concatenate([vectors.row_upper, np.zeros(extra_rows)])
        self._row_nonbasic = _nonbasic_status(row_lower, row_upper)

    def _delta(self, problem: RMPCProblem) -> FloatArray:
        if problem.robust == "none":
            return np.zeros((problem.horizon, problem.ny))
        return robust_mod.robust_margins(self._margin_operator, problem.d_sigma)

    @staticmethod
    def _tightening(problem: RMPCProblem, delta: FloatArray) -> FloatArray:
        return np.zeros_like(delta) if problem.robust == "dual" else delta

    def _update(self, problem: RMPCProblem, delta: FloatArray) -> None:
        layout = self._layout
        highs = self._highs
        vectors = lp_vectors(problem, layout, self._tightening(problem, delta))
        old = self._vectors
        changed = np.flatnonzero(vectors.cost != old.cost).astype(np.int32)
        if changed.size:
            highs.changeColsCost(changed.size, changed, vectors.cost[changed])
        for change_bounds, lower, upper, old_lower, old_upper in (
            (highs.changeColsBounds, vectors.col_lower, vectors.col_upper,
             old.col_lower, old.col_upper),
            (highs.changeRowsBounds, vectors.row_lower, vectors.row_upper,
             old.row_lower, old.row_upper),
        ):  # fmt: skip
            changed = np.flatnonzero((lower != old_lower) | (upper != old_upper)).astype(np.int32)
            if changed.size:
                change_bounds(changed.size, changed, lower[changed], upper[changed])
        self._vectors = vectors
        self._bounds_changed()

        p = problem.power_coeff_kw_per_kg_s
        steps, inputs = np.nonzero(p != self._power_coeff)
        if steps.size:
            rows = layout.row_power[steps].tolist()
            cols = layout.col_u[steps, inputs].tolist()
            for row, col, value in zip(rows, cols, (-p[steps, inputs]).tolist(), strict=True):
                highs.changeCoeff(row, col, value)
            self._power_coeff = p.copy()
        phi = problem.phi
        (steps_phi,) = np.nonzero(phi != self._phi)
        for step in steps_phi.tolist():
            highs.changeCoeff(
                int(layout.row_peak[step]), int(layout.col_power[step]), float(phi[step])
            )
        self._phi = phi.copy()
        if layout.robust == "dual" and not np.array_equal(problem.d_sigma, self._sigma):
            sigma = problem.d_sigma.ravel()[layout.dual_sigma_index] * layout.dual_sign
            for row, col_1, col_2, value in zip(
                layout.dual_rows.tolist(),
                layout.dual_cols_1.tolist(),
                layout.dual_cols_2.tolist(),
                sigma.tolist(),
                strict=True,
            ):
                highs.changeCoeff(row, col_1, value)
                highs.changeCoeff(row, col_2, value)
            self._sigma = problem.d_sigma.copy()

    # ------------------------------------------------------------------ solve
    def solve(self, problem: RMPCProblem) -> RMPCSolution:
        """Solve ``problem`` (same structure as the solver's), warm-started when possible.

        Raises
        ------
        ProblemError
            if ``problem`` has a different structure (A, B, E, C, N, reserve mask, robust
            mode); build a new :class:`RMPCSolver` for it.
        """
        start = time.perf_counter()
        if problem.structure is not self._structure:
            differences = self._structure.differences(problem.structure)
            if differences:
                raise ProblemError(
                    f"the problem's structure differs from the solver's in {differences}",
                    source="RMPCSolver",
                    field=differences[0],
                    hint="build a new RMPCSolver for a problem with another structure",
                )
        delta = self._delta(problem)
        if problem is not self._last_problem:
            self._update(problem, delta)
            self._last_problem = problem
        if self._basis is not None and (self._time_shift or self._basis_given):
            self._start_from(*self._basis)
        warm = self._has_basis
        highs_time, status = self._run(warm)
        iterations = int(self._highs.getInfo().simplex_iteration_count)
        if status is SolveStatus.ERROR and warm:
            self._highs.clearSolver()
            retry_time, status = self._run(False)
            highs_time += retry_time
            iterations += int(self._highs.getInfo().simplex_iteration_count)
            warm = False
        values = np.asarray(self._highs.getSolution().col_value) if status.ok else None
        self._basis_given = False
        if values is not None:
            self._basis = self._optimal_basis(values)
            self._has_basis = True
        else:
            self._basis = None
            self._has_basis = bool(self._highs.getBasis().valid)
        return self._solution(problem, delta, status, start, highs_time, iterations, warm, values)

    def _start_from(self, col_status: NDArray[np.int8], row_status: NDArray[np.int8]) -> None:
        """Pass a basis (rotated by one step if ``time_shift``) to HiGHS for the next run.

        Nonbasic statuses that the current bounds do not allow (a bound that became
        infinite) are replaced by the one the bounds imply.
        """
        if self._time_shift:
            col_status = col_status[self._col_rotation]
            row_status = row_status[self._row_rotation]
        col_status = self._consistent(col_status, self._col_lower, self._col_upper)
        row_status = np.where(row_status == _BASIC, _BASIC, self._row_nonbasic)
        basis = highspy.HighsBasis()
        basis.col_status = _HIGHS_BASIS_STATUS.take(col_status).tolist()
        basis.row_status = _HIGHS_BASIS_STATUS.take(row_status).tolist()
        basis.valid = True
        basis.alien = False  # a rotation of a basis keeps the count of basic variables
        if self._highs.setBasis(basis) == highspy.HighsStatus.kError:
            self._highs.clearSolver()  # start cold rather than fail
            self._has_basis = False
        else:
            self._has_basis = True

    def _consistent(
        self, status: NDArray[np.int8], lower: FloatArray, upper: FloatArray
    ) -> NDArray[np.int8]:
        bad = ((status == _LOWER) & ~np.isfinite(lower)) | (
            (status == _UPPER) & ~np.isfinite(upper)
        )
        bad |= (status == _ZERO) & (np.isfinite(lower) | np.isfinite(upper))
        bad |= status > _ZERO
        if bad.any():
            status = np.where(bad, self._col_nonbasic, status).astype(np.int8)
        return status

    def _optimal_basis(self, values: FloatArray) -> tuple[NDArray[np.int8], NDArray[np.int8]]:
        """Statuses of HiGHS's current (optimal) basis from its basic variables and ``values``.

        A nonbasic column sits at the bound nearer to its value; a nonbasic row at its only
        finite bound (every row is an equality or one-sided).
        """
        lower, upper = self._col_lower, self._col_upper
        with np.errstate(invalid="ignore"):
            at_upper = np.isfinite(upper) & (
                ~np.isfinite(lower) | (values - lower > upper - values)
            )
        col_status = np.where(at_upper, _UPPER, self._col_nonbasic).astype(np.int8)
        row_status = self._row_nonbasic.copy()
        _, basic = self._highs.getBasicVariables()
        basic = np.asarray(basic)
        col_status[basic[basic >= 0]] = _BASIC
        row_status[-1 - basic[basic < 0]] = _BASIC
        return col_status, row_status

    def _run(self, warm: bool) -> tuple[float, SolveStatus]:
        scale = _WARM_SCALE_STRATEGY if warm else self._cold_scale_strategy
        if scale != self._scale_strategy:
            self._highs.setOptionValue("simplex_scale_strategy", scale)
            self._scale_strategy = scale
        if self._time_limit_s is not None:
            # HiGHS checks ``time_limit`` against the Highs object's run clock, which
            # accumulates over every run() of this object: re-arm it so the limit is per solve.
            self._highs.setOptionValue(
                "time_limit", float(self._highs.getRunTime()) + self._time_limit_s
            )
        tick = time.perf_counter()
        run_status = self._highs.run()
        elapsed = time.perf_counter() - tick
        if run_status == highspy.HighsStatus.kError:
            return elapsed, SolveStatus.ERROR
        return elapsed, _STATUS_MAP.get(self._highs.getModelStatus(), SolveStatus.ERROR)

    def _message(
        self, problem: RMPCProblem, delta: FloatArray, status: SolveStatus, iterations: int
    ) -> str:
        model_status = self._highs.modelStatusToString(self._highs.getModelStatus())
        if status is SolveStatus.OPTIMAL:
            return f"optimal ({iterations} simplex iterations)"
        if status is SolveStatus.INFEASIBLE:
            cap = problem.slack_max_kelvin
            return (
                f"infeasible (HiGHS: {model_status}): no plan keeps both the served and the "
                f"curtailed trajectory within the comfort band (tightened by up to "
                f"{float(delta.max(initial=0.0)):.3g} K for robustness) with "
                f"slack ≤ {cap} K; allow more slack (slack_max_kelvin=None makes comfort "
                f"soft), reduce the uncertainty σ, or widen the band"
            )
        if status is SolveStatus.UNBOUNDED:
            return f"unbounded (HiGHS: {model_status}): check for negative penalties or prices"
        if status is SolveStatus.TIME_LIMIT:
            return (
                f"time limit reached after {iterations} simplex iterations before optimality "
                f"(HiGHS: {model_status}); no plan returned, raise time_limit_s"
            )
        return (
            f"solver failure (HiGHS: {model_status}) after {iterations} simplex iterations; "
            f"no plan returned, fall back to a safe rule"
        )

    def _solution(
        self,
        problem: RMPCProblem,
        delta: FloatArray,
        status: SolveStatus,
        start: float,
        highs_time: float,
        iterations: int,
        warm: bool,
        values: FloatArray | None,
    ) -> RMPCSolution:
        layout = self._layout
        message = self._message(problem, delta, status, iterations)
        if values is None:
            return failed_solution(
                problem,
                status=status,
                message=message,
                delta=delta,
                start=start,
                highs_time_s=highs_time,
                simplex_iterations=iterations,
                warm_start=warm,
            )
        r = np.zeros((layout.horizon, layout.m))
        r[:, layout.reserve_inputs] = np.maximum(values[layout.col_r], 0.0)
        x_served = np.vstack([problem.x0, values[layout.col_x]])
        if layout.has_curtailed:
            x_curtailed = np.vstack([problem.x0, values[layout.col_z]])
        elif layout.has_reserve:  # event model: the event (s = 0, L = D)
            x_curtailed = events_mod.event_trajectory(problem, x_served, r)
        else:
            x_curtailed = x_served
        return plan_solution(
            problem,
            status=status,
            message=message,
            u=values[layout.col_u],
            r=r,
            slack=np.maximum(values[layout.col_eps], 0.0),
            peak_charge_sgd=float(values[layout.col_beta]),
            x_served=x_served,
            x_curtailed=x_curtailed,
            delta=delta,
            start=start,
            highs_time_s=highs_time,
            simplex_iterations=iterations,
            warm_start=warm,
        )

    def highs_objective_sgd(self) -> float:
        """HiGHS's objective value of the last solve (includes the reserve tie-break) [SGD]."""
        return float(self._highs.getInfo().objective_function_value)

    # ------------------------------------------------------------------ basis
    def get_basis(self) -> SolverBasis | None:
        """The basis of the last solve (picklable; as solved, not rotated), or None if none yet."""
        if self._basis is not None:
            return SolverBasis(
                fingerprint=self._fingerprint,
                col_status=self._basis[0].copy(),
                row_status=self._basis[1].copy(),
            )
        basis = self._highs.getBasis()
        if not basis.valid:
            return None
        return SolverBasis(
            fingerprint=self._fingerprint,
            col_status=np.array([int(s) for s in basis.col_status], dtype=np.int8),
            row_status=np.array([int(s) for s in basis.row_status], dtype=np.int8),
        )

    def set_basis(self, basis: SolverBasis) -> None:
        """Start the next solve from ``basis`` (from :meth:`get_basis` of a same-structure solver).

        With ``time_shift`` the basis is taken as the previous step's and rotated by one step,
        exactly as after a solve of this solver: a checkpoint resumes as if never stopped.

        Raises
        ------
        ProblemError
            if the basis belongs to another structure or HiGHS rejects it.
        """
        if (
            basis.fingerprint != self._fingerprint
            or basis.col_status.size != self.num_cols
            or basis.row_status.size != self.num_rows
        ):
            raise ProblemError(
                "the basis was saved from a solver with another problem structure",
                source="RMPCSolver",
                field="basis",
                hint="restore a basis only into a solver built for the same A, B, E, C, N, "
                "reserve mask and robust mode",
            )
        col_status = np.asarray(basis.col_status, dtype=np.int8)
        row_status = np.asarray(basis.row_status, dtype=np.int8)
        num_basic = int(
            np.count_nonzero(col_status == _BASIC) + np.count_nonzero(row_status == _BASIC)
        )
        if (
            num_basic != self.num_rows
            or min(col_status.min(), row_status.min()) < 0
            or max(col_status.max(), row_status.max()) > _ZERO + 1
        ):
            raise ProblemError(
                f"not a simplex basis: {num_basic} basic variables for {self.num_rows} rows, "
                "or status codes outside 0..4",
                source="RMPCSolver",
                field="basis",
                hint="pass a basis from get_basis(), or solve cold",
            )
        self._basis = (col_status.copy(), row_status.copy())
        self._basis_given = True
        self._has_basis = True


def solve_rmpc(problem: RMPCProblem, *, time_limit_s: float | None = None) -> RMPCSolution:
    """Solve one problem from scratch (see :class:`RMPCSolver` for sequences).

    Parameters
    ----------
    problem : the validated problem
    time_limit_s : wall-clock limit [s]; None = no limit

    Returns
    -------
    :class:`RMPCSolution`; check ``sol.status`` (arrays are NaN unless OPTIMAL).
    ``robust="feedback"`` problems go to :class:`hvacflex.opt.feedback.FeedbackSolver`.
    """
    if problem.robust == "feedback":
        from hvacflex.opt.feedback import FeedbackSolver  # imports this module

        return FeedbackSolver(problem, time_limit_s=time_limit_s).solve(problem)
    return RMPCSolver(problem, time_limit_s=time_limit_s).solve(problem)


# ---------------------------------------------------------------------- generic LP


class LPResult(NamedTuple):
    """Outcome of :func:`solve_lp`: status, primal values (NaN unless optimal), message, time."""

    status: SolveStatus
    x: FloatArray
    message: str
    time_s: float


def solve_lp(
    cost: FloatArray,
    a_csr: Any,
    row_lower: FloatArray,
    row_upper: FloatArray,
    col_lower: FloatArray,
    col_upper: FloatArray,
    *,
    time_limit_s: float | None = None,
    method: str = "choose",
) -> LPResult:
    """Solve ``min costᵀx s.t. row_lower ≤ A x ≤ row_upper, col_lower ≤ x ≤ col_upper`` cold.

    A generic one-shot HiGHS call for LPs assembled elsewhere (the affine-feedback problem of
    :mod:`hvacflex.opt.feedback`); single-threaded and silent like :class:`RMPCSolver`.

    Parameters
    ----------
    cost, col_lower, col_upper : (num_cols,) objective and column bounds (±inf allowed)
    a_csr : (num_rows, num_cols) ``scipy.sparse.csr_matrix`` constraint matrix
    row_lower, row_upper : (num_rows,) row bounds (±inf allowed)
    time_limit_s : wall-clock limit [s]; None = no limit
    method : HiGHS ``solver`` option: "choose", "simplex" or "ipm"

    Returns
    -------
    :class:`LPResult`; ``x`` is NaN unless the status is OPTIMAL; ``time_s`` is the wall time
    of HiGHS ``run()``.
    """
    highs: Any = cast(Any, highspy.Highs)()
    for option, value in (
        ("output_flag", False),
        ("log_to_console", False),
        ("threads", 1),
        ("solver", method),
        ("time_limit", float(time_limit_s) if time_limit_s is not None else np.inf),
    ):
        highs.setOptionValue(option, value)
    num_rows, num_cols = a_csr.shape
    lp = highspy.HighsLp()
    lp.num_col_ = num_cols
    lp.num_row_ = num_rows
    lp.col_cost_ = np.asarray(cost, dtype=np.float64)
    lp.col_lower_ = np.asarray(col_lower, dtype=np.float64)
    lp.col_upper_ = np.asarray(col_upper, dtype=np.float64)
    lp.row_lower_ = np.asarray(row_lower, dtype=np.float64)
    lp.row_upper_ = np.asarray(row_upper, dtype=np.float64)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.num_col_ = num_cols
    lp.a_matrix_.num_row_ = num_rows
    lp.a_matrix_.start_ = a_csr.indptr.astype(np.int32)
    lp.a_matrix_.index_ = a_csr.indices.astype(np.int32)
    lp.a_matrix_.value_ = a_csr.data.astype(np.float64)
    if highs.passModel(lp) == highspy.HighsStatus.kError:
        return LPResult(SolveStatus.ERROR, _nan((num_cols,)), "HiGHS refused the LP", 0.0)
    tick = time.perf_counter()
    run_status = highs.run()
    elapsed = time.perf_counter() - tick
    model_status = highs.getModelStatus()
    if run_status == highspy.HighsStatus.kError:
        status = SolveStatus.ERROR
    else:
        status = _STATUS_MAP.get(model_status, SolveStatus.ERROR)
    info = highs.getInfo()
    message = (
        f"HiGHS: {highs.modelStatusToString(model_status)} "
        f"({int(info.simplex_iteration_count)} simplex, {int(info.ipm_iteration_count)} IPM "
        f"iterations)"
    )
    if not status.ok:
        return LPResult(status, _nan((num_cols,)), message, elapsed)
    return LPResult(status, np.asarray(highs.getSolution().col_value), message, elapsed)
