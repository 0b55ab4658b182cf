r"""Feeder coordination of one step: dual decomposition, then power caps (``scheme =
"prices"``, issue 17), and the cap helpers every scheme shares (:func:`allocate_caps`,
:func:`keep_or_cap`, :func:`project_caps`). The default scheme is :mod:`hvacflex.fleet.bundle`.

The fleet's step problem is the buildings' LPs coupled by the feeder rows

.. math:: \sum_b P_{b,k} \le F_k, \qquad k = 0..N-1,

with F the feeder limit times (1 − ``feeder_margin``). Relaxing them with prices
λ_k ≥ 0 [SGD/MWh] separates it: each building solves its own LP with λ added to its energy
price (in parallel, warm-started), and the Lagrangian
``L(λ) = Σ_b J_b(λ) − Δt Σ_k λ_k F_k / 1000`` is a lower bound of the fleet optimum.

Iteration (projected subgradient, sign-adaptive step per period): λ_k ← max(0, λ_k +
α_k (ΣP − F)_k); α_k starts at α₀ = ``step_sgd_per_mwh`` (default: the mean energy price)
per 5 % of the limit, grows ×1.5 while period k's excess keeps its sign and halves when it
flips (prices that must reach the comfort penalty's scale get there in a few
iterations). λ starts from the previous step's prices shifted by one period. Only periods where
the buildings' maximum powers could exceed F carry a price. Stop when the plans are within
``feasibility_tolerance`` (relative) of F and the duality gap
``(Σ_b cost_b − max L) / |Σ_b cost_b|`` is below ``gap_tolerance``, or after
``max_iterations``.

Then the applied plan is made feasible exactly. If the last plans already satisfy every
feeder row they are kept. Otherwise every period that could exceed F gets per-building
caps ``cap_b,k ≥ P_min_b,k`` with ``Σ_b cap_b,k = F_k``: the part of F above the minimum
powers is shared in proportion to each building's requested power above its minimum
(averaged over the second half of the iterations), and each building re-solves once,
warm, with its caps as bounds on its plan's power (``RMPCProblem.power_max_kw``). The
plan therefore satisfies Σ P ≤ F over the whole horizon; its first step is applied. Where the
minimum powers alone exceed F (``feeder_infeasible``), every building runs at its minimum
and the excess is reported.

The averaged requests can be far from the best split of F (morning pull-down). A few
**cap-reallocation rounds** (primal decomposition, ``cap_rounds``) follow: the marginal value
μ_b,k ≥ 0 [SGD/kW] of each building's cap (the dual of its power bound, from its own LP)
says who would gain most from one more kW; caps move from low-μ to high-μ buildings,
stay on Σ_b cap = F and the buildings re-solve in parallel; a round is kept only if the
fleet cost falls (:func:`reallocate_caps`). Every allocation sums to F, so the guarantee
holds after any number of rounds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hvacflex.control.base import FloatArray

CapValuesAll = Callable[[], FloatArray]
"""() → (B, N) marginal values of the caps at the buildings' last solves [SGD/kW]."""
SolveAll = Callable[[FloatArray], tuple[FloatArray, FloatArray, FloatArray]]
"""λ (N,) → (B, N) powers [kW], (B,) costs [SGD], (B,) Lagrangian objectives [SGD]."""
FinalizeAll = Callable[[FloatArray, FloatArray], tuple[FloatArray, FloatArray, FloatArray]]
"""(λ (N,), caps (B, N)) → like :data:`SolveAll`."""

VIOLATION_FLOOR_KW = 1e-6
MAX_PRICE_FACTOR = 2000.0
"""Feeder prices stay below this multiple of the mean energy price (HiGHS loses accuracy on
LPs whose costs span many more orders of magnitude)."""


@dataclass(frozen=True)
class CoordinationOptions:
    max_iterations: int = 25
    gap_tolerance: float = 0.002
    feasibility_tolerance: float = 0.005
    step_sgd_per_mwh: float = 0.0
    cap_rounds: int = 4
    """Cap-reallocation rounds after the caps are first allocated (0 = none)."""
    cap_step_share: float = 0.25
    """First reallocation move: this share of the mean headroom above P_min per building."""
    scheme: str = "bundle"
    """"bundle" (caps by a trust-region bundle, :mod:`hvacflex.fleet.bundle`), "envelope"
    (one proportional cap allocation) or "prices" (this module's price iterations + cap
    reallocation)."""
    plan_tolerance_kw: float = 0.01
    """Bundle: stop when no building's plan moved more than this in a binding period [kW]."""


