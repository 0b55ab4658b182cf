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


def _run(script: str, cwd: Path) -> str:
    path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / script)],
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
    tested = {"compare_rmpc_nmpc.py", "peak_price.py", "one_room.py"}
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
    charge = _summary(tmp_path / "results/examples/phi_4")["ppp_charge_sgd"]
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
