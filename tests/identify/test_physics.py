"""Physical bounds and priors of a fitted zone, against hand-computed values."""

from __future__ import annotations

import math

import pytest

from hvacflex.identify.fit import BOUNDS, INITIAL
from hvacflex.identify.idf_geometry import Aperture, ZoneGeometry
from hvacflex.identify.physics import (
    BOUNDS_PER_M2,
    OPAQUE_SOLAR_SHARE,
    ZonePhysics,
    coupling_bounds,
    zone_bounds,
    zone_physics,
    zone_priors,
)

SOUTH_SOUTH_WEST = ZoneGeometry(
    "Office",
    100.0,
    windows=(Aperture(10.0, 210.0, 90.0),),
    walls=(Aperture(40.0, 210.0, 90.0),),
)


def test_a_zone_facing_210_degrees_gets_sun_from_south_and_west_only() -> None:
    physics = zone_physics(SOUTH_SOUTH_WEST, 100.0)
    north, east, south, west = physics.wall_solar_max_m2 or ()
    facing = 10.0 + OPAQUE_SOLAR_SHARE * 40.0  # the window and a share of the wall
    assert south == pytest.approx(facing * math.cos(math.radians(30.0)))
    assert west == pytest.approx(facing * math.cos(math.radians(60.0)))
    assert north == 0.0 and east == 0.0  # faced away: fixed at 0
    assert physics.horizontal_solar_max_m2 == pytest.approx(facing)


def test_bounds_scale_with_the_floor_area_and_fix_the_facades_it_lacks() -> None:
    bounds = zone_bounds(zone_physics(SOUTH_SOUTH_WEST, 100.0), BOUNDS)
    low, high = BOUNDS_PER_M2["c_mass_kj_per_k"]
    assert bounds["c_mass_kj_per_k"] == pytest.approx((100.0 * low, 100.0 * high))
    assert bounds["solar_wall_north_m2"] == (0.0, 0.0)
    assert bounds["base_gain_kw"][0] == 0.0  # a constant gain is not negative
    assert bounds["ua_kw_per_k"] == BOUNDS["ua_kw_per_k"]  # couplings: generic


def test_a_windowless_core_gets_no_sun() -> None:
    core = ZoneGeometry("Core", 180.0)
    bounds = zone_bounds(zone_physics(core, 180.0), BOUNDS)
    for name in ("solar_air_m2", "solar_mass_m2", "solar_wall_east_m2", "solar_wall_west_m2"):
        assert bounds[name] == (0.0, 0.0)


def test_without_area_or_facades_the_generic_bounds_and_priors_apply() -> None:
    unknown = ZonePhysics()
    assert not unknown.area_known
    bounds = zone_bounds(unknown, BOUNDS)
    assert bounds == BOUNDS
    assert zone_priors(unknown, INITIAL, bounds) == INITIAL


def test_priors_lie_inside_the_bounds() -> None:
    physics = zone_physics(SOUTH_SOUTH_WEST, 100.0)
    bounds = zone_bounds(physics, BOUNDS)
    priors = zone_priors(physics, INITIAL, bounds)
    for name, value in priors.items():
        assert bounds[name][0] <= value <= bounds[name][1], name
    assert priors["c_air_kj_per_k"] == pytest.approx(1000.0)  # 10 kJ/(K m²) × 100 m²


def test_a_coupling_is_bounded_by_the_shared_area() -> None:
    low, high, prior = coupling_bounds(20.0)  # 20 m² of partition
    assert (low, high) == pytest.approx((20.0 * 0.2e-3, 20.0 * 6.0e-3))
    assert low < prior < high
