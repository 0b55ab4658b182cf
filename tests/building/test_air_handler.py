"""Supply fan (power law, EnergyPlus's part-load curve) and outdoor air (share, need)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hvacflex.building.air_handler import (
    PRESSURE_RESET_FAN_COEFFICIENTS,
    fan_marginal_kw_per_kg_s,
    fan_power_kw,
    fan_secant_from,
    outdoor_air_kg_s,
    outdoor_air_secant,
)
from hvacflex.building.model import HvacSystem

BASE = HvacSystem(
    supply_temp_degc=13.0,
    flow_min_kg_s=(0.0, 0.0),
    flow_max_kg_s=(4.0, 6.0),
    outdoor_air_fraction=0.3,
    cop=4.0,
    fan_coeff_kw=0.03,
    fan_exponent=2.5,
    reserve_zones=("a", "b"),
)
CURVED = dataclasses.replace(BASE, fan_part_load_coefficients=PRESSURE_RESET_FAN_COEFFICIENTS)


def test_fan_curve_has_the_design_power_and_a_static_pressure_floor() -> None:
    design = 0.03 * 10.0**2.5
    assert float(fan_power_kw(CURVED, 10.0)) == pytest.approx(
        design * sum(PRESSURE_RESET_FAN_COEFFICIENTS)
    )
    assert float(fan_power_kw(CURVED, 0.0)) == 0.0  # off
    # at 30 % flow: 0.0408 + 0.0880·0.3 − 0.0729·0.09 + 0.9437·0.027 of design, by hand
    by_hand = 0.040759894 + 0.08804497 * 0.3 - 0.07292612 * 0.09 + 0.943739823 * 0.027
    assert float(fan_power_kw(CURVED, 3.0)) == pytest.approx(design * by_hand)
    assert float(fan_power_kw(CURVED, 3.0)) > 1.5 * float(fan_power_kw(BASE, 3.0))
    # the slope is the curve's derivative
    s, h = 5.0, 1e-6
    numeric = (fan_power_kw(CURVED, s + h) - fan_power_kw(CURVED, s - h)) / (2 * h)
    assert float(fan_marginal_kw_per_kg_s(CURVED, s)) == pytest.approx(float(numeric), rel=1e-6)


@pytest.mark.parametrize("hvac", [BASE, CURVED])
def test_fan_secant_exact_at_the_ends_and_above_the_curve(hvac: HvacSystem) -> None:
    for s_min in (1.0, 3.61, 6.0):
        intercept, slope = fan_secant_from(hvac, s_min)
        s = np.linspace(s_min, 10.0, 201)
        curve, line = fan_power_kw(hvac, s), intercept + slope * s
        assert line[0] == pytest.approx(curve[0]) and line[-1] == pytest.approx(curve[-1])
        assert np.all(line >= curve - 1e-12)


def test_outdoor_air_share_or_need() -> None:
    flows = np.array([0.0, 0.5, 2.0, 10.0])
    np.testing.assert_allclose(outdoor_air_kg_s(BASE, flows), 0.3 * flows)
    need = dataclasses.replace(BASE, outdoor_air_kg_s=1.32)
    np.testing.assert_allclose(outdoor_air_kg_s(need, flows), [0.0, 0.5, 1.32, 1.32])
    a, b = outdoor_air_secant(BASE, np.array([0.0, 3.0]))
    np.testing.assert_allclose(a, 0.0) and np.testing.assert_allclose(b, 0.3)
    a, b = outdoor_air_secant(need, np.array([0.0, 3.61]))
    # from (0, 0) to (10, 1.32); at or above the need the secant is the constant need
    np.testing.assert_allclose(a, [0.0, 1.32]) and np.testing.assert_allclose(b, [0.132, 0.0])


def test_a_closed_damper_admits_no_outdoor_air_at_a_night_flow() -> None:
    """A small night flow is 100 % outdoor air with the damper open (need ≥ S) and 0 % closed;
    the secant of a closed step is 0 + 0·S."""
    need = dataclasses.replace(BASE, outdoor_air_kg_s=1.5)
    night = np.array([0.4, 0.4])
    np.testing.assert_allclose(outdoor_air_kg_s(need, night), [0.4, 0.4])
    np.testing.assert_array_equal(outdoor_air_kg_s(need, night, [False, True]), [0.0, 0.4])
    np.testing.assert_array_equal(outdoor_air_kg_s(BASE, 10.0, False), 0.0)
    a, b = outdoor_air_secant(need, np.array([0.0, 0.0]), np.array([False, True]))
    assert (a[0], b[0]) == (0.0, 0.0)
    # open: min(1.5, S) over [0, 10] as a secant through (0, 0) and (10, 1.5)
    assert (a[1], b[1]) == pytest.approx((0.0, 0.15))
    a, b = outdoor_air_secant(BASE, np.array([0.0, 0.0]), np.array([False, True]))
    np.testing.assert_array_equal(b, [0.0, 0.3])


def test_damper_opens_while_occupied_and_for_the_purge_before() -> None:
    occupied = np.array([0, 0, 0, 0, 1, 1, 0, 0, 0, 1], dtype=bool)
    np.testing.assert_array_equal(BASE.outdoor_air_open_at(occupied), occupied)
    purge = dataclasses.replace(BASE, outdoor_air_purge_h=1.0)  # two 30-min steps
    expected = np.array([0, 0, 1, 1, 1, 1, 0, 1, 1, 1], dtype=bool)
    np.testing.assert_array_equal(purge.outdoor_air_open_at(occupied), expected)
    # 15-min steps: four
    expected_15 = np.array([1, 1, 1, 1, 1, 1, 1, 1, 1, 1], dtype=bool)
    np.testing.assert_array_equal(purge.outdoor_air_open_at(occupied, 900.0), expected_15)
