"""The fleet's guard: the excess of the fleet's predicted power over its limit is shed where
comfort allows first, and not at all while the fleet has headroom."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.generate import generate_fleet
from hvacflex.fleet.guard import comfort_floor_flow_kg_s, guard_caps_kw, path_flow_kg_s
from hvacflex.fleet.schema import fleet_from_dict


def test_the_comfort_floor_cuts_each_zone_to_its_upper_band() -> None:
    """Zone 0 ends 2 K below its band at 1 kg/s and cools 2 K per kg/s: 1 kg/s could go, but
    its lower bound keeps 0.2; zone 1 ends 0.5 K below: 0.25 kg/s goes; zone 2 is above
    its band and keeps its flow."""
    floor = comfort_floor_flow_kg_s(
        end_temp_degc=np.array([24.0, 25.5, 26.5]),
        gain_k_per_kg_s=np.array([-2.0, -2.0, -2.0]),
        upper_degc=np.full(3, 26.0),
        flow_kg_s=np.ones(3),
        low_kg_s=np.full(3, 0.2),
    )
    np.testing.assert_allclose(floor, [0.2, 0.75, 1.0])


def test_the_path_falls_from_the_plan_to_the_floor_then_to_the_lower_bounds() -> None:
    low, floor, flow = np.array([0.2, 0.2]), np.array([0.2, 0.8]), np.array([1.0, 1.0])
    np.testing.assert_allclose(path_flow_kg_s(2.0, low, floor, flow), flow)
    np.testing.assert_allclose(path_flow_kg_s(1.5, low, floor, flow), [0.6, 0.9])
    np.testing.assert_allclose(path_flow_kg_s(1.0, low, floor, flow), floor)
    np.testing.assert_allclose(path_flow_kg_s(0.5, low, floor, flow), [0.2, 0.5])
    np.testing.assert_allclose(path_flow_kg_s(0.0, low, floor, flow), low)
    path = np.array([path_flow_kg_s(s, low, floor, flow) for s in np.linspace(0, 2, 41)])
    assert np.all(np.diff(path, axis=0) >= 0.0)  # every flow rises with s


POWER = np.array([100.0, 100.0, 100.0])
FREE = np.array([90.0, 95.0, 80.0])  # comfort-free parts 10, 5, 20 kW
MINIMUM = np.array([50.0, 50.0, 50.0])
ROOM = np.array([0.5, 2.0, 1.0])  # building 1 is furthest below its band, then 2, then 0


def test_with_headroom_nothing_is_cut_and_the_caps_share_it() -> None:
    """A building above its own share of the limit is not cut while the fleet is under it."""
    caps = guard_caps_kw(np.array([130.0, 90.0, 60.0]), FREE, MINIMUM, ROOM, 300.0)
    np.testing.assert_allclose(caps, [130.0 + 20 / 3, 90.0 + 20 / 3, 60.0 + 20 / 3])
    assert caps.sum() == pytest.approx(300.0)


@pytest.mark.parametrize(
    ("limit_kw", "expected"),
    [
        (295.0, [100.0, 95.0, 100.0]),  # 5 kW: all from building 1's free part
        (288.0, [100.0, 95.0, 93.0]),  # 12 kW: building 1's 5, then 7 of building 2's 20
        (268.0, [93.0, 95.0, 80.0]),  # 32 kW: 5 + 20, then 7 of building 0's 10
    ],
)
def test_the_excess_is_shed_from_the_roomiest_comfort_free_parts_first(
    limit_kw: float, expected: list[float]
) -> None:
    caps = guard_caps_kw(POWER, FREE, MINIMUM, ROOM, limit_kw)
    np.testing.assert_allclose(caps, expected)
    assert caps.sum() == pytest.approx(limit_kw)


def test_beyond_the_free_parts_the_rest_is_shared_in_proportion_to_what_is_left() -> None:
    """45 kW over: the free parts give 35, the last 10 kW come from the buildings in
    proportion to their floor-to-minimum spans 40, 45 and 30 kW."""
    caps = guard_caps_kw(POWER, FREE, MINIMUM, ROOM, 255.0)
    spans = FREE - MINIMUM
    np.testing.assert_allclose(caps, FREE - 10.0 * spans / spans.sum())
    assert caps.sum() == pytest.approx(255.0)
    assert np.all(caps >= MINIMUM)


def test_a_limit_below_the_minima_holds_every_building_at_its_minimum() -> None:
    np.testing.assert_allclose(guard_caps_kw(POWER, FREE, MINIMUM, ROOM, 120.0), MINIMUM)


def test_a_building_with_no_comfort_free_part_is_passed_over() -> None:
    """The roomiest building can shed nothing for free: the next one sheds."""
    caps = guard_caps_kw(POWER, np.array([90.0, 100.0, 80.0]), MINIMUM, ROOM, 295.0)
    np.testing.assert_allclose(caps, [100.0, 100.0, 95.0])


def test_a_locked_building_is_never_cut_and_no_limit_means_no_cap() -> None:
    power, room = np.array([100.0, 100.0]), np.array([-np.inf, 0.5])
    caps = guard_caps_kw(power, np.array([100.0, 90.0]), np.array([100.0, 50.0]), room, 190.0)
    np.testing.assert_allclose(caps, [100.0, 90.0])
    assert np.all(np.isinf(guard_caps_kw(POWER, FREE, MINIMUM, ROOM, np.inf)))


def _group(start: str) -> tuple[BuildingGroup, np.ndarray]:
    """Two buildings (seed 3) with their first step begun and planned without caps; (the
    group, their plans' powers (2, N) [kW])."""
    doc = generate_fleet(2, 3, feeder_limit_kw=float("inf"))
    fleet = fleet_from_dict(doc)
    group = BuildingGroup(doc, [0, 1], FleetSettings.of(fleet, start, 1 / 24))
    group.begin_step()
    horizon = fleet.spec.horizon_steps
    power, _, _ = group.finalize(np.zeros(horizon), np.full((2, horizon), np.inf))
    return group, power


def test_a_building_above_its_own_cap_is_not_cut_while_the_fleet_has_headroom() -> None:
    """At 02:00 the plant's power model predicts more than the plan's affine power (the
    secant under-states small flows): held to its own cap (the plan's power), building 0
    would be cut; the fleet guard, with the fleet's limit above the buildings' predicted
    sum, cuts nothing."""
    group, power = _group("2014-03-03T02:00")
    caps = power.copy()
    caps[1] = np.inf  # building 0 held to its own plan, building 1 free
    group.finalize(np.zeros(power.shape[1]), caps)
    predicted, free, minimum, room = group.guard_view()
    assert predicted[0] > power[0, 0] + 0.1  # its own cap would cut it
    limit = float(predicted.sum()) + 1.0
    rows = group.advance(False, guard_caps_kw(predicted, free, minimum, room, limit))
    np.testing.assert_array_equal(rows["fallback"], [0.0, 0.0])  # nothing cut
    np.testing.assert_allclose(rows["planned_power_kw"], power[:, 0], rtol=1e-9)


def test_a_fleet_over_its_limit_is_brought_to_it_on_the_meter() -> None:
    """At 11:00, the limit 5 % below the buildings' predicted sum: the guard cuts, the
    fleet's meter reads within 1 % of the limit, and no building is cut below its minimum
    flows' power."""
    group, _ = _group("2014-03-03T11:00")
    predicted, free, minimum, room = group.guard_view()
    assert np.all(minimum <= free) and np.all(free <= predicted + 1e-9)
    limit = 0.95 * float(predicted.sum())
    assert limit > minimum.sum()
    caps = guard_caps_kw(predicted, free, minimum, room, limit)
    rows = group.advance(False, caps)
    assert rows["fallback"].max() == 1.0  # cut
    assert rows["power_kw"].sum() <= 1.01 * limit
    assert rows["power_kw"].sum() >= 0.97 * limit  # cut to the limit, not to the minimum
