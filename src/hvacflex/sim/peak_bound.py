"""The perfect-foresight optimum of the controller's LP model (same comfort band, same
days): the reference Fig. 7's peaks are graded against (``bound_peak_kw`` of
``fig7_ppp_sweep_energyplus.csv``, issue 61). Not a proven lower bound on any plant: the
power rows are secants of the plant's power and the start is the configuration's initial
state, so a plant may meter a lower peak.

One LP over the whole period on the controller's model (docs/explanation/model.md): the affine RC
model x_{k+1} = A x_k + B u_k + E d_k + g with the data's disturbances d_k (perfect
foresight), the flows in [u_min,k, u_max], the LP's affine power rows P_k = p0_k + p_kᵀ u_k
(the building's power model at the data's outdoor air, as the MPC's), and the comfort band
on the zone temperatures at the period ends, C x_{k+1} ∈ [y_min,k, y_max,k] (the tighter of
the two periods' bands, as the MPC's; no plan margin below the night bound):

    min β   s.t.   P_k ≤ β for every k,   the dynamics, the flow bounds and the band.

The band may be out of reach (a start outside it, a hot afternoon beyond the air system):
the LP is solved in two stages, first the least total excursion Σ s over the band
(y_min − s ≤ C x ≤ y_max + s, s ≥ 0), then the least β with the excursion held at that
least (so the bound is "the same comfort the controller could reach at best"). β is the
peak of the 30-min mean power over the whole period, the monthly peak where the period lies
in one calendar month (Fig. 7's 28 days from 2014-03-03 do).

:func:`minimum_peak` solves the LP on arrays (:class:`PeakBoundProblem`);
:func:`bound_peak_kw` builds it from a scenario (its building, data and initial state).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from hvacflex.building.channels import DisturbanceChannel
from hvacflex.building.identified import initial_node_temps_degc
from hvacflex.config import ScenarioConfig
from hvacflex.control.plan_band import band_at_period_ends
from hvacflex.control.problem_builder import lp_power_rows
from hvacflex.errors import InputError, SolverError
from hvacflex.opt.highs_lp import LPResult, solve_lp
from hvacflex.opt.solution import SolveStatus

FloatArray = npt.NDArray[np.float64]

LP_METHOD = "ipm"
"""HiGHS's method for the bound's LPs (interior point with crossover: about twice as fast
as the simplex on four days of office5)."""
FALLBACK_LP_METHOD = "simplex"
"""The method an LP is solved again with where :data:`LP_METHOD` stops without an optimum
(numerical trouble: the 28-day bound on office5's closed-loop power table ended in HiGHS's
``ERROR`` status under the interior point; an interior point's "infeasible or unbounded" is
checked the same way, as the excursion slacks make the LP feasible for any band). The
second method's status is the one reported."""

EXCURSION_REL_TOLERANCE = 1e-7
EXCURSION_ABS_TOLERANCE_K = 1e-7
"""Room the second stage gives the first stage's least excursion (a sum over thousands of
slacks from an interior-point solve, accurate to its tolerances only):
``least (1 + EXCURSION_REL_TOLERANCE) + EXCURSION_ABS_TOLERANCE_K`` [K, summed over zones
and periods] (:func:`excursion_room_k`)."""


def excursion_room_k(least_k: float) -> float:
    """The most excursion [K] the second stage allows after a least excursion ``least_k``
    [K]: relative room plus absolute room (:data:`EXCURSION_REL_TOLERANCE`)."""
    return least_k * (1.0 + EXCURSION_REL_TOLERANCE) + EXCURSION_ABS_TOLERANCE_K


@dataclass(frozen=True)
class PeakBoundProblem:
    """The whole-period LP on arrays (module docstring). T periods, n states, m zones, nd
    disturbance channels.

    Attributes
    ----------
    a : (n, n), b : (n, m), e : (n, nd), g : (n,), c : (m, n): the model.
    x0_degc : (n,) the state at the start [°C].
    d : (T, nd) the disturbances of each period.
    u_min_kg_s : (T, m), u_max_kg_s : (m,) flow bounds [kg/s].
    y_min_degc, y_max_degc : (T, m) the band on the zone temperatures at the end of each
        period [°C].
    p0_kw : (T,) [kW], p_kw_per_kg_s : (T, m) [kW per kg/s] the power rows.
    """

    a: FloatArray
    b: FloatArray
    e: FloatArray
    g: FloatArray
    c: FloatArray
    x0_degc: FloatArray
    d: FloatArray
    u_min_kg_s: FloatArray
    u_max_kg_s: FloatArray
    y_min_degc: FloatArray
    y_max_degc: FloatArray
    p0_kw: FloatArray
    p_kw_per_kg_s: FloatArray


