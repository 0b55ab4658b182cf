"""Fleet KPIs on a hand-made fleet frame whose answers are computed by hand."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex import results as schema
from hvacflex.fleet.kpi import as_kpi_frame, fleet_summary, load_fleet_results
from hvacflex.sim.run_files import summary_text

TZ = "Asia/Singapore"


def fleet_frame(freq: str = "30min") -> pd.DataFrame:
    """Four steps: 100, 200, 100, 0 kW at 200 SGD/MWh; 50 kW settled twice at 10 SGD/MWh."""
    index = pd.date_range("2014-03-03 06:00", periods=4, freq=freq, tz=TZ, name="time")
    columns = {name: np.zeros(4) for name in schema.FLEET_FLOAT_UNITS}
    columns |= {
        "fleet_power_kw": np.array([100.0, 200.0, 100.0, 0.0]),
        "planned_fleet_power_kw": np.array([100.0, 150.0, 100.0, 0.0]),
        "feeder_limit_kw": np.array([150.0, 150.0, np.inf, 150.0]),
        "fleet_reserve_kw": np.array([50.0, 20.0, 50.0, 0.0]),
        "settled_reserve_kw": np.array([50.0, 0.0, 50.0, 0.0]),
        "energy_price_sgd_per_mwh": np.full(4, 200.0),
        "reserve_price_sgd_per_mwh": np.full(4, 10.0),
        "coordination_gap": np.array([0.001, 0.002, 0.0, 0.0]),
        "step_time_s": np.array([1.0, 2.0, 3.0, 4.0]),
        "discomfort_kelvin_hours": np.array([0.1, 0.0, 0.2, 0.4]),
        "bid_accepted": np.array([True, False, True, False]),
        "feeder_infeasible": np.array([False, False, False, True]),
        "il_activated": np.array([False, False, True, False]),
        "il_baseline_power_kw": np.array([np.nan, np.nan, 200.0, np.nan]),
        "il_delivered_kw": np.array([0.0, 0.0, 100.0, 0.0]),
        "il_shortfall_kw": np.array([0.0, 0.0, 0.0, 0.0]),
        "coordination_iterations": np.array([3, 5, 1, 2]),
    }
    return pd.DataFrame(columns, index=index)[schema.fleet_columns()]


def test_fleet_summary_by_hand() -> None:
    buildings = pd.DataFrame({"building": ["a", "b", "a"]})
    out = fleet_summary(fleet_frame(), buildings)
    # energy 400 kW × 0.5 h; cost 200 kWh × 0.2 SGD/kWh; revenue 100 kW × 0.5 h × 0.01
    assert out["energy_kwh"] == pytest.approx(200.0)
    assert out["energy_cost_sgd"] == pytest.approx(40.0)
    assert out["reserve_revenue_sgd"] == pytest.approx(0.5)
    assert out["net_cost_sgd"] == pytest.approx(39.5)
    assert out["peak_fleet_power_kw"] == pytest.approx(200.0)
    assert out["max_planned_over_limit_kw"] == pytest.approx(0.0)
    assert out["max_realised_over_limit_pct"] == pytest.approx(100.0 / 3.0)
    assert out["feeder_infeasible_steps"] == 1.0
    assert out["bid_accepted_share"] == pytest.approx(0.5)
    assert out["mean_fleet_reserve_kw"] == pytest.approx(30.0)
    assert out["coordination_iterations_mean"] == pytest.approx(2.75)
    assert out["coordination_iterations_max"] == 5.0
    assert out["coordination_gap_max"] == pytest.approx(0.002)
    assert out["discomfort_kelvin_hours"] == pytest.approx(0.7)
    # without the flagged period 3 (and the unlimited period 2 for the limit)
    assert out["discomfort_unflagged_kelvin_hours"] == pytest.approx(0.3)
    assert out["max_planned_over_limit_unflagged_kw"] == pytest.approx(0.0)
    assert out["max_realised_over_limit_unflagged_pct"] == pytest.approx(100.0 / 3.0)
    # period 2 activated: 50 kW settled for 0.5 h, 100 kW delivered below its baseline
    assert out["il_activated_steps"] == 1.0
    assert out["il_offered_kwh"] == pytest.approx(25.0)
    assert out["il_delivered_kwh"] == pytest.approx(50.0)
    assert out["il_shortfall_kwh"] == pytest.approx(0.0)
    assert out["step_time_s_mean"] == pytest.approx(2.5)
    assert out["buildings"] == 2.0 and out["steps"] == 4.0


def test_a_summary_without_a_feeder_limit_is_strict_json() -> None:
    frame = fleet_frame()
    frame["feeder_limit_kw"] = np.inf  # no limit: nothing is over it
    out = fleet_summary(frame)
    assert out["max_planned_over_limit_kw"] == -np.inf  # in memory: the max of nothing

    def refuse(constant: str) -> object:
        raise AssertionError(f"not JSON: {constant}")

    written = json.loads(summary_text(out), parse_constant=refuse)
    for key in (
        "max_planned_over_limit_kw",
        "max_realised_over_limit_pct",
        "max_planned_over_limit_unflagged_kw",
        "max_realised_over_limit_unflagged_pct",
    ):
        assert written[key] is None
    assert written["energy_kwh"] == pytest.approx(200.0)


def test_fleet_energy_takes_the_step_from_the_index() -> None:
    out = fleet_summary(fleet_frame(freq="15min"))
    assert out["energy_kwh"] == pytest.approx(100.0)
    assert out["energy_cost_sgd"] == pytest.approx(20.0)
    assert out["reserve_revenue_sgd"] == pytest.approx(0.25)
    assert np.isnan(out["buildings"])


def test_kpi_frame_plays_the_fleet_as_one_building() -> None:
    frame = as_kpi_frame(fleet_frame())
    assert frame["power_kw"].tolist() == [100.0, 200.0, 100.0, 0.0]
    assert frame["reserve_kw"].tolist() == [50.0, 0.0, 50.0, 0.0]  # the settled bid
    assert frame.index.equals(fleet_frame().index)


def test_fleet_results_are_told_by_their_metadata(tmp_path: Path) -> None:
    fleet_dir, single_dir = tmp_path / "fleet", tmp_path / "single"
    fleet_dir.mkdir()
    single_dir.mkdir()
    schema.write_results(fleet_frame(), fleet_dir / schema.RESULTS_FILENAME, {"fleet": "f"})
    schema.write_results(fleet_frame(), single_dir / schema.RESULTS_FILENAME, {"run_key": "k"})
    loaded = load_fleet_results(fleet_dir)
    assert loaded is not None
    pd.testing.assert_frame_equal(loaded, fleet_frame(), check_freq=False)
    assert load_fleet_results(single_dir) is None
    assert load_fleet_results(tmp_path) is None  # no results file
    (tmp_path / "notes.parquet").write_text("not parquet")
    assert load_fleet_results(tmp_path / "notes.parquet") is None
