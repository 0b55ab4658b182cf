"""Smoke run of ``benchmarks/run_all.py`` (issue 63 item 6): at the ``--quick`` size it writes
``table.csv`` with the stated columns and ``summary.json`` with the CPU figures the issue
names, and a benchmark whose correctness check fails makes it exit 1 (after writing both)."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest
from bench_smoke import BENCHMARKS, RUN_BENCHMARKS, SOLVER_BENCHMARKS

import hvacflex

SOURCE = str(Path(hvacflex.__file__).resolve().parents[1])


def _run_all_module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("run_all", BENCHMARKS / "run_all.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_benchmark_has_a_stated_size() -> None:
    run_all = _run_all_module()
    assert sorted(run_all.SIZES) == sorted({**SOLVER_BENCHMARKS, **RUN_BENCHMARKS})
    assert all(size for _, size in run_all.SIZES.values())


def test_quick_run_writes_the_table_and_the_summary(tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([SOURCE, os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run(
        [
            sys.executable,
            str(BENCHMARKS / "run_all.py"),
            "--quick",
            "--out",
            str(tmp_path),
            "--only",
            "bench_cvxpy_events",
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    with (tmp_path / "table.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0])[:7] == [
        "method",
        "median",
        "p90",
        "ratio",
        "iterations",
        "machine",
        "load",
    ]
    assert {r["benchmark"] for r in rows} == {"bench_cvxpy_events"}
    assert all(float(r["median"]) > 0 and r["machine"] and r["load"] for r in rows)
    assert all(float(r["mean"]) > 0 for r in rows)  # per-step samples: their mean too
    summary = json.loads((tmp_path / "summary.json").read_text())
    for key in ("warm_overhead_ms_median", "office5_event_cvxpy_ratio"):  # startup_s: below
        assert summary[key] > 0, key
    assert summary["failures"] == {} and summary["quick"] is True
    assert (tmp_path / "bench_cvxpy_events.log").read_text().count("checks passed:") == 1


def test_a_failed_check_fails_the_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A benchmark that raises, and one that prints no ``checks passed:``, both fail it."""
    run_all = _run_all_module()
    fake = tmp_path / "benchmarks"
    fake.mkdir()
    (fake / "bench_raises.py").write_text("raise RuntimeError('CVXPY and hvacflex disagree')\n")
    (fake / "bench_silent.py").write_text('print(\'RESULT {"summary": {"startup_s": 1.0}}\')\n')
    (fake / "bench_good.py").write_text("print('checks passed: fine')\n")
    monkeypatch.setattr(run_all, "BENCHMARKS", fake)
    monkeypatch.setattr(
        run_all, "SIZES", {n: ((), "tiny") for n in ("bench_raises", "bench_silent", "bench_good")}
    )
    out = tmp_path / "out"
    assert run_all.main(["--quick", "--out", str(out)]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["failures"]) == {"bench_raises", "bench_silent"}
    assert "exited 1" in summary["failures"]["bench_raises"]
    assert "warm_overhead_ms_median" in summary["missing_summary_keys"]
    assert "startup_s" not in summary["missing_summary_keys"]  # bench_silent gave it
    assert "FAILED" in capsys.readouterr().err
    monkeypatch.setattr(run_all, "SIZES", {"bench_good": ((), "tiny")})
    assert run_all.main(["--quick", "--out", str(out)]) == 2  # a benchmark without a size
