"""The zone-time-step rules on EnergyPlus: the setpoint rule and the peak guard's shed."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.sim.plant import PeakGuard
from hvacflex.sim.zone_step_rules import (
    ANTICIPATION_TOLERANCE_K,
    AVAILABILITY_ON,
    GUARD_GAIN,
    GUARD_RELEASE_GAIN,
    SETPOINT_DEADBAND_K,
    SetpointRule,
    next_shed_level,
    shed_toward_band,
)


def _rule() -> tuple[SetpointRule, np.ndarray, np.ndarray]:
    """Two zones, zone 1's heating schedule read as variable 2; two availability schedules."""
    rule = SetpointRule(2)
    rule.heating_vars = [2, None]
    now = np.array([25.0, 25.0, 22.2])
    commanded = np.array([26.0, 26.0, np.nan, np.nan, np.nan, np.nan])
    return rule, now, commanded


def test_heating_setpoints_stay_a_deadband_below_the_cooling_ones() -> None:
    rule, now, commanded = _rule()
    commanded[:2] = [22.5, 26.0]
    applied = rule.apply(now, commanded)
    expected = [22.5 - SETPOINT_DEADBAND_K, 26.0 - SETPOINT_DEADBAND_K]
    np.testing.assert_allclose(applied[2:4], expected)
    now[2] = 20.0  # the IDF's own heating setpoint, lower: kept
    np.testing.assert_allclose(rule.apply(now, commanded)[2], 20.0)
    released = rule.apply(now, np.full(6, np.nan))
    assert np.isnan(released[:4]).all()  # every zone to the IDF's own schedules


def test_the_loop_is_forced_on_while_a_zone_is_warmer_than_its_setpoint() -> None:
    rule, now, commanded = _rule()
    commanded[:2] = [24.5, 26.0]
    assert np.all(rule.apply(now, commanded)[4:] == AVAILABILITY_ON)  # 25 > 24.5
    commanded[:2] = 26.0
    assert np.isnan(rule.apply(now, commanded)[4:]).all()  # the IDF decides


def test_a_zone_about_to_pass_its_limit_starts_the_loop_a_step_early() -> None:
    """0.6 K a step from 25.0 to 25.6: below the 26 °C limit now, 26.2 °C at the next step,
    more than the tolerance above it."""
    rule, now, commanded = _rule()
    rule.apply(now, commanded)
    now[0] = 25.6
    assert np.isnan(rule.apply(now, commanded)[4:]).all()  # no limit given: not anticipated
    rule.reset()
    rule.limit_degc = np.full(2, 26.0)
    now[0] = 25.0
    assert np.isnan(rule.apply(now, commanded)[4:]).all()  # no previous step yet
    now[0] = 25.6
    assert np.all(rule.apply(now, commanded)[4:] == AVAILABILITY_ON)
    assert np.isnan(rule.apply(now, commanded)[4:]).all()  # steady again
    # within the tolerance the loop waits for the zone to pass its setpoint
    rule.previous_zone_degc = np.array([25.75, 25.0])
    now[0] = 25.9  # 0.15 K a step: 26.05 °C next, within the tolerance
    assert now[0] + 0.15 < 26.0 + ANTICIPATION_TOLERANCE_K
    assert np.isnan(rule.apply(now, commanded)[4:]).all()
    rule.reset()
    assert rule.limit_degc is None and rule.previous_zone_degc is None


def test_shed_level_rises_while_over_the_cap_and_falls_once_it_fits() -> None:
    assert next_shed_level(0.0, 44.0, 40.0) == pytest.approx(0.1 * GUARD_GAIN)
    assert next_shed_level(0.9, 80.0, 40.0) == 1.0
    assert next_shed_level(0.5, 36.0, 40.0) == pytest.approx(0.5 - 0.1 * GUARD_RELEASE_GAIN)
    assert GUARD_RELEASE_GAIN < GUARD_GAIN  # released more slowly than taken
    assert next_shed_level(0.0, 30.0, 40.0) == 0.0


def test_shed_toward_band_moves_only_the_zones_below_their_bound() -> None:
    guard = PeakGuard(40.0, np.array([26.0, 26.0, 26.0]), np.array([0.1, 0.1, 0.1]))
    temps = np.array([24.0, 26.5, 24.0])  # zone 2 is already above its bound
    setpoints = np.array([24.0, 24.0, 27.0])  # zone 3's setpoint is above it: never lowered
    np.testing.assert_allclose(
        shed_toward_band(setpoints, temps, guard, 0.5, setpoint=True), [25.0, 24.0, 27.0]
    )
    flows = np.array([0.5, 0.5, 0.05])  # zone 3 below its floor: never raised
    np.testing.assert_allclose(
        shed_toward_band(flows, temps, guard, 0.5, setpoint=False), [0.3, 0.5, 0.05]
    )
    np.testing.assert_allclose(shed_toward_band(flows, temps, guard, 0.0, setpoint=False), flows)
