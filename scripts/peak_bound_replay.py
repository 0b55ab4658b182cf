"""Run the peak bound's plan open loop on the plant: what would the meter show? (issue 61 item 1)

python scripts/peak_bound_replay.py --forecast perfect --out DIR [--days 28]

Fig. 7 on EnergyPlus grades the realised peaks against ``bound_peak_kw``: the least monthly
peak over the sweep's days on the controller's model with perfect foresight
(:func:`hvacflex.sim.peak_bound.bound_peak_kw`). That bound is the controller's model's. This
script takes the sweep's configuration (``energyplus-ppp-<φ>`` or its ``-realistic`` twin from
``hvacflex.reproduce_plan.ppp_energyplus_jobs``; the bound does not depend on φ), computes the
bound and its plan (flows, and the zone temperatures they give on the model), and applies the
plan to the configuration's plant through the closed loop, as the MPC's decisions are applied:
on EnergyPlus the zones' setpoints are the plan's end-of-period temperatures clipped to the band
(``hvacflex.sim.closed_loop.setpoint_actuation_degc``). No activations are applied and the
peak guard is off: the plan alone. Writes ``DIR/results.parquet`` (the closed loop's columns,
``planned_power_kw`` the bound's power) and prints, as JSON, the bound, the metered peak over
the run and over the occupied periods (``hvacflex.kpi.occupied_mask``), where they fall, the
plan's power there, and the planned and metered energy.

The bound's second LP minimises the peak only, so its plan is one of many with that peak and
is indifferent to energy (it may pre-cool to the lower bound where the band widens); the
occupied peak is the figure to compare with the MPC's.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from hvacflex import kpi
from hvacflex.control.base import Action, FloatArray, PeriodInputs
from hvacflex.reproduce_plan import Plan, ppp_energyplus_jobs
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.peak_bound import bound_peak_kw
from hvacflex.sim.setup import prepare


class PlanReplay:
    """A controller that applies a fixed plan: period k's flows and end-of-period zone
    temperatures (T, m) [kg/s, °C] and power (T,) [kW], no reserve."""

    takes_measurements = False
    commits_ahead = 0

    def __init__(self, flow_kg_s: FloatArray, temps_degc: FloatArray, power_kw: FloatArray):
        self.flow_kg_s, self.temps_degc, self.power_kw = flow_kg_s, temps_degc, power_kw
        self.k = 0

    def act(self, inputs: PeriodInputs) -> Action:
        k = self.k
        self.k += 1
        return Action.unoptimised(
            self.flow_kg_s[k],
            np.zeros(self.flow_kg_s.shape[1]),
            float(self.power_kw[k]),
            self.temps_degc[k],
            self.temps_degc[k],
            status="optimal",
        )

    def get_state(self) -> dict[str, Any]:
        return {"k": self.k}

    def set_state(self, state: dict[str, Any]) -> None:
        self.k = int(state["k"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--forecast", choices=("perfect", "realistic"), default="perfect")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--days", type=float, help="fewer days than the sweep's (a smoke run)")
    args = parser.parse_args()
    _, config = next(
        job
        for job in ppp_energyplus_jobs(Plan.full(energyplus=True))
        if job[0]["forecast"] == args.forecast
    )
    config = replace(
        config,
        controller=replace(config.controller, peak_guard="off"),
        activation=replace(config.activation, mode="never"),
    )
    if args.days is not None:
        config = replace(config, days=args.days)
    bound = bound_peak_kw(config)
    steps = config.steps
    replay = PlanReplay(bound.flow_kg_s, bound.zone_temp_degc, bound.power_kw)
    loop = ClosedLoop(prepare(config), replay)
    while loop.k < steps:
        loop.step()
    frame = loop.frame()
    args.out.mkdir(parents=True, exist_ok=True)
    frame.to_parquet(args.out / "results.parquet")
    metered = frame["power_kw"].to_numpy()
    occupied = kpi.occupied_mask(frame).any(axis=1).to_numpy()
    if not occupied.any():
        parser.error("the days run have no occupied period: run more days (or weekdays)")
    top, top_occupied = int(np.argmax(metered)), int(np.argmax(np.where(occupied, metered, -1.0)))
    report = {
        "forecast": args.forecast,
        "days": config.days,
        "bound_peak_kw": bound.peak_kw,
        "metered_peak_kw": float(metered[top]),
        "metered_peak_time": str(frame.index[top]),
        "planned_kw_then": float(bound.power_kw[top]),
        "metered_occupied_peak_kw": float(metered[top_occupied]),
        "metered_occupied_peak_time": str(frame.index[top_occupied]),
        "planned_kw_then_occupied": float(bound.power_kw[top_occupied]),
        "planned_energy_kwh": float(bound.power_kw.sum() * config.dt_s / 3600.0),
        "metered_energy_kwh": float(metered.sum() * config.dt_s / 3600.0),
    }
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
