r"""Feeder coordination by power caps: an envelope, then a bundle method (issue 31).

The fleet step ``min Σ_b J_b(P_b) s.t. Σ_b P_b,k ≤ F_k`` over the periods k where the
buildings' maximum powers could exceed F (elsewhere nothing couples them; where the minimum
powers alone exceed F every building's cap is its minimum and the period is flagged). Every
scheme ends with per-building caps that sum to F in those periods and one re-solve of every
building inside its caps (``RMPCProblem.power_max_kw``), so the applied plans are feasible.

1. **Envelope** (``scheme = "envelope"``): every building solves without caps and reports its
   plan and its range [P_min, P_max]; if the plans fit they are kept; otherwise F above the
   minima is shared in proportion to each building's request above its minimum
   (:func:`hvacflex.fleet.coordinate.allocate_caps`) and each building re-plans once.
2. **Dual bundle** (``scheme = "bundle"``, the default): from the envelope, a trust-region
   bundle method maximises the dual function ``L(π) = Σ_b min_P (J_b(P) + π·P) − π·F`` over
   feeder prices π ≥ 0 [SGD/kW] (one building solve per round: every building re-solves at
   the round's prices, warm, in parallel, and returns a plan — a column — and its Lagrangian
   value), and recovers a primal plan by **Dantzig–Wolfe**: the restricted master
   (:func:`solve_restricted_master`) picks the cheapest convex combination of each
   building's plans that fits under F. The combined plan is feasible for the building's own
   LP at the combined cost, so capping each building at its combined power and re-solving
   costs at most the master's value. The dual model (:func:`solve_dual_model`) is maximised
   inside a box |π − π̂| ≤ Δ; a step that achieves ≥ ``SERIOUS_STEP_SHARE`` of the predicted
   ascent moves π̂ (Δ × ``TRUST_GROWTH``), otherwise Δ × ``TRUST_SHRINK``.
3. **Cap-space bundle** (``scheme = "caps"``): primal decomposition — with
   V_b(c) = min {J_b(P) : P ≤ c} convex and piecewise linear and the cap values
   μ_b ≥ 0 [SGD/kW] of each solve as subgradients (``RMPCSolver.power_cap_values_sgd_per_kw``),
   Kelley cuts ``V_b(c) ≥ V_b(cʲ) − μʲ·(c − cʲ)`` and a trust region |c − ĉ| ≤ Δ_k
   (:func:`solve_master`). Kept for comparison: B × P cap dimensions against P prices make
   it converge much more slowly (docs/guide/fleet.md).

Stop (bundle) when (a) ``(master − bound) / |master|`` ≤ ``gap_tolerance`` with the bound
the best Lagrangian value (a lower bound of the fleet optimum), (b) the model predicts less
ascent than ``gap_tolerance`` × the cost, (c) no building's plan in a binding period moved
more than ``plan_tolerance_kw`` since the last round, or (d) after ``max_iterations``
rounds. The master LPs are solved by :func:`hvacflex.opt.solve.solve_lp` (HiGHS stays behind
:mod:`hvacflex.opt`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse

from hvacflex.control.base import FloatArray
from hvacflex.fleet.coordinate import (
    VIOLATION_FLOOR_KW,
    CapValuesAll,
    CoordinationOptions,
    CoordinationResult,
    FinalizeAll,
    SolveAll,
    keep_or_cap,
    project_caps_periods,
)
from hvacflex.opt.solve import solve_lp
from hvacflex.units import KWH_PER_MWH

log = logging.getLogger(__name__)

SERIOUS_STEP_SHARE = 0.1
"""A round is kept when it achieves this share of the master's predicted decrease."""
TRUST_GROWTH = 2.0
TRUST_SHRINK = 0.5
INITIAL_TRUST_SHARE = 1.0
"""First trust radius per period: this share of the mean headroom above P_min per building."""
MIN_TRUST_KW = 1e-4
"""Below this trust radius [kW] the round cannot move the caps: stop."""


