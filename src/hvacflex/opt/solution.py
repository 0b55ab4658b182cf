"""The outcome of a solve: :class:`SolveStatus`, :class:`RMPCSolution` and their builders.

Solutions are built in one place for both solvers: :func:`plan_solution` from a plan (the
cost split follows from u, r, ε and β as in the LP), :func:`failed_solution` without one
(every plan array NaN), :func:`plan_from_values` reads a plan from an LP's primal values.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass

import numpy as np

from hvacflex.opt.events import event_trajectory, reserve_responses, worst_event_output
from hvacflex.opt.lp import PlanColumns
from hvacflex.opt.options import RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR
from hvacflex.opt.problem import FloatArray, IntArray, RMPCProblem
from hvacflex.units import KWH_PER_MWH

__all__ = [
    "Plan",
    "RMPCSolution",
    "SolveStatus",
    "comfort_penalty_sgd",
    "failed_solution",
    "plan_from_values",
    "plan_solution",
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


@dataclass(frozen=True, eq=False)
class RMPCSolution:
    """The plan and its cost split. Arrays are NaN unless ``status`` is OPTIMAL.

    Attributes
    ----------
    status, message : outcome and a human-readable explanation
    objective_sgd : energy_cost − reserve_revenue + comfort_penalty + peak_charge [SGD]
        (the reserve tie-break ``tie_break_sgd`` is excluded)
    u, r : (N, m) planned flows and reserve flows [kg/s] (r = 0 on masked inputs)
    power_kw : (N,) P_k = p0_k + p_k·u_k [kW];  reserve_kw : (N,) R_k = q_k·r_k [kW], or
        the visible offers where the problem has ``offer_baselines``
    peak_kw : max_k P_k [kW];  peak_charge_sgd : β [SGD]
    slack : (N, ny) ε_k for outputs at steps 1..N [K];  delta : (N, ny) robust margins δ_k [K]
        (zero for robust="none"; for robust="dual" the equivalent tightening, for reference)
    x_served, x_curtailed : (N+1, n) nominal (w = 0) trajectories from x0 [°C]; in the IL
        event model (``events`` set, D = its ``max_steps``) ``x_curtailed`` is the trajectory
        under the event (s = 0, L = D), otherwise under curtailment for the whole horizon
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


def comfort_penalty_sgd(problem: RMPCProblem, slack_kelvin: FloatArray) -> float:
    """The comfort penalty of a plan's slack ε (N, ny) [K] in ``problem`` [SGD]: ρ·Δt·Σε, plus
    (ρ₂ − ρ)·Δt·Σ max(ε − δ, 0) with a :class:`~hvacflex.opt.blocks.ComfortKnee`."""
    rho, knee = problem.comfort_penalty_sgd_per_kelvin_hour, problem.comfort_knee
    slack = np.asarray(slack_kelvin, dtype=float)
    cost = rho * slack.sum()
    if knee is not None:
        beyond = np.maximum(slack - knee.knee_kelvin, 0.0).sum()
        cost += knee.surcharge_sgd_per_kelvin_hour(rho) * beyond
    return float(problem.dt_h * cost)


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


@dataclass(frozen=True, eq=False)
class Plan:
    """A plan read from an LP solution: u, r (N, m) [kg/s], slack (N, ny) [K], β [SGD], the
    nominal trajectories (N+1, n) [°C] and, where the LP paid only the offers its baselines
    see (:func:`hvacflex.opt.lp.add_visible_offers`), those offers (N,) [kW]."""

    u: FloatArray
    r: FloatArray
    slack: FloatArray
    peak_charge_sgd: float
    x_served: FloatArray
    x_curtailed: FloatArray
    offered_kw: FloatArray | None = None


