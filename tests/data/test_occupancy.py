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
    early_arrival_gain_disturbances,
    first_arrival_offset_steps,
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


def test_the_first_arrivals_quantile_is_the_drawn_shifts_quantile() -> None:
    """The offset −s is uniform on −2 … 2 periods: P(≤ −2) = 0.2 ≥ 5 %, P(≤ 0) = 0.6 ≥ 50 %;
    checked against the model's own draws: the 5 % quantile of the day's first period with
    people present after 03:00 (each zone, working days, against the schedule's 06:00)."""
    assert first_arrival_offset_steps(0.05) == -2 and first_arrival_offset_steps(0.2) == -2
    assert first_arrival_offset_steps(0.21) == -1 and first_arrival_offset_steps(0.5) == 0
    assert first_arrival_offset_steps(1.0) == MAX_SHIFT_STEPS
    year = pd.date_range("2014-01-06", periods=48 * 7 * 20, freq="30min", tz="Asia/Singapore")
    zone = {**ZONE, "lighting_w_per_m2": 0.0, "equipment_w_per_m2": 0.0}  # people alone
    first_periods = []
    for position in range(5):
        people = stochastic_zone_gains_w(year, **zone, seed=4, zone_position=position)
        for day in people.reshape(-1, 48)[[d for d in range(140) if d % 7 < 5]]:
            present = np.flatnonzero(day[6:24] > 0) + 6  # from 03:00: not last night's
            if present.size:
                first_periods.append(present[0] - 12)  # the schedule's first: 06:00
    assert np.quantile(first_periods, 0.05) == first_arrival_offset_steps(0.05)
    for bad in (0.0, 1.5):
        with pytest.raises(ConfigError, match="first_arrival_quantile"):
            first_arrival_offset_steps(bad)


def test_the_plan_takes_the_early_arrivals_gains_before_occupancy_only() -> None:
    """Before 08:00 on working days the gain is the larger of the schedule's and the
    schedule's one hour later (07:00–08:00 takes 08:00's); every other period, the weekend
    and the other channels keep the schedule's."""
    channels = (outdoor_temp_channel(), internal_gain_channel("a"))
    scheduled = zone_internal_gains_w(INDEX, **ZONE)
    d = np.column_stack([np.full(len(INDEX), 30.0), scheduled])
    out = early_arrival_gain_disturbances(d, channels, INDEX, [300.0], Gains())
    np.testing.assert_array_equal(out[:, 0], 30.0)
    np.testing.assert_array_equal(d[:, 1], scheduled)  # the input is not changed
    later = zone_internal_gains_w(INDEX + pd.Timedelta(hours=1), **ZONE)
    hour = np.asarray(INDEX.hour)
    weekday = np.asarray(INDEX.day_of_week) < 5
    morning = weekday & (hour < 8)
    np.testing.assert_array_equal(out[morning, 1], np.maximum(scheduled, later)[morning])
    np.testing.assert_array_equal(out[~morning, 1], scheduled[~morning])
    seven = weekday & (hour == 7)
    by_hand = 300.0 * (75.0 / 10.0 * 0.95 + 10.0 * 0.9 + 12.0 * 0.9)  # 08:00's fractions
    np.testing.assert_allclose(out[seven, 1], by_hand)
    assert (out[seven, 1] > scheduled[seven]).all()
    same = early_arrival_gain_disturbances(d, channels, INDEX, [300.0], Gains(), quantile=0.9)
    np.testing.assert_array_equal(same, d)  # a late quantile plans the schedule
