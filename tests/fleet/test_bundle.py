"""The cap coordination schemes (envelope, cap-space bundle, dual bundle) against an
independent LP of the whole fleet (scipy's ``linprog``) on buildings whose optimal plans are
known in closed form."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import linprog

from hvacflex.fleet.bundle import (
    _Columns,
    coordinate_caps,
    solve_dual_model,
    solve_restricted_master,
)
from hvacflex.fleet.coordinate import CoordinationOptions, CoordinationResult

DT_H = 0.5


class ToyFleet:
    """B buildings, N periods; building b's cost in period k is
    ``e_k P + a_b,k max(0, d_b,k − P)`` (energy + a linear comfort penalty for power below
    its demand d) with P ∈ [lo, hi] and P ≤ cap. At a feeder price π [SGD/kW] the optimum
    is P = clip(d, lo, min(hi, cap)) when a > e + π, else lo (closed form, per period)."""

    def __init__(self, seed: int, buildings: int = 4, horizon: int = 6) -> None:
        rng = np.random.default_rng(seed)
        self.lo = rng.uniform(1.0, 3.0, (buildings, horizon))
        self.hi = self.lo + rng.uniform(10.0, 20.0, (buildings, horizon))
        self.d = self.lo + rng.uniform(2.0, 18.0, (buildings, horizon))
        self.a = rng.uniform(1.0, 10.0, (buildings, horizon))
        self.e = rng.uniform(0.05, 0.2, horizon)
        self.values = np.zeros((buildings, horizon))
        self.solves = 0

    def _solve(self, price: np.ndarray, caps: np.ndarray) -> tuple[np.ndarray, ...]:
        self.solves += 1
        pi = price * DT_H / 1000.0  # SGD/MWh → SGD/kW of the period
        top = np.minimum(self.hi, np.maximum(caps, self.lo))
        worth = self.a > self.e + pi
        power = np.where(worth, np.clip(self.d, self.lo, top), self.lo)
        cost = (self.e * power + self.a * np.maximum(self.d - power, 0.0)).sum(axis=1)
        lagrangian = cost + (pi * power).sum(axis=1)
        capped = worth & (top < self.d) & (caps < self.hi)
        self.values = np.where(capped, self.a - self.e - pi, 0.0)
        return power, cost, lagrangian

    def solve_all(self, price: np.ndarray) -> tuple[np.ndarray, ...]:
        return self._solve(price, np.full(self.lo.shape, np.inf))

    def finalize_all(self, price: np.ndarray, caps: np.ndarray) -> tuple[np.ndarray, ...]:
        return self._solve(price, caps)

    def cap_values_all(self) -> np.ndarray:
        return self.values

    def coordinate(self, limit: np.ndarray, options: CoordinationOptions) -> CoordinationResult:
        """:func:`coordinate_caps` of this fleet under the feeder ``limit`` (N,) [kW]."""
        return coordinate_caps(
            self.solve_all,
            self.finalize_all,
            self.cap_values_all,
            limit,
            self.lo,
            self.hi,
            DT_H,
            options,
        )

    def optimum(self, limit: np.ndarray) -> float:
        """The fleet optimum by linprog: columns P (B·N) and shortfalls s ≥ d − P (B·N)."""
        n = self.lo.size
        cost = np.concatenate([np.broadcast_to(self.e, self.lo.shape).ravel(), self.a.ravel()])
        shortfall = np.hstack([-np.eye(n), -np.eye(n)])  # −P − s ≤ −d
        horizon = self.lo.shape[1]
        coupling = np.hstack([np.tile(np.eye(horizon), self.lo.shape[0]), np.zeros((horizon, n))])
        bounds = [*zip(self.lo.ravel(), self.hi.ravel(), strict=True)] + [(0, None)] * n
        result = linprog(
            cost,
            A_ub=np.vstack([shortfall, coupling]),
            b_ub=np.concatenate([-self.d.ravel(), limit]),
            bounds=bounds,
            method="highs",
        )
        assert result.status == 0
        return float(result.fun)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dual_bundle_reaches_the_fleet_optimum_and_respects_the_limit(seed: int) -> None:
    fleet = ToyFleet(seed)
    limit = 0.6 * fleet.d.sum(axis=0)  # binds in every period
    options = CoordinationOptions(max_iterations=40, gap_tolerance=1e-4, scheme="bundle")
    result = fleet.coordinate(limit, options)
    optimum = fleet.optimum(limit)
    total = float(result.cost_sgd.sum())
    assert total == pytest.approx(optimum, rel=1e-3)
    assert np.all(result.power_kw.sum(axis=0) <= limit + 1e-9)
    assert result.lower_bound_sgd <= optimum + 1e-6  # a true lower bound
    envelope = fleet.coordinate(limit, replace(options, scheme="envelope"))
    assert total <= float(envelope.cost_sgd.sum()) + 1e-9


def test_cap_space_bundle_never_worse_than_the_envelope() -> None:
    fleet = ToyFleet(5)
    limit = 0.6 * fleet.d.sum(axis=0)
    caps = fleet.coordinate(limit, CoordinationOptions(max_iterations=20, scheme="caps"))
    envelope = fleet.coordinate(limit, CoordinationOptions(scheme="envelope"))
    assert caps.cost_sgd.sum() <= envelope.cost_sgd.sum() + 1e-9
    assert caps.cost_sgd.sum() >= fleet.optimum(limit) - 1e-6
    assert np.all(caps.power_kw.sum(axis=0) <= limit + 1e-9)


def test_free_plans_that_fit_are_kept_after_one_solve() -> None:
    fleet = ToyFleet(3)
    limit = 2.0 * fleet.hi.sum(axis=0)
    result = fleet.coordinate(limit, CoordinationOptions())
    assert not result.capped and result.iterations == 0
    assert result.cost_sgd.sum() == pytest.approx(fleet.optimum(limit))
    assert fleet.solves == 2  # the free solve and its staging


def test_infeasible_periods_put_every_building_at_its_minimum() -> None:
    fleet = ToyFleet(4)
    limit = 0.6 * fleet.d.sum(axis=0)
    limit[2] = 0.5 * fleet.lo[:, 2].sum()  # the minima alone exceed it
    result = fleet.coordinate(limit, CoordinationOptions(max_iterations=30))
    assert result.infeasible[2] and result.infeasible.sum() == 1
    assert result.excess_kw[2] == pytest.approx(fleet.lo[:, 2].sum() - limit[2])
    np.testing.assert_allclose(result.power_kw[:, 2], fleet.lo[:, 2], atol=1e-6)
    others = np.arange(limit.size) != 2
    assert np.all(result.power_kw.sum(axis=0)[others] <= limit[others] + 1e-9)


def test_restricted_master_by_hand() -> None:
    # two buildings, one period, F = 10: building 0 has plans (P 8, cost 1) and (P 2, cost 5),
    # building 1 has (P 6, cost 2) and (P 4, cost 3). Mixing: the cheapest use of 10 kW is
    # building 0 at 8·w + 2·(1 − w) with building 1 at 4 (cost 3) → 6w + 2 + 4 ≤ 10 → w = 2/3;
    # cost 3 + (1·2/3 + 5/3) = 5.333…, against building 1 at 6: 6w + 2 ≤ 4 → w = 1/3,
    # cost 2 + 1/3 + 10/3 = 5.667. So 16/3.
    columns = _Columns()
    columns.add(np.array([[8.0], [6.0]]), np.array([1.0, 2.0]))
    columns.add(np.array([[2.0], [4.0]]), np.array([5.0, 3.0]))
    found = solve_restricted_master(columns, np.array([10.0]))
    assert found is not None
    combined, cost = found
    assert cost == pytest.approx(16.0 / 3.0)
    np.testing.assert_allclose(combined.ravel(), [6.0, 4.0], atol=1e-9)
    # the dual model's maximum equals the master's minimum (LP duality) when unboxed
    model = solve_dual_model(columns, np.array([10.0]), np.zeros(1), np.full(1, 100.0))
    assert model is not None
    assert model[1] == pytest.approx(16.0 / 3.0)
    assert model[0][0] == pytest.approx(2.0 / 3.0)  # the slope of building 0's mix
