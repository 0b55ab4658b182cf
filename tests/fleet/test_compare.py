"""``fleet compare``: the coordinated plans against the centralised LP from the same states."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.errors import InputError
from hvacflex.fleet.compare import (
    COMPARE_COLUMNS,
    COMPARE_FILE,
    SPLIT_TERMS,
    compare_fleet,
    reference_limit_kw,
)
from hvacflex.fleet.generate import generate_fleet, write_fleet


@pytest.fixture(scope="module")
def tight_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two buildings under a limit that binds from 08:00 (their minima stay below it)."""
    doc = generate_fleet(2, 3, feeder_limit_kw=75.0)
    doc["coordination"]["max_iterations"] = 25
    return write_fleet(doc, tmp_path_factory.mktemp("compare") / "fleet.toml")


def test_compare_two_steps_centralised_is_a_lower_bound(tight_fleet: Path, tmp_path: Path) -> None:
    frame = compare_fleet(tight_fleet, "2014-03-03T08:00", 2, tmp_path)
    written = pd.read_csv(tmp_path / COMPARE_FILE)
    assert list(written.columns[: len(COMPARE_COLUMNS)]) == list(COMPARE_COLUMNS)
    assert written["step"].tolist() == [0, 1]
    np.testing.assert_allclose(
        written["gap"], written["coordinated_sgd"] / written["centralised_sgd"] - 1.0
    )
    # the centralised LP is the optimum of the same problems: nothing coordinated beats it
    assert np.all(frame["gap"] >= -1e-6)
    assert np.all(frame["gap"] <= 0.02)
    assert np.all(frame["coordinated_max_over_limit_kw"] <= 1e-3)
    # the parts add up to each side's objective (the centralised one carries the reserve
    # tie-break, a few cents at most) and the gaps are the formula
    for side in ("centralised", "coordinated"):
        parts = sum(written[f"{side}_{term}_sgd"] for term in SPLIT_TERMS)
        np.testing.assert_allclose(parts, written[f"{side}_sgd"], rtol=1e-6, atol=0.05)
    for term in SPLIT_TERMS:
        central, ours = written[f"centralised_{term}_sgd"], written[f"coordinated_{term}_sgd"]
        expected = 100.0 * (ours - central) / central.abs()
        np.testing.assert_allclose(
            written[f"gap_{term}_pct"].fillna(0.0), expected.where(central != 0, 0.0)
        )
    assert (written["centralised_comfort_sgd"] >= 0).all()
    assert (written["centralised_reserve_sgd"] <= 0).all()
    # the second step's centralised LP starts from the first step's basis, rotated
    assert written["centralised_warm"].tolist() == [False, True]


@pytest.fixture(scope="module")
def short_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tight fleet planning over 6 h (small LPs: the warm start and Dask tests)."""
    doc = generate_fleet(2, 3, feeder_limit_kw=75.0)
    doc["horizon_steps"] = 12
    return write_fleet(doc, tmp_path_factory.mktemp("short") / "fleet.toml")


def test_compare_runs_on_dask_workers_like_simulate(short_fleet: Path, tmp_path: Path) -> None:
    """The buildings as Dask actors (an in-process cluster: the actor calls, the problems
    and the cost split travelling back, without the start-up of worker processes)."""
    from dask.distributed import Client, LocalCluster

    in_process = compare_fleet(short_fleet, "2014-03-03T08:00", 2, tmp_path / "a")
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        Client(cluster),
    ):
        on_dask = compare_fleet(
            short_fleet, "2014-03-03T08:00", 2, tmp_path / "b", scheduler=cluster.scheduler_address
        )
    assert on_dask["centralised_warm"].tolist() == [False, True]
    for column in COMPARE_COLUMNS:
        np.testing.assert_allclose(on_dask[column], in_process[column], rtol=1e-6, atol=1e-6)


def test_the_reference_is_held_to_the_minimum_power_where_the_limit_is_below_it() -> None:
    p_min = np.array([[20.0, 35.0, 10.0], [15.0, 30.0, 5.0]])  # Σ = 35, 65, 15 kW
    limit = np.array([50.0, 60.0, np.inf])
    np.testing.assert_array_equal(reference_limit_kw(limit, p_min), [50.0, 65.0, np.inf])


def test_compare_under_a_limit_below_the_fleets_minimum_power(tmp_path: Path) -> None:
    """At 60 kW two buildings' minimum powers alone exceed the limit from 10:00: the
    coordination runs them at their minimum there (and pays comfort slack); the centralised
    LP, held to the same minimum in those periods, still has the optimum to compare with
    (it was infeasible, NaN, with the limit as a hard row)."""
    path = write_fleet(generate_fleet(2, 3, feeder_limit_kw=60.0), tmp_path / "fleet.toml")
    frame = compare_fleet(path, "2014-03-03T10:00", 1, tmp_path / "out")
    assert np.isfinite(frame["centralised_sgd"]).all()
    assert np.all(frame["gap"] >= -1e-6) and np.all(frame["gap"] <= 0.02)
    assert np.all(frame["coordinated_max_over_limit_kw"] <= 1e-3)


def test_compare_cli_prints_the_table(tight_fleet: Path, tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    done = CliRunner().invoke(
        app,
        [
            "fleet",
            "compare",
            "--fleet",
            str(tight_fleet),
            "--start",
            "2014-03-03T10:00",
            "--out",
            str(out),
        ],
    )
    assert done.exit_code == 0, done.output
    assert "coordinated_max_over_limit_kw" in done.output
    assert (out / COMPARE_FILE).is_file()


def test_compare_refuses_a_fleet_too_large(tmp_path: Path) -> None:
    path = write_fleet(generate_fleet(21, 1, feeder_limit_kw=500.0), tmp_path / "big.toml")
    with pytest.raises(InputError, match="too large"):
        compare_fleet(path, "2014-03-03", 1, tmp_path)
    done = CliRunner().invoke(
        app, ["fleet", "compare", "--fleet", str(path), "--out", str(tmp_path / "o")]
    )
    assert done.exit_code == 2 and "at most 20 buildings" in done.output


def test_compare_guards_at_the_limit_in_force_as_simulate_does(
    tmp_path: Path, guard_limits: Any
) -> None:
    """``fleet compare`` advances its buildings as ``fleet simulate`` does, through the guard
    at the limit in force, not at the planning limit (1 − ``feeder_margin``) × it."""
    import hvacflex.fleet.compare as compare

    doc = generate_fleet(2, 3, feeder_limit_kw=75.0)
    doc["horizon_steps"] = 12
    doc["feeder_margin"] = 0.2
    guarded_at = guard_limits(compare)
    compare_fleet(write_fleet(doc, tmp_path / "fleet.toml"), "2014-03-03T08:00", 1, tmp_path / "o")
    assert guarded_at == [75.0]
