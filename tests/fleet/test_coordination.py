"""Coordination of one fleet step against the centralised LP of the whole fleet."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.centralised import solve_centralised
from hvacflex.fleet.coordinate import (
    CoordinationOptions,
    allocate_caps,
    coordinate,
    project_caps,
    project_caps_periods,
    reallocate_caps,
)
from hvacflex.fleet.generate import generate_fleet
from hvacflex.fleet.schema import fleet_from_dict

COORDINATION_GAP = 2.0
"""Stated gap bound for this hard case (08:00, occupancy pull-down, limit 90 % of the
uncoordinated peak): measured 84-155 % above the centralised optimum depending on the
iteration count (docs/guide/fleet.md); at midday steps it is ~4 %. The price iterations are the
weak part; the cap machinery itself is exact (next assertion)."""


@pytest.fixture(scope="module")
def group_at_morning() -> BuildingGroup:
    doc = generate_fleet(4, 3)
    fleet = fleet_from_dict(doc)
    group = BuildingGroup(doc, list(range(4)), FleetSettings.of(fleet, "2014-03-03", 1))
    free = np.full((4, 48), np.inf)
    for _ in range(16):  # to 08:00 with no limit
        group.begin_step()
        group.solve(np.zeros(48))
        group.finalize(np.zeros(48), free)
        group.advance()
    return group


def test_coordinated_plan_feasible_and_near_centralised(group_at_morning: BuildingGroup) -> None:
    group = group_at_morning
    p_min, p_max, price = group.begin_step()
    free_power, _, _ = group.solve(np.zeros(48))
    limit = np.full(48, 0.9 * free_power.sum(axis=0).max())
    central = solve_centralised([a.problem for a in group.agents], limit)
    assert central.status.ok
    assert np.all(central.power_kw.sum(axis=0) <= limit + 1e-6)
    result = coordinate(
        group.solve,
        group.finalize,
        limit,
        p_min,
        p_max,
        price,
        0.5,
        CoordinationOptions(max_iterations=15),
    )
    # the coordinated plan respects the feeder over the whole horizon
    assert np.all(result.power_kw.sum(axis=0) <= limit + 1e-6)
    assert not result.infeasible.any()
    cost = float(np.sum(result.cost_sgd))
    gap = (cost - central.objective_sgd) / abs(central.objective_sgd)
    assert -1e-6 <= gap <= COORDINATION_GAP
    # the dual bound is below the optimum (weak duality, up to solver tolerance)
    assert result.lower_bound_sgd <= central.objective_sgd * (1 + 1e-4)
    # caps allocated from the centralised plan reproduce the centralised optimum exactly
    caps = allocate_caps(limit, p_min, p_max, central.power_kw)
    power, costs, _ = group.finalize(result.price_sgd_per_mwh, caps)
    assert np.all(power.sum(axis=0) <= limit + 1e-6)
    assert float(np.sum(costs)) == pytest.approx(central.objective_sgd, rel=1e-6)


def test_cap_reallocation_lowers_the_cost_and_stays_feasible(
    group_at_morning: BuildingGroup,
) -> None:
    group = group_at_morning
    p_min, p_max, price = group.begin_step()
    free_power, _, _ = group.solve(np.zeros(48))
    limit = np.full(48, 0.9 * free_power.sum(axis=0).max())
    result = coordinate(
        group.solve,
        group.finalize,
        limit,
        p_min,
        p_max,
        price,
        0.5,
        CoordinationOptions(max_iterations=5, cap_rounds=4),
        cap_values_all=group.cap_values,
    )
    assert result.capped and result.cap_rounds > 0
    assert np.all(result.power_kw.sum(axis=0) <= limit + 1e-6)
    assert np.all(result.cap_kw.sum(axis=0) <= limit + 1e-6)
    # the plans staged on the buildings are the returned ones
    for agent, power in zip(group.agents, result.power_kw, strict=True):
        assert agent._staged is not None
        np.testing.assert_allclose(agent._last.power_kw, power, atol=1e-6)  # type: ignore[union-attr]
    # never worse than the first allocation (measured: 83 % → 43 % above the optimum)
    assert float(np.sum(result.cost_sgd)) <= result.capped_cost_sgd * (1 + 1e-9)


def test_finalize_with_values_is_finalize_then_cap_values(
    group_at_morning: BuildingGroup,
) -> None:
    """What run.py sends per reallocation round (one call) equals the two calls it replaced."""
    group = group_at_morning
    p_min, p_max, _ = group.begin_step()
    free_power, _, _ = group.solve(np.zeros(48))
    caps = allocate_caps(np.full(48, 0.8 * free_power.sum(axis=0).max()), p_min, p_max, free_power)
    power, cost, lagrangian, values = group.finalize_with_values(np.zeros(48), caps)
    again = group.finalize(np.zeros(48), caps)
    np.testing.assert_array_equal(power, again[0])
    np.testing.assert_array_equal(cost, again[1])
    np.testing.assert_array_equal(lagrangian, again[2])
    np.testing.assert_array_equal(values, group.cap_values())
    assert values.shape == (4, 48) and np.all(values >= 0) and values.max() > 0


def test_project_caps_periods_is_project_caps_per_period() -> None:
    rng = np.random.default_rng(2)
    lower = rng.uniform(0, 10, (7, 30))
    upper = lower + rng.uniform(1, 40, (7, 30))
    total = 0.5 * (lower.sum(axis=1) + upper.sum(axis=1))
    caps = rng.normal(0, 30, (7, 30))
    together = project_caps_periods(caps, lower, upper, total)
    for k in range(7):
        np.testing.assert_array_equal(
            together[k], project_caps(caps[k], lower[k], upper[k], float(total[k]))
        )
        assert together[k].sum() <= total[k] and together[k].sum() == pytest.approx(total[k])


def test_minimum_powers_above_limit_flagged(group_at_morning: BuildingGroup) -> None:
    group = group_at_morning
    p_min, p_max, price = group.begin_step()
    limit = np.full(48, np.inf)
    limit[:4] = 0.5 * p_min[:, :4].sum(axis=0).max()
    result = coordinate(
        group.solve,
        group.finalize,
        limit,
        p_min,
        p_max,
        price,
        0.5,
        CoordinationOptions(max_iterations=3),
    )
    first = p_min[:, 0].sum() > limit[0]
    assert result.infeasible[0] == first
    if first:
        assert result.excess_kw[0] == pytest.approx(p_min[:, 0].sum() - limit[0])
        np.testing.assert_allclose(result.power_kw[:, 0], p_min[:, 0], atol=1e-4)


def test_allocate_caps_sum_to_limit() -> None:
    rng = np.random.default_rng(0)
    p_min = rng.uniform(0, 10, (5, 6))
    p_max = p_min + rng.uniform(5, 20, (5, 6))
    request = rng.uniform(p_min, p_max)
    limit = np.array([1e3, request.sum(0)[1] * 0.8, p_min.sum(0)[2] * 0.5, 40.0, 60.0, 80.0])
    caps = allocate_caps(limit, p_min, p_max, request)
    for k in range(6):
        if p_max[:, k].sum() <= limit[k]:
            assert np.all(np.isinf(caps[:, k]))
        elif p_min[:, k].sum() >= limit[k]:
            np.testing.assert_allclose(caps[:, k], p_min[:, k])
        else:
            assert caps[:, k].sum() == pytest.approx(limit[k])
            assert np.all(caps[:, k] >= p_min[:, k] - 1e-9)


def test_project_caps_sums_to_limit_within_bounds() -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        lower = rng.uniform(0, 10, 6)
        upper = lower + rng.uniform(0, 20, 6)
        total = float(rng.uniform(lower.sum(), upper.sum()))
        caps = project_caps(rng.normal(0, 30, 6), lower, upper, total)
        assert caps.sum() <= total + 1e-9
        assert caps.sum() == pytest.approx(total, abs=1e-6)
        assert np.all(caps >= lower - 1e-12)
        assert np.all(caps <= upper + 1e-12)


def test_reallocation_moves_cap_to_high_value_buildings() -> None:
    """Toy fleet: building b wants ``want`` kW and pays ``weight`` SGD per kW short of it."""
    want = np.array([[30.0, 30.0], [30.0, 30.0], [30.0, 30.0]])
    weight = np.array([[1.0, 1.0], [5.0, 5.0], [20.0, 20.0]])
    p_min = np.zeros((3, 2))
    p_max = np.full((3, 2), 40.0)
    limit = np.array([60.0, 60.0])
    state: dict[str, np.ndarray] = {}

    def finalize_all(
        price: np.ndarray, caps: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        power = np.minimum(want, caps)
        state["values"] = np.where(caps < want, weight, 0.0)
        cost = (weight * (want - power)).sum(axis=1)
        return power, cost, cost

    first_caps = allocate_caps(limit, p_min, p_max, want)  # equal shares: 20 kW each
    power, cost, _ = finalize_all(np.zeros(2), first_caps)
    caps, power, cost, rounds = reallocate_caps(
        finalize_all,
        lambda: state["values"],
        np.zeros(2),
        (first_caps, power, cost),
        limit,
        p_min,
        p_max,
        CoordinationOptions(cap_rounds=8),
    )
    assert rounds > 0
    assert np.all(caps.sum(axis=0) <= limit + 1e-9)
    assert np.all(power.sum(axis=0) <= limit + 1e-9)
    # the optimum gives the two high-value buildings 30 kW each: cost 30 × 1 per period
    assert cost.sum() < 0.5 * (weight * (want - np.minimum(want, first_caps))).sum()
    assert caps[0, 0] < first_caps[0, 0] and caps[2, 0] > first_caps[2, 0]
