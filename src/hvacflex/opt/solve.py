"""Solve :class:`~hvacflex.opt.problem.RMPCProblem` with HiGHS (through
:mod:`hvacflex.opt.highs_lp`, the only highspy importer).

:func:`~hvacflex.opt.factory.make_solver` gives the warm-started solver of a problem's robust
mode, with the same keywords for both: :class:`RMPCSolver` (open loop, here) or
:class:`FeedbackSolver` (:mod:`hvacflex.opt.feedback_solve`). Both are strategies on one
:class:`~hvacflex.opt.highs_lp.HighsSession` (handle, options, runs, time limit, status,
basis, retries); what stays here is the open-loop LP and how a basis maps onto it.

:class:`RMPCSolver` builds the sparse LP of :mod:`hvacflex.opt.lp` once per structure
(A, B, E, C, N, reserve mask, robust mode). Each :meth:`RMPCSolver.solve` rebuilds the LP's
costs and bounds without its constant coefficients, pushes only what changed since the
previous solve — costs, column bounds, row bounds (x0, d̂, g, δ, bounds, p0) and the
step-varying coefficients (``p_k`` on the power rows, ``φ_k`` on the peak rows, ρ·p_k and q_k
on the visible-offer rows, σ in the dual form) — and re-solves with the dual simplex (warm
start). The step-varying coefficients sit in the last core rows, the *moving rows*: where
they are not too sparse among them, they are replaced as one block with the lazy event rows'
change, in HiGHS's row order, instead of one ``changeCoeff`` per moved coefficient
(:mod:`hvacflex.opt.held_rows`, which keeps the rows HiGHS holds).
:class:`FeedbackSolver` solves the affine-feedback LP of :mod:`hvacflex.opt.feedback` (warm,
:mod:`hvacflex.opt.feedback_solve`). HiGHS runs single-threaded with its output silenced, so
results are reproducible.
:func:`~hvacflex.opt.factory.solve_rmpc` is the one-shot wrapper for both.

Warm start (measurements in ``docs/reference/performance.md``). Successive problems of a receding
horizon are shifted by one step, so the previous optimal basis is a poor start *position by
position*, but a good one once rotated: by default (``time_shift=True``) the statuses of step
k + 1 of every time-indexed block (x, z, u, r, ε, P and their rows: the blocks the builder
marks ``time_indexed``) start step k, and those of step 0 start step N − 1 (a rotation keeps
the number of basic variables, so HiGHS takes the basis as is). The basis is read after each
optimal solve from HiGHS's basic-variable list and the primal values (every row of the LP is
an equality or one-sided, so a nonbasic row's status follows from its bounds), which is much
cheaper than ``getBasis``. HiGHS uses Devex dual pricing on cold runs; warm runs price as
:data:`~hvacflex.opt.highs_lp.WARM_PRICING` says for the LP family (Dantzig on the event model,
Devex on the whole-horizon model). Warm solves run without scaling; cold solves
keep HiGHS's default scaling and presolve.

IL event rows (``RMPCSolver(..., event_rows="lazy")``, the default): the event model's
≈ N²·ny/2 rows are mostly slack at the optimum, so HiGHS holds only the core rows plus the
event rows that were nonbasic or near-active at the previous optimum (rotated by the event
permutation) and those of events starting at 0; after each run the activities of all event
rows are one sparse product, every absent row violated by more than 1e-7 K is added (HiGHS
keeps its basis, new rows basic) and the LP re-solved warm until none is. The optimum is the
full model's; bases are kept over all rows (absent rows basic), so checkpoints are
interchangeable with ``event_rows="full"``. Warm runs of the event model use Dantzig pricing
(cold runs Devex).

Failures are never silent: :class:`SolveStatus` says what happened, ``RMPCSolution.message``
says it in words, and every plan array (u, r, P, R, ε, trajectories, costs) is NaN unless the
status is :attr:`SolveStatus.OPTIMAL`. If a warm-started solve ends in a solver error (with
the building's ZOH matrices, entries down to 1e-10, a rotated basis is now and then
numerically singular and HiGHS's dual simplex stops), the solve is retried from the previous
basis unrotated, then from scratch (cold), before the error is reported.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any, Literal

import numpy as np

from hvacflex.errors import ProblemError
from hvacflex.opt.basis import (
    BASIC,
    SolverBasis,
    StatusArray,
    bounded_start,
    nonbasic_status,
    optimal_statuses,
    rotation,
)
from hvacflex.opt.events import reserve_responses, violated_rows
from hvacflex.opt.feedback_solve import DEFAULT_LP_METHOD, FeedbackSolver
from hvacflex.opt.held_rows import HeldRows
from hvacflex.opt.highs_lp import (
    HIGHS_ERROR,
    WARM_PRICING,
    HighsSession,
    LPResult,
    SessionOptions,
    highs_lp,
    solve_lp,
)
from hvacflex.opt.lp import LinearProgram, LPLayout, build_lp, sparse_matrix
from hvacflex.opt.problem import FloatArray, RMPCProblem
from hvacflex.opt.robust import impulse_responses, margin_operator, robust_margins
from hvacflex.opt.solution import (
    RMPCSolution,
    SolveStatus,
    failed_solution,
    plan_from_values,
    plan_solution,
)

__all__ = [
    "DEFAULT_LP_METHOD",
    "FeedbackSolver",
    "LPResult",
    "RMPCSolution",
    "RMPCSolver",
    "SolveStatus",
    "SolverBasis",
    "solve_lp",
]

#: Lazy event rows: an absent event row violated by more than this is added [K].
LAZY_VIOLATION_TOLERANCE_K = 1e-7
#: Lazy event rows: rows with a slack up to this at the optimum stay in the next step's LP [K].
LAZY_NEAR_ACTIVE_K = 1e-3
#: How the IL event rows enter the LP: all of them, or generated lazily.
EventRowMode = Literal["full", "lazy"]


class RMPCSolver:
    """Warm-started HiGHS solver for a sequence of problems of one structure.

    Parameters
    ----------
    problem : the first problem; fixes the structure (A, B, E, C, N, reserve mask, robust,
        the step linearisation's scale)
    time_limit_s : wall-clock limit per solve [s] (each :meth:`solve`, not cumulative);
        None = no limit
    time_shift : each problem is the previous one a step later (receding horizon): start
        from the previous optimal basis rotated by one step (see the module docstring), except
        for a solve marked ``same_step`` (:meth:`solve`). False: start from the previous basis
        as is.
    event_rows : IL event model only: "full" passes every event row to HiGHS; "lazy" passes
        the rows that were nonbasic or near-active (slack ≤ :data:`LAZY_NEAR_ACTIVE_K`) at
        the previous optimum (rotated) and the rows of events starting at 0, then adds every
        absent row violated by more than :data:`LAZY_VIOLATION_TOLERANCE_K` and re-solves
        warm until there is none — the same optimum.
        Bases (:meth:`get_basis`) always cover every row (absent rows basic).
    feasibility_tolerance : HiGHS's primal and dual feasibility tolerances of every solve;
        None keeps HiGHS's 1e-7

    Examples
    --------
    >>> solver = RMPCSolver(problem)                     # doctest: +SKIP
    >>> for step in range(steps):                        # doctest: +SKIP
    ...     sol = solver.solve(problem_at(step))
    """

    def __init__(
        self,
        problem: RMPCProblem,
        *,
        time_limit_s: float | None = None,
        time_shift: bool = True,
        event_rows: EventRowMode = "lazy",
        feasibility_tolerance: float | None = None,
    ) -> None:
        self._structure = problem.structure
        options = SessionOptions(time_limit_s, time_shift, feasibility_tolerance)
        family = "whole-horizon" if problem.events is None else "event"
        self._session = HighsSession(
            "RMPCSolver", self._structure.fingerprint(), options, warm_pricing=WARM_PRICING[family]
        )
        if problem.robust == "feedback":
            raise ProblemError(
                "RMPCSolver solves the open-loop problem only",
                source="RMPCSolver",
                field="robust",
                value=problem.robust,
                hint="use hvacflex.opt.feedback.FeedbackSolver (or solve_rmpc) for feedback",
            )
        self._responses = impulse_responses(
            problem.a_matrix, problem.e_matrix, problem.c_matrix, problem.horizon
        )
        self._margin_operator = margin_operator(self._responses)
        self._event_responses = reserve_responses(
            problem.a_matrix,
            problem.b_matrix[:, np.asarray(problem.reserve_mask, dtype=bool)],
            problem.c_matrix,
            problem.horizon,
        )
        if event_rows not in ("full", "lazy"):
            raise ProblemError(
                "unknown event row mode",
                source="RMPCSolver",
                field="event_rows",
                value=event_rows,
                hint="use 'full' or 'lazy'",
            )
        self._event_mode = event_rows
        self._build(problem)
        self._col_rotation, self._row_rotation = rotation(self._lp)
        self._last_problem: RMPCProblem | None = problem
        self._optimal = False  # the last solve ended optimal (its duals are meaningful)

    # ------------------------------------------------------------------ properties
    @property
    def _highs(self) -> Any:
        """The session's HiGHS handle, which holds this solver's LP."""
        return self._session.highs

    @property
    def layout(self) -> LPLayout:
        """Column/row indices of the LP."""
        return self._layout

    @property
    def num_cols(self) -> int:
        """Number of LP variables."""
        return self._lp.num_cols

    @property
    def num_rows(self) -> int:
        """Number of LP constraints."""
        return self._lp.num_rows

    @property
    def num_model_rows(self) -> int:
        """Number of constraints HiGHS holds (lazy event rows: core rows + rows present)."""
        return int(self._held.model_rows.size)

    @property
    def num_nonzeros(self) -> int:
        """Nonzeros of the constraint matrix as HiGHS holds it (lazy: the rows present)."""
        return int(self._highs.getNumNz())

    # ------------------------------------------------------------------ model
    def _build(self, problem: RMPCProblem) -> None:
        delta = self._delta(problem)
        lp, self._layout = build_lp(
            problem, self._tightening(problem, delta), responses=self._responses
        )
        assert lp.constant is not None
        matrix = sparse_matrix(lp, lp.constant, keep_varying_zeros=True, csc=True)
        events = self._layout.event_rows
        self._lazy = self._event_mode == "lazy" and events.size > 0
        num_core = int(events[0]) if events.size else lp.num_rows
        assert events.size == 0 or int(events[-1]) == lp.num_rows - 1  # event rows come last
        self._held = HeldRows(self._highs, lp, matrix, num_core, lazy=self._lazy)
        num_model = self._held.model_rows.size
        self._near = np.zeros(events.size, dtype=bool)  # near-active at the last optimum
        self._seed = self._layout.events.start == 0
        model = highs_lp(
            lp.cost,
            matrix[:num_model],
            lp.row_lower[:num_model],
            lp.row_upper[:num_model],
            lp.col_lower,
            lp.col_upper,
        )
        if self._highs.passModel(model) == HIGHS_ERROR:
            raise ProblemError(
                "HiGHS refused the assembled LP",
                source="RMPCSolver",
                hint="check the problem arrays for extreme magnitudes",
            )
        # HiGHS holds the matrix now: the structural coefficients (≈ 4 MiB) are not kept
        self._lp: LinearProgram = dataclasses.replace(lp, constant=None)
        self._bounds_changed()
        if self._lazy:
            self._held.set_event_rows(self._seed, self._lp)

    def _generate_rows(self, values: FloatArray) -> tuple[float, int, SolveStatus, FloatArray]:
        """Lazy mode: add violated event rows and re-solve warm until none is violated.

        Returns the HiGHS time [s], the simplex iterations, the final status and the primal
        values (num_cols,) of the last run; records which rows are near-active for the next
        step.
        """
        highs_time, iterations, status = 0.0, 0, SolveStatus.OPTIMAL
        upper = self._lp.row_upper[self._held.num_core :]
        while True:
            violation = self._held.event_matrix @ values - upper
            add = violated_rows(violation, ~self._held.present, LAZY_VIOLATION_TOLERANCE_K)
            if add.size == 0:
                self._near = violation >= -LAZY_NEAR_ACTIVE_K
                return highs_time, iterations, status, values
            self._held.add_event_rows(add, self._lp)
            elapsed, status = self._session.run(True)
            highs_time += elapsed
            iterations += self._session.iterations()
            if not status.ok:
                return highs_time, iterations, status, values
            values = self._session.values()

    def _bounds_changed(self) -> None:
        """Refresh the bound data that basis statuses are derived from (after any update)."""
        lp = self._lp
        self._col_lower, self._col_upper = lp.col_lower, lp.col_upper
        self._col_nonbasic = nonbasic_status(lp.col_lower, lp.col_upper)
        self._row_nonbasic = nonbasic_status(lp.row_lower, lp.row_upper)

    def _delta(self, problem: RMPCProblem) -> FloatArray:
        if problem.robust == "none":
            return np.zeros((problem.horizon, problem.ny))
        return robust_margins(self._margin_operator, problem.d_sigma)

    @staticmethod
    def _tightening(problem: RMPCProblem, delta: FloatArray) -> FloatArray:
        return np.zeros_like(delta) if problem.robust == "dual" else delta

    def _update(self, problem: RMPCProblem, delta: FloatArray) -> bool:
        """Push the costs, bounds and varying coefficients that differ from the last LP;
        whether the moving rows are to be replaced (:meth:`HeldRows.push`, before the next run;
        then HiGHS's basis must be set again)."""
        highs = self._highs
        tightening = self._tightening(problem, delta)
        old = self._lp
        lp, _ = build_lp(
            problem,
            tightening,
            responses=self._responses,
            constants=False,
            varying_pattern=old.varying,
        )
        changed = np.flatnonzero(lp.cost != old.cost).astype(np.int32)
        if changed.size:
            highs.changeColsCost(changed.size, changed, lp.cost[changed])
        varying = lp.varying
        moved = np.flatnonzero(varying.values != old.varying.values)
        replace_rows = self._held.moving is not None and moved.size > 0
        rows = self._held.model_rows  # the rows HiGHS holds, in its order
        if replace_rows:  # the rows from the first moving one on come with their new bounds
            assert self._held.moving is not None
            rows = rows[: self._held.moving.rows[0]]
        for change_bounds, lower, upper, old_lower, old_upper in (
            (highs.changeColsBounds, lp.col_lower, lp.col_upper, old.col_lower, old.col_upper),
            (
                highs.changeRowsBounds,
                lp.row_lower[rows],
                lp.row_upper[rows],
                old.row_lower[rows],
                old.row_upper[rows],
            ),
        ):
            changed = np.flatnonzero((lower != old_lower) | (upper != old_upper)).astype(np.int32)
            if changed.size:
                change_bounds(changed.size, changed, lower[changed], upper[changed])
        if replace_rows:
            self._held.stale = True  # pushed with the event rows, before the next run
        else:
            for row, col, value in zip(
                varying.rows[moved].tolist(),
                varying.cols[moved].tolist(),
                varying.values[moved].tolist(),
                strict=True,
            ):
                highs.changeCoeff(row, col, value)
        self._lp = lp
        self._bounds_changed()
        return replace_rows

    # ------------------------------------------------------------------ solve
    def solve(self, problem: RMPCProblem, *, same_step: bool = False) -> RMPCSolution:
        """Solve ``problem`` (same structure as the solver's), warm-started when possible.

        ``same_step``: ``problem`` is the previous solve's step again (other prices or power
        caps, as a fleet coordinator re-solves it): HiGHS goes on from the basis it holds,
        not rotated, whatever ``time_shift`` says. The first solve of every step is not
        ``same_step``.

        Raises
        ------
        ProblemError
            if ``problem`` has a different structure (A, B, E, C, N, reserve mask, robust
            mode, step linearisation); build a new :class:`RMPCSolver` for it.
        """
        start = time.perf_counter()
        if problem.structure is not self._structure:
            self._session.check_same_structure(self._structure.differences(problem.structure))
            self._structure = problem.structure  # equal: its variants skip the comparison
        delta = self._delta(problem)
        replaced = False
        if problem is not self._last_problem:
            replaced = self._update(problem, delta)
            self._last_problem = problem
        session = self._session
        shift = not same_step
        if session.basis is not None and (
            (session.time_shift and shift) or session.basis_given or replaced
        ):
            self._start_from(shift=shift)
        elif replaced:  # HiGHS's basis would lose the moving rows' statuses
            self._held.push(self._held.present.copy() if self._lazy else None, self._lp)
            self._highs.clearSolver()
            session.has_basis = False
        status, highs_time, iterations, warm = session.run_with_retries(
            session.has_basis, lambda: self._start_from(shift=False)
        )
        values = session.values() if status.ok else None
        if self._lazy and values is not None:
            more_time, more_iterations, status, values = self._generate_rows(values)
            highs_time += more_time
            iterations += more_iterations
            if not status.ok:
                values = None
        self._optimal = values is not None and status is SolveStatus.OPTIMAL
        session.keep(self._optimal_basis(values) if values is not None else None)
        return self._solution(problem, delta, status, start, highs_time, iterations, warm, values)

    def _start_from(self, *, shift: bool = True) -> bool:
        """Start HiGHS's next run from the stored basis (rotated by one step if the session
        :meth:`~hvacflex.opt.highs_lp.HighsSession.rotates`); whether HiGHS took it.

        Lazy event rows: HiGHS then holds the rows nonbasic or near-active in that basis and
        the seed rows. Nonbasic statuses that the current bounds do not allow (a bound that
        became infinite) are replaced by the one the bounds imply.
        """
        session = self._session
        col_status, row_status = session.start_statuses(
            (self._col_rotation, self._row_rotation), shift=shift
        )
        if self._lazy:  # nonbasic and near-active rows (rotated) and the seed
            near = self._near
            if session.rotates(shift):
                near = near[self._row_rotation[self._held.num_core :] - self._held.num_core]
            self._held.set_event_rows(
                (row_status[self._held.num_core :] != BASIC) | near | self._seed, self._lp
            )
        elif self._held.stale:
            self._held.push(None, self._lp)
        rows = self._held.model_rows
        start = bounded_start(
            col_status,
            row_status[rows],
            self._col_lower,
            self._col_upper,
            self._col_nonbasic,
            self._row_nonbasic[rows],
        )
        return session.set_start(*start)

    def _optimal_basis(self, values: FloatArray) -> tuple[StatusArray, StatusArray]:
        """Statuses of HiGHS's current (optimal) basis (see :func:`optimal_statuses`)."""
        basic = self._session.basic_variables()
        rows = basic < 0  # HiGHS row i is LP row model_rows[i]
        basic[rows] = -1 - self._held.model_rows[-1 - basic[rows]]
        col_status, row_status = optimal_statuses(
            values,
            self._col_lower,
            self._col_upper,
            self._col_nonbasic,
            self._row_nonbasic,
            basic,
        )
        if self._lazy:  # absent event rows count as basic
            row_status[self._held.num_core :][~self._held.present] = BASIC
        return col_status, row_status

    def _message(
        self, problem: RMPCProblem, delta: FloatArray, status: SolveStatus, iterations: int
    ) -> str:
        model_status = self._session.model_status_text()
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
        return plan_solution(
            problem,
            status=status,
            message=message,
            plan=plan_from_values(
                problem,
                self._layout.plan,
                values,
                (self._layout.offered, self._layout.unseen),
            ),
            delta=delta,
            start=start,
            highs_time_s=highs_time,
            simplex_iterations=iterations,
            warm_start=warm,
            event_responses=self._event_responses,
        )

    def highs_objective_sgd(self) -> float:
        """HiGHS's objective value of the last solve (includes the reserve tie-break) [SGD]."""
        return float(self._highs.getInfo().objective_function_value)

    def power_cap_values_sgd_per_kw(self) -> FloatArray:
        """(N,) marginal value of the power caps at the last optimum [SGD per kW of cap].

        Entry k is how much the optimal objective falls per kW added to
        the cap (``RMPCProblem.power_cap``) in period k: minus the reduced cost (column dual) of the
        plan's power column k, ≥ 0, and 0 where the cap is slack (or +inf). With lazy event
        rows it is the dual of the final LP, which has the same optimum as the full one.

        Raises
        ------
        ProblemError
            if the last :meth:`solve` did not end optimal (or none ran yet).
        """
        if not self._optimal:
            raise ProblemError(
                "no optimal solution to take the cap values from",
                source="RMPCSolver",
                field="power_cap",
                hint="call solve() first and check that its status is OPTIMAL",
            )
        duals = np.asarray(self._highs.getSolution().col_dual, dtype=float)
        value: FloatArray = np.maximum(-duals[self._layout.plan.power], 0.0)
        return value

    # ------------------------------------------------------------------ basis
    def get_basis(self) -> SolverBasis | None:
        """The basis of the last solve (picklable; as solved, not rotated), or None if none yet."""
        # lazy event rows: HiGHS's own basis covers some rows only (moved rows keep the order)
        return self._session.get_basis(or_highs=not self._lazy)

    def set_basis(self, basis: SolverBasis) -> None:
        """Start the next solve from ``basis`` (from :meth:`get_basis` of a same-structure solver).

        With ``time_shift`` the basis is taken as the previous step's and rotated by one step,
        exactly as after a solve of this solver: a checkpoint resumes as if never stopped.

        Raises
        ------
        ProblemError
            if the basis belongs to another structure or HiGHS rejects it.
        """
        self._session.set_basis(basis, self.num_cols, self.num_rows)
