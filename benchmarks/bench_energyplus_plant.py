"""The EnergyPlus plant's own overhead per 30-min step: engine side vs Python side.

Runs the shipped 5ZoneAirCooled model (Singapore) for ``--days`` days under a trivial
supervisory controller (the IDF's own setpoint schedule sent as actuations) and reports,
per 30-min step:

* engine wait: the time :meth:`CoSimulation.advance` waits for EnergyPlus (3 zone time steps
  at 6 per hour, plus the two queue hand-offs between the threads);
  of which the Python callbacks (reading variables and meters, the per-time-step setpoint
  rule, setting actuators) take the "callbacks" part;
* Python side: the rest of :meth:`EnergyPlusPlant.step` (actuation → actuator values,
  readings → observation);
* bare engine: the same model run by ``energyplus()`` without callbacks, for ``--days`` days
  and for 1 day; the difference over the difference in periods cancels the start-up (sizing
  and warm-up).

Wall times on a shared machine swing with its load (printed); CPU times (both threads of this
process) are steadier.

    python benchmarks/bench_energyplus_plant.py [--days 7]
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.energyplus.api import load_api
from hvacflex.paths import resources_dir
from hvacflex.sim.energyplus_plant import EnergyPlusPlant
from hvacflex.sim.plant import Actuation, Disturbance

IDF = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"
EPW = resources_dir() / "weather" / "SGP_SG_Singapore-Changi.Intl.AP.486980_TMYx.2009-2023.epw"
ZONES = tuple(f"space{i}-1" for i in range(1, 6))
START = pd.Timestamp("2014-03-17", tz="Asia/Singapore")
ZONE_TEMP_PLAUSIBLE_DEGC = (15.0, 40.0)  # a Singapore office under its own schedule [°C]


def bare_engine_s(days: int) -> tuple[float, float]:
    """Wall and CPU time of one plain ``energyplus()`` run of ``days`` days [s]."""
    plant = EnergyPlusPlant.from_file(IDF, ZONES, start=START, steps=48 * days, epw_path=EPW)
    api = load_api()
    with tempfile.TemporaryDirectory(prefix="hvacflex-bench-") as folder:
        idf = Path(folder) / "in.idf"
        idf.write_text(plant._spec.idf_text, encoding="utf-8")
        state = api.new_state()
        api.lib.setConsoleOutputState(state, 0)
        began, cpu = time.perf_counter(), time.process_time()
        rc = api.run(state, ["-d", folder, "-w", str(EPW), str(idf)])
        elapsed, cpu = time.perf_counter() - began, time.process_time() - cpu
        api.lib.stateDelete(state)
    if rc != 0:
        raise RuntimeError(f"bare EnergyPlus run failed (rc {rc})")
    return elapsed, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--days", type=int, default=7)
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.days = 1
    steps = 48 * args.days
    plant = EnergyPlusPlant.from_file(IDF, ZONES, start=START, steps=steps, epw_path=EPW)
    hours = (np.arange(steps) % 48) / 2.0
    times = START + pd.to_timedelta(np.arange(steps) * 30, "min")
    weekday = np.asarray(times.day_of_week) < 5
    setpoint = np.where(weekday & (hours >= 6.0) & (hours < 20.0), 23.9, 29.4)
    disturbance = Disturbance(np.zeros(1), 30.0, 0.018)

    began = time.perf_counter()
    plant.reset(25.0)
    startup_s = time.perf_counter() - began
    cpu0 = time.process_time()
    assert plant._sim is not None
    callback0_s = plant._sim.callback_time_s
    step_times = np.empty(steps)
    zone_temp_degc = np.empty((steps, len(ZONES)))
    for k in range(steps):
        t0 = time.perf_counter()
        actuation = Actuation(setpoint_degc=np.full(len(ZONES), setpoint[k]))
        observation = plant.step(actuation, disturbance, 1800.0)
        step_times[k] = time.perf_counter() - t0
        zone_temp_degc[k] = observation.zone_temp_degc
    assert plant._sim is not None
    engine_s = plant._sim.engine_time_s
    callback_s = plant._sim.callback_time_s - callback0_s
    cpu_s = time.process_time() - cpu0
    plant.close()
    bare_s, bare_cpu_s = bare_engine_s(args.days)
    one_s, one_cpu_s = (bare_s, bare_cpu_s) if args.days == 1 else bare_engine_s(1)

    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load average {load}; {args.days} days = {steps} steps of 5ZoneAirCooled (Singapore)"
    )
    per = 1e3 / steps
    bare_per = 1e3 / max(steps - 48, 1)
    print(f"start-up (sizing + warm-up, reset):   {startup_s:8.2f} s")
    print(
        f"step, median / p90:                    {np.median(step_times) * 1e3:8.3f} / "
        f"{np.percentile(step_times, 90) * 1e3:.3f} ms"
    )
    print(f"  engine wait per step:                {engine_s * per:8.3f} ms")
    print(f"    of which Python callbacks (CPU):     {callback_s * per:8.3f} ms")
    print(f"  Python side per step (caller):       {plant.python_time_s * per:8.3f} ms")
    print(f"  CPU per step (both threads):         {cpu_s * per:8.3f} ms")
    if args.days > 1:
        print(
            f"bare engine per step, wall / CPU:      {(bare_s - one_s) * bare_per:8.3f} / "
            f"{(bare_cpu_s - one_cpu_s) * bare_per:.3f} ms (runs of {args.days} d: "
            f"{bare_s:.2f} s, 1 d: {one_s:.2f} s)"
        )
    else:  # one day: no second run to cancel the start-up against
        print(
            f"bare engine, one 1-d run (start-up included): {bare_s:.2f} s / {bare_cpu_s:.2f} s CPU"
        )
    low, high = ZONE_TEMP_PLAUSIBLE_DEGC
    if not ((zone_temp_degc > low) & (zone_temp_degc < high)).all():
        raise RuntimeError(f"zone temperatures outside {low}–{high} °C: the co-simulation broke")
    print(f"checks passed: {steps} steps, zone temperatures within {low}–{high} °C, bare run rc 0")


if __name__ == "__main__":
    main()
