import dataclasses
import hashlib
import json
import re
from pathlib import Path

import pytest

from hvacflex.config import (
    BASELINE_PRESETS,
    PAPER_MODEL_SCENARIOS,
    PAPER_SCENARIOS,
    PRESET_NAMES,
    ScenarioConfig,
    load_config,
    preset,
    resolve_key,
    resolve_scenario,
    scaled_uncertainty,
    with_overrides,
)
from hvacflex.config.model import ForecastConfig
from hvacflex.errors import ConfigError
from hvacflex.sim.recording import recorded_problems


def test_paper_presets_match_the_paper_scenarios() -> None:
    a, b, c = (preset(PAPER_SCENARIOS[letter]) for letter in "abc")
    assert a.controller.robust == "none" and a.controller.reserve
    assert b.controller.robust == "tightening" and b.controller.peak_price_sgd_per_kw == 0.0
    assert c.controller.peak_price_sgd_per_kw == 1.5
    assert not preset("thermostat").controller.reserve
    assert set(PAPER_SCENARIOS.values()) <= set(PRESET_NAMES)


def test_product_presets_bill_the_peak_per_billing_period_paper_presets_per_horizon() -> None:
    for name in ("nmpc", "rmpc", "rmpc-ppp", "rmpc-output-feedback", *BASELINE_PRESETS):
        assert preset(name).controller.billing_mode == "billing-period", name
    for name in ("paper-nmpc", "paper-rmpc", "paper-rmpc-ppp", "rmpc-feedback"):
        assert preset(name).controller.billing_mode == "horizon", name


def test_baseline_presets_are_rule_based_at_25_5_degc_with_optimal_start() -> None:
    kinds = {name: preset(name).controller.kind for name in BASELINE_PRESETS}
    assert kinds == {
        "thermostat-25.5": "thermostat",
        "thermostat-25.5-float": "thermostat",
        "trim-respond": "trim-respond",
        "demand-limit": "demand-limit",
        "gta-dr": "gta-dr",
    }
    for name in BASELINE_PRESETS:
        cfg = preset(name).controller
        assert cfg.optimal_start and cfg.robust == "none"
        assert cfg.reserve == (name == "gta-dr")
    assert preset("thermostat-25.5").controller.thermostat_setpoint_degc == 25.5
    # the night float: today's 1 K below the unoccupied bound, 0.25 K for the -float rule
    assert preset("thermostat-25.5").controller.unoccupied_margin_k == 1.0
    floating = preset("thermostat-25.5-float").controller
    assert floating.unoccupied_margin_k == 0.25 and floating.thermostat_setpoint_degc == 25.5
    assert preset("gta-dr").reserve.event_max_steps == 4  # the setpoint raise is α of events
    assert not preset("thermostat").controller.optimal_start  # the old baseline is unchanged


def test_scenarios_share_the_uncertainty_box_of_the_world() -> None:
    # nominal and robust controllers face the same realised errors
    assert preset("nmpc").uncertainty == preset("rmpc").uncertainty


def test_overrides_by_leaf_or_dotted_name_agree() -> None:
    cfg = preset("rmpc")
    one = with_overrides(cfg, {"peak_price_sgd_per_kw": 2})
    two = with_overrides(cfg, {"controller.peak_price_sgd_per_kw": 2.0})
    assert one == two
    assert one.config_hash() != cfg.config_hash()


def test_a_table_override_sets_what_it_names_like_a_toml_table(tmp_path: Path) -> None:
    cfg = preset("rmpc-ppp")
    table = with_overrides(cfg, {"controller": {"peak_price_sgd_per_kw": 2.5}})
    assert table == with_overrides(cfg, {"controller.peak_price_sgd_per_kw": 2.5})
    assert table.controller.robust == cfg.controller.robust  # the rest of the table stays
    nested = with_overrides(cfg, {"uncertainty": {"relative": {"solar": 0.5}}})
    assert nested.uncertainty.relative == {"solar": 0.5}  # a setting's own table: replaced
    # a unique leaf named like a table still sets the leaf; a dict sets the table
    assert not with_overrides(cfg, {"reserve": False}).controller.reserve
    assert with_overrides(cfg, {"reserve": {"event_max_steps": 2}}).reserve.event_max_steps == 2
    file = tmp_path / "s.toml"
    file.write_text('preset = "rmpc-ppp"\n[uncertainty.relative]\nsolar = 0.5\n')
    assert load_config(file).uncertainty == nested.uncertainty


