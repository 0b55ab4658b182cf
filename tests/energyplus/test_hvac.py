"""What an IDF's HVAC offers to sense and actuate, read from the shipped 5ZoneAirCooled."""

from __future__ import annotations

import pytest

from hvacflex.energyplus import hvac
from hvacflex.energyplus.idf import parse_idf, read_idf
from hvacflex.errors import InputError
from hvacflex.paths import resources_dir

IDF = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"


@pytest.fixture(scope="module")
def objects():  # type: ignore[no-untyped-def]
    return parse_idf(read_idf(IDF), IDF)


def test_conditioned_zones_have_inlets_and_thermostats_the_plenum_does_not(objects) -> None:  # type: ignore[no-untyped-def]
    for zone in ("SPACE1-1", "space5-1"):  # names match case-insensitively
        assert hvac.zone_inlet_nodes(objects, zone, IDF)
        assert hvac.has_thermostat(objects, zone)
    assert not hvac.has_thermostat(objects, "PLENUM-1")


def test_the_air_loop_availability_is_found(objects) -> None:  # type: ignore[no-untyped-def]
    schedules = hvac.availability_schedules(objects)
    assert schedules and all(kind and name for kind, name in schedules)


def test_flow_actuation_needs_ideal_loads(objects) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError, match="IdealLoadsAirSystem"):
        hvac.ideal_loads_name(objects, "SPACE1-1", IDF)
