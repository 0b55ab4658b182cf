"""Stochastic occupancy: seeded, reproducible, independent of the run's start, near the
schedule on average."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest

from hvacflex.building.channels import internal_gain_channel, outdoor_temp_channel
from hvacflex.data.gains import zone_internal_gains_w
from hvacflex.data.occupancy import (
    MAX_SHIFT_STEPS,
    stochastic_gain_disturbances,
    stochastic_zone_gains_w,
)
from hvacflex.errors import ConfigError

INDEX = pd.date_range("2014-03-03", periods=48 * 14, freq="30min", tz="Asia/Singapore")
ZONE = {"floor_area_m2": 300.0, "occupancy_m2_per_person": 10.0, "sensible_w_per_person": 75.0,
        "lighting_w_per_m2": 10.0, "equipment_w_per_m2": 12.0}  # fmt: skip


@dataclass(frozen=True)
class Gains:
    occupancy_m2_per_person: float = 10.0
    sensible_w_per_person: float = 75.0
    latent_w_per_person: float = 55.0
    lighting_w_per_m2: float = 10.0
    equipment_w_per_m2: float = 12.0


def _gains(index: pd.DatetimeIndex, seed: int, zone: int = 0) -> np.ndarray:
    return stochastic_zone_gains_w(index, **ZONE, seed=seed, zone_position=zone)


def test_same_seed_same_gains_other_seed_or_zone_other_gains() -> None:
    first, again = _gains(INDEX, 1), _gains(INDEX, 1)
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, _gains(INDEX, 2))
    assert not np.array_equal(first, _gains(INDEX, 1, zone=1))


def test_a_day_does_not_depend_on_when_the_run_starts() -> None:
    whole = _gains(INDEX, 3)
    part = _gains(INDEX[100:300], 3)
    np.testing.assert_array_equal(part, whole[100:300])


def test_occupancy_differs_from_the_schedule_but_follows_it_on_average() -> None:
    year = pd.date_range("2014-01-06", periods=48 * 7 * 20, freq="30min", tz="Asia/Singapore")
    stochastic = _gains(year, 5)
    schedule = zone_internal_gains_w(year, **ZONE)
    assert (stochastic >= 0).all()
    assert np.abs(stochastic - schedule).max() > 500.0  # W: real occupants, not the profile
    assert stochastic.mean() == pytest.approx(schedule.mean(), rel=0.05)
    # people come at most MAX_SHIFT_STEPS periods early: none at 03:00
    night = np.asarray(year.hour) == 3
    base = ZONE["floor_area_m2"] * (10.0 * 0.05 + 12.0 * 0.4)  # lights + plugs at night [W]
    assert stochastic[night].max() <= base * 1.3 + 1e-9
    assert MAX_SHIFT_STEPS == 2


def test_disturbances_replace_only_the_gain_channels() -> None:
    channels = (outdoor_temp_channel(), internal_gain_channel("a"), internal_gain_channel("b"))
    d = np.column_stack([np.full(len(INDEX), 30.0), np.ones(len(INDEX)), np.ones(len(INDEX))])
    out = stochastic_gain_disturbances(d, channels, INDEX, [300.0, 100.0], Gains(), seed=9)
    np.testing.assert_array_equal(out[:, 0], 30.0)
    np.testing.assert_array_equal(out[:, 1], _gains(INDEX, 9, zone=0))
    assert out[:, 2].mean() < out[:, 1].mean()  # the smaller zone
    np.testing.assert_array_equal(d[:, 1], 1.0)  # the input is not changed


def test_bad_density_is_refused() -> None:
    with pytest.raises(ConfigError, match="occupancy_m2_per_person"):
        stochastic_zone_gains_w(INDEX, 100.0, 0.0, 75.0, 10.0, 12.0, seed=1, zone_position=0)