def plan_from_values(
    problem: RMPCProblem,
    plan: PlanColumns,
    values: FloatArray,
    offer_columns: tuple[IntArray, IntArray] | None = None,
) -> Plan:
    """The plan in the primal ``values`` of an LP with the plan columns ``plan`` (and the
    columns (R, σ) of :func:`~hvacflex.opt.lp.add_visible_offers`, if it has them: the
    offers are then max(0, R − σ), and on the committed steps k < g, which were sold
    before, q_k·r_k)."""
    r = np.zeros((problem.horizon, problem.m))
    r[:, plan.reserve_inputs] = np.maximum(values[plan.r], 0.0)
    x_served = np.vstack([problem.x0, values[plan.x]])
    if plan.has_curtailed:
        x_curtailed = np.vstack([problem.x0, values[plan.z]])
    elif plan.has_reserve and plan.event_model:  # the event (s = 0, L = D)
        x_curtailed = event_trajectory(
            problem.a_matrix,
            problem.b_matrix[:, plan.reserve_inputs],
            x_served,
            problem.scaled_flows(r[:, plan.reserve_inputs], plan.reserve_inputs),
            None if problem.events is None else problem.events.max_steps,
        )
    else:
        x_curtailed = x_served
    return Plan(
        u=values[plan.u],
        r=r,
        slack=np.maximum(values[plan.eps], 0.0),
        peak_charge_sgd=float(values[plan.beta]),
        x_served=x_served,
        x_curtailed=x_curtailed,
        offered_kw=_offered_kw(problem, r, values, offer_columns),
    )


def _offered_kw(
    problem: RMPCProblem,
    r: FloatArray,
    values: FloatArray,
    offer_columns: tuple[IntArray, IntArray] | None,
) -> FloatArray | None:
    if offer_columns is None or offer_columns[0].size == 0:
        return None
    offered, unseen = offer_columns
    paid: FloatArray = np.maximum(values[offered] - values[unseen], 0.0)
    g = problem.fixed_reserve_steps
    paid[:g] = np.einsum("km,km->k", problem.reserve_kw_per_kg_s[:g], r[:g])
    return paid


def plan_solution(
    problem: RMPCProblem,
    *,
    status: SolveStatus,
    message: str,
    plan: Plan,
    delta: FloatArray,
    start: float,
    highs_time_s: float,
    simplex_iterations: int,
    warm_start: bool,
    feedback_gains: FloatArray | None = None,
    event_responses: FloatArray | None = None,
) -> RMPCSolution:
    """An :class:`RMPCSolution` from a plan: power, reserve and the cost split follow from
    its ``u`` (N, m), ``r`` (N, m) [kg/s], ``slack`` (N, ny) [K] and β [SGD] as in the LP.

    ``start`` is the ``time.perf_counter()`` reading when the solve call began;
    ``event_responses`` (N, ny, m_r) the reserve responses of
    :func:`~hvacflex.opt.events.reserve_responses` (computed if None; a solver caches them).
    """
    ridx = np.flatnonzero(np.asarray(problem.reserve_mask, dtype=bool))
    if event_responses is None:
        event_responses = reserve_responses(
            problem.a_matrix, problem.b_matrix[:, ridx], problem.c_matrix, problem.horizon
        )
    y_event_worst = worst_event_output(
        event_responses,
        plan.x_served[1:] @ problem.c_matrix.T,
        problem.scaled_flows(plan.r[:, ridx], ridx),
        delta,
        None if problem.events is None else problem.events.max_steps,
    )
    dt = problem.dt_h
    p = problem.power_coeff_kw_per_kg_s
    u, r, slack, peak_charge_sgd = plan.u, plan.r, plan.slack, plan.peak_charge_sgd
    power = problem.power_offset_kw + np.einsum("km,km->k", p, u)
    reserve = (
        np.einsum("km,km->k", problem.reserve_kw_per_kg_s, r)
        if plan.offered_kw is None
        else plan.offered_kw
    )
    energy = float(dt * problem.energy_price_sgd_per_mwh @ power / KWH_PER_MWH)
    revenue = float(dt * problem.reserve_price_sgd_per_mwh @ reserve / KWH_PER_MWH)
    comfort = comfort_penalty_sgd(problem, slack)
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
        x_served=plan.x_served,
        x_curtailed=plan.x_curtailed,
        energy_cost_sgd=energy,
        reserve_revenue_sgd=revenue,
        comfort_penalty_sgd=comfort,
        tie_break_sgd=float(RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR * dt * r.sum()),
        solve_time_s=time.perf_counter() - start,
        highs_time_s=highs_time_s,
        simplex_iterations=simplex_iterations,
        warm_start=warm_start,
        y_event_worst=y_event_worst,
        feedback_gains=feedback_gains,
    )
