"""The fleet's power-cap guard (``FleetController.act``): what holding a building's cap on the
plant's power model costs.

One office5-like building of a generated fleet (seed 3) decides its first period at 02:00
(small pre-cooling flows, where the LP's affine power under-predicts the plant). Measured
side by side in one run: one prediction of the period's power
(``FleetController.predicted_power_kw``), an ``act`` without a cap, and an ``act`` whose cap
is the plan's own affine power (the guard's bisection runs). Prints per-call times (median,
p90) in µs and the machine's load.

    python benchmarks/bench_fleet_cap_guard.py [--calls 300]
"""

from __future__ import annotations

import argparse

import numpy as np
from bench_loop_parts import (  # beside this script: on sys.path when run
    machine_line,
    per_call_us,
    print_us_rows,
)

from hvacflex.control.base import PeriodInputs
from hvacflex.fleet.agent import BuildingAgent, FleetSettings
from hvacflex.fleet.generate import generate_fleet
from hvacflex.fleet.schema import fleet_from_dict


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--calls", type=int, default=300)
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.calls = 3
    fleet = fleet_from_dict(generate_fleet(1, 3, feeder_limit_kw=float("inf")))
    agent = BuildingAgent(fleet.buildings[0], 0, FleetSettings.of(fleet, "2014-03-03T02:00", 1))
    agent.begin_step()
    horizon = fleet.spec.horizon_steps
    plan_kw = float(agent.finalize(np.zeros(horizon), np.full(horizon, np.inf)).power_kw[0])
    plan = agent._staged  # the coordinated plan act applies
    controller, setup = agent.controller, agent.setup
    inputs = PeriodInputs(
        x_degc=agent.loop.x.copy(),
        forecast=setup.forecaster.forecast(0, horizon + 1),
        peak_floor_kw=0.0,
        plan=plan,
    )
    flow = np.asarray(plan.u[0], dtype=float)

    def act(cap_kw: float) -> None:
        controller.cap_now_kw = cap_kw
        controller.act(inputs)

    rows = {
        "one predicted period power": per_call_us(
            lambda i: controller.predicted_power_kw(inputs, flow), args.calls
        ),
        "act, no cap": per_call_us(lambda i: act(np.inf), args.calls),
        "act, cap at the plan's affine power (guard binds)": per_call_us(
            lambda i: act(plan_kw), args.calls
        ),
    }
    print(
        machine_line(
            f"plan {plan_kw:.2f} kW, predicted {controller.predicted_power_kw(inputs, flow):.2f} kW"
        )
    )
    print_us_rows(rows)
    predicted_kw = controller.predicted_power_kw(inputs, flow)
    if not (np.isfinite(plan_kw) and np.isfinite(predicted_kw) and plan_kw > 0.0):
        raise RuntimeError(f"plan {plan_kw} kW, predicted {predicted_kw} kW: not a plan")
    print("checks passed: a finite plan and prediction, act with and without a cap")


if __name__ == "__main__":
    main()
