"""Run a benchmark of ``benchmarks/`` at its ``--quick`` size in a fresh interpreter (shared by
the two smoke-test files, which ``-n 2 --dist loadfile`` runs side by side).

Every benchmark takes ``--quick`` (its smallest size), raises (exit ≠ 0) when one of its
correctness checks fails and prints a line starting ``checks passed:`` when they all held."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import hvacflex

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
SMOKE_TIMEOUT_S = 300

#: benchmark → extra arguments of its smoke run
SOLVER_BENCHMARKS: dict[str, tuple[str, ...]] = {
    "bench_cvxpy_events": (),
    "bench_feedback": (),
    "bench_fleet_cap_guard": (),
    "bench_fleet_master": (),
    "bench_il_events": (),
    "bench_open_loop": (),
    "bench_pricing": (),
    "bench_rmpc": (),
    "bench_zones": (),
}
RUN_BENCHMARKS: dict[str, tuple[str, ...]] = {
    "bench_control_step": (),
    "bench_energyplus_plant": (),
    "bench_fleet_scale": (),
    "bench_loop_parts": (),
    "bench_meter_response": (),
    "bench_service_kill": ("sqlite",),
    "bench_service_load": (),
    "bench_startup": (),
    "bench_sweep": (),
    "bench_visible_offers": (),
    "bench_years": (),
}


def run_quick(name: str, extra: tuple[str, ...]) -> str:
    """Run ``benchmarks/<name>.py --quick *extra`` with this interpreter and this checkout's
    hvacflex; assert exit 0 and the ``checks passed`` line; return its output."""
    source = str(Path(hvacflex.__file__).resolve().parents[1])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (source, env.get("PYTHONPATH", "")) if p)
    done = subprocess.run(
        [sys.executable, str(BENCHMARKS / f"{name}.py"), "--quick", *extra],
        cwd=BENCHMARKS.parent,
        env=env,
        capture_output=True,
        text=True,
        timeout=SMOKE_TIMEOUT_S,
        check=False,
    )
    output = done.stdout + done.stderr
    assert done.returncode == 0, f"{name} --quick exited {done.returncode}:\n{output[-3000:]}"
    assert "checks passed:" in done.stdout, f"{name} ran no correctness check:\n{output[-3000:]}"
    return done.stdout
