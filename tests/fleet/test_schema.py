from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.config import DataConfig
from hvacflex.config.presets import PRODUCT_RESERVE
from hvacflex.data.forecast import default_weather_file
from hvacflex.data.market import synthetic_reserve_prices
from hvacflex.errors import BuildingConfigError
from hvacflex.fleet.agent import BuildingAgent, FleetSettings, building_setup
from hvacflex.fleet.generate import generate_fleet, to_toml, write_fleet
from hvacflex.fleet.schema import FleetConfigError, load_fleet
from hvacflex.paths import data_dir, resources_dir


def test_generate_is_heterogeneous_valid_and_seeded(tmp_path: Path) -> None:
    doc = generate_fleet(6, 11)
    assert doc == generate_fleet(6, 11)
    assert doc != generate_fleet(6, 12)
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert len(fleet.buildings) == 6
    cops = {b.building.hvac.cop for b in fleet.buildings}
    areas = {round(sum(z.floor_area_m2 for z in b.building.zones)) for b in fleet.buildings}
    assert len(cops) > 1 and len(areas) > 1
    # the chiller is sized to the floor like the air flows (office5: 180 kW for 1,296 m²)
    for b in fleet.buildings:
        chiller, area = b.building.hvac.chiller, b.building.floor_area_m2
        assert chiller is not None
        assert chiller.capacity_kw / area == pytest.approx(180.0 / 1296.0, rel=0.01)
    text = (tmp_path / "f.toml").read_text()
    for key in ("feeder_limit_kw", "min_bid_mw", "[reserve]", "[ppp]"):
        assert key in text
    assert tomllib.loads(to_toml(doc)) == doc


def test_infinite_limit_round_trips(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1, feeder_limit_kw=float("inf"))
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert fleet.spec.feeder_limit_kw == float("inf")