@pytest.mark.parametrize(
    ("overrides", "field", "words"),
    [
        ({"controller": {"peak_price": 1.0}}, "controller.peak_price", "peak_price_sgd_per_kw"),
        ({"controller": {"peak_price_sgd_per_kw": -1.0}}, "controller.peak_price_sgd_per_kw", "≥"),
        ({"controller": 3}, "controller", "must be a table"),
        ({"dayz": 1}, "dayz", "unknown setting"),
    ],
)
def test_a_bad_table_override_names_its_field(
    overrides: dict[str, object], field: str, words: str
) -> None:
    with pytest.raises(ConfigError) as err:
        with_overrides(preset("rmpc"), overrides)
    assert err.value.field == field
    assert words in str(err.value)


def test_resolve_scenario_takes_a_preset_a_file_or_a_config(tmp_path: Path) -> None:
    file = tmp_path / "mine.toml"
    file.write_text('preset = "nmpc"\ndays = 2\n')
    from_file = resolve_scenario(file, {"seed": 7})
    assert from_file == resolve_scenario(str(file), {"seed": 7})
    assert (from_file.name, from_file.controller.robust, from_file.days) == ("nmpc", "none", 2)
    assert from_file.seed == 7
    by_name = resolve_scenario("rmpc", {"start": "2014-03-03", "price_gap_fill": "previous-day"})
    assert by_name.start == "2014-03-03" and by_name.data.price_gap_fill == "previous-day"
    assert resolve_scenario(by_name) is by_name
    with pytest.raises(ConfigError) as err:
        resolve_scenario("rmcp")
    assert err.value.field == "scenario" and "rmpc-ppp" in str(err.value)


def test_config_hash_ignores_the_name() -> None:
    assert (
        with_overrides(preset("rmpc"), {"name": "x"}).config_hash() == preset("rmpc").config_hash()
    )


def test_steps_from_days() -> None:
    assert preset("rmpc", days=365).steps == 17_520


