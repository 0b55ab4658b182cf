"""The scripts in ``examples/`` run on the public API and print what they promise."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import hvacflex

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SRC = Path(hvacflex.__file__).resolve().parents[1]
"""The source folder of the hvacflex under test (the scripts must import the same one)."""

TIMEOUT_S = 120
"""Each script runs in well under 30 s alone; the limit leaves room for a loaded machine."""


def _run(script: str, cwd: Path, *args: str) -> str:
    path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": path},
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def _summary(run_dir: Path) -> dict[str, float]:
    summary: dict[str, float] = json.loads((run_dir / "summary.json").read_text())
    return summary


def test_every_example_is_tested() -> None:
    tested = {"compare_rmpc_nmpc.py", "peak_price.py", "one_room.py", "openadr_vtn.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_compare_rmpc_nmpc(tmp_path: Path) -> None:
    out = _run("compare_rmpc_nmpc.py", tmp_path)
    nmpc, rmpc = (_summary(tmp_path / "results/examples" / n) for n in ("nmpc", "rmpc"))
    assert nmpc["steps"] == rmpc["steps"] == 48
    row = next(line for line in out.splitlines() if line.startswith("net_cost_sgd"))
    assert row.split()[1:] == [f"{nmpc['net_cost_sgd']:.2f}", f"{rmpc['net_cost_sgd']:.2f}"]
    assert "rmpc: reserve offered in" in out


def test_peak_price(tmp_path: Path) -> None:
    out = _run("peak_price.py", tmp_path)
    rows = [line.split() for line in out.splitlines()[1:]]
    assert [row[0] for row in rows] == ["0.0", "1.5", "4.0"]
    peaks_kw = [float(row[1]) for row in rows]
    assert peaks_kw[2] < peaks_kw[0]  # pricing the peak lowers it
    charge = _summary(tmp_path / "results/examples/phi_4")["ppp_charge_monthly_sgd"]
    assert float(rows[2][3]) == pytest.approx(charge, abs=0.005)
    assert float(rows[0][3]) == 0.0


def test_one_room(tmp_path: Path) -> None:
    out = _run("one_room.py", tmp_path)
    assert out.splitlines()[0] == "room1: 1 zone(s), 83.6 m² floor area"
    summary = _summary(tmp_path / "results/examples/room1")
    energy = next(line for line in out.splitlines() if line.startswith("energy_kwh "))
    assert float(energy.split()[1]) == pytest.approx(summary["energy_kwh"], abs=0.005)
    config = json.loads((tmp_path / "results/examples/room1/config.json").read_text())
    assert config["building"] == "room1"


def test_openadr_vtn_runs_bounded_and_prints_the_clock_offset(tmp_path: Path) -> None:
    """The example VTN alone (no VEN: `tests/service/test_openadr.py` drives a VEN) starts,
    prints its URL and the offset that maps its first event onto the service's 2014 day,
    and stops by itself."""
    import socket

    import pandas as pd

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    out = _run("openadr_vtn.py", tmp_path, "--port", str(port), "--duration-s", "1")
    lines = out.splitlines()
    assert f"VTN on http://127.0.0.1:{port}/OpenADR2/Simple/2.0b" in lines
    events = next(line for line in lines if line.startswith("events from "))
    start, offset = events.removeprefix("events from ").split("; pass --clock-offset ")
    mapped = pd.Timestamp(start) + pd.Timedelta(offset.strip("'"))
    assert mapped == pd.Timestamp("2014-03-03T15:30+08:00")
    assert pd.Timestamp(start) > pd.Timestamp.now(tz="UTC")
    assert lines[-1] == "stopped after 1 s; 0 VEN registrations"
    live = _run("openadr_vtn.py", tmp_path, "--port", str(port), "--duration-s", "1", "--live")
    assert any(line.endswith("; pass --clock-offset '0min'") for line in live.splitlines())


def test_the_validation_variant_of_office5_is_office5_with_the_sky_and_angular_windows() -> None:
    """``examples/office5_sky_angular.toml`` (docs/explanation/validation.md) differs from office5
    only in the façades' and windows' emissivity and the windows' SHGC, so EnergyPlus sees office5
    (and in the power models fitted to office5's meters, which a validation of the thermal
    model does not read)."""
    from dataclasses import replace

    from hvacflex.building.io import load_building
    from hvacflex.building.rc import build_network
    from hvacflex.paths import resolve_building

    variant = load_building(EXAMPLES / "office5_sky_angular.toml")
    shipped = load_building(resolve_building("office5"))
    kinds = [ch.kind for ch in build_network(variant).channels]
    assert kinds.count("sky_longwave") == 1 and kinds.count("window_solar_gain") == 4
    undone = replace(
        variant,
        walls=tuple(replace(w, thermal_emissivity=None) for w in variant.walls),
        windows=tuple(
            replace(w, thermal_emissivity=None, shgc=0.35, shgc_normal=None)
            for w in variant.windows
        ),
        power_models=shipped.power_models,
    )
    assert undone == shipped
