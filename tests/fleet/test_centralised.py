"""The centralised LP: its warm-started solver across steps and the objective split."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.centralised import CentralisedSolver, solve_centralised, stacked_lp
from hvacflex.fleet.compare import reference_limit_kw
from hvacflex.fleet.generate import generate_fleet, write_fleet
from hvacflex.fleet.schema import load_fleet_document


@pytest.fixture(scope="module")
def short_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tight fleet planning over 6 h (small LPs: the warm start and Dask tests)."""
    doc = generate_fleet(2, 3, feeder_limit_kw=75.0)
    doc["horizon_steps"] = 12
    return write_fleet(doc, tmp_path_factory.mktemp("short") / "fleet.toml")


def test_the_warm_centralised_solver_finds_the_cold_optimum(short_fleet: Path) -> None:
    fleet, document = load_fleet_document(short_fleet)
    settings = FleetSettings.of(fleet, "2014-03-03T08:00", 1.0)
    group = BuildingGroup(document, [0, 1], settings)
    solver = CentralisedSolver()
    limit = np.full(settings.horizon_steps, 75.0)
    objectives = []
    for _ in range(3):
        p_min, _, _ = group.begin_step()
        problems = group.problems()
        warm = solver.solve(problems, reference_limit_kw(limit, p_min))
        cold = solve_centralised(problems, reference_limit_kw(limit, p_min))
        np.testing.assert_allclose(warm.objective_sgd, cold.objective_sgd, rtol=1e-7)
        objectives.append(warm)
        price = np.zeros(settings.horizon_steps)
        for agent in group.agents:  # stage each building's own optimum, then advance
            agent.finalize(price, np.full(settings.horizon_steps, np.inf))
            own = agent.staged_split_sgd()
            solution = agent._staged
            assert solution is not None
            np.testing.assert_allclose(own.sum(), solution.objective_sgd, rtol=1e-9)
            np.testing.assert_allclose(own[0], solution.energy_cost_sgd + solution.peak_charge_sgd)
            np.testing.assert_allclose(own[2], solution.comfort_penalty_sgd)
        group.advance()
    assert [r.warm_start for r in objectives] == [False, True, True]
    assert np.mean([r.iterations for r in objectives[1:]]) < 0.5 * objectives[0].iterations


def test_a_stacked_lp_solves_to_the_centralised_optimum(short_fleet: Path) -> None:
    fleet, document = load_fleet_document(short_fleet)
    settings = FleetSettings.of(fleet, "2014-03-03T08:00", 1.0)
    group = BuildingGroup(document, [0, 1], settings)
    p_min, _, _ = group.begin_step()
    problems = group.problems()
    limit = reference_limit_kw(np.full(settings.horizon_steps, 75.0), p_min)
    stacked = stacked_lp(problems, limit)
    result = stacked.solve()
    reference = solve_centralised(problems, limit)
    assert result.status.ok and reference.status.ok
    np.testing.assert_allclose(stacked.cost @ result.x, reference.objective_sgd, rtol=1e-9)
    power = np.sum([result.x[cols] for cols in stacked.power_cols], axis=0)
    assert np.all(power <= limit + 1e-6)  # the feeder rows hold
