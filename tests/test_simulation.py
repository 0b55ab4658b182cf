"""``hvacflex.Simulation``: a stepped closed loop grades as ``simulate`` does."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

import hvacflex
from hvacflex.data.forecast import Forecast
from hvacflex.errors import ConfigError, HvacflexError, InputError
from hvacflex.simulation import Forecaster, Simulation, flow_action

SCENARIO, START, DAYS = "thermostat-25.5", "2014-03-03", 1
TIMING_COLUMNS = ["solve_time_s"]


def _timing_key(key: str) -> bool:
    return key == "steps_per_s" or key.startswith("time_")


def _same(a: Any, b: Any) -> bool:
    return a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b))


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> hvacflex.RunResult:
    """``simulate`` of the scenario: what every stepped run below is compared with."""
    out = tmp_path_factory.mktemp("simulate") / "run"
    return hvacflex.simulate(SCENARIO, out, quiet=True, start=START, days=DAYS)


def _flows(frame: pd.DataFrame, zones: tuple[str, ...]) -> np.ndarray:
    """(T, m) the flows a run applied [kg/s]."""
    return frame[[f"flow_{zone}_kg_s" for zone in zones]].to_numpy()


def test_run_gives_the_summary_and_results_of_simulate(reference: hvacflex.RunResult) -> None:
    sim = Simulation(SCENARIO, start=START, days=DAYS)
    assert (sim.k, sim.steps, sim.done, sim.actuation) == (0, 48, False, "flow")
    result = sim.run()
    assert sim.done and isinstance(result, hvacflex.SimulationResult)
    expected = {k: v for k, v in reference.summary.items() if not _timing_key(k)}
    assert set(result.summary) == set(expected)
    assert {k: v for k, v in expected.items() if not _same(v, result.summary[k])} == {}
    pd.testing.assert_frame_equal(
        result.results.drop(columns=TIMING_COLUMNS),
        reference.results.drop(columns=TIMING_COLUMNS),
        check_freq=False,
    )
    ours, theirs = hvacflex.kpi_summary(result), hvacflex.kpi_summary(reference)
    assert pd.Series(ours).equals(pd.Series(theirs))  # NaN where a ratio has no events


def test_steps_with_the_controllers_flows_equal_the_controllers_own(
    reference: hvacflex.RunResult,
) -> None:
    sim = Simulation(SCENARIO, start=START, days=DAYS, own_controller=False)
    assert sim.controller is None
    flows = _flows(reference.results, sim.zone_names)
    rows = [sim.step(flows[k]) for k in range(sim.steps)]
    assert [row["power_kw"] for row in rows] == reference.results["power_kw"].tolist()
    assert rows[0]["solve_status"] == "rule"
    pd.testing.assert_frame_equal(
        sim.results.drop(columns=TIMING_COLUMNS),
        reference.results.drop(columns=TIMING_COLUMNS),
        check_freq=False,
    )


def test_a_given_action_is_applied_and_the_controller_takes_over(
    reference: hvacflex.RunResult,
) -> None:
    sim = Simulation(SCENARIO, start=START, days=DAYS)
    sim.step()
    half = 0.5 * sim.flow_max_kg_s
    row = sim.step(half)
    assert [row[f"flow_{zone}_kg_s"] for zone in sim.zone_names] == half.tolist()
    full = sim.step(flow_action(sim.flow_max_kg_s))
    assert full["flow_core_kg_s"] == sim.flow_max_kg_s[-1]
    assert full["power_kw"] > reference.results["power_kw"].iloc[2]  # more air, more power
    result = sim.run()
    assert len(result.results) == 48
    assert result.results["flow_core_kg_s"].iloc[1] == half[-1]
    assert (result.results["solve_status"] == "rule").all()


def test_restart_runs_the_same_periods_again() -> None:
    sim = Simulation(SCENARIO, start=START, days=0.25)
    first = sim.run().results
    sim.restart()
    assert sim.k == 0 and not sim.done
    again = sim.run().results
    pd.testing.assert_frame_equal(
        first.drop(columns=TIMING_COLUMNS), again.drop(columns=TIMING_COLUMNS)
    )


class _CountingForecaster:
    """A user's forecaster: the scenario's, counting its calls."""

    def __init__(self, inner: Forecaster) -> None:
        self.inner = inner
        self.calls: list[int] = []

    def forecast(self, k: int, horizon: int) -> Forecast:
        self.calls.append(k)
        return self.inner.forecast(k, horizon)


def test_a_users_forecaster_is_asked_each_period() -> None:
    plain = Simulation(SCENARIO, start=START, days=0.25)
    counting = _CountingForecaster(plain.setup.forecaster)
    assert isinstance(counting, hvacflex.Forecaster)
    assert isinstance(plain.setup.forecaster, hvacflex.Forecaster)  # the shipped one too
    sim = Simulation(SCENARIO, start=START, days=0.25, forecaster=counting)
    result = sim.run()
    assert counting.calls == list(range(12))
    assert result.summary["energy_kwh"] == plain.run().summary["energy_kwh"]


def test_a_users_controller_set_before_the_first_period() -> None:
    class Constant:
        takes_measurements = False
        commits_ahead = 0

        def __init__(self, flow_kg_s: np.ndarray) -> None:
            self.flow_kg_s = flow_kg_s
            self.periods = 0

        def act(self, inputs: Any) -> Any:
            self.periods += 1
            return flow_action(self.flow_kg_s)

        def get_state(self) -> dict[str, Any]:
            return {"periods": self.periods}

        def set_state(self, state: dict[str, Any]) -> None:
            self.periods = state["periods"]

    sim = Simulation(SCENARIO, start=START, days=0.25, own_controller=False)
    mine = Constant(0.25 * sim.flow_max_kg_s)
    sim.controller = mine
    result = sim.run()
    assert mine.periods == 12
    assert np.allclose(_flows(result.results, sim.zone_names), 0.25 * sim.flow_max_kg_s)
    sim.restart()  # the controller back in its first state
    assert mine.periods == 0
    sim.step()
    with pytest.raises(InputError, match="before the first period"):
        sim.controller = Constant(sim.flow_max_kg_s)


def test_bad_steps_and_scenarios_are_refused(tmp_path: Path) -> None:
    sim = Simulation(SCENARIO, start=START, days=0.25, own_controller=False)
    with pytest.raises(InputError, match="no period simulated yet"):
        _ = sim.summary
    with pytest.raises(InputError, match=r"shape \(5,\)") as err:
        sim.step([0.1, 0.2])
    assert err.value.field == "action" and "north" in str(err.value)
    with pytest.raises(InputError, match="finite"):
        sim.step([0.1, 0.2, math.nan, 0.1, 0.1])
    with pytest.raises(HvacflexError, match="no controller"):
        sim.step()
    for _ in range(sim.steps):
        sim.step(sim.flow_max_kg_s)
    with pytest.raises(InputError, match="restart"):
        sim.step(sim.flow_max_kg_s)
    with pytest.raises(ConfigError) as bad:
        Simulation(SCENARIO, dayz=1)
    assert bad.value.field == "dayz"


def test_a_dict_for_controller_or_plant_overrides_the_scenarios_table() -> None:
    sim = Simulation(SCENARIO, start=START, days=0.25, controller={"peak_price_sgd_per_kw": 2.5})
    assert sim.scenario.controller.peak_price_sgd_per_kw == 2.5
    assert sim.controller is not None  # still the scenario's own controller
    assert (sim.run().results["peak_price_sgd_per_kw"] == 2.5).all()
    with pytest.raises(ConfigError) as err:
        Simulation(SCENARIO, plant={"kind": "trnsys"})
    assert err.value.field is not None and err.value.field.startswith("plant")