def test_load_config_from_toml_with_preset(tmp_path: Path) -> None:
    path = tmp_path / "week.toml"
    path.write_text(
        'preset = "rmpc-ppp"\nstart = "2014-03-01"\ndays = 7\n'
        "[controller]\npeak_price_sgd_per_kw = 2.5\n"
        "[uncertainty]\nrelative = { solar = 0.3, internal_gain = 0.1 }\n"
    )
    cfg = load_config(path)
    assert cfg.name == "rmpc-ppp"
    assert cfg.controller.robust == "tightening"
    assert cfg.controller.peak_price_sgd_per_kw == 2.5
    assert cfg.uncertainty.relative == {"solar": 0.3, "internal_gain": 0.1}
    assert cfg.steps == 336


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("colour = 1\n", "colour"),
        ("[controller]\nrobust = 'maybe'\n", "controller.robust"),
        ("[controller]\nhorizon_steps = 0\n", "controller.horizon_steps"),
        ("[comfort]\noccupied_degc = [26, 23]\n", "comfort.occupied_degc"),
        ("[uncertainty]\nrelative = { wind = 0.1 }\n", "uncertainty.relative.wind"),
        ("[uncertainty]\nrelative = { solar = -0.1 }\n", "uncertainty.relative.solar"),
        ("[activation]\nrate = 2.0\n", "activation.rate"),
        ("start = 'yesterday-ish'\n", "start"),
        ("start = '2014-03-01T08:10'\n", "start"),
        ("start = '2014-03-01T08:00+08:00'\n", "start"),
        ("[controller]\nkind = 'thermostat'\n", "controller.reserve"),
        ("[controller]\nkind = 'trim-respond'\n", "controller.reserve"),
        ("[controller]\nkind = 'demand-limit'\n", "controller.reserve"),
        ("[controller]\nkind = 'gta-dr'\n", "reserve.event_max_steps"),
        (
            "[controller]\nkind = 'demand-limit'\nreserve = false\ndemand_limit_fraction = 0\n",
            "controller.demand_limit_fraction",
        ),
        ("[controller]\nreserve_share = 1.5\n", "controller.reserve_share"),
        ("dt_s = 900\n", "dt_s"),  # the data are half-hourly
        ("[realisation]\nar1_coefficient = -0.5\n", "realisation.ar1_coefficient"),
    ],
)
def test_bad_scenario_files_name_file_field_and_value(
    tmp_path: Path, text: str, field: str
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(path) in str(err.value)
    assert field in str(err.value)


def test_scaled_uncertainty_sets_heat_gain_fractions() -> None:
    cfg = scaled_uncertainty(preset("rmpc"), 0.5)
    assert cfg.uncertainty.relative == {"solar": 0.5, "internal_gain": 0.5}
    assert cfg.uncertainty.absolute == preset("rmpc").uncertainty.absolute


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        (b"", "the scenario file is empty"),
        (b"# nothing yet\n", "the scenario file is empty"),
        (b"name = 'r\xe9sum\xe9'\n", "not UTF-8 text"),
        (b"[controller\n", "not valid TOML"),
    ],
)
def test_unreadable_scenario_file_names_the_file_and_the_problem(
    tmp_path: Path, content: bytes, problem: str
) -> None:
    path = tmp_path / "odd.toml"
    path.write_bytes(content)
    with pytest.raises(ConfigError, match=problem) as err:
        load_config(path)
    assert err.value.source == str(path)


def test_missing_scenario_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="scenario file not found"):
        load_config(tmp_path / "nowhere.toml")


def test_product_presets_plan_for_events_paper_presets_for_the_whole_horizon() -> None:
    for name in ("nmpc", "rmpc", "rmpc-ppp"):
        reserve = preset(name).reserve
        assert reserve.event_max_steps == 4  # the NEMS 120-min rule
        assert reserve.event_allowance_k > 0 and reserve.event_recovery_steps >= 0
    for letter, name in PAPER_MODEL_SCENARIOS.items():
        paper, product = preset(name), preset(PAPER_SCENARIOS[letter])
        assert paper.reserve.event_max_steps is None
        # the same controller but for the billing: the paper's per-horizon peak (issue 26)
        assert paper.controller == dataclasses.replace(product.controller, billing_mode="horizon")
    # the feedback LP has no event model: those presets keep the whole horizon
    assert preset("rmpc-feedback").reserve.event_max_steps is None


def test_reserve_section_is_read_and_recorded(tmp_path: Path) -> None:
    path = tmp_path / "events.toml"
    path.write_text(
        'preset = "paper-rmpc"\n[reserve]\nevent_max_steps = 2\nevent_allowance_k = 0.5\n'
        "event_recovery_steps = 1\nnon_delivery_penalty_sgd_per_mwh = 1000\n"
    )
    cfg = load_config(path)
    assert cfg.reserve.event_max_steps == 2 and cfg.reserve.event_allowance_k == 0.5
    assert cfg.to_dict()["reserve"] == {
        "event_max_steps": 2,
        "event_allowance_k": 0.5,
        "event_recovery_steps": 1,
        "non_delivery_penalty_sgd_per_mwh": 1000.0,
        "non_delivery_forfeits_reserve_payment": True,
        "il_baseline": "pre-event",
        "commit_ahead_periods": 2,
        "meter_calibrated_offers": True,
        "plan_visible_offers": True,
    }
    assert cfg.config_hash() != preset("paper-rmpc").config_hash()


