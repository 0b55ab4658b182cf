"""Smoke runs of the LP benchmarks (``--quick``): each exits 0 with its correctness checks
held (CVXPY = hvacflex, warm = cold, lazy = full rows, feasible masters), so a broken
benchmark fails the suite. Also: every benchmark of ``benchmarks/`` has a smoke run."""

from __future__ import annotations

import pytest
from bench_smoke import BENCHMARKS, RUN_BENCHMARKS, SOLVER_BENCHMARKS, run_quick


def test_every_benchmark_has_one_smoke_run() -> None:
    scripts = sorted(path.stem for path in BENCHMARKS.glob("bench_*.py"))
    assert not set(SOLVER_BENCHMARKS) & set(RUN_BENCHMARKS)
    assert sorted({**SOLVER_BENCHMARKS, **RUN_BENCHMARKS}) == scripts


@pytest.mark.parametrize("name", sorted(SOLVER_BENCHMARKS))
def test_solver_benchmark_smoke_run(name: str) -> None:
    output = run_quick(name, SOLVER_BENCHMARKS[name])
    if name == "bench_cvxpy_events":  # issue 56 item 9: it compares the optimum it times
        assert "checks passed: CVXPY = hvacflex on 1 paired steps" in output
