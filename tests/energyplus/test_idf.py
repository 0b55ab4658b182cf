"""IDF text handling: parsing, version check, run-period/site rewriting, zones, weather cover."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hvacflex.energyplus.hvac import (
    availability_schedules,
    heating_setpoint_schedule,
    ideal_loads_name,
    zone_inlet_nodes,
)
from hvacflex.energyplus.idf import (
    check_weather_covers,
    match_zones,
    objects_of,
    parse_idf,
    prepare_idf,
    read_idf,
)
from hvacflex.errors import DataError, InputError
from hvacflex.paths import resources_dir

IDF = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"
EPW = resources_dir() / "weather" / "SGP_SG_Singapore-Changi.Intl.AP.486980_TMYx.2009-2023.epw"
DAY = pd.Timestamp("2014-03-04")


def _prepare(text: str, **kwargs: object) -> object:
    return prepare_idf(
        text, "test.idf", start_date=DAY, end_date=DAY, timesteps_per_hour=6, **kwargs
    )  # type: ignore[arg-type]


def test_parse_keeps_fields_spans_and_lines() -> None:
    text = "! header\n  Version,25.2;\nZone,\n  Room A,   !- Name\n  0;\nTimestep,4;\n"
    objects = parse_idf(text, "t.idf")
    assert [o.class_name for o in objects] == ["Version", "Zone", "Timestep"]
    assert objects[1].fields == ("Room A", "0")
    assert objects[1].line == 3
    assert text[objects[0].start : objects[0].end] == "Version,25.2;"


def test_unclosed_object_names_its_line() -> None:
    with pytest.raises(InputError, match=r"t.idf:3.*not closed by ';'"):
        parse_idf("Version,25.2;\n\nZone,\n  Room A\n", "t.idf")


def test_empty_and_missing_files_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no EnergyPlus object"):
        parse_idf("! only a comment\n", "t.idf")
    with pytest.raises(InputError, match="IDF file not found"):
        read_idf(tmp_path / "absent.idf")


def test_other_version_is_refused_naming_both() -> None:
    text = read_idf(IDF).replace("Version,25.2;", "Version,24.1;")
    with pytest.raises(InputError, match=r"EnergyPlus 24\.1, hvacflex runs EnergyPlus 25\.2"):
        _prepare(text)
    with pytest.raises(InputError, match="no Version object"):
        _prepare(read_idf(IDF).replace("Version,25.2;", ""))


def test_prepare_sets_run_period_timestep_and_singapore_site() -> None:
    prepared = _prepare(read_idf(IDF))
    objects = prepared.objects  # type: ignore[attr-defined]
    (run,) = objects_of(objects, "RunPeriod")
    assert run.fields[1:7] == ("3", "4", "2014", "3", "4", "2014")
    assert run.field(8) == "No" and run.field(9) == "No"  # no weather-file holidays, no DST
    assert [o.fields for o in objects_of(objects, "Timestep")] == [("6",)]
    (site,) = objects_of(objects, "Site:Location")
    assert float(site.field(1)) == pytest.approx(1.37)
    design = objects_of(objects, "SizingPeriod:DesignDay")
    assert sorted(float(d.field(4)) for d in design) == [23.3, 33.2]
    (ground,) = objects_of(objects, "Site:GroundTemperature:BuildingSurface")
    assert set(ground.fields) == {"26"}
    assert "5ZoneAirCooled.idf" in prepared.text  # type: ignore[attr-defined]  # header kept


def test_daylight_saving_is_removed_with_a_warning_and_special_days_kept() -> None:
    text = read_idf(IDF) + (
        "\nRunPeriodControl:DaylightSavingTime,2nd Sunday in March,1st Sunday in November;\n"
        "RunPeriodControl:SpecialDays,Founding,3/4,1,Holiday;\n"
    )
    with pytest.warns(UserWarning, match="DaylightSavingTime"):
        prepared = _prepare(text)
    objects = prepared.objects  # type: ignore[attr-defined]
    assert not objects_of(objects, "RunPeriodControl:DaylightSavingTime")
    assert [o.field(0) for o in objects_of(objects, "RunPeriodControl:SpecialDays")] == ["Founding"]


def test_bad_timestep_is_refused() -> None:
    with pytest.raises(InputError, match="timesteps_per_hour"):
        prepare_idf(read_idf(IDF), "t.idf", start_date=DAY, end_date=DAY, timesteps_per_hour=5)


def test_zones_match_case_insensitively_and_unknown_ones_are_named() -> None:
    available = ("PLENUM-1", "SPACE1-1", "SPACE2-1")
    assert match_zones(("space2-1", "Space1-1"), available, "t.idf", "f") == (
        "SPACE2-1",
        "SPACE1-1",
    )
    with pytest.raises(InputError, match=r"no such zone.*'office'.*SPACE1-1"):
        match_zones(("office",), available, "t.idf", "zones.energyplus_zone")


def test_hvac_discovery_on_the_five_zone_model() -> None:
    objects = parse_idf(read_idf(IDF), IDF)
    assert zone_inlet_nodes(objects, "space3-1", IDF) == ("SPACE3-1 In Node",)
    assert heating_setpoint_schedule(objects, "SPACE1-1") == "Htg-SetP-Sch"
    schedules = {name.lower() for _, name in availability_schedules(objects)}
    # the VAV boxes' schedule too: off at night and at weekends from April
    assert {"fanavailsched", "coolingcoilavailsched", "reheatcoilavailsched"} <= schedules
    with pytest.raises(InputError, match="AirTerminal:SingleDuct:VAV:Reheat has no flow"):
        ideal_loads_name(objects, "SPACE1-1", IDF)


def test_weather_must_cover_every_day(tmp_path: Path) -> None:
    check_weather_covers(EPW, DAY, DAY + pd.Timedelta(days=2))
    lines = EPW.read_text(encoding="latin-1").splitlines()
    january = tmp_path / "january.epw"
    january.write_text("\n".join(lines[: 8 + 31 * 24]) + "\n", encoding="latin-1")
    check_weather_covers(january, pd.Timestamp("2014-01-30"), pd.Timestamp("2014-01-31"))
    with pytest.raises(DataError, match=r"does not cover the run.*04 March"):
        check_weather_covers(january, DAY, DAY)
    with pytest.raises(DataError, match=r"no rows for 29 February"):
        check_weather_covers(EPW, pd.Timestamp("2016-02-28"), pd.Timestamp("2016-03-01"))
    with pytest.raises(DataError, match="weather file not found"):
        check_weather_covers(tmp_path / "none.epw", DAY, DAY)
