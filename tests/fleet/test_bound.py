"""The comfort bound (``fleet bound``) and the limit windows checked before a run."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.control.plan_linearisation import plan_affine_shift, plan_input_scale
from hvacflex.fleet.agent import BuildingGroup
from hvacflex.fleet.bound import (
    BOUND_COLUMNS,
    BOUND_FILE,
    bound_fleet,
    budgeted_bound,
    check_limit_windows,
    comfort_bound,
    least_energy_for_comfort,
    limit_window_shortfalls,
    run_model,
    run_settings,
    unlimited_energy_kwh,
)
from hvacflex.fleet.generate import generate_fleet, write_fleet
from hvacflex.fleet.schema import FleetConfigError, load_fleet_document

START = "2014-03-03"  # a Monday


def _fleet(tmp_path: Path, windows: list[dict[str, object]], name: str = "f.toml") -> Path:
    doc = generate_fleet(2, 3, feeder_limit_kw=float("inf"), min_bid_mw=0.1)
    doc["feeder_limits"] = windows
    return write_fleet(doc, tmp_path / name)


@pytest.fixture(scope="module")
def unlimited(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    path = _fleet(tmp_path_factory.mktemp("bound"), [])
    fleet, document = load_fleet_document(path)
    return path, run_model(fleet, document, START, 1.0)


def test_the_run_model_covers_the_run_with_the_limit_in_force(tmp_path: Path) -> None:
    path = _fleet(tmp_path, [{"start": "10:00", "end": "17:00", "limit_kw": 500.0}])
    fleet, document = load_fleet_document(path)
    model = run_model(fleet, document, START, 1.0)
    assert model.p_min_kw.shape == (2, 48) and len(model.problems) == 2
    assert all(p.horizon == 48 for p in model.problems)
    inside = (model.index.hour >= 10) & (model.index.hour < 17)
    np.testing.assert_array_equal(model.planning_kw, np.where(inside, 500.0, np.inf))


def test_the_bound_counts_the_band_itself_whatever_the_plans_lower_margin(
    tmp_path: Path, unlimited: tuple[Path, object]
) -> None:
    """``lower_plan_margin_k`` moves the plans, not the band the bound grades against."""
    doc = generate_fleet(2, 3, feeder_limit_kw=float("inf"), min_bid_mw=0.1)
    doc["lower_plan_margin_k"] = 0.4
    fleet, document = load_fleet_document(write_fleet(doc, tmp_path / "margin.toml"))
    assert fleet.spec.lower_plan_margin_k == 0.4
    margin = run_model(fleet, document, START, 1.0)
    _, plain = unlimited
    for with_margin, without in zip(margin.problems, plain.problems, strict=True):  # type: ignore[attr-defined]
        np.testing.assert_array_equal(with_margin.y_min, without.y_min)


def test_the_bound_grades_the_nights_against_the_band_not_the_plans_margin(
    unlimited: tuple[Path, object],
) -> None:
    """The plans keep ``unoccupied_plan_margin_k`` (0.5 K) below the unoccupied upper bound;
    the bound's LP takes the band itself, as ``results.parquet`` counts discomfort."""
    _, model = unlimited
    doc = generate_fleet(2, 3, feeder_limit_kw=float("inf"), min_bid_mw=0.1)
    for problem, entry in zip(model.problems, doc["buildings"], strict=True):  # type: ignore[attr-defined]
        lower_degc, upper_degc = entry["comfort_unoccupied_degc"]
        assert np.max(problem.y_max) == upper_degc
        assert np.min(problem.y_min) == lower_degc