@dataclass
class _Cuts:
    """The cuts collected so far over the binding periods: caps (J, B, P), values (J, B),
    slopes μ (J, B, P) [SGD/kW]."""

    caps_kw: list[FloatArray] = field(default_factory=list)
    values_sgd: list[FloatArray] = field(default_factory=list)
    slopes_sgd_per_kw: list[FloatArray] = field(default_factory=list)

    def add(self, caps_kw: FloatArray, values_sgd: FloatArray, slopes: FloatArray) -> None:
        self.caps_kw.append(caps_kw.copy())
        self.values_sgd.append(values_sgd.copy())
        self.slopes_sgd_per_kw.append(slopes.copy())


def solve_master(
    cuts: _Cuts,
    lower_kw: FloatArray,
    upper_kw: FloatArray,
    total_kw: FloatArray,
) -> tuple[FloatArray, float] | None:
    """Minimise the cut model ``Σ_b max_j (V_j,b − μ_j,b·(c_b − c_j,b))`` over caps c (B, P)
    in [lower, upper] (B, P) [kW] with ``Σ_b c_b,k = total_k`` (P,) [kW].

    Returns the caps (B, P) and the model's minimum [SGD], or None if the LP failed.
    """
    n_b, n_p = lower_kw.shape
    n_c = n_b * n_p
    rows, cols, vals, row_lo = [], [], [], []
    row = 0
    for caps, values, slopes in zip(
        cuts.caps_kw, cuts.values_sgd, cuts.slopes_sgd_per_kw, strict=True
    ):
        for b in range(n_b):  # θ_b + μ_b·c_b ≥ V_b + μ_b·c_j,b
            rows += [row] * (n_p + 1)
            cols += [*range(b * n_p, (b + 1) * n_p), n_c + b]
            vals += [*slopes[b], 1.0]
            row_lo.append(float(values[b] + slopes[b] @ caps[b]))
            row += 1
    for k in range(n_p):  # Σ_b c_b,k = F_k
        rows += [row] * n_b
        cols += [b * n_p + k for b in range(n_b)]
        vals += [1.0] * n_b
        row += 1
    matrix = sparse.csr_matrix((vals, (rows, cols)), shape=(row, n_c + n_b))
    lower = np.concatenate([np.asarray(row_lo), total_kw])
    upper = np.concatenate([np.full(len(row_lo), np.inf), total_kw])
    cost = np.concatenate([np.zeros(n_c), np.ones(n_b)])
    col_lo = np.concatenate([lower_kw.ravel(), np.full(n_b, -np.inf)])
    col_hi = np.concatenate([upper_kw.ravel(), np.full(n_b, np.inf)])
    result = solve_lp(cost, matrix, lower, upper, col_lo, col_hi)
    if not result.status.ok:
        return None
    return result.x[:n_c].reshape(n_b, n_p), float(cost @ result.x)


@dataclass(frozen=True)
class _Step:
    """The fixed data of one step's cap problem: the binding periods (P,) and their bounds."""

    periods: np.ndarray
    lower_kw: FloatArray
    upper_kw: FloatArray
    total_kw: FloatArray

    @staticmethod
    def of(limit_kw: FloatArray, p_min: FloatArray, p_max: FloatArray) -> _Step:
        binding = (p_max.sum(axis=0) > limit_kw) & (p_min.sum(axis=0) < limit_kw)
        periods = np.flatnonzero(binding)
        return _Step(
            periods,
            p_min[:, periods].copy(),
            np.maximum(p_max[:, periods], p_min[:, periods]),
            limit_kw[periods],
        )


def common_cap_value(slopes: FloatArray, caps: FloatArray, step: _Step) -> FloatArray:
    """(P,) the buildings' common marginal cap value [SGD/kW] over the binding periods: the
    mean μ (B, P) of the buildings whose cap (B, P) is inside its range (at the fleet optimum
    they are equal), or the largest μ where no cap is inside."""
    inside = (caps > step.lower_kw + VIOLATION_FLOOR_KW) & (
        caps < step.upper_kw - VIOLATION_FLOOR_KW
    )
    counted = np.maximum(inside.sum(axis=0), 1)
    value: FloatArray = np.where(
        inside.any(axis=0), (slopes * inside).sum(axis=0) / counted, slopes.max(axis=0)
    )
    return value


def _feeder_price(
    slopes: FloatArray, caps: FloatArray, step: _Step, horizon: int, dt_h: float
) -> FloatArray:
    """(N,) feeder price [SGD/MWh]: :func:`common_cap_value` as an energy price."""
    price = np.zeros(horizon)
    if step.periods.size:
        price[step.periods] = common_cap_value(slopes, caps, step) * KWH_PER_MWH / dt_h
    return price