@dataclass(frozen=True)
class CoordinationResult:
    """Outcome of one step's coordination.

    Attributes
    ----------
    power_kw : (B, N) the coordinated plans' powers [kW] (Σ_b ≤ F wherever feasible).
    cost_sgd : (B,) plan costs without the feeder price [SGD].
    price_sgd_per_mwh : (N,) final feeder prices λ.
    cap_kw : (B, N) caps applied (inf where none).
    iterations : price iterations (building solves per building, caps re-solve excluded).
    lower_bound_sgd : best Lagrangian bound on the fleet optimum [SGD].
    gap : (Σ cost − bound) / |Σ cost|.
    infeasible : (N,) bool, periods where Σ P_min > F.
    excess_kw : (N,) Σ P_min − F where infeasible, else 0.
    capped : whether caps were needed (a re-solve happened).
    cap_rounds : reallocation rounds run (each one solve per building).
    capped_cost_sgd : fleet cost of the first cap allocation [SGD] (NaN if not capped).
    """

    power_kw: FloatArray
    cost_sgd: FloatArray
    price_sgd_per_mwh: FloatArray
    cap_kw: FloatArray
    iterations: int
    lower_bound_sgd: float
    gap: float
    infeasible: np.ndarray
    excess_kw: FloatArray
    capped: bool
    cap_rounds: int = 0
    capped_cost_sgd: float = float("nan")


def allocate_caps(
    limit_kw: FloatArray, p_min: FloatArray, p_max: FloatArray, request_kw: FloatArray
) -> FloatArray:
    """(B, N) caps: Σ_b cap_b,k = F_k with P_min ≤ cap ≤ P_max where Σ P_max > F, else inf.

    ``request_kw`` (B, N) is what each building asked for at the coordinated prices. Below
    the limit the headroom goes to buildings in proportion to their room above the request;
    above it, the limit above the minima is shared in proportion to the request above the
    minimum. Where Σ P_min ≥ F every cap is P_min.
    """
    caps = np.full(p_min.shape, np.inf)
    binding = p_max.sum(axis=0) > limit_kw
    request = np.clip(np.nan_to_num(request_kw, nan=np.inf), p_min, p_max)
    for k in np.flatnonzero(binding):
        f, lo, hi, want = limit_kw[k], p_min[:, k], p_max[:, k], request[:, k]
        if lo.sum() >= f:
            caps[:, k] = lo
        elif want.sum() <= f:
            room = hi - want
            caps[:, k] = want + (f - want.sum()) * room / max(room.sum(), VIOLATION_FLOOR_KW)
        else:
            extra = want - lo
            caps[:, k] = lo + (f - lo.sum()) * extra / max(extra.sum(), VIOLATION_FLOOR_KW)
    return caps


def project_caps(
    caps_kw: FloatArray, lower_kw: FloatArray, upper_kw: FloatArray, total_kw: float
) -> FloatArray:
    """(B,) ``caps_kw`` shifted by one common amount and clipped to [lower, upper] so that
    they sum to ``total_kw`` (never above it; needs Σ lower ≤ total ≤ Σ upper)."""
    projected: FloatArray = project_caps_periods(
        caps_kw[None, :], lower_kw[None, :], upper_kw[None, :], np.array([total_kw])
    )[0]
    return projected


def project_caps_periods(
    caps_kw: FloatArray, lower_kw: FloatArray, upper_kw: FloatArray, total_kw: FloatArray
) -> FloatArray:
    """:func:`project_caps` for P periods at once: rows of (P, B) ``caps_kw``, bounds (P, B),
    totals (P,) [kW]; one bisection on the P shifts together."""
    low = np.min(lower_kw - caps_kw, axis=1)
    high = np.max(upper_kw - caps_kw, axis=1)
    for _ in range(80):  # bisection on the shifts; keeps the side whose sum is ≤ total
        mid = 0.5 * (low + high)
        over = np.clip(caps_kw + mid[:, None], lower_kw, upper_kw).sum(axis=1) > total_kw
        high = np.where(over, mid, high)
        low = np.where(over, low, mid)
    projected: FloatArray = np.clip(caps_kw + low[:, None], lower_kw, upper_kw)
    return projected


def _total_cost(cost_sgd: FloatArray) -> float:
    return float(np.sum(cost_sgd)) if np.all(np.isfinite(cost_sgd)) else np.inf