def test_commit_ahead_periods_is_read_and_must_fit_the_horizon(tmp_path: Path) -> None:
    path = tmp_path / "commit.toml"
    path.write_text('preset = "rmpc"\n[reserve]\ncommit_ahead_periods = 3\n')
    assert load_config(path).reserve.commit_ahead_periods == 3
    path.write_text(
        'preset = "rmpc"\n[controller]\nhorizon_steps = 4\n[reserve]\ncommit_ahead_periods = 4\n'
    )
    with pytest.raises(ConfigError, match="commit_ahead_periods") as info:
        load_config(path)
    assert "0 … 3" in str(info.value)


def test_product_presets_are_activated_at_random_and_rarely() -> None:
    for name in ("nmpc", "rmpc", "rmpc-ppp", "rmpc-output-feedback", "gta-dr"):
        activation = preset(name).activation
        assert activation.mode == "random"
        assert 0 < activation.events_per_year <= 12  # rare: a few a year
        assert preset(name).reserve.commit_ahead_periods == 2
    for name in ("paper-rmpc", "thermostat-25.5", "rmpc-feedback"):
        assert preset(name).activation.mode == "never"


@pytest.mark.parametrize(
    ("text", "field", "words"),
    [
        ("[reserve]\nevent_max_steps = 0\n", "reserve.event_max_steps", "≥ 1"),
        ("[reserve]\nevent_allowance_k = -1\n", "reserve.event_allowance_k", "≥ 0"),
        ("[reserve]\nevent_recovery_steps = 1.5\n", "reserve.event_recovery_steps", "integer"),
        (
            "[controller]\nrobust = 'feedback'\n[reserve]\nevent_max_steps = 4\n",
            "reserve.event_max_steps",
            "not available",
        ),
        ("[activation]\nrate = 0.1\n", "activation.rate", "events_per_year"),
        ("[activation]\nmode = 'file'\n", "activation.file", "needs a file"),
        ("[comfort]\noccupied_degc = [23]\n", "comfort.occupied_degc", "pair"),
        ("[controller]\nreserve = 1\n", "controller.reserve", "true or false"),
    ],
)
def test_schema_errors_name_the_field_and_say_what_to_do(
    tmp_path: Path, text: str, field: str, words: str
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert err.value.field == field
    assert words in str(err.value)


def test_overrides_are_validated_and_can_clear_the_event_model() -> None:
    cfg = with_overrides(preset("rmpc"), {"event_max_steps": None})
    assert cfg.reserve.event_max_steps is None
    with pytest.raises(ConfigError, match=r"reserve\.event_max_steps"):
        with_overrides(preset("rmpc"), {"controller.robust": "dual"})
    with pytest.raises(ConfigError, match="unknown setting"):
        with_overrides(preset("rmpc"), {"nonsense": 1})


def test_resolve_scenario_prefers_a_preset_to_a_file_of_its_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "nmpc").write_text('preset = "rmpc"\n')
    monkeypatch.chdir(tmp_path)
    assert resolve_scenario("nmpc").controller.robust == "none"
    assert resolve_scenario(Path("nmpc")).controller.robust == "tightening"


