"""Start-up of a 1-day ``simulate``: CPU and wall time before its first period (issue 63 item 4).

Run::

    python benchmarks/bench_startup.py [--repeats 5] [--days 1]

Each repeat starts a fresh interpreter that runs ``hvacflex simulate --scenario rmpc --start
2014-03-03 --days 1`` into a temporary folder and stops at the first call of
``ClosedLoop.step``: what it spent until then (interpreter, imports, configuration, data
loading, the controller and plant built) is the start-up. The first repeat fills the data cache
(:mod:`hvacflex.data.cache`, in a temporary cache folder) and writes hvacflex's bytecode
(``__pycache__`` beside the sources, also under a test run or CI that sets
``PYTHONDONTWRITEBYTECODE``: the probe runs without it, which would compile every module of
hvacflex again in each start, 0.2–0.5 CPU-s); the others find both, as every run after a user's
first does. Prints the process CPU and wall time of each repeat and the median of
the warm ones (goal: < 1.5 s on an idle core). ``--quick``: two repeats (the smoke run).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

#: Run in the fresh interpreter: the CLI's simulate, stopped at the first period.
PROBE = """
import json, os, sys, time
wall0 = time.perf_counter()
from hvacflex.cli import app  # first, as the ``hvacflex`` script imports it
from hvacflex.sim import closed_loop

def first_period(self, *args, **kwargs):
    print("STARTUP " + json.dumps({"cpu_s": time.process_time(),
                                   "wall_s": time.perf_counter() - wall0}), flush=True)
    os._exit(0)

closed_loop.ClosedLoop.step = first_period
app(sys.argv[1:])
"""


def one_start(days: float, out: Path, cache: Path) -> dict[str, float]:
    """CPU and wall [s] of one fresh process until its first period."""
    env = dict(os.environ, HVACFLEX_CACHE_DIR=str(cache))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's Python caches bytecode
    command = [sys.executable, "-c", PROBE, "simulate", "--scenario", "rmpc"]
    command += ["--start", "2014-03-03", "--days", f"{days:g}", "--out", str(out), "--fresh"]
    done = subprocess.run([*command, "-q"], capture_output=True, text=True, env=env, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith("STARTUP ")]
    if not lines:
        raise RuntimeError(f"simulate never reached its first period:\n{done.stderr[-2000:]}")
    figures: dict[str, float] = json.loads(lines[0].removeprefix("STARTUP "))
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--days", type=float, default=1.0)
    parser.add_argument("--quick", action="store_true", help="two repeats (the smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.repeats = 2
    with tempfile.TemporaryDirectory() as tmp:
        starts = [
            one_start(args.days, Path(tmp) / "run", Path(tmp) / "cache")
            for _ in range(max(2, args.repeats))
        ]
    warm = starts[1:]
    cpu_s = statistics.median(s["cpu_s"] for s in warm)
    wall_s = statistics.median(s["wall_s"] for s in warm)
    print(f"load average {' / '.join(f'{x:.1f}' for x in os.getloadavg())}")
    for i, s in enumerate(starts):
        kind = "cache filled" if i == 0 else "cache found"
        print(f"start {i}: CPU {s['cpu_s']:.2f} s, wall {s['wall_s']:.2f} s ({kind})")
    print(
        f"start-up before the first period, median of {len(warm)}: CPU {cpu_s:.2f} s, "
        f"wall {wall_s:.2f} s (goal < 1.5 s)"
    )
    row = {
        "method": f"start-up, 1-day simulate ({len(warm)} starts)",
        "median": cpu_s,
        "p90": max(s["cpu_s"] for s in warm),
        "unit": "s",
    }
    print("RESULT " + json.dumps({"row": row, "summary": {"startup_s": cpu_s}}))
    print(f"checks passed: {len(starts)} starts reached their first period")


if __name__ == "__main__":
    main()