def test_the_envelope_is_on_unless_the_file_says_false(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    assert load_fleet(write_fleet(doc, tmp_path / "f.toml")).spec.envelope is True
    doc["envelope"] = False
    assert load_fleet(write_fleet(doc, tmp_path / "f.toml")).spec.envelope is False
    doc["envelope"] = "no"
    with pytest.raises(FleetConfigError, match=r"f\.toml.*envelope"):
        load_fleet(write_fleet(doc, tmp_path / "f.toml"))


def test_the_comfort_penalty_reaches_every_building_and_is_validated(tmp_path: Path) -> None:
    doc = generate_fleet(2, 1)
    default = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert default.spec.comfort_penalty_sgd_per_kelvin_hour == 100.0
    doc["comfort_penalty_sgd_per_kelvin_hour"] = 12.5
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    settings = FleetSettings.of(fleet, "2014-03-03", 1 / 24)
    for index, entry in enumerate(fleet.buildings):
        controller = building_setup(entry, index, settings).config.controller
        assert controller.comfort_penalty_sgd_per_kelvin_hour == 12.5
    agent = BuildingAgent(fleet.buildings[1], 1, settings)
    agent.begin_step()
    assert agent.problem.comfort_penalty_sgd_per_kelvin_hour == 12.5
    for bad in (0.0, -1.0, float("inf")):
        doc["comfort_penalty_sgd_per_kelvin_hour"] = bad
        with pytest.raises(FleetConfigError, match=r"f\.toml.*comfort_penalty_sgd_per_kelvin_hour"):
            load_fleet(write_fleet(doc, tmp_path / "f.toml"))


def _refused(doc: dict[str, object], tmp_path: Path, key: str, value: object, match: str) -> None:
    """The fleet file with ``key = value`` is refused with a message matching ``match``."""
    doc[key] = value
    with pytest.raises(FleetConfigError, match=match):
        load_fleet(write_fleet(doc, tmp_path / "f.toml"))


def test_the_comfort_knee_reaches_every_building_and_is_validated(tmp_path: Path) -> None:
    doc = generate_fleet(2, 1)
    assert load_fleet(write_fleet(doc, tmp_path / "f.toml")).spec.comfort_knee_k is None
    doc.update(
        comfort_penalty_sgd_per_kelvin_hour=3.0,
        comfort_knee_k=1.0,
        comfort_penalty_beyond_knee_sgd_per_kelvin_hour=100.0,
    )
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    settings = FleetSettings.of(fleet, "2014-03-03", 1 / 24)
    agent = BuildingAgent(fleet.buildings[0], 0, settings)
    agent.begin_step()
    knee = agent.problem.comfort_knee
    assert knee is not None
    assert (knee.knee_kelvin, knee.penalty_beyond_sgd_per_kelvin_hour) == (1.0, 100.0)
    # ρ₂ below ρ: not convex
    _refused(
        doc, tmp_path, "comfort_penalty_beyond_knee_sgd_per_kelvin_hour", 2.0, r"f\.toml.*at least"
    )
    _refused(doc, tmp_path, "comfort_knee_k", -1.0, r"f\.toml.*comfort_knee_k")


def test_the_linearisation_margin_sets_every_buildings_t0_and_is_validated(
    tmp_path: Path,
) -> None:
    """``linearisation_margin_k``: T₀ = each building's occupied upper bound − the margin
    (the default 1 K gives the scenario's own T₀); the model and the power rows follow it;
    a margin wider than a building's band is refused, naming the building."""
    doc = generate_fleet(2, 1)
    doc["buildings"][0]["comfort_occupied_degc"] = [23.0, 26.0]
    doc["buildings"][1]["comfort_occupied_degc"] = [22.5, 25.5]
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert fleet.spec.linearisation_margin_k == 1.0
    settings = FleetSettings.of(fleet, "2014-03-03", 1 / 24)
    default = [building_setup(e, i, settings) for i, e in enumerate(fleet.buildings)]
    assert [s.linearisation_temp_degc for s in default] == [25.0, 24.5]
    doc["linearisation_margin_k"] = 2.0
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    settings = FleetSettings.of(fleet, "2014-03-03", 1 / 24)
    lowered = [building_setup(e, i, settings) for i, e in enumerate(fleet.buildings)]
    assert [s.linearisation_temp_degc for s in lowered] == [24.0, 23.5]
    # a zone linearised 1 K cooler: its supply air cools it less per kg/s (B closer to 0)
    assert np.all(np.abs(lowered[0].model.b) <= np.abs(default[0].model.b) + 1e-12)
    assert not np.allclose(lowered[0].model.b, default[0].model.b)
    # the LP's power rows: the coil's heat per kg/s, and so its power, taken 1 K cooler
    cool = BuildingAgent(fleet.buildings[0], 0, settings)
    warm = BuildingAgent(
        fleet.buildings[0],
        0,
        FleetSettings.of(
            load_fleet(write_fleet({**doc, "linearisation_margin_k": 1.0}, tmp_path / "g.toml")),
            "2014-03-03",
            1 / 24,
        ),
    )
    for agent in (cool, warm):
        agent.begin_step()
    p_cool, p_warm = cool.problem.power_coeff_kw_per_kg_s, warm.problem.power_coeff_kw_per_kg_s
    assert np.all(p_cool < p_warm)
    margin = r"f\.toml.*linearisation_margin_k"
    _refused(doc, tmp_path, "linearisation_margin_k", 3.5, margin + r".*buildings\[0\].*'b0000'")
    _refused(doc, tmp_path, "linearisation_margin_k", -1.0, margin)
    # the band's whole width is allowed, however its ends round: T₀ is the lower bound
    doc["buildings"][0]["comfort_occupied_degc"] = [22.0, 24.3]
    doc["linearisation_margin_k"] = 2.3
    edge = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    setup = building_setup(edge.buildings[0], 0, FleetSettings.of(edge, "2014-03-03", 1 / 24))
    assert setup.linearisation_temp_degc == 22.0
    # a T₀ at the supply air: refused with the building named (supply air 13 °C)
    doc["buildings"][0]["comfort_occupied_degc"] = [13.0, 14.0]
    _refused(doc, tmp_path, "linearisation_margin_k", 1.0, margin + r".*'b0000'.*supply air")


@pytest.mark.parametrize(
    ("key", "default", "value", "bad", "match"),
    [
        ("linearisation", "fixed", "plan", "trajectory", r"f\.toml.*linearisation.*'plan'"),
        ("lower_plan_margin_k", 0.0, 0.4, -0.1, r"f\.toml.*lower_plan_margin_k"),
    ],
)
def test_a_controller_key_reaches_every_building_and_is_validated(
    tmp_path: Path, key: str, default: object, value: object, bad: object, match: str
) -> None:
    doc = generate_fleet(2, 1)
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert getattr(fleet.spec, key) == default
    doc[key] = value
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    settings = FleetSettings.of(fleet, "2014-03-03", 1 / 24)
    setups = [building_setup(e, i, settings) for i, e in enumerate(fleet.buildings)]
    assert all(getattr(s.config.controller, key) == value for s in setups)
    _refused(doc, tmp_path, key, bad, match)


def test_example_fleet_ships() -> None:
    fleet = load_fleet(resources_dir() / "fleets" / "example.toml")
    assert len(fleet.buildings) == 3 and fleet.spec.min_bid_mw == 0.1


def test_unknown_key_names_file_and_field(tmp_path: Path) -> None:
    path = write_fleet(generate_fleet(1, 1), tmp_path / "f.toml")
    path.write_text(path.read_text().replace("min_bid_mw", "min_bid_MW"))
    with pytest.raises(FleetConfigError, match=r"f\.toml.*min_bid_MW.*unknown key"):
        load_fleet(path)


def test_bad_building_names_the_building(tmp_path: Path) -> None:
    doc = generate_fleet(2, 1)
    doc["buildings"][1]["building"]["zones"][0]["floor_area_m2"] = -1.0
    path = write_fleet(doc, tmp_path / "f.toml")
    with pytest.raises(BuildingConfigError, match=r"buildings\[1\]\.building.*floor_area_m2"):
        load_fleet(path)


def test_limit_needs_exactly_one_form(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    doc["feeder_limit_csv"] = "limit.csv"
    path = write_fleet(doc, tmp_path / "f.toml")
    with pytest.raises(FleetConfigError, match="exactly one"):
        load_fleet(path)


def test_reserve_defaults_to_the_product_event_model(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    del doc["reserve"]  # a fleet file without [reserve] gets the product's contract
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    config = fleet.spec.reserve.config()
    assert config.event_max_steps == PRODUCT_RESERVE["event_max_steps"]
    assert config.event_allowance_k == PRODUCT_RESERVE["event_allowance_k"]
    assert config.event_recovery_steps == PRODUCT_RESERVE["event_recovery_steps"]
    settings = FleetSettings.of(fleet, "2014-03-03", 1)
    assert settings.il_events == config
    # every building's controller builds event-model problems with these settings
    agent = BuildingAgent(fleet.buildings[0], 0, settings)
    agent.begin_step()
    events = agent.problem.events
    assert events is not None
    assert events.max_steps == config.event_max_steps
    assert events.allowance_kelvin == config.event_allowance_k
    # … on each building's own power model: the fleet's bid is checked on the fleet's meter
    assert not config.meter_calibrated_offers and not config.plan_visible_offers
    assert agent.problem.offer_baselines is None
    assert events.recovery_steps == config.event_recovery_steps
    assert agent.control.allowance_carry_steps == 0


def test_whole_horizon_reserve_and_its_errors(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    doc["reserve"] = {"enabled": True, "event_max_steps": 0}
    with pytest.raises(FleetConfigError, match=r"reserve.*allowance"):
        load_fleet(write_fleet(doc, tmp_path / "a.toml"))
    doc["reserve"].update(event_allowance_k=0.0, event_recovery_steps=0)
    config = load_fleet(write_fleet(doc, tmp_path / "b.toml")).spec.reserve.config()
    assert config.event_max_steps is None and config.event_allowance_k == 0.0
    doc["reserve"] = {"event_max_steps": -1}
    with pytest.raises(FleetConfigError, match=r"reserve\.event_max_steps"):
        load_fleet(write_fleet(doc, tmp_path / "c.toml"))


@pytest.mark.parametrize(
    ("key", "value", "field"),
    [
        ("initial_temp_degc", -500.0, "initial_temp_degc"),
        ("comfort_occupied_degc", [200.0, 300.0], "comfort_occupied_degc"),
    ],
)
def test_impossible_temperatures_are_refused(
    tmp_path: Path, key: str, value: object, field: str
) -> None:
    doc = generate_fleet(2, 1)
    doc["buildings"][1][key] = value
    path = write_fleet(doc, tmp_path / "f.toml")
    with pytest.raises(FleetConfigError, match=rf"buildings\[1\]\.{field}"):
        load_fleet(path)


def test_generate_caps_the_number_of_buildings() -> None:
    from hvacflex.constants import MAX_FLEET_BUILDINGS
    from hvacflex.errors import ConfigError

    with pytest.raises(ConfigError, match=r"field 'buildings'.*1 … 1000"):
        generate_fleet(MAX_FLEET_BUILDINGS + 1, 1)


def _data_folder(folder: Path) -> tuple[Path, Path]:
    """A copy of the shipped weather file and of the March 2014 USEP file under
    ``folder/inputs``: (EPW file, USEP folder)."""
    inputs = folder / "inputs" / "usep"
    inputs.mkdir(parents=True)
    weather = folder / "inputs" / "site.epw"
    shutil.copyfile(default_weather_file(), weather)
    shutil.copyfile(data_dir() / "nems_usep_2014" / "USEP_Mar-2014.csv", inputs / "march.csv")
    return weather, inputs


def test_data_table_reaches_every_building_with_paths_from_the_fleet_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    weather, usep = _data_folder(tmp_path / "site")
    doc = generate_fleet(2, 1)
    doc["data"] = {
        "weather_file": "inputs/site.epw",
        "usep_source": "inputs/usep",
        "reserve_price_scale": 150.0,
        "reserve_price_correlation": 0.5,
        "price_gap_fill": "previous-day",
    }
    path = write_fleet(doc, tmp_path / "site" / "fleet.toml")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # relative paths are the fleet file's, not the cwd's
    fleet = load_fleet(Path("..") / "site" / "fleet.toml")
    expected = DataConfig(
        weather_file=str(Path("..") / "site" / "inputs" / "site.epw"),
        usep_source=str(Path("..") / "site" / "inputs" / "usep"),
        reserve_price_scale=150.0,
        reserve_price_correlation=0.5,
        price_gap_fill="previous-day",
    )
    assert fleet.data == expected
    assert Path(fleet.data.weather_file or "").resolve() == weather.resolve()
    assert Path(fleet.data.usep_source or "").resolve() == usep.resolve()
    settings = FleetSettings.of(fleet, "2014-03-03", 1)
    assert settings.data == expected
    prices = []
    for i, entry in enumerate(fleet.buildings):
        setup = building_setup(entry, i, settings)  # reads the copied files: paths resolve
        assert setup.config.data == expected
        exo = setup.exogenous
        # the [data] scale and ρ shape the price every building sees (one market)
        energy = pd.Series(exo.energy_price_sgd_per_mwh, index=exo.index)
        synthetic = synthetic_reserve_prices(
            energy, seed=fleet.spec.seed, scale_sgd_per_mwh=150.0, correlation=0.5
        )
        np.testing.assert_allclose(exo.reserve_price_sgd_per_mwh, synthetic.to_numpy())
        prices.append(exo.reserve_price_sgd_per_mwh)
    np.testing.assert_array_equal(prices[0], prices[1])
    assert path.is_file()


def test_data_defaults_to_the_shipped_data(tmp_path: Path) -> None:
    fleet = load_fleet(write_fleet(generate_fleet(1, 1), tmp_path / "f.toml"))
    assert fleet.data == DataConfig()
    assert FleetSettings.of(fleet, "2014-03-03", 1).data == DataConfig()


def test_bad_data_value_names_the_data_field(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    doc["data"] = {"reserve_price_correlation": 2.0}
    path = write_fleet(doc, tmp_path / "f.toml")
    with pytest.raises(FleetConfigError) as caught:
        load_fleet(path)
    assert caught.value.field == "data.reserve_price_correlation"
    assert caught.value.value == 2.0
    assert caught.value.source == str(path)
    doc["data"] = {"reserve_price_scal": 2.0}  # a misspelt key: the table's valid keys
    with pytest.raises(FleetConfigError, match=r"data\.reserve_price_scal.*unknown key.*calendar"):
        load_fleet(write_fleet(doc, tmp_path / "g.toml"))


def test_reserve_source_refuses_the_synthetic_price_keys(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    doc["data"] = {"reserve_source": "reserve.csv", "reserve_price_scale": 30.0}
    with pytest.raises(FleetConfigError) as caught:
        load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert caught.value.field == "data.reserve_price_scale"
    assert caught.value.value == 30.0
    assert "reserve_source" in str(caught.value)


def test_old_top_level_reserve_price_scale_is_refused_with_the_fix(tmp_path: Path) -> None:
    doc = generate_fleet(1, 1)
    doc["reserve_price_scale"] = 200.0
    path = write_fleet(doc, tmp_path / "f.toml")
    with pytest.raises(FleetConfigError) as caught:
        load_fleet(path)
    assert caught.value.field == "reserve_price_scale"
    assert caught.value.value == 200.0
    assert "moved to [data] reserve_price_scale" in str(caught.value)


def test_the_run_key_follows_every_file_the_fleet_names(tmp_path: Path) -> None:
    from hvacflex.fleet.run import fleet_key

    doc = generate_fleet(1, 1)
    del doc["feeder_limit_kw"]
    doc["feeder_limit_csv"] = "limit.csv"
    doc["activation"] = {"mode": "file", "file": "events.csv"}
    path = write_fleet(doc, tmp_path / "f.toml")
    limit, events = tmp_path / "limit.csv", tmp_path / "events.csv"
    limit.write_text("time,feeder_limit_kw\n2014-03-03 00:00,100\n")
    events.write_text("time,activated\n2014-03-03 10:00,1\n")
    fleet = load_fleet(path)
    assert fleet.feeder_limit_path == limit and fleet.activation.file == str(events)
    key = fleet_key(fleet, path, "2014-03-03", 1.0)
    assert fleet_key(fleet, path, "2014-03-03", 1.0) == key
    assert fleet_key(fleet, path, "2014-03-03", 2.0) != key
    limit.write_text("time,feeder_limit_kw\n2014-03-03 00:00,90\n")
    edited_limit = fleet_key(fleet, path, "2014-03-03", 1.0)
    assert edited_limit != key
    events.write_text("time,activated\n2014-03-03 11:00,1\n")
    assert fleet_key(fleet, path, "2014-03-03", 1.0) not in (key, edited_limit)


def _windowed(tmp_path: Path, windows: list[dict[str, object]], limit: float) -> Path:
    doc = generate_fleet(1, 1, feeder_limit_kw=limit)
    doc["feeder_limits"] = windows
    return write_fleet(doc, tmp_path / "f.toml")


def test_limit_windows_set_the_limit_in_force(tmp_path: Path) -> None:
    windows = [
        {"start": "10:00", "end": "17:00", "limit_kw": 50.0},  # weekdays (the default)
        {"start": "14:00", "end": "16:00", "limit_kw": 40.0, "days": "all"},
        {"start": "2014-03-03T11:00", "end": "2014-03-03T12:00", "limit_kw": 45.0},
        {"start": "12:00", "end": "13:00", "limit_kw": 500.0},  # looser: the base holds
    ]
    fleet = load_fleet(_windowed(tmp_path, windows, 60.0))
    index = pd.date_range("2014-03-01", periods=4 * 48, freq="30min", tz="Asia/Singapore")
    limit = pd.Series(fleet.limit_series_kw(index), index=index)
    # Saturday 2014-03-01: only the every-day window; period starts in [14:00, 16:00)
    saturday = limit["2014-03-01"]
    assert set(saturday[saturday < 60].index.strftime("%H:%M")) == {
        "14:00",
        "14:30",
        "15:00",
        "15:30",
    }
    assert saturday.min() == 40.0
    monday = limit["2014-03-03"]  # a weekday: 10:00–17:00 at 50, 14–16 at 40, 11–12 at 45
    expected = np.full(48, 60.0)
    expected[20:34] = 50.0
    expected[28:32] = 40.0
    expected[22:24] = 45.0
    np.testing.assert_array_equal(monday.to_numpy(), expected)
    assert limit["2014-03-04"].min() == 40.0  # the ISO window is one day only
    assert limit["2014-03-04 11:00"] == 50.0


def test_a_window_is_planned_for_from_its_lookahead_before_it(tmp_path: Path) -> None:
    windows = [
        {"start": "10:00", "end": "17:00", "limit_kw": 50.0},
        {"start": "2014-03-04T14:00", "end": "2014-03-04T16:00", "limit_kw": 40.0},
    ]
    doc = generate_fleet(1, 1, feeder_limit_kw=float("inf"))
    doc["feeder_limits"] = windows
    assert load_fleet(write_fleet(doc, tmp_path / "f.toml")).spec.window_lookahead_h == np.inf
    doc["window_lookahead_h"] = 10.0
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    index = pd.date_range("2014-03-03", periods=2 * 48, freq="30min", tz="Asia/Singapore")
    full = fleet.limit_series_kw(index)

    def seen(at: str) -> pd.Series:
        now = pd.Timestamp(at, tz="Asia/Singapore")
        return pd.Series(fleet.limit_series_kw(index, seen_at=now), index=index)

    # from Monday 17:00 neither Tuesday's daily window (10 h ahead from 00:00) nor the ISO one
    evening = seen("2014-03-03 17:00")
    assert np.isinf(evening["2014-03-04"]).all()
    assert (evening["2014-03-03 10:00":"2014-03-03 16:30"] == 50.0).all()  # today's: seen
    midnight = seen("2014-03-04 00:00")  # Tuesday's daily window now, not yet the ISO one
    assert (midnight["2014-03-04 10:00":"2014-03-04 16:30"] == 50.0).all()
    assert seen("2014-03-04 04:00")["2014-03-04 14:00"] == 40.0  # 10 h before 14:00
    np.testing.assert_array_equal(seen("2014-03-04 04:00").to_numpy(), full)
    doc["window_lookahead_h"] = -1.0
    with pytest.raises(FleetConfigError, match=r"f\.toml.*window_lookahead_h"):
        load_fleet(write_fleet(doc, tmp_path / "f.toml"))


@pytest.mark.parametrize(
    ("window", "field", "message"),
    [
        ({"start": "17:00", "end": "10:00", "limit_kw": 5.0}, "feeder_limits[0]", "end after"),
        ({"start": "10:00", "end": "2014-03-03T17:00", "limit_kw": 5.0}, "", "both"),
        ({"start": "25:00", "end": "26:00", "limit_kw": 5.0}, "", "neither"),
        ({"start": "10:00", "end": "17:00", "limit_kw": -5.0}, "limit_kw", "greater than 0"),
        ({"start": "10:00", "end": "17:00", "limit_kw": 5.0, "days": "weekends"}, "days", ""),
        ({"start": "10:00", "end": "17:00", "limit_kw": 5.0, "hours": 2}, "hours", "unknown"),
        (
            {
                "start": "2014-03-03T10:00",
                "end": "2014-03-03T17:00",
                "limit_kw": 5.0,
                "days": "all",
            },
            "",
            "days applies to daily windows",
        ),
    ],
)
def test_bad_limit_windows_name_the_field_and_value(
    tmp_path: Path, window: dict[str, object], field: str, message: str
) -> None:
    with pytest.raises(FleetConfigError) as error:
        load_fleet(_windowed(tmp_path, [window], 60.0))
    text = str(error.value)
    assert "f.toml" in text and "feeder_limits[0]" in text
    assert field in text and message in text