@dataclass
class _Allocation:
    caps_kw: FloatArray
    power_kw: FloatArray
    cost_sgd: FloatArray
    values: FloatArray

    @property
    def total_sgd(self) -> float:
        return _total_cost(self.cost_sgd)


def reallocate_caps(
    finalize_all: FinalizeAll,
    cap_values_all: CapValuesAll,
    price: FloatArray,
    first: tuple[FloatArray, FloatArray, FloatArray],
    limit_kw: FloatArray,
    p_min: FloatArray,
    p_max: FloatArray,
    options: CoordinationOptions,
) -> tuple[FloatArray, FloatArray, FloatArray, int]:
    """Move cap from buildings that value it little to those that value it much.

    ``first`` = (caps, powers, costs) of the first allocation, (B, N) / (B,). Each round
    shifts every capped period's caps by ``step × (μ_b − mean μ) / max |μ − mean μ|``,
    with μ_b,k ≥ 0 [SGD/kW] the marginal value of building b's cap (the dual of its power
    bound), projects them back onto Σ_b cap = F, cap ∈ [P_min, P_max]
    (:func:`project_caps`) and re-solves every building (warm, in parallel). A round that
    lowers the fleet cost is kept and the step grows ×1.5; otherwise the step halves. The
    kept caps always sum to F, so the plans stay feasible. Returns the best (caps, powers,
    costs) — staged on the buildings — and the rounds run.
    """
    caps, power, cost = first
    periods = np.flatnonzero(np.isfinite(caps).all(axis=0) & (p_min.sum(axis=0) < limit_kw))
    if periods.size == 0 or options.cap_rounds <= 0:
        return caps, power, cost, 0
    best = _Allocation(caps, power, cost, cap_values_all())
    headroom = (limit_kw[periods] - p_min[:, periods].sum(axis=0)) / caps.shape[0]
    step = options.cap_step_share * headroom
    staged_is_best, rounds = True, 0
    for _ in range(options.cap_rounds):
        centred = best.values[:, periods] - best.values[:, periods].mean(axis=0)
        scale = np.abs(centred).max(axis=0)
        move = np.where(scale > 1e-9, centred / np.maximum(scale, 1e-9), 0.0) * step
        if not np.any(move):
            break
        trial = best.caps_kw.copy()
        trial[:, periods] = project_caps_periods(
            np.ascontiguousarray((best.caps_kw[:, periods] + move).T),
            np.ascontiguousarray(p_min[:, periods].T),
            np.ascontiguousarray(p_max[:, periods].T),
            limit_kw[periods],
        ).T
        power, cost, _ = finalize_all(price, trial)
        rounds += 1
        if _total_cost(cost) < best.total_sgd:
            best = _Allocation(trial, power, cost, cap_values_all())
            step, staged_is_best = 1.5 * step, True
        else:
            step, staged_is_best = 0.5 * step, False
    if not staged_is_best:  # stage the best plans again
        power, cost, _ = finalize_all(price, best.caps_kw)
        best = _Allocation(best.caps_kw, power, cost, best.values)
    return best.caps_kw, best.power_kw, best.cost_sgd, rounds


def keep_or_cap(
    power: FloatArray,
    request: FloatArray,
    limit_kw: FloatArray,
    p_min: FloatArray,
    p_max: FloatArray,
    may_bind: np.ndarray,
) -> tuple[FloatArray, bool]:
    """(B, N) caps for the final solve and whether the plans had to be capped."""
    if not may_bind.any() or bool(np.all(power.sum(axis=0) <= limit_kw + VIOLATION_FLOOR_KW)):
        # keep the plans; the first period's caps still bound the applied step (and any
        # fallback): each building's planned power plus an equal share of the spare limit
        caps = np.full(p_min.shape, np.inf)
        if may_bind[0]:
            first = np.maximum(power[:, 0], p_min[:, 0])
            caps[:, 0] = first + max(float(limit_kw[0] - first.sum()), 0.0) / first.size
        return caps, False
    return allocate_caps(limit_kw, p_min, p_max, request), True