def test_a_tighter_limit_never_lowers_the_bound(unlimited: tuple[Path, object]) -> None:
    _, model = unlimited
    free = comfort_bound(model)  # type: ignore[arg-type]
    assert free.feasible and free.raised_periods == 0
    assert np.all(free.discomfort_kelvin_hours >= 0)
    minimum = model.p_min_kw.sum(axis=0)  # type: ignore[attr-defined]
    # a limit a little above the minimum all afternoon: feasible, never less discomfort
    tight = np.full(48, np.inf)
    tight[24:36] = minimum[24:36].max() + 1.0
    limited = comfort_bound(_with_limit(model, tight))
    assert limited.feasible
    assert np.all(limited.discomfort_kelvin_hours >= free.discomfort_kelvin_hours - 1e-6)
    assert limited.discomfort_kelvin_hours.sum() > free.discomfort_kelvin_hours.sum() + 1e-3
    # per period, summed over the run, is the total
    np.testing.assert_allclose(
        limited.per_period_kelvin_hours.sum(axis=1), limited.discomfort_kelvin_hours
    )


def test_an_energy_budget_trades_discomfort_for_energy(unlimited: tuple[Path, object]) -> None:
    _, model = unlimited
    minimum = model.p_min_kw.sum(axis=0)  # type: ignore[attr-defined]
    limited = _afternoon_limited(model)
    free_kwh = unlimited_energy_kwh(model)  # type: ignore[arg-type]
    assert free_kwh > 0.5 * minimum.sum()
    bound = comfort_bound(limited)  # type: ignore[arg-type]
    no_budget = budgeted_bound(limited, np.inf)  # type: ignore[arg-type]
    assert no_budget.solved and no_budget.max_excursion_k is None
    np.testing.assert_allclose(
        no_budget.bound.discomfort_kelvin_hours, bound.discomfort_kelvin_hours, atol=1e-5
    )
    totals = []
    for budget_kwh in (1.0 * free_kwh, 0.9 * free_kwh):
        point = budgeted_bound(limited, budget_kwh)  # type: ignore[arg-type]
        assert point.solved and point.energy_kwh <= budget_kwh + 1e-3
        assert point.energy_kwh == pytest.approx(0.5 * point.power_kw.sum())
        totals.append(point.bound.discomfort_kelvin_hours.sum())
    # less energy never buys less discomfort, and the tighter budget binds
    assert bound.discomfort_kelvin_hours.sum() - 1e-5 <= totals[0] < totals[1] - 1e-3
    # below the buildings' minimum energy no plan exists
    assert not budgeted_bound(limited, 0.5 * 0.5 * minimum.sum()).solved  # type: ignore[arg-type]


def test_the_least_energy_meeting_a_comfort_target(unlimited: tuple[Path, object]) -> None:
    _, model = unlimited
    limited = _afternoon_limited(model)
    bound = comfort_bound(limited).discomfort_kelvin_hours  # type: ignore[arg-type]
    allowed = bound + 0.5
    point = least_energy_for_comfort(limited, allowed)  # type: ignore[arg-type]
    assert point.solved and np.isinf(point.budget_kwh)
    assert np.all(point.bound.discomfort_kelvin_hours <= allowed + 1e-6)
    # no plan within less energy meets the target: a budget 1 % below it costs comfort
    below = budgeted_bound(limited, 0.99 * point.energy_kwh)  # type: ignore[arg-type]
    assert below.bound.discomfort_kelvin_hours.sum() > allowed.sum() + 1e-4
    # a target whose sum is below the bound's has no plan (the bound minimises the sum)
    assert bound.min() > 0.1
    assert not least_energy_for_comfort(limited, bound - 0.05).solved  # type: ignore[arg-type]


def test_an_excursion_cap_bounds_every_zone_slack(unlimited: tuple[Path, object]) -> None:
    _, model = unlimited
    free_kwh = unlimited_energy_kwh(model)  # type: ignore[arg-type]
    loose = budgeted_bound(model, 0.9 * free_kwh)  # type: ignore[arg-type]
    cap = 0.5 * loose.largest_slack_k
    capped = budgeted_bound(model, 0.9 * free_kwh, max_excursion_k=cap)  # type: ignore[arg-type]
    assert loose.largest_slack_k > 0.1
    assert capped.solved and capped.largest_slack_k <= cap + 1e-6
    total = capped.bound.discomfort_kelvin_hours.sum()
    assert total >= loose.bound.discomfort_kelvin_hours.sum() - 1e-5


