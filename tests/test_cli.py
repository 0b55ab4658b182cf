from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hvacflex import __version__
from hvacflex.cli import _check_days, _scenario_config, app


def test_version_command_prints_version() -> None:
    result = CliRunner().invoke(app, ["version"])
    assert result.exit_code == 0
    assert __version__ in result.output


@pytest.mark.parametrize(
    ("days", "problem"),
    [
        ("inf", "finite"),
        ("nan", "finite"),
        ("1e9", "at most 3660"),
        ("0.01", "at least one 30-min period"),
        ("0", "> 0"),
        ("1.01", "whole number of 30-min periods"),
    ],
)
@pytest.mark.parametrize("command", ["simulate", "sweep"])
def test_bad_days_exit_2_naming_the_option(command: str, days: str, problem: str) -> None:
    args = [command, "--days", days, "--out", "unused"]
    if command == "sweep":
        args += ["--param", "peak_price_sgd_per_kw=1"]
    result = CliRunner().invoke(app, args, env={"COLUMNS": "300"})
    assert result.exit_code == 2, result.output
    assert "'--days'" in result.output and problem in result.output


def test_days_callback_accepts_whole_periods() -> None:
    assert _check_days(None) is None
    assert _check_days(0.5) == 0.5 and _check_days(1 / 48) == 1 / 48 and _check_days(365) == 365


def test_start_outside_the_price_data_exits_2_with_the_covered_dates(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app,
        ["simulate", "--start", "2016-03-03", "--days", "1", "--out", str(tmp_path / "r"), "-q"],
        env={"COLUMNS": "300"},
    )
    assert result.exit_code == 2, result.output
    assert "outside the USEP price data" in result.output
    assert "2014-01-01 … 2014-12-31" in result.output
    assert not (tmp_path / "r" / "results.parquet").exists()


def test_price_gap_fill_option_overrides_the_scenario_setting(tmp_path: Path) -> None:
    cfg = _scenario_config("rmpc", None, None, None, "previous-day")
    assert cfg.data.price_gap_fill == "previous-day"
    assert _scenario_config("rmpc", None, None, None).data.price_gap_fill == "none"
    result = CliRunner().invoke(
        app,
        ["simulate", "--price-gap-fill", "zero", "--out", str(tmp_path / "r"), "-q"],
        env={"COLUMNS": "300"},
    )
    assert result.exit_code == 2, result.output
    assert "price_gap_fill" in result.output and "previous-day" in result.output


def test_simulate_help_names_every_preset_in_full_at_80_columns() -> None:
    from hvacflex.config import PRESET_NAMES

    for command in ("simulate", "sweep"):
        result = CliRunner().invoke(app, [command, "--help"], env={"COLUMNS": "80"})
        assert result.exit_code == 0
        lines = result.output.splitlines()
        assert max(len(line) for line in lines) <= 80, command
        presets = lines[next(i for i, t in enumerate(lines) if "Presets (--scenario" in t) + 1 :]
        assert {word for line in presets for word in line.split()} == set(PRESET_NAMES)
        assert "[default: rmpc" in result.output  # rmpc or rmpc-ppp
        assert "Default: the scenario's days (7 unless" in " ".join(result.output.split())


def test_version_option_prints_the_version() -> None:
    result = CliRunner().invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.output.strip() == f"hvacflex {__version__}"