def coordinate(
    solve_all: SolveAll,
    finalize_all: FinalizeAll,
    limit_kw: FloatArray,
    p_min: FloatArray,
    p_max: FloatArray,
    energy_price_sgd_per_mwh: FloatArray,
    dt_h: float,
    options: CoordinationOptions,
    initial_price: FloatArray | None = None,
    cap_values_all: CapValuesAll | None = None,
) -> CoordinationResult:
    """Coordinate one step (see the module docstring).

    Parameters
    ----------
    solve_all, finalize_all : the buildings' solves (in parallel behind these calls).
    limit_kw : (N,) feeder limit F over the horizon [kW] (inf = none).
    p_min, p_max : (B, N) the buildings' power ranges [kW].
    energy_price_sgd_per_mwh : (B, N) energy prices (for the default step size).
    dt_h : period length [h].
    initial_price : (N,) λ to start from (e.g. the previous step's, shifted).
    cap_values_all : the buildings' cap values at their last solves; with it, caps are
        reallocated for ``options.cap_rounds`` rounds (:func:`reallocate_caps`).
    """
    horizon = limit_kw.shape[0]
    may_bind = p_max.sum(axis=0) > limit_kw
    infeasible = p_min.sum(axis=0) > limit_kw
    excess = np.where(infeasible, p_min.sum(axis=0) - limit_kw, 0.0)
    finite_limit = np.where(np.isfinite(limit_kw), limit_kw, 0.0)
    price = np.zeros(horizon) if initial_price is None else np.maximum(initial_price, 0.0)
    price = np.where(may_bind & ~infeasible, price, 0.0)
    alpha0 = options.step_sgd_per_mwh or float(np.mean(np.abs(energy_price_sgd_per_mwh)))
    scale_kw = max(0.05 * float(np.mean(finite_limit[may_bind])) if may_bind.any() else 1.0, 1.0)
    best_bound = -np.inf
    history: list[FloatArray] = []
    iterations = 0
    power = p_max
    cost = np.zeros(p_min.shape[0])
    step = np.full(horizon, alpha0 / scale_kw)
    price_max = MAX_PRICE_FACTOR * alpha0
    last_sign = np.zeros(horizon)
    active = may_bind & ~infeasible
    for t in range(1, options.max_iterations + 1):
        iterations = t
        power, cost, lagrangian = solve_all(price)
        power = np.where(np.isnan(power), p_max, power)
        history.append(power)
        if np.all(np.isfinite(lagrangian)):  # a bound only when every building solved
            bound = float(np.sum(lagrangian)) - dt_h * float(price @ finite_limit) / 1000.0
            best_bound = max(best_bound, bound)
        over = np.where(active, power.sum(axis=0) - limit_kw, 0.0)
        relative = float(np.max(over / np.maximum(finite_limit, VIOLATION_FLOOR_KW), initial=0.0))
        primal = float(np.nansum(cost))
        gap = (primal - best_bound) / max(abs(primal), 1e-9)
        if not active.any() or (
            relative <= options.feasibility_tolerance and gap <= options.gap_tolerance
        ):
            break
        # sign-adaptive step per period: grow while the excess keeps its sign, halve on a flip
        sign = np.sign(np.where(price > 0, over, np.maximum(over, 0.0)))
        step = np.where(
            sign * last_sign > 0, 1.5 * step, np.where(sign * last_sign < 0, 0.5 * step, step)
        )
        last_sign = np.where(sign != 0, sign, last_sign)
        price = np.where(active, np.clip(price + step * over, 0.0, price_max), 0.0)
    request = np.mean(history[len(history) // 2 :], axis=0)
    caps, capped = keep_or_cap(power, request, limit_kw, p_min, p_max, may_bind)
    final_power, final_cost, _ = finalize_all(price, caps)
    capped_cost, rounds = np.nan, 0
    if capped and cap_values_all is not None:
        capped_cost = _total_cost(final_cost)
        caps, final_power, final_cost, rounds = reallocate_caps(
            finalize_all,
            cap_values_all,
            price,
            (caps, final_power, final_cost),
            limit_kw,
            p_min,
            p_max,
            options,
        )
    final_power = np.where(np.isnan(final_power), p_max, final_power)
    primal = float(np.nansum(final_cost))
    return CoordinationResult(
        power_kw=final_power,
        cost_sgd=final_cost,
        price_sgd_per_mwh=price,
        cap_kw=caps,
        iterations=iterations,
        lower_bound_sgd=best_bound,
        gap=(primal - best_bound) / max(abs(primal), 1e-9),
        infeasible=infeasible,
        excess_kw=excess,
        capped=capped,
        cap_rounds=rounds,
        capped_cost_sgd=capped_cost,
    )
