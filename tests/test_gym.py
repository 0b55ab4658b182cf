"""``hvacflex.gym``: a scenario as a Gymnasium environment."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env

import hvacflex
from hvacflex.errors import ConfigError, has_extra
from hvacflex.gym import HvacflexEnv, make_env

SCENARIO, START = "thermostat-25.5", "2014-03-03"


def _timing_key(key: str) -> bool:
    return key == "steps_per_s" or key.startswith("time_")


def _flows(frame: pd.DataFrame, zones: tuple[str, ...]) -> np.ndarray:
    return frame[[f"flow_{zone}_kg_s" for zone in zones]].to_numpy()


def _play(env: HvacflexEnv, actions: np.ndarray) -> tuple[list[float], dict[str, object], int]:
    """Rewards, the last info and the step count of an episode of ``actions``."""
    env.reset(seed=0)
    rewards: list[float] = []
    info: dict[str, object] = {}
    terminated = False
    for action in actions:
        assert not terminated
        _, reward, terminated, truncated, info = env.step(action)
        assert not truncated
        rewards.append(reward)
    assert terminated
    return rewards, info, len(rewards)


@pytest.fixture(scope="module")
def env() -> HvacflexEnv:
    return make_env(SCENARIO, start=START, days=1)


def test_the_env_passes_gymnasiums_checker(env: HvacflexEnv) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its advice (normalised spaces) is not a failure
        check_env(env)
    m = len(env.zone_names)
    assert env.action_space.shape == (m,)
    assert env.observation_space.shape == (3 * m + 9,) == (len(env.observation_names),)
    assert np.allclose(env.action_space.high, env.simulation.flow_max_kg_s)


def test_thermostat_flows_through_the_env_give_the_kpis_of_simulate(
    env: HvacflexEnv, tmp_path_factory: pytest.TempPathFactory
) -> None:
    out = tmp_path_factory.mktemp("gym") / "run"
    reference = hvacflex.simulate(SCENARIO, out, quiet=True, start=START, days=1)
    rewards, info, steps = _play(env, _flows(reference.results, env.zone_names))
    assert steps == 48  # a 1-day episode
    kpis = info["kpi"]
    assert isinstance(kpis, dict)
    for key, value in reference.summary.items():
        if _timing_key(key):
            continue
        assert kpis[key] == value or (math.isnan(value) and math.isnan(kpis[key])), key
    # the return is minus the bill: energy + the peak charge + the comfort penalty
    weight = env.scenario.controller.comfort_penalty_sgd_per_kelvin_hour
    bill = kpis["energy_cost_sgd"] + kpis["ppp_charge_monthly_sgd"]
    bill += weight * kpis["discomfort_kelvin_hours"]
    assert sum(rewards) == pytest.approx(-bill, rel=1e-12, abs=1e-9)


def test_the_comfort_penalty_and_the_action_bounds(env: HvacflexEnv) -> None:
    """All-zero flows: clipped to each period's minimum (higher when occupied); the zones
    warm past the band, and the penalty is the scenario's weight × the discomfort."""
    zeros = np.zeros((env.simulation.steps, len(env.zone_names)))
    rewards, info, _ = _play(env, zeros)
    frame = env.simulation.results
    hvac = env.simulation.setup.building.hvac
    occupied = env.simulation.setup.exogenous.occupied[: len(frame)]
    expected = np.where(
        occupied[:, None],
        hvac.flow_min_at(np.array([True]))[0],
        hvac.flow_min_at(np.array([False]))[0],
    )
    assert np.array_equal(_flows(frame, env.zone_names), expected)
    kpis = info["kpi"]
    assert isinstance(kpis, dict) and kpis["discomfort_kelvin_hours"] > 1.0
    weight = env.scenario.controller.comfort_penalty_sgd_per_kelvin_hour
    assert info["comfort_penalty_sgd"] == pytest.approx(weight * info["discomfort_kelvin_hours"])
    total = kpis["energy_cost_sgd"] + kpis["ppp_charge_monthly_sgd"]
    assert sum(rewards) == pytest.approx(-(total + weight * kpis["discomfort_kelvin_hours"]))


def test_the_peak_charge_restarts_with_each_month() -> None:
    """Two days across 31 March / 1 April: two bills, so the charges of both months add up
    in the return (kpi.ppp_charge_monthly_sgd sums the months' whole charges; the reward
    charges each increment of a month's peak, not the charge prorated to the days run)."""
    env = make_env(SCENARIO, start="2014-03-31", days=2, peak_price_sgd_per_kw=2.0)
    actions = np.tile(env.simulation.flow_max_kg_s, (env.simulation.steps, 1))
    rewards, info, steps = _play(env, actions)
    kpis = info["kpi"]
    assert isinstance(kpis, dict) and steps == 96
    assert kpis["ppp_charge_monthly_sgd"] > 1.5 * 2.0 * kpis["peak_power_kw"]  # two bills
    weight = env.scenario.controller.comfort_penalty_sgd_per_kelvin_hour
    bill = kpis["energy_cost_sgd"] + kpis["ppp_charge_monthly_sgd"]
    assert sum(rewards) == pytest.approx(-(bill + weight * kpis["discomfort_kelvin_hours"]))


def test_reset_starts_the_same_episode_and_observes_the_first_period(env: HvacflexEnv) -> None:
    first, info = env.reset(seed=1)
    assert info == {"period": 0}
    env.step(env.action_space.high)
    again, _ = env.reset(seed=2)
    assert np.array_equal(first, again) and env.simulation.k == 0
    named = dict(zip(env.observation_names, first.tolist(), strict=True))
    initial = env.scenario.initial_temp_degc
    assert named["zone_temp_core_degc"] == pytest.approx(initial)
    assert named["hour_sin"] == 0.0 and named["hour_cos"] == 1.0  # midnight
    assert named["weekday"] == 0.0  # 2014-03-03 is a Monday
    assert named["month_peak_kw"] == 0.0 and named["previous_power_kw"] == 0.0
    exo = env.simulation.setup.exogenous
    assert named["energy_price_sgd_per_mwh"] == pytest.approx(exo.energy_price_sgd_per_mwh[0])


def test_a_bad_scenario_is_refused_before_anything_runs() -> None:
    with pytest.raises(ConfigError) as err:
        make_env("thermostat-25", start=START, days=1)
    assert err.value.field == "scenario"
    with pytest.raises(ConfigError) as bad_days:
        make_env(SCENARIO, start=START, days=-1)
    assert bad_days.value.field == "days"


@pytest.mark.skipif(not has_extra("energyplus"), reason="needs the energyplus extra")
def test_on_energyplus_the_action_is_the_zones_set_points() -> None:
    env = make_env(
        SCENARIO, start=START, days=0.125, plant={"kind": "energyplus", "actuation": "setpoint"}
    )
    try:
        assert env.simulation.actuation == "setpoint"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            check_env(env)
        exo = env.simulation.setup.exogenous
        assert env.action_space.low[0] == exo.comfort_lower_degc[:6].min()
        assert env.action_space.high[0] == exo.comfort_upper_degc[:6].max()
        setpoints = np.full((6, len(env.zone_names)), 24.0)
        rewards, info, steps = _play(env, setpoints)
        assert steps == 6 and info["kpi"]["plant"] == "energyplus"  # type: ignore[index]
        end = env.simulation.results[[f"temp_end_{z}_degc" for z in env.zone_names]]
        assert np.allclose(end.iloc[-1], 24.0, atol=0.05)  # EnergyPlus's loop held them
        assert all(r <= 0 for r in rewards)
    finally:
        env.close()