def test_a_limit_below_the_minimum_is_raised_and_not_feasible(
    unlimited: tuple[Path, object],
) -> None:
    _, model = unlimited
    minimum = model.p_min_kw.sum(axis=0)  # type: ignore[attr-defined]
    below = np.full(48, np.inf)
    below[30] = minimum[30] - 5.0
    result = comfort_bound(_with_limit(model, below))
    assert not result.feasible and result.raised_periods == 1
    assert np.isfinite(result.discomfort_kelvin_hours).all()


def _afternoon_limited(model: object) -> object:
    """``model`` with a limit 1 kW above the fleet's minimum power from 12:00 to 18:00."""
    minimum = model.p_min_kw.sum(axis=0)  # type: ignore[attr-defined]
    tight = np.full(48, np.inf)
    tight[24:36] = minimum[24:36].max() + 1.0
    return _with_limit(model, tight)


def _with_limit(model: object, planning_kw: np.ndarray) -> object:
    import dataclasses

    return dataclasses.replace(model, planning_kw=planning_kw)  # type: ignore[type-var]


def test_windows_below_the_minimum_are_refused_with_the_numbers(
    unlimited: tuple[Path, object], tmp_path: Path
) -> None:
    _, model = unlimited
    minimum = model.p_min_kw.sum(axis=0)  # type: ignore[attr-defined]
    afternoon = float(minimum[28:32].max())
    low = round(afternoon - 10.0, 1)
    path = _fleet(
        tmp_path,
        [
            {"start": "00:00", "end": "02:00", "limit_kw": 10_000.0},  # met
            {"start": "14:00", "end": "16:00", "limit_kw": low},  # below the minimum
        ],
    )
    fleet, document = load_fleet_document(path)
    shortfalls = limit_window_shortfalls(fleet, run_model(fleet, document, START, 1.0))
    assert [s.position for s in shortfalls] == [1]
    assert shortfalls[0].minimum_kw == pytest.approx(afternoon)
    assert shortfalls[0].limit_kw == low
    with pytest.raises(FleetConfigError) as error:
        check_limit_windows(fleet, document, START, 1.0, allow=False)
    text = str(error.value)
    assert "feeder_limits[1].limit_kw" in text and f"{low:.1f} kW" in text
    assert f"{afternoon:.1f} kW" in text and "--allow-infeasible-limits" in text
    warnings = check_limit_windows(fleet, document, START, 1.0, allow=True)
    assert len(warnings) == 1 and "flagged infeasible" in warnings[0]
    # a Saturday: the weekday window is not in force, nothing to refuse
    assert check_limit_windows(fleet, document, "2014-03-08", 1.0, allow=False) == []


def test_simulate_refuses_an_infeasible_window_and_runs_it_flagged_when_allowed(
    unlimited: tuple[Path, object], tmp_path: Path
) -> None:
    _, model = unlimited
    minimum = model.p_min_kw.sum(axis=0)  # type: ignore[attr-defined]
    low = round(float(minimum[28:30].min()) - 5.0, 1)
    assert low > 0
    path = _fleet(tmp_path, [{"start": "14:00", "end": "15:00", "limit_kw": low}])
    args = ["fleet", "simulate", "--fleet", str(path), "--start", f"{START}T14:00"]
    args += ["--days", "0.0625"]
    args += ["--workers", "0", "--out", str(tmp_path / "run")]
    runner = CliRunner()
    done = runner.invoke(app, args)
    assert done.exit_code == 2, done.output
    assert "feeder_limits[0].limit_kw" in done.output and "Traceback" not in done.output
    assert "minimum feasible power" in done.output and f"{low:.1f} kW" in done.output
    assert not (tmp_path / "run" / "results.parquet").exists()
    done = runner.invoke(app, [*args, "--allow-infeasible-limits"])
    assert done.exit_code == 0, done.output
    assert "flagged infeasible" in done.output
    frame = pd.read_parquet(tmp_path / "run" / "results.parquet")
    # the limit in force each period: the window's over 14:00–15:00, none after it
    np.testing.assert_array_equal(frame["feeder_limit_kw"].to_numpy(), [low, low, np.inf])
    assert frame["feeder_infeasible"].iloc[:2].all()