def _total(cost_sgd: FloatArray) -> float:
    return float(np.sum(cost_sgd)) if np.all(np.isfinite(cost_sgd)) else np.inf


@dataclass
class _Best:
    caps_kw: FloatArray
    power_kw: FloatArray
    cost_sgd: FloatArray
    slopes: FloatArray

    @property
    def total_sgd(self) -> float:
        return _total(self.cost_sgd)


def _rounds(
    finalize_all: FinalizeAll,
    cap_values_all: CapValuesAll,
    best: _Best,
    step: _Step,
    options: CoordinationOptions,
) -> tuple[_Best, int, float, bool]:
    """The trust-region bundle rounds from ``best``; (best, rounds, lower bound, staged).

    ``staged`` says whether the best allocation's plans are the buildings' last solves."""
    zero = np.zeros(best.caps_kw.shape[1])
    cuts = _Cuts()
    cuts.add(best.caps_kw[:, step.periods], best.cost_sgd, best.slopes[:, step.periods])
    headroom = (step.total_kw - step.lower_kw.sum(axis=0)) / best.caps_kw.shape[0]
    radius = INITIAL_TRUST_SHARE * np.maximum(headroom, MIN_TRUST_KW)
    bound, rounds, staged = -np.inf, 0, True
    last_power = best.power_kw[:, step.periods]
    for _ in range(options.max_iterations):
        whole = solve_master(cuts, step.lower_kw, step.upper_kw, step.total_kw)
        if whole is not None:
            bound = max(bound, whole[1])
        if _gap(best.total_sgd, bound) <= options.gap_tolerance:
            break
        centre = best.caps_kw[:, step.periods]
        lower = np.maximum(step.lower_kw, centre - radius)
        upper = np.minimum(step.upper_kw, centre + radius)
        local = solve_master(cuts, lower, upper, step.total_kw)
        if local is None:
            break
        predicted = best.total_sgd - local[1]
        if predicted <= options.gap_tolerance * max(abs(best.total_sgd), 1e-9):
            break
        trial = best.caps_kw.copy()
        trial[:, step.periods] = local[0]
        power, cost, _ = finalize_all(zero, trial)
        slopes = cap_values_all()
        rounds += 1
        if np.all(np.isfinite(cost)):
            cuts.add(local[0], cost, slopes[:, step.periods])
        moved = float(np.max(np.abs(power[:, step.periods] - last_power), initial=0.0))
        log.debug(
            "bundle round %d: best %.4f, trial %.4f, predicted %.4g, bound %.4f, radius %.4g kW, "
            "moved %.4g kW",
            rounds,
            best.total_sgd,
            _total(cost),
            predicted,
            bound,
            float(np.max(radius)),
            moved,
        )
        last_power = power[:, step.periods]
        if best.total_sgd - _total(cost) >= SERIOUS_STEP_SHARE * predicted:
            best, staged = _Best(trial, power, cost, slopes), True
            radius = TRUST_GROWTH * radius
        else:
            staged = False
            radius = TRUST_SHRINK * radius
        if moved <= options.plan_tolerance_kw or float(np.max(radius)) < MIN_TRUST_KW:
            break
    return best, rounds, bound, staged


def _gap(total_sgd: float, bound_sgd: float) -> float:
    return (total_sgd - bound_sgd) / max(abs(total_sgd), 1e-9)


# ------------------------------------------------------------ dual bundle (Dantzig–Wolfe)


@dataclass
class _Columns:
    """Every building's plans so far over the binding periods: powers (J, B, P) [kW] and
    costs without the feeder price (J, B) [SGD]."""

    power_kw: list[FloatArray] = field(default_factory=list)
    cost_sgd: list[FloatArray] = field(default_factory=list)

    def add(self, power_kw: FloatArray, cost_sgd: FloatArray) -> None:
        ok = np.isfinite(cost_sgd) & np.all(np.isfinite(power_kw), axis=1)
        self.power_kw.append(np.where(ok[:, None], power_kw, 0.0))
        self.cost_sgd.append(np.where(ok, cost_sgd, np.inf))


