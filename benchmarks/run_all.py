"""Run every benchmark at a stated size and write one table of figures (issue 63 item 6).

Run::

    python benchmarks/run_all.py --out bench-results            # the stated sizes (long)
    python benchmarks/run_all.py --quick --out bench-results    # every one at its --quick size
    python benchmarks/run_all.py --only bench_startup,bench_cvxpy_events --out DIR
    python benchmarks/run_all.py --years-days 28 --out DIR    # the three years extrapolated
    python benchmarks/run_all.py --source ../old/src --only … --out OLD  # another checkout

Each ``benchmarks/bench_*.py`` runs in a fresh interpreter (this one, with this checkout's
hvacflex) at the size :data:`SIZES` states (``--quick``: its smoke size), one after another.
A benchmark passes when it exits 0 and prints its ``checks passed:`` line (its correctness
checks: CVXPY = hvacflex, warm = cold, …); the figures it reports for the table come in lines
``RESULT {"row": {...}, "summary": {...}}`` (JSON). A benchmark without such a line gets one
row: its whole run's CPU [s].

Writes ``DIR/table.csv`` (columns :data:`TABLE_COLUMNS`: ``method``, ``median``, ``p90``,
``ratio``, ``iterations``, ``machine``, ``load``, plus the ``mean`` where a benchmark samples
per step (what a long run's time follows: a few steps of thousands of iterations weigh in the
mean, not in the median), the ``unit`` of median, p90 and mean and the
``benchmark`` and ``size`` it came from), ``DIR/summary.json`` (the benchmarks' summary figures,
among them ``warm_overhead_ms_median``, ``office5_event_cvxpy_ratio``, ``startup_s`` — CPU
figures — and, without ``--quick``, ``years_x3_wall_s``; the machine, the load, each
benchmark's CPU and wall time and the failures) and ``DIR/<benchmark>.log`` (its output).
Exits 1 when a benchmark failed or a summary key is missing, after writing everything.
Timings are CPU time where the benchmark says so; the machine's load average is in every row.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

BENCHMARKS = Path(__file__).resolve().parent
TABLE_COLUMNS = (
    "method",
    "median",
    "p90",
    "ratio",
    "iterations",
    "machine",
    "load",
    "mean",
    "unit",
    "benchmark",
    "size",
)
#: benchmark → (arguments of its stated size, the size in words)
SIZES: dict[str, tuple[tuple[str, ...], str]] = {
    "bench_control_step": ((), "rmpc, 3 days from 2014-03-03, stress activations"),
    "bench_cvxpy_events": ((), "office5 rmpc event LP, 48 steps, CVXPY every 3rd"),
    "bench_energyplus_plant": ((), "7 days"),
    "bench_feedback": ((), "48 steps, cold every 4th"),
    "bench_fleet_cap_guard": ((), "300 calls"),
    "bench_fleet_master": ((), "100 and 1,000 buildings, 5 and 20 plans"),
    "bench_fleet_scale": ((), "10 and 100 buildings, 1 and 2 workers, 3 steps"),
    "bench_il_events": ((), "40 steps"),
    "bench_loop_parts": ((), "2,000 calls"),
    "bench_meter_response": ((), "2,000 calls, 96 periods"),
    "bench_open_loop": ((), "office5 rmpc, 96 steps"),
    "bench_pricing": ((), "office5, 48 steps of the event, whole-horizon and feedback LPs"),
    "bench_rmpc": ((), "office5, 200 warm steps, 30 cold, 10 CVXPY"),
    "bench_service_kill": (("sqlite",), "SQLite, 5 kills, 4 buildings, 12 periods"),
    "bench_service_load": ((), "20 buildings, 20 readers, 3 rounds"),
    "bench_startup": ((), "1-day simulate, 5 fresh processes"),
    "bench_sweep": ((), "4 PPP runs of 2 days on 1 and 2 workers"),
    "bench_visible_offers": ((), "96 periods, 2 rounds"),
    "bench_years": ((), "nmpc, rmpc, rmpc-ppp, 365 days each, 2 workers"),
    "bench_zones": ((), "office5 and office15, 24 steps"),
}
#: benchmark → arguments its --quick run needs besides --quick
QUICK_EXTRA: dict[str, tuple[str, ...]] = {"bench_service_kill": ("sqlite",)}
#: summary keys every run must produce (CPU figures), and those of a run at the stated sizes
REQUIRED = ("warm_overhead_ms_median", "office5_event_cvxpy_ratio", "startup_s")
REQUIRED_FULL = ("years_x3_wall_s",)
RESULT_PREFIX = "RESULT "
CHECKS_PASSED = "checks passed:"
TIMEOUT_S = 4 * 3600


def machine() -> str:
    """CPU model, cores, Python (the machine a figure belongs to)."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.partition(":")[2].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


def load_now() -> str:
    """The 1-, 5- and 15-minute load averages."""
    return " / ".join(f"{x:.1f}" for x in os.getloadavg())


