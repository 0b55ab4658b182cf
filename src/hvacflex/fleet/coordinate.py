r"""Feeder coordination of one step: dual decomposition, then power caps.

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
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hvacflex.control.base import FloatArray

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
    feasible = not may_bind.any() or bool(
        np.all(power.sum(axis=0) <= limit_kw + VIOLATION_FLOOR_KW)
    )
    if feasible:
        # keep the plans; the first period's caps still bound the applied step (and any
        # fallback): each building's planned power plus an equal share of the spare limit
        caps = np.full(p_min.shape, np.inf)
        if may_bind[0]:
            first = np.maximum(power[:, 0], p_min[:, 0])
            caps[:, 0] = first + max(float(limit_kw[0] - first.sum()), 0.0) / first.size
        capped = False
    else:
        caps = allocate_caps(limit_kw, p_min, p_max, request)
        capped = True
    final_power, final_cost, _ = finalize_all(price, caps)
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
    )