def solve_restricted_master(
    columns: _Columns, total_kw: FloatArray
) -> tuple[FloatArray, float] | None:
    """The Dantzig–Wolfe restricted master: weights w (J, B) ≥ 0 with Σ_j w_j,b = 1 that
    minimise Σ w·cost subject to Σ_j,b w_j,b P_j,b,k ≤ F_k (P,) [kW]. Returns the combined
    plans' powers (B, P) [kW] and the master's cost [SGD], or None if infeasible."""
    power = np.asarray(columns.power_kw)  # (J, B, P)
    cost = np.asarray(columns.cost_sgd)  # (J, B)
    n_j, n_b, n_p = power.shape
    usable = np.isfinite(cost)
    # column (j, b) at j * n_b + b; rows: one convexity row per building, one per period
    conv = sparse.csr_matrix(
        (np.ones(n_j * n_b), (np.tile(np.arange(n_b), n_j), np.arange(n_j * n_b))),
        shape=(n_b, n_j * n_b),
    )
    coupling = sparse.csr_matrix(power.reshape(n_j * n_b, n_p).T)
    matrix = sparse.vstack([conv, coupling]).tocsr()
    lower = np.concatenate([np.ones(n_b), np.full(n_p, -np.inf)])
    upper = np.concatenate([np.ones(n_b), total_kw])
    col_hi = np.where(usable.ravel(), 1.0, 0.0)
    result = solve_lp(
        np.where(usable, cost, 0.0).ravel(), matrix, lower, upper, np.zeros(n_j * n_b), col_hi
    )
    if not result.status.ok:
        return None
    weights = result.x.reshape(n_j, n_b)
    combined = np.einsum("jb,jbp->bp", weights, power)
    return combined, float(np.where(usable, cost, 0.0).ravel() @ result.x)


def solve_dual_model(
    columns: _Columns, total_kw: FloatArray, lower: FloatArray, upper: FloatArray
) -> tuple[FloatArray, float] | None:
    """Maximise the cutting-plane model of the dual function,
    ``Σ_b min_j (cost_j,b + π·P_j,b) − π·F``, over feeder prices π (P,) [SGD/kW] in the box
    [lower, upper]; returns π and the model's value [SGD], or None if the LP failed."""
    power = np.asarray(columns.power_kw)
    cost = np.asarray(columns.cost_sgd)
    n_j, n_b, n_p = power.shape
    rows, cols, vals, row_hi = [], [], [], []
    row = 0
    for j in range(n_j):
        for b in range(n_b):  # θ_b − π·P_j,b ≤ cost_j,b
            if not np.isfinite(cost[j, b]):
                continue
            rows += [row] * (n_p + 1)
            cols += [*range(n_p), n_p + b]
            vals += [*(-power[j, b]), 1.0]
            row_hi.append(float(cost[j, b]))
            row += 1
    matrix = sparse.csr_matrix((vals, (rows, cols)), shape=(row, n_p + n_b))
    objective = np.concatenate([total_kw, -np.ones(n_b)])  # min π·F − Σθ
    col_lo = np.concatenate([lower, np.full(n_b, -np.inf)])
    col_hi = np.concatenate([upper, np.full(n_b, np.inf)])
    result = solve_lp(objective, matrix, np.full(row, -np.inf), np.asarray(row_hi), col_lo, col_hi)
    if not result.status.ok:
        return None
    return result.x[:n_p], -float(objective @ result.x)


def _price_vector(pi: FloatArray, step: _Step, horizon: int, dt_h: float) -> FloatArray:
    """(N,) feeder price [SGD/MWh] of the binding periods' prices π (P,) [SGD/kW]."""
    price = np.zeros(horizon)
    price[step.periods] = pi * KWH_PER_MWH / dt_h
    return price


@dataclass
class _DualState:
    """The dual bundle's centre π̂ (P,) [SGD/kW], its dual value [SGD], the trust radius
    (P,) [SGD/kW] and the best lower bound [SGD]."""

    centre: FloatArray
    centre_value_sgd: float
    radius: FloatArray
    bound_sgd: float