@pytest.mark.parametrize(
    "command",
    [["simulate"], ["reproduce"], ["kpi"], ["sweep"], ["data", "show"], ["fleet", "simulate"]],
)
def test_help_shows_click_metavars_and_flags_without_a_value(command: list[str]) -> None:
    result = CliRunner().invoke(app, [*command, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    for typer_style in ("<bool>", "<str>", "<int>", "<float>", "<path>", "list[Path]"):
        assert typer_style not in result.output
    assert "PATH" in result.output or "TEXT" in result.output
    help_line = next(line for line in result.output.splitlines() if "--help" in line)
    assert "BOOLEAN" not in help_line and "Show this message" in help_line


def test_optional_paths_read_path_in_help() -> None:
    result = CliRunner().invoke(app, ["simulate", "--help"], env={"COLUMNS": "200"})
    config = next(line for line in result.output.splitlines() if "--config" in line)
    assert "PATH" in config and " path " not in config


def test_quick_is_a_flag_and_workers_an_integer_in_help() -> None:
    result = CliRunner().invoke(app, ["reproduce", "--help"], env={"COLUMNS": "200"})
    quick = next(line for line in result.output.splitlines() if "--quick" in line)
    workers = next(line for line in result.output.splitlines() if "--workers" in line)
    assert "One week" in quick and "BOOLEAN" not in quick and "TEXT" not in quick
    assert "INTEGER" in workers


@pytest.mark.parametrize(
    "command", [["simulate"], ["sweep"], ["data", "show"], ["fleet", "simulate"]]
)
def test_every_command_shows_the_one_default_start(command: list[str]) -> None:
    from hvacflex.config import ScenarioConfig, preset
    from hvacflex.config.presets import PRESET_NAMES
    from hvacflex.constants import DEFAULT_START

    assert ScenarioConfig().start == DEFAULT_START
    assert {preset(name).start for name in PRESET_NAMES} == {DEFAULT_START}
    result = CliRunner().invoke(app, [*command, "--help"], env={"COLUMNS": "200"})
    assert DEFAULT_START in result.output and "YYYY-MM-DD" in result.output


def test_data_show_takes_a_building_file_not_a_building_id() -> None:
    result = CliRunner().invoke(app, ["data", "show", "--help"], env={"COLUMNS": "200"})
    assert "--building-file" in result.output
    refused = CliRunner().invoke(app, ["data", "show", "--building", "office5"])
    assert refused.exit_code == 2 and "No such option" in refused.output


def test_run_label_names_scenario_building_and_dates() -> None:
    from hvacflex.cli import run_label
    from hvacflex.config import preset

    label = run_label(preset("thermostat", start="2014-03-04T08:00", days=0.5))
    assert label == (
        "scenario thermostat, building office5, plant rc, 2014-03-04T08:00 to 2014-03-04T20:00"
    )
    on_energyplus = run_label(preset("plant-baseline", days=1))
    assert ", plant energyplus (generated IDF), " in on_energyplus
    assert run_label(preset("rmpc", days=2)).endswith("2014-01-01 to 2014-01-03")


def test_reproduce_prints_its_run_lines_and_ends_with_the_verdict(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The command hands ``reproduce`` a printer that works piped (CliRunner's output is no
    terminal): every line the reproduction logs reaches the output, the verdict last."""
    import hvacflex.reproduce
    from hvacflex.reproduce import Reproduction

    def fake(out: Path, *, log: Callable[[str], None], **_: object) -> Reproduction:
        log("  [1/1] rmpc ok · elapsed 0:01 · ETA 0:00")
        log(f"report: {out / 'report.html'}")
        log("verdict: of the paper's findings tested here, 1 holds.")
        return Reproduction(report=out / "report.html", outcomes=[])

    monkeypatch.setattr(hvacflex.reproduce, "reproduce", fake)
    result = CliRunner().invoke(app, ["reproduce", "--quick", "--out", str(tmp_path / "r")])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0] == "  [1/1] rmpc ok · elapsed 0:01 · ETA 0:00"
    assert lines[-1] == "verdict: of the paper's findings tested here, 1 holds."


def test_sweep_and_reproduce_share_their_dask_options() -> None:
    """--scheduler, --workers and --fresh are declared once for both commands: same help,
    bounds and defaults."""
    import typer.main

    group = typer.main.get_command(app)
    options = {
        command: {p.name: p for p in group.commands[command].params}  # type: ignore[attr-defined]
        for command in ("sweep", "reproduce")
    }
    for name in ("scheduler", "workers", "fresh"):
        sweep, reproduce = options["sweep"][name], options["reproduce"][name]
        assert sweep.help == reproduce.help and sweep.help
        assert sweep.default == reproduce.default
    workers = options["sweep"]["workers"]
    assert workers.default == 2
    for argv in (["sweep", "--param", "x=1"], ["reproduce"]):  # the bounds travel with it
        done = CliRunner().invoke(app, [*argv, "--workers", "0"])
        assert done.exit_code == 2 and "--workers" in done.output, done.output
    assert options["reproduce"]["fresh"].default is False
    assert options["sweep"]["scheduler"].default is None