def children_cpu_s() -> float:
    """CPU [s] of this process's ended children so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_one(name: str, arguments: tuple[str, ...], log: Path, source: Path) -> dict[str, Any]:
    """Run ``benchmarks/<name>.py *arguments`` on the hvacflex in ``source`` (a ``src``
    folder); its outcome: ok, error, CPU and wall [s], the rows and summary figures of its
    ``RESULT`` lines. Its output goes to ``log``."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(source), env.get("PYTHONPATH")) if p)
    cpu0, tick = children_cpu_s(), time.perf_counter()
    try:
        done = subprocess.run(
            [sys.executable, str(BENCHMARKS / f"{name}.py"), *arguments],
            cwd=BENCHMARKS.parent,
            env=env,
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
            check=False,
        )
        output, code = done.stdout + done.stderr, done.returncode
    except subprocess.TimeoutExpired:
        output, code = f"timed out after {TIMEOUT_S} s", -1
    wall_s, cpu_s = time.perf_counter() - tick, children_cpu_s() - cpu0
    log.write_text(output)
    rows: list[dict[str, Any]] = []
    summary: dict[str, Any] = {}
    for line in output.splitlines():
        if line.startswith(RESULT_PREFIX):
            result = json.loads(line.removeprefix(RESULT_PREFIX))
            rows += [result["row"]] if "row" in result else []
            rows += result.get("rows", [])
            summary.update(result.get("summary", {}))
    error = None
    if code != 0:
        error = f"exited {code}: {output.strip().splitlines()[-1:] or ['']}"
    elif CHECKS_PASSED not in output:
        error = "ran no correctness check (no 'checks passed:' line)"
    if not rows:
        rows = [{"method": f"{name}: the whole run, CPU", "median": cpu_s, "unit": "s"}]
    return {
        "ok": error is None,
        "error": error,
        "cpu_s": cpu_s,
        "wall_s": wall_s,
        "rows": rows,
        "summary": summary,
        "load": load_now(),
    }


def write_table(path: Path, results: dict[str, dict[str, Any]], sizes: dict[str, str]) -> None:
    """``table.csv``: one line per row of every benchmark."""
    where = machine()
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=TABLE_COLUMNS)
        writer.writeheader()
        for name, result in results.items():
            for row in result["rows"]:
                line = {key: row.get(key, "") for key in TABLE_COLUMNS}
                line |= {
                    "machine": where,
                    "load": result["load"],
                    "benchmark": name,
                    "size": sizes[name],
                }
                writer.writerow(line)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmarks, write the table and summary; 0 when all passed, else 1."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for table.csv etc.")
    parser.add_argument("--quick", action="store_true", help="every benchmark at its --quick size")
    parser.add_argument("--only", default="", help="comma-separated benchmark names")
    parser.add_argument(
        "--source",
        type=Path,
        default=BENCHMARKS.parent / "src",
        help="the hvacflex to measure (a src folder; default: this checkout's), e.g. an older "
        "checkout's, to compare side by side",
    )
    parser.add_argument(
        "--years-days",
        type=float,
        default=None,
        help="bench_years at this many days instead of 365 (its year then extrapolated)",
    )
    args = parser.parse_args(argv)
    present = sorted(p.stem for p in BENCHMARKS.glob("bench_*.py"))
    unknown = [n for n in present if n not in SIZES]
    names = [n.strip() for n in args.only.split(",") if n.strip()] or present
    missing = [n for n in names if n not in present]
    if unknown or missing:
        print(
            f"run_all: no stated size for {unknown} / no such benchmark {missing}: add it to "
            "SIZES in benchmarks/run_all.py or fix --only",
            file=sys.stderr,
        )
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    sizes = {n: "--quick" if args.quick else SIZES[n][1] for n in names}
    results: dict[str, dict[str, Any]] = {}
    for name in names:
        arguments = ("--quick", *QUICK_EXTRA.get(name, ())) if args.quick else SIZES[name][0]
        if name == "bench_years" and args.years_days is not None and not args.quick:
            arguments = ("--days", f"{args.years_days:g}")
            sizes[name] = f"nmpc, rmpc, rmpc-ppp, {args.years_days:g} days each, 2 workers"
        print(f"{name} {' '.join(arguments)} …", flush=True)
        results[name] = run_one(name, arguments, args.out / f"{name}.log", args.source)
        state = "ok" if results[name]["ok"] else f"FAILED: {results[name]['error']}"
        print(
            f"  {state} ({results[name]['wall_s']:.0f} s wall, {results[name]['cpu_s']:.0f} CPU-s)",
            flush=True,
        )
    summary: dict[str, Any] = {}
    for result in results.values():
        summary |= result["summary"]
    full = not args.quick and args.years_days is None
    required = REQUIRED + REQUIRED_FULL if full else REQUIRED
    absent = [k for k in required if k not in summary] if not args.only else []
    failures = {n: r["error"] for n, r in results.items() if not r["ok"]}
    summary |= {
        "quick": args.quick,
        "source": str(args.source),
        "machine": machine(),
        "load_at_end": load_now(),
        "benchmarks": {
            n: {"ok": r["ok"], "cpu_s": r["cpu_s"], "wall_s": r["wall_s"], "size": sizes[n]}
            for n, r in results.items()
        },
        "failures": failures,
        "missing_summary_keys": absent,
    }
    write_table(args.out / "table.csv", results, sizes)
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"wrote {args.out / 'table.csv'} and {args.out / 'summary.json'}")
    if failures or absent:
        print(
            f"FAILED: {failures or ''} {('missing ' + str(absent)) if absent else ''}",
            file=sys.stderr,
        )
        return 1
    print(f"checks passed: {len(results)} benchmarks")
    return 0


if __name__ == "__main__":
    sys.exit(main())