def _evaluate(
    finalize_all: FinalizeAll,
    columns: _Columns,
    pi: FloatArray,
    fixed_caps: FloatArray,
    step: _Step,
    dt_h: float,
) -> tuple[float, FloatArray]:
    """Every building solves at feeder price π; (dual value [SGD], powers (B, P) [kW])."""
    power, cost, lagrangian = finalize_all(
        _price_vector(pi, step, fixed_caps.shape[1], dt_h), fixed_caps
    )
    columns.add(power[:, step.periods], cost)
    value = float(np.sum(lagrangian)) - float(pi @ step.total_kw)
    return (value if np.all(np.isfinite(lagrangian)) else -np.inf), power[:, step.periods]


def _dual_rounds(
    finalize_all: FinalizeAll,
    columns: _Columns,
    state: _DualState,
    fixed_caps: FloatArray,
    step: _Step,
    dt_h: float,
    options: CoordinationOptions,
) -> tuple[FloatArray | None, float, int]:
    """Trust-region bundle on the dual with Dantzig–Wolfe primal recovery.

    Returns the restricted master's combined powers (B, P) [kW] (None if it never became
    feasible), the best lower bound [SGD] and the rounds run."""
    rounds = 0
    last_power: FloatArray | None = None
    combined: tuple[FloatArray, float] | None = None
    for _ in range(options.max_iterations):
        combined = solve_restricted_master(columns, step.total_kw)
        if combined is not None and _gap(combined[1], state.bound_sgd) <= options.gap_tolerance:
            break
        lower = np.maximum(state.centre - state.radius, 0.0)
        model = solve_dual_model(columns, step.total_kw, lower, state.centre + state.radius)
        if model is None:
            break
        predicted = model[1] - state.centre_value_sgd
        scale = abs(combined[1]) if combined is not None else abs(state.centre_value_sgd)
        if predicted <= options.gap_tolerance * max(scale, 1e-9):
            break
        value, power = _evaluate(finalize_all, columns, model[0], fixed_caps, step, dt_h)
        rounds += 1
        state.bound_sgd = max(state.bound_sgd, value)
        if value - state.centre_value_sgd >= SERIOUS_STEP_SHARE * predicted:
            state.centre, state.centre_value_sgd = model[0], value
            state.radius = TRUST_GROWTH * state.radius
        else:
            state.radius = TRUST_SHRINK * state.radius
        moved = np.inf if last_power is None else float(np.max(np.abs(power - last_power)))
        log.debug(
            "dual bundle round %d: bound %.4f, master %.4f, predicted %.4g, moved %.4g kW",
            rounds,
            state.bound_sgd,
            combined[1] if combined is not None else np.nan,
            predicted,
            moved,
        )
        last_power = power
        if moved <= options.plan_tolerance_kw:
            break
    combined = solve_restricted_master(columns, step.total_kw)
    return (None if combined is None else combined[0]), state.bound_sgd, rounds


def _dual_bundle(
    finalize_all: FinalizeAll,
    envelope: _Best,
    free: tuple[FloatArray, FloatArray] | None,
    fixed_caps: FloatArray,
    step: _Step,
    dt_h: float,
    options: CoordinationOptions,
    initial_price: FloatArray | None,
) -> tuple[_Best, int, float]:
    """The dual bundle from the envelope allocation; (best allocation, rounds, bound).

    ``free`` = the uncapped plans (powers (B, N), costs (B,)) when they are feasible for the
    buildings' problems with ``fixed_caps`` (no feeder-infeasible period), else None. The
    first prices are ``initial_price`` (N,) [SGD/MWh] (the previous step's, shifted) where
    it is positive in a binding period, else the envelope's common cap values."""
    columns = _Columns()
    if free is not None:
        columns.add(free[0][:, step.periods], free[1])
    columns.add(envelope.power_kw[:, step.periods], envelope.cost_sgd)
    pi0 = common_cap_value(
        envelope.slopes[:, step.periods], envelope.caps_kw[:, step.periods], step
    )
    if initial_price is not None and np.any(initial_price[step.periods] > 0):
        pi0 = np.maximum(initial_price[step.periods], 0.0) * dt_h / KWH_PER_MWH
    value0, _ = _evaluate(finalize_all, columns, pi0, fixed_caps, step, dt_h)
    floor = max(float(np.mean(pi0)), 1e-6)
    state = _DualState(pi0, value0, np.maximum(pi0, floor), value0)
    combined, bound, rounds = _dual_rounds(
        finalize_all, columns, state, fixed_caps, step, dt_h, options
    )
    zero = np.zeros(fixed_caps.shape[1])
    if combined is not None:
        caps = fixed_caps.copy()
        low = np.clip(combined, step.lower_kw, step.upper_kw)
        caps[:, step.periods] = project_caps_periods(
            np.ascontiguousarray(low.T),
            np.ascontiguousarray(low.T),
            np.ascontiguousarray(step.upper_kw.T),
            step.total_kw,
        ).T
        power, cost, _ = finalize_all(zero, caps)
        if _total(cost) <= envelope.total_sgd:
            return _Best(caps, power, cost, envelope.slopes), rounds + 2, bound
    power, cost, _ = finalize_all(zero, envelope.caps_kw)  # stage the envelope's plans again
    return _Best(envelope.caps_kw, power, cost, envelope.slopes), rounds + 3, bound


