"""Generated fleets: the default feeder limit and the design minimum power."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hvacflex.building.hvac import hvac_power_kw
from hvacflex.building.io import building_from_dict
from hvacflex.fleet.agent import BuildingGroup, FleetSettings
from hvacflex.fleet.generate import (
    DEFAULT_LIMIT_FRACTION,
    MIN_POWER_MARGIN,
    design_min_power_kw,
    design_power_kw,
    generate_fleet,
    write_fleet,
)
from hvacflex.fleet.run import minimum_power_warning
from hvacflex.fleet.schema import fleet_from_dict, load_fleet


def test_design_minimum_is_the_ventilation_flow_power() -> None:
    doc = generate_fleet(1, 7, feeder_limit_kw=100.0)
    building = building_from_dict(doc["buildings"][0]["building"])
    low = np.asarray(building.hvac.flow_min_at(np.array([True]))[0])
    expected = float(hvac_power_kw(building.hvac, low, np.full(low.shape, 28.0), 32.0, 0.020))
    assert design_min_power_kw(building) == pytest.approx(expected)
    assert 0 < design_min_power_kw(building) < design_power_kw(doc["buildings"][0]["building"])


@pytest.mark.parametrize(("buildings", "seed"), [(8, 3), (20, 17)])
def test_default_limit_covers_the_design_minimum(buildings: int, seed: int) -> None:
    doc = generate_fleet(buildings, seed)
    raws = [e["building"] for e in doc["buildings"]]
    minimum = sum(design_min_power_kw(building_from_dict(r)) for r in raws)
    design = sum(design_power_kw(r) for r in raws)
    limit = doc["feeder_limit_kw"]
    assert limit >= MIN_POWER_MARGIN * minimum - 0.05
    assert limit == pytest.approx(
        max(DEFAULT_LIMIT_FRACTION * design, MIN_POWER_MARGIN * minimum), abs=0.05
    )


def test_limit_and_min_bid_written_as_top_level_keys(tmp_path: Path) -> None:
    path = write_fleet(
        generate_fleet(2, 1, feeder_limit_kw=math.inf, min_bid_mw=0.01), tmp_path / "f.toml"
    )
    text = path.read_text()
    assert "\nfeeder_limit_kw = inf\n" in text and "\nmin_bid_mw = 0.01\n" in text
    fleet = load_fleet(path)
    assert math.isinf(fleet.spec.feeder_limit_kw or 0.0) and fleet.spec.min_bid_mw == 0.01


def test_minimum_power_warning_only_below_the_minima(tmp_path: Path) -> None:
    doc = generate_fleet(2, 1, feeder_limit_kw=1.0)
    low = write_fleet(doc, tmp_path / "low.toml")
    warning = minimum_power_warning(load_fleet(low), "2014-03-03", 1.0)
    assert warning is not None and "flagged infeasible" in warning and "1.0 kW" in warning
    doc["feeder_limit_kw"] = math.inf
    assert (
        minimum_power_warning(
            load_fleet(write_fleet(doc, tmp_path / "inf.toml")), "2014-03-03", 1.0
        )
        is None
    )


@pytest.mark.slow
def test_default_limit_covers_the_planned_minima_of_a_hot_day() -> None:
    # 2014-03-05: the 20-building fleet's planned minimum powers peak at 14:30, above the old
    # default (0.33 × design power = 635 kW); the controllers' own P_min over the day ahead
    doc = generate_fleet(20, 17)
    fleet = fleet_from_dict(doc)
    group = BuildingGroup(doc, list(range(20)), FleetSettings.of(fleet, "2014-03-05", 1))
    p_min, _, _ = group.begin_step()
    peak_minimum = float(p_min.sum(axis=0).max())
    assert peak_minimum > DEFAULT_LIMIT_FRACTION * sum(
        design_power_kw(e["building"]) for e in doc["buildings"]
    )
    assert peak_minimum < doc["feeder_limit_kw"]


def test_a_variant_does_not_carry_the_template_s_metered_power_models() -> None:
    """office5's power models were fitted to office5's meters; a variant (another area, COP,
    construction) has no meter of its own, so it plans with its design curves."""
    doc = generate_fleet(2, 3)
    template = building_from_dict(doc["buildings"][0]["building"], source="b0000")
    assert template.power_models == {}
    assert template.with_power_model_for("rc").metered_power is None