def test_plant_table_defaults_to_rc_and_keeps_the_run_key(tmp_path: Path) -> None:
    default = ScenarioConfig()
    assert default.plant.kind == "rc" and default.plant.resolved_actuation == "flow"
    path = tmp_path / "eplus.toml"
    path.write_text('[plant]\nkind = "energyplus"\nidf = "model.idf"\n')
    config = load_config(path)
    # taken from the scenario file's folder, like the other paths it names
    assert config.plant.idf == str(tmp_path / "model.idf")
    assert config.plant.timesteps_per_hour == 6
    assert config.plant.resolved_actuation == "setpoint"
    assert config.plant.curtailed_setpoint == "plan"
    assert config.config_hash() != default.config_hash()
    path.write_text('[plant]\nkind = "energyplus"\ncurtailed_setpoint = "limit"\n')
    assert load_config(path).plant.curtailed_setpoint == "limit"


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ('[plant]\nkind = "modelica"\n', "plant.kind"),
        ('[plant]\nkind = "energyplus"\nbogus = 1\n', "plant.bogus"),
        ('[plant]\nkind = "energyplus"\ntimesteps_per_hour = 5\n', "plant.timesteps_per_hour"),
        ('[plant]\nactuation = "setpoint"\n', "plant.actuation"),
        ('[plant]\nkind = "energyplus"\nactuation = "valve"\n', "plant.actuation"),
        ('[plant]\ncurtailed_setpoint = "limit"\n', "plant.curtailed_setpoint"),
        (
            '[plant]\nkind = "energyplus"\nactuation = "flow"\ncurtailed_setpoint = "limit"\n',
            "plant.curtailed_setpoint",
        ),
        ('[plant]\nkind = "energyplus"\ncurtailed_setpoint = "max"\n', "plant.curtailed_setpoint"),
    ],
)
def test_bad_plant_tables_name_the_field(tmp_path: Path, text: str, field: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=re.escape(field)):
        load_config(path)


def test_forecast_occupancy_and_calibration_tables(tmp_path: Path) -> None:
    default = ScenarioConfig()
    assert default.forecast.weather == "perfect" and default.realisation.occupancy == "schedule"
    assert default.uncertainty.calibrate is None
    path = tmp_path / "realistic.toml"
    path.write_text(
        'start = "2014-03-03"\ndays = 3\n[forecast]\nweather = "statistical"\ntrain_days = 14\n'
        '[realisation]\nmode = "zero"\noccupancy = "stochastic"\n'
        "box_absolute = { outdoor_temp = 1.5 }\n"
        '[uncertainty]\ncalibrate = { train = "2014-02-24..2014-03-02", quantile = 0.9 }\n'
    )
    config = load_config(path)
    assert config.forecast.train_days == 14
    assert config.realisation.box_absolute == {"outdoor_temp": 1.5}
    assert config.uncertainty.calibrate is not None
    assert config.uncertainty.calibrate.quantile == 0.9
    first, last = config.uncertainty.calibrate.train_days
    assert (last - first).days == 6
    assert config.config_hash() != default.config_hash()
    again = with_overrides(config, {"days": 2})  # the tables survive a round trip
    assert again.uncertainty.calibrate == config.uncertainty.calibrate


def test_the_default_curtailed_setpoint_keeps_the_run_keys_of_energyplus_runs() -> None:
    cfg = with_overrides(preset("rmpc-ppp"), {"plant.kind": "energyplus"})
    earlier = cfg.to_dict()  # the payload before [plant] curtailed_setpoint existed
    earlier.pop("name")
    earlier["plant"].pop("curtailed_setpoint")
    for key in ("occupancy", "occupancy_seed", "box_relative", "box_absolute"):
        earlier["realisation"].pop(key, None)
    earlier["uncertainty"].pop("calibrate")
    earlier["data"].pop("reserve_price_correlation")
    for key in (
        "comfort_knee_k",
        "comfort_penalty_beyond_knee_sgd_per_kelvin_hour",
        "lower_plan_margin_k",
    ):
        earlier["controller"].pop(key)
    if cfg.forecast == ForecastConfig():
        earlier.pop("forecast")
    digest = hashlib.sha256(json.dumps(earlier, sort_keys=True).encode()).hexdigest()[:12]
    assert cfg.config_hash() == digest
    limit = with_overrides(cfg, {"plant.curtailed_setpoint": "limit"})
    assert limit.config_hash() != cfg.config_hash()
    margin = with_overrides(cfg, {"controller.lower_plan_margin_k": 0.3})  # a margin: new key
    assert margin.config_hash() != cfg.config_hash()


