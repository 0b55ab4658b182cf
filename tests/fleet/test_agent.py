"""The fleet's building agents: the run's first solves start from a template building's basis,
and the results do not depend on how the buildings are grouped."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.generate import generate_fleet
from hvacflex.fleet.schema import fleet_from_dict
from hvacflex.opt import SolverBasis, solve_rmpc

START = "2014-03-03 08:00"


def _first_solves(
    doc: dict[str, object], indices: list[int]
) -> tuple[BuildingGroup, np.ndarray, np.ndarray]:
    fleet = fleet_from_dict(doc)
    group = BuildingGroup(doc, indices, FleetSettings.of(fleet, START, 1))
    group.begin_step()
    power, cost, _ = group.solve(np.zeros(48))
    return group, power, cost


@pytest.fixture(scope="module")
def doc() -> dict[str, object]:
    return generate_fleet(3, 3)


def test_first_solves_are_seeded_and_independent_of_the_grouping(doc: dict[str, object]) -> None:
    whole, power_all, cost_all = _first_solves(doc, [0, 1, 2])
    _, power_part, cost_part = _first_solves(doc, [2, 1])  # building 0 held elsewhere
    np.testing.assert_array_equal(power_part, power_all[[2, 1]])
    np.testing.assert_array_equal(cost_part, cost_all[[2, 1]])
    for agent in whole.agents[1:]:
        seeded = agent._last
        assert seeded is not None and seeded.warm_start
        cold = solve_rmpc(agent.problem)
        assert seeded.objective_sgd == pytest.approx(cold.objective_sgd, rel=1e-9, abs=1e-6)
        assert seeded.simplex_iterations < 0.5 * cold.simplex_iterations


def test_a_basis_of_another_size_is_refused_and_the_solve_starts_cold(
    doc: dict[str, object],
) -> None:
    fleet = fleet_from_dict(doc)
    group = BuildingGroup(doc, [1], FleetSettings.of(fleet, START, 1))
    group.begin_step()
    agent = group.agents[0]
    other = SolverBasis("other", np.ones(3, dtype=np.int8), np.zeros(2, dtype=np.int8))
    assert not agent.controller.seed_basis(agent.problem, other)
    power, _, _ = group.solve(np.zeros(48))
    assert agent._last is not None and not agent._last.warm_start
    assert np.all(np.isfinite(power))
