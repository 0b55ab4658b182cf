from pathlib import Path

import pytest

from hvacflex.config import (
    PAPER_MODEL_SCENARIOS,
    PAPER_SCENARIOS,
    PRESET_NAMES,
    load_config,
    preset,
    scaled_uncertainty,
    with_overrides,
)
from hvacflex.errors import ConfigError


def test_paper_presets_match_the_paper_scenarios() -> None:
    a, b, c = (preset(PAPER_SCENARIOS[letter]) for letter in "abc")
    assert a.controller.robust == "none" and a.controller.reserve
    assert b.controller.robust == "tightening" and b.controller.peak_price_sgd_per_kw == 0.0
    assert c.controller.peak_price_sgd_per_kw == 1.5
    assert not preset("thermostat").controller.reserve
    assert set(PAPER_SCENARIOS.values()) <= set(PRESET_NAMES)


def test_scenarios_share_the_uncertainty_box_of_the_world() -> None:
    # nominal and robust controllers face the same realised errors
    assert preset("nmpc").uncertainty == preset("rmpc").uncertainty


def test_overrides_by_leaf_or_dotted_name_agree() -> None:
    cfg = preset("rmpc")
    one = with_overrides(cfg, {"peak_price_sgd_per_kw": 2})
    two = with_overrides(cfg, {"controller.peak_price_sgd_per_kw": 2.0})
    assert one == two
    assert one.config_hash() != cfg.config_hash()


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
        assert paper.controller == product.controller
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
    }
    assert cfg.config_hash() != preset("paper-rmpc").config_hash()


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