def test_default_forecast_settings_keep_the_run_keys_of_earlier_versions() -> None:
    cfg = preset("rmpc")
    earlier = cfg.to_dict()  # the payload before [forecast] and the new keys existed
    for key in ("name", "plant", "forecast"):
        earlier.pop(key)
    for key in ("occupancy", "occupancy_seed", "box_relative", "box_absolute"):
        earlier["realisation"].pop(key)
    earlier["uncertainty"].pop("calibrate")
    earlier["data"].pop("reserve_price_correlation")
    for key in (
        "comfort_knee_k",
        "comfort_penalty_beyond_knee_sgd_per_kelvin_hour",
        "lower_plan_margin_k",
    ):
        earlier["controller"].pop(key)
    digest = hashlib.sha256(json.dumps(earlier, sort_keys=True).encode()).hexdigest()[:12]
    assert cfg.config_hash() == digest


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ('[forecast]\nweather = "oracle"\n', "forecast.weather"),
        ("[forecast]\ntrain_days = 0\n", "forecast.train_days"),
        ('[realisation]\noccupancy = "random"\n', "realisation.occupancy"),
        ("[realisation]\nbox_relative = { wind = 0.1 }\n", "realisation.box_relative"),
        ('[uncertainty]\ncalibrate = { train = "2014-02-24" }\n', "uncertainty.calibrate.train"),
        ('[uncertainty]\ncalibrate = { train = "2014-03-02..2014-02-24" }\n', "calibrate.train"),
        ('[uncertainty]\ncalibrate = { train = "2014-02-24..2014-03-02", quantile = 1.0 }\n',
         "uncertainty.calibrate.quantile"),
        ('start = "2014-03-03"\n[uncertainty]\ncalibrate = { train = "2014-03-01..2014-03-04" }\n',
         "uncertainty.calibrate.train"),
    ],
)  # fmt: skip
def test_bad_forecast_tables_name_the_field(tmp_path: Path, text: str, field: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=re.escape(field)):
        load_config(path)


@pytest.mark.parametrize("key", ["reserve_price_scale = 30.0", "reserve_price_correlation = 1.0"])
def test_synthetic_price_keys_are_refused_beside_real_reserve_prices(
    tmp_path: Path, key: str
) -> None:
    """A key that shapes the synthetic price would be silently ignored with real prices."""
    path = tmp_path / "real.toml"
    path.write_text(f'[data]\nreserve_source = "il.csv"\n{key}\n')
    with pytest.raises(ConfigError, match=r"data\.reserve_price_\w+.*reserve_source gives"):
        load_config(path)
    path.write_text('[data]\nreserve_source = "il.csv"\n')
    assert load_config(path).data.reserve_source is not None


def test_il_baseline_is_a_reserve_setting(tmp_path: Path) -> None:
    path = tmp_path / "baseline.toml"
    path.write_text('preset = "rmpc"\n[reserve]\nil_baseline = "similar-days"\n')
    assert load_config(path).reserve.il_baseline == "similar-days"
    path.write_text('preset = "rmpc"\n[reserve]\nil_baseline = "yesterday"\n')
    with pytest.raises(ConfigError, match="il_baseline"):
        load_config(path)


def test_start_is_stored_normalised_and_only_iso_8601_is_read(tmp_path: Path) -> None:
    assert with_overrides(preset("rmpc"), {"start": "2014-03-04T00:00"}).start == "2014-03-04"
    cfg = with_overrides(preset("rmpc"), {"start": "2014-03-04T08:30"})
    assert cfg.to_dict()["start"] == "2014-03-04T08:30"  # what config.json keeps
    path = tmp_path / "us.toml"
    path.write_text('start = "04/03/2014"\n')
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert err.value.field == "start" and "ISO 8601" in str(err.value)