def test_bound_cli_writes_bound_csv(tmp_path: Path) -> None:
    path = _fleet(tmp_path, [{"start": "10:00", "end": "17:00", "limit_kw": 10_000.0}])
    out = tmp_path / "bound"
    args = ["fleet", "bound", "--fleet", str(path), "--start", START, "--days", "1"]
    done = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert done.exit_code == 0, done.output
    frame = pd.read_csv(out / BOUND_FILE)
    assert tuple(frame.columns) == BOUND_COLUMNS
    assert list(frame["building"]) == ["b0000", "b0001"] and frame["feasible"].all()
    assert (frame["discomfort_kelvin_hours"] >= 0).all()
    done = CliRunner().invoke(app, [*args[:-1], "8", "--out", str(tmp_path / "b8")])
    assert done.exit_code == 2 and "--days" in done.output and "Traceback" not in done.output


def test_bound_cli_within_an_energy_budget_and_an_excursion_cap(tmp_path: Path) -> None:
    path = _fleet(tmp_path, [{"start": "10:00", "end": "17:00", "limit_kw": 10_000.0}])
    args = ["fleet", "bound", "--fleet", str(path), "--start", START, "--days", "1"]
    free = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "free")])
    capped = [*args, "--out", str(tmp_path / "capped"), "--energy-budget-pct", "0"]
    done = CliRunner().invoke(app, [*capped, "--max-excursion-k", "0.5"])
    assert free.exit_code == 0 and done.exit_code == 0, done.output
    assert "the plan's energy" in done.output and "largest zone slack" in done.output
    loose = pd.read_csv(tmp_path / "free" / BOUND_FILE)["discomfort_kelvin_hours"]
    tight = pd.read_csv(tmp_path / "capped" / BOUND_FILE)
    assert tuple(tight.columns) == BOUND_COLUMNS and tight["feasible"].all()
    assert (tight["discomfort_kelvin_hours"] >= loose - 1e-6).all()
    for bad in (["--energy-budget-pct", "-5"], ["--max-excursion-k", "nan"]):
        done = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "bad"), *bad])
        assert done.exit_code == 2 and "Traceback" not in done.output


def test_a_budget_without_an_unlimited_plan_to_measure_it_by_is_a_solver_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.fleet.bound as bound_module
    from hvacflex.errors import SolverError

    path = _fleet(tmp_path, [{"start": "10:00", "end": "17:00", "limit_kw": 10_000.0}])
    monkeypatch.setattr(bound_module, "unlimited_energy_kwh", lambda model: float("nan"))
    with pytest.raises(SolverError, match="unlimited plan"):
        bound_module.budgeted_fleet_bound(
            path, START, 1, tmp_path / "out", energy_budget_pct=5.0, max_excursion_k=None
        )
    assert not (tmp_path / "out" / BOUND_FILE).exists()  # nothing written