def coordinate_caps(
    solve_all: SolveAll,
    finalize_all: FinalizeAll,
    cap_values_all: CapValuesAll,
    limit_kw: FloatArray,
    p_min: FloatArray,
    p_max: FloatArray,
    dt_h: float,
    options: CoordinationOptions,
    initial_price: FloatArray | None = None,
) -> CoordinationResult:
    """Coordinate one step by caps (see the module docstring).

    Parameters
    ----------
    solve_all, finalize_all : the buildings' solves at a feeder price (N,) [SGD/MWh],
        without and with caps (B, N) [kW].
    cap_values_all : (B, N) cap values μ [SGD/kW] of the buildings' last solves.
    limit_kw : (N,) feeder limit F [kW] (inf = none).
    p_min, p_max : (B, N) the buildings' power ranges [kW].
    dt_h : period length [h].
    options : ``scheme`` "envelope", "caps" or "bundle", ``max_iterations`` (rounds),
        ``gap_tolerance``, ``plan_tolerance_kw``.
    initial_price : (N,) feeder prices to start the dual bundle from [SGD/MWh].
    """
    horizon = limit_kw.shape[0]
    zero = np.zeros(horizon)
    infeasible = p_min.sum(axis=0) > limit_kw
    excess = np.where(infeasible, p_min.sum(axis=0) - limit_kw, 0.0)
    may_bind = p_max.sum(axis=0) > limit_kw
    free_power, free_cost, _ = solve_all(zero)
    free_power = np.where(np.isnan(free_power), p_max, free_power)
    caps, capped = keep_or_cap(free_power, free_power, limit_kw, p_min, p_max, may_bind)
    power, cost, _ = finalize_all(zero, caps)
    step = _Step.of(limit_kw, p_min, p_max)
    first_cost, rounds, bound = _total(cost), 0, -np.inf
    best = _Best(caps, power, cost, np.zeros_like(caps))
    if capped and step.periods.size and options.scheme in ("caps", "bundle"):
        best.slopes = cap_values_all()
        if options.scheme == "caps":
            best, rounds, bound, staged = _rounds(finalize_all, cap_values_all, best, step, options)
            if not staged:
                power, cost, _ = finalize_all(zero, best.caps_kw)
                best = _Best(best.caps_kw, power, cost, best.slopes)
        else:
            fixed = np.where(infeasible[None, :], p_min, np.inf) * np.ones_like(p_min)
            free = None if infeasible.any() else (free_power, free_cost)
            best, rounds, bound = _dual_bundle(
                finalize_all, best, free, fixed, step, dt_h, options, initial_price
            )
    final_power = np.where(np.isnan(best.power_kw), p_max, best.power_kw)
    total = _total(best.cost_sgd)
    if not capped:
        bound = total  # the free plans fit: they are optimal for the fleet
    return CoordinationResult(
        power_kw=final_power,
        cost_sgd=best.cost_sgd,
        price_sgd_per_mwh=_feeder_price(
            best.slopes[:, step.periods], best.caps_kw[:, step.periods], step, horizon, dt_h
        ),
        cap_kw=best.caps_kw,
        iterations=rounds,
        lower_bound_sgd=bound,
        gap=_gap(total, bound) if np.isfinite(bound) else float("nan"),
        infeasible=infeasible,
        excess_kw=excess,
        capped=capped,
        cap_rounds=rounds,
        capped_cost_sgd=first_cost if capped else float("nan"),
    )