@pytest.mark.parametrize(
    ("text", "field", "words"),
    [
        ("days = 1e-9\n", "days", "at least one 30-min period"),
        ("days = 0.3\n", "days", "whole number of 30-min periods"),
        ("days = 1e6\n", "days", "at most 3660"),
        ("initial_temp_degc = -500\n", "initial_temp_degc", "between -40 and 60"),
        ("[controller]\nhorizon_steps = 100000000\n", "controller.horizon_steps", "≤ 336"),
        ("[comfort]\nunoccupied_degc = [20, 300]\n", "comfort.unoccupied_degc", "upper bound"),
        ("[controller]\nthermostat_setpoint_degc = 75\n", "controller.thermostat_setpoint_degc",
         "between 0 and 50"),
    ],
)  # fmt: skip
def test_impossible_values_are_refused_with_the_allowed_range(
    tmp_path: Path, text: str, field: str, words: str
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert err.value.field == field
    assert words in str(err.value)


def test_the_horizon_cap_is_the_services() -> None:
    from hvacflex.constants import MAX_HORIZON_STEPS
    from hvacflex.service.runtime import MAX_HORIZON_STEPS as SERVICE_MAX_HORIZON_STEPS

    assert MAX_HORIZON_STEPS == SERVICE_MAX_HORIZON_STEPS
    assert with_overrides(preset("rmpc"), {"horizon_steps": MAX_HORIZON_STEPS}).controller


def test_paths_in_a_scenario_file_are_relative_to_the_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "project"
    folder.mkdir()
    (folder / "scenario.toml").write_text(
        'building = "buildings/mine.toml"\n'
        "[data]\nweather_file = 'weather.epw'\nusep_source = '/abs/usep'\n"
        "[activation]\nmode = 'file'\nfile = 'events.csv'\n"
    )
    monkeypatch.chdir(tmp_path)
    cfg = load_config(Path("project/scenario.toml"))
    assert Path(cfg.building) == Path("project/buildings/mine.toml")
    assert Path(str(cfg.data.weather_file)) == Path("project/weather.epw")
    assert cfg.data.usep_source == "/abs/usep"  # absolute paths stay as written
    assert Path(str(cfg.activation.file)) == Path("project/events.csv")
    shipped = tmp_path / "named.toml"
    shipped.write_text('building = "office5"\n')
    assert load_config(shipped).building == "office5"  # a shipped name is not a path


def test_a_preset_scenario_file_keeps_the_presets_own_values(tmp_path: Path) -> None:
    folder = tmp_path / "sub"
    folder.mkdir()
    (folder / "s.toml").write_text('preset = "rmpc-ppp"\ndays = 1\n')
    cfg = load_config(folder / "s.toml")
    assert cfg.building == preset("rmpc-ppp").building and cfg.days == 1


def test_plant_baseline_is_the_plants_own_control_on_energyplus_only() -> None:
    cfg = preset("plant-baseline")
    assert cfg.controller.kind == "plant" and not cfg.controller.reserve
    assert cfg.plant.kind == "energyplus" and cfg.plant.resolved_actuation == "setpoint"
    with pytest.raises(ConfigError, match="setpoint-actuated EnergyPlus"):
        with_overrides(cfg, {"plant": {"kind": "rc", "actuation": "flow"}})


def test_reserve_correlation_and_occupancy_seed_defaults_keep_the_run_keys() -> None:
    base = preset("rmpc")
    explicit = with_overrides(base, {"data.reserve_price_correlation": 1.0})
    assert explicit.config_hash() == base.config_hash()
    assert base.realisation.occupancy_seed is None
    changed = [
        with_overrides(base, {"data.reserve_price_correlation": 0.5}),
        with_overrides(base, {"realisation.occupancy_seed": 3}),
    ]
    assert len({base.config_hash(), *(c.config_hash() for c in changed)}) == 3
    with pytest.raises(ConfigError, match="reserve_price_correlation"):
        with_overrides(base, {"data.reserve_price_correlation": -0.1})


@pytest.mark.parametrize(
    ("text", "field", "suggested"),
    [
        ('preset = "rmpc-pp"\n', "preset", "rmpc-ppp"),
        ('[controler]\nrobust = "none"\n', "controler", "controller"),
        (
            "[controller]\npeak_price_sgd_per_k = 2\n",
            "controller.peak_price_sgd_per_k",
            "peak_price_sgd_per_kw",
        ),
    ],
)
def test_a_misspelt_preset_or_key_gets_a_did_you_mean(
    tmp_path: Path, text: str, field: str, suggested: str
) -> None:
    path = tmp_path / "typo.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as refused:
        load_config(path)
    assert refused.value.field == field
    assert (refused.value.hint or "").startswith(f"did you mean {suggested!r}? ")


def test_an_unknown_preset_name_gets_a_did_you_mean_on_the_command_line() -> None:
    from typer.testing import CliRunner

    from hvacflex.cli import app

    result = CliRunner().invoke(app, ["simulate", "--scenario", "rmcp"], env={"COLUMNS": "80"})
    assert result.exit_code == 2 and "Did you mean 'rmpc'?" in result.output
    assert "Traceback" not in result.output
    with pytest.raises(ConfigError, match="Did you mean 'peak_price_sgd_per_kw'"):
        resolve_key("peak_price_sgd_per_k")


def test_a_comfort_knee_reaches_the_problem_and_changes_the_run_key(tmp_path: Path) -> None:
    """``[controller] comfort_knee_k`` (issue 60): the MPC's problem gets a ComfortKnee with
    the file's δ and ρ₂; left out, no knee and the run key of before."""
    path = tmp_path / "knee.toml"
    path.write_text(
        'preset = "rmpc"\ndays = 0.5\n[controller]\ncomfort_penalty_sgd_per_kelvin_hour = 5\n'
        "comfort_knee_k = 0.5\ncomfort_penalty_beyond_knee_sgd_per_kelvin_hour = 100\n"
    )
    config = load_config(path)
    assert config.controller.comfort_knee_k == 0.5
    plain = with_overrides(config, {"controller.comfort_knee_k": None})
    assert config.config_hash() != plain.config_hash()
    (problem,) = recorded_problems(config, 1)
    assert problem.comfort_knee is not None
    assert problem.comfort_knee.knee_kelvin == 0.5
    assert problem.comfort_knee.penalty_beyond_sgd_per_kelvin_hour == 100.0
    (linear,) = recorded_problems(plain, 1)
    assert linear.comfort_knee is None
    # ρ₂ acts only beyond a knee: without one it leaves the run key alone
    beyond = with_overrides(
        plain, {"controller.comfort_penalty_beyond_knee_sgd_per_kelvin_hour": 7}
    )
    assert beyond.config_hash() == plain.config_hash()


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("comfort_knee_k = -0.5\n", "controller.comfort_knee_k"),
        (
            "comfort_knee_k = 0.5\ncomfort_penalty_beyond_knee_sgd_per_kelvin_hour = 50\n",
            "controller.comfort_penalty_beyond_knee_sgd_per_kelvin_hour",
        ),
    ],
)
def test_bad_comfort_knees_name_the_field(tmp_path: Path, text: str, field: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text("[controller]\n" + text)
    with pytest.raises(ConfigError, match=re.escape(field)):
        load_config(path)


def test_plan_linearisation_is_refused_with_affine_feedback(tmp_path: Path) -> None:
    """The feedback LP's responses assume one B: ``linearisation = "plan"`` with it is
    refused when the file is read, naming the field and the alternatives."""
    path = tmp_path / "bad.toml"
    path.write_text('[controller]\nrobust = "feedback"\nlinearisation = "plan"\n')
    with pytest.raises(ConfigError, match=r"controller\.linearisation.*'fixed' or 'trajectory'"):
        load_config(path)
    path.write_text('[controller]\nrobust = "tightening"\nlinearisation = "plan"\n')
    assert load_config(path).controller.linearisation == "plan"