def _replay_script(monkeypatch: pytest.MonkeyPatch) -> Any:
    """``scripts/fleet_plan_replay.py`` as a module (it imports ``peak_bound_replay`` beside it)."""
    import importlib.util

    scripts = Path(__file__).parents[2] / "scripts"
    monkeypatch.syspath_prepend(str(scripts))
    spec = importlib.util.spec_from_file_location(
        "fleet_plan_replay", scripts / "fleet_plan_replay.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_replay_s_relinearisation_is_the_closed_loop_s(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``along`` at every step's T₀ gives the fixed problem back; elsewhere its input scale
    and affine shift are :mod:`hvacflex.control.plan_linearisation`'s and its power rows the
    design curves' at those temperatures."""
    script = _replay_script(monkeypatch)
    fleet, document = load_fleet_document(_fleet(tmp_path, []))
    group = BuildingGroup(document, [0], run_settings(fleet, START, 1.0))
    group.begin_step()
    agent = group.agents[0]
    problem, model = agent.problem, agent.controller.contract.model
    at_t0 = np.full((problem.horizon, problem.ny), model.linearisation_temp_degc)
    same = script.along(problem, agent, at_t0)
    np.testing.assert_allclose(same.step_linearisation.input_scale, 1.0)
    np.testing.assert_allclose(
        np.broadcast_to(same.affine_term, (problem.horizon, problem.a_matrix.shape[0])),
        np.broadcast_to(problem.affine_term, (problem.horizon, problem.a_matrix.shape[0])),
        atol=1e-12,
    )
    np.testing.assert_allclose(same.power_offset_kw, problem.power_offset_kw, rtol=1e-12)
    np.testing.assert_allclose(same.power_coeff_kw_per_kg_s, problem.power_coeff_kw_per_kg_s)
    warmer = at_t0 + 1.5
    moved = script.along(problem, agent, warmer)
    scale = plan_input_scale(model, warmer)
    np.testing.assert_array_equal(moved.step_linearisation.input_scale, scale)
    shift = plan_affine_shift(model, scale)  # zero where the model has no ṁ_ref
    np.testing.assert_allclose(
        np.broadcast_to(moved.affine_term - problem.affine_term, shift.shape), shift, atol=1e-12
    )
    # a warmer zone: each kg/s cools more, and the coil's power per kg/s grows with it
    assert np.all(scale > 1.0)
    assert np.all(moved.power_coeff_kw_per_kg_s >= problem.power_coeff_kw_per_kg_s - 1e-9)
    assert np.any(moved.power_coeff_kw_per_kg_s > problem.power_coeff_kw_per_kg_s + 1e-6)


def test_the_plan_replay_script_meters_both_plans_along_their_own_temperatures(
    tmp_path: Path,
) -> None:
    """``scripts/fleet_plan_replay.py`` (docs/history/2026-12-08-fleet-plan-replay.md): the
    unlimited and least-energy plans, at the fixed T₀ and re-linearised, each metered on the
    buildings' RC plants. Without a limit the priced plan meets the comfort allowance, so on
    the same (fixed) model the least-energy plan needs no more energy."""
    import re
    import subprocess
    import sys

    path = _fleet(tmp_path, [])
    bound = bound_fleet(path, START, 1.0, tmp_path / "bound")
    assert bound.feasible
    script = Path(__file__).parents[2] / "scripts" / "fleet_plan_replay.py"
    done = subprocess.run(
        [sys.executable, str(script), "--fleet", str(path), "--days", "1", "--rounds", "1",
         "--bound", str(tmp_path / "bound" / "bound.csv"), "--max-excursion", "3"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    pattern = r"^(unlimited|least energy), round (\d): planned ([\d,.]+) kWh, metered ([\d,.]+)"
    metered = {
        (m[1], int(m[2])): (float(m[3].replace(",", "")), float(m[4].replace(",", "")))
        for m in re.finditer(pattern, done.stdout, flags=re.MULTILINE)
    }
    assert set(metered) == {(c, r) for c in ("unlimited", "least energy") for r in (0, 1)}
    for planned_kwh, metered_kwh in metered.values():
        assert metered_kwh == pytest.approx(planned_kwh, rel=0.02)  # the plants' meters
    for case in ("unlimited", "least energy"):  # the second round's model is another
        assert abs(metered[(case, 1)][0] - metered[(case, 0)][0]) > 1e-3
    assert metered[("least energy", 0)][0] <= metered[("unlimited", 0)][0] + 1e-6