@dataclass(frozen=True)
class PeakBound:
    """The LP's answer.

    Attributes
    ----------
    peak_kw : the least peak β [kW].
    excursion_k : the least total excursion over the band Σ s [K, summed over zones and
        periods]; 0 where the band can be kept throughout.
    flow_kg_s : (T, m) the flows that reach it [kg/s].
    power_kw : (T,) their power P_k [kW].
    zone_temp_degc : (T, m) the zone temperatures they give at the end of each period on the
        model [°C].
    """

    peak_kw: float
    excursion_k: float
    flow_kg_s: FloatArray
    power_kw: FloatArray
    zone_temp_degc: FloatArray


def _constraints(
    problem: PeakBoundProblem,
) -> tuple[sp.csr_matrix, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Rows and column bounds of the LP over z = [u (T·m), x_1…x_T (T·n), s (T·m), β]."""
    t_steps, m = problem.u_min_kg_s.shape
    n = problem.a.shape[0]
    nu, nx = t_steps * m, t_steps * n
    eye_t = sp.identity(t_steps, format="csr")
    shift = sp.eye(t_steps, k=-1, format="csr")  # x_k of row k+1
    drive = problem.d @ problem.e.T + problem.g  # (T, n)
    drive[0] += problem.a @ problem.x0_degc
    dynamics = sp.hstack(
        [
            -sp.kron(eye_t, sp.csr_matrix(problem.b)),
            sp.kron(eye_t, sp.identity(n)) - sp.kron(shift, sp.csr_matrix(problem.a)),
            sp.csr_matrix((nx, nu + 1)),
        ]
    )
    zones = sp.kron(eye_t, sp.csr_matrix(problem.c))
    slack = sp.identity(nu)
    low_rows = sp.hstack([sp.csr_matrix((nu, nu)), zones, slack, sp.csr_matrix((nu, 1))])
    high_rows = sp.hstack([sp.csr_matrix((nu, nu)), zones, -slack, sp.csr_matrix((nu, 1))])
    power_rows = sp.hstack(
        [
            sp.block_diag([sp.csr_matrix(row[None, :]) for row in problem.p_kw_per_kg_s]),
            sp.csr_matrix((t_steps, nx + nu)),
            -np.ones((t_steps, 1)),
        ]
    )
    rows = sp.vstack([dynamics, low_rows, high_rows, power_rows], format="csr")
    inf = np.full(nu, np.inf)
    row_lower = np.concatenate(
        [drive.ravel(), problem.y_min_degc.ravel(), -inf, np.full(t_steps, -np.inf)]
    )
    row_upper = np.concatenate(
        [drive.ravel(), inf, problem.y_max_degc.ravel(), -np.asarray(problem.p0_kw)]
    )
    col_lower = np.concatenate(
        [problem.u_min_kg_s.ravel(), np.full(nx, -np.inf), np.zeros(nu), [-np.inf]]
    )
    col_upper = np.concatenate(
        [np.tile(problem.u_max_kg_s, t_steps), np.full(nx + nu, np.inf), [np.inf]]
    )
    return rows, row_lower, row_upper, col_lower, col_upper


def minimum_peak(problem: PeakBoundProblem) -> PeakBound:
    """The least peak over the period with the least excursion over the band (module
    docstring: two LPs on HiGHS).

    Raises
    ------
    InputError
        When the LP is infeasible or unbounded (flow bounds that cross, data with NaN).
    SolverError
        When HiGHS finds no optimum for another reason (its status named).
    """
    t_steps, m = problem.u_min_kg_s.shape
    nu, nx = t_steps * m, t_steps * problem.a.shape[0]
    rows, row_lower, row_upper, col_lower, col_upper = _constraints(problem)
    excursion_cost = np.concatenate([np.zeros(nu + nx), np.ones(nu), [0.0]])
    first = _solve(excursion_cost, rows, row_lower, row_upper, col_lower, col_upper)
    _check(first.status, "the least excursion")
    least = float(excursion_cost @ first.x)
    rows = sp.vstack([rows, sp.csr_matrix(excursion_cost[None, :])], format="csr")
    row_lower = np.append(row_lower, -np.inf)
    row_upper = np.append(row_upper, excursion_room_k(least))
    peak_cost = np.zeros(nu + nx + nu + 1)
    peak_cost[-1] = 1.0
    second = _solve(peak_cost, rows, row_lower, row_upper, col_lower, col_upper)
    _check(second.status, "the least peak")
    flow = second.x[:nu].reshape(t_steps, m)
    power = problem.p0_kw + np.einsum("km,km->k", problem.p_kw_per_kg_s, flow)
    states = second.x[nu : nu + nx].reshape(t_steps, -1)
    return PeakBound(
        peak_kw=float(second.x[-1]),
        excursion_k=least,
        flow_kg_s=flow,
        power_kw=power,
        zone_temp_degc=states @ problem.c.T,
    )


def _solve(
    cost: FloatArray,
    rows: sp.csr_matrix,
    row_lower: FloatArray,
    row_upper: FloatArray,
    col_lower: FloatArray,
    col_upper: FloatArray,
) -> LPResult:
    """One of the bound's LPs with :data:`LP_METHOD`, again with :data:`FALLBACK_LP_METHOD`
    where the first stops without an optimum (whose status then decides)."""
    result = solve_lp(cost, rows, row_lower, row_upper, col_lower, col_upper, method=LP_METHOD)
    if result.status is SolveStatus.OPTIMAL:
        return result
    return solve_lp(
        cost, rows, row_lower, row_upper, col_lower, col_upper, method=FALLBACK_LP_METHOD
    )


def _check(status: SolveStatus, stage: str) -> None:
    """Refuse a solve without an optimum: the input's fault where the LP is infeasible or
    unbounded (the excursion slacks keep it feasible for any band: flow bounds that cross,
    data with NaN), the solver's otherwise (a time limit, numerical trouble)."""
    if status is SolveStatus.OPTIMAL:
        return
    message = f"the peak bound's LP ({stage}) has no optimum: {status.name}"
    if status in (SolveStatus.INFEASIBLE, SolveStatus.UNBOUNDED):
        raise InputError(
            message,
            field="bound_peak_kw",
            hint="check the scenario's flow limits and data (no NaN) over the period",
        )
    raise SolverError(
        f"{message} (HiGHS {LP_METHOD}, then {FALLBACK_LP_METHOD}; a solver failure, not the input)"
    )


def _outdoor_index(channels: Sequence[DisturbanceChannel], config: ScenarioConfig) -> int:
    """The column of the outdoor temperature among the model's disturbance ``channels``."""
    for i, channel in enumerate(channels):
        if channel.kind == "outdoor_temp":
            return i
    raise InputError(
        "the building's model has no outdoor_temp disturbance channel: the bound's power rows "
        "need the outdoor temperature",
        source=config.building,
        field="channels",
        value=[channel.kind for channel in channels],
        hint="use a building whose model has an outdoor_temp channel",
    )


def bound_peak_kw(config: ScenarioConfig) -> PeakBound:
    """The least peak of ``config``'s period on its building's model with perfect
    foresight (the data's disturbances), its comfort band and its power model at the
    controller's linearisation temperature, from the scenario's initial state."""
    from hvacflex.sim.setup import prepare

    setup = prepare(config)
    model, exo, building = setup.model, setup.exogenous, setup.building
    steps = config.steps
    occupied = np.asarray(exo.occupied, dtype=bool)
    y_min, y_max = band_at_period_ends(exo.comfort_lower_degc, exo.comfort_upper_degc, steps)
    d = np.asarray(exo.disturbances[:steps], dtype=np.float64)
    outdoor = d[:, _outdoor_index(model.channels, config)]
    u_min = building.hvac.flow_min_at(occupied[:steps])
    p0, p = lp_power_rows(
        building,
        outdoor,
        exo.outdoor_humidity_ratio_kg_per_kg[:steps],
        np.asarray(exo.occupant_latent_w, dtype=np.float64)[:steps],
        occupied[:steps],
        building.hvac.outdoor_air_open_at(occupied, model.dt_s)[:steps],
        setup.linearisation_temp_degc,
        u_min,
        total_flow_max_kg_s=float(np.sum(building.hvac.flow_max_kg_s)),
    )
    if building.identified is not None:
        x0 = initial_node_temps_degc(building.identified, config.initial_temp_degc)
    else:
        x0 = np.full(len(model.node_names), config.initial_temp_degc)
    return minimum_peak(
        PeakBoundProblem(
            a=model.a,
            b=model.b,
            e=model.e,
            g=model.g,
            c=model.c,
            x0_degc=np.asarray(x0, dtype=np.float64),
            d=d,
            u_min_kg_s=u_min,
            u_max_kg_s=np.asarray(building.hvac.flow_max_kg_s, dtype=np.float64),
            y_min_degc=y_min,
            y_max_degc=y_max,
            p0_kw=np.asarray(p0, dtype=np.float64),
            p_kw_per_kg_s=np.asarray(p, dtype=np.float64),
        )
    )
