"""The fleet's perfect-foresight plans re-linearised along themselves, then metered on the
RC plants: what issue 60's energy target costs on a model that is right where the plans go.

python scripts/fleet_plan_replay.py --fleet F --bound B/bound.csv [--start 2014-03-03]
    [--days 5] [--rounds 3] [--damping 0.0] [--max-excursion 1.0]

Two centralised plans over the run, on `fleet bound`'s run model (every building from the
closed loop's initial state, one horizon over the run, perfect foresight, no margins, the
limits in force; `hvacflex.fleet.bound.run_model`):

* **unlimited**: the controllers' objective without any limit (`priced_only`), the
  reference of "energy ≤ +10 % over the unlimited days";
* **least energy**: the least fleet energy with each building's discomfort ≤ its bound
  (``--bound``, from `fleet bound` on the same file: the fixed T₀ model's, as issue 60
  defines it) + 0.5 K·h per day and every zone's slack ≤ ``--max-excursion`` [K]
  (`least_energy_for_comfort`'s LP).

Round 0 is the fleet file's fixed T₀ model (what `fleet bound` and `fleet_tradeoff.py`
solve). Each further round takes every building's model and power rows along the previous
round's zone temperatures (each step at the mean of its start and end), as
``linearisation = "plan"`` does step by step in the closed loop
(`hvacflex.control.plan_linearisation`), and solves again: a sequential LP, an estimate
for the nonlinear plants, not a bound; the rounds need not settle (the unoccupied hours'
wide band leaves the zones' temperatures free there; ``--damping`` w takes each round at
w × the previous round's temperatures + (1 − w) × its plan's). Buildings on a power model fitted to
a meter are refused (their power rows follow the flows, not the temperatures); the
limits' raise to the minimum power stays the fixed model's. Round 0's and the last round's
plans are then applied open loop to each building's RC plant (its flows, no activations),
and the meters read: planned and metered energy [kWh] by block of the day (00–07 / 07–10 /
10–17 / 17–24), and the discomfort per building-day on the plant. Open loop over days, the
zones drift from the plan (nothing feeds back), so the energy is the figure to read; the
comfort is the plan's own (the LP's rows).
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from peak_bound_replay import PlanReplay
from scipy import sparse

from hvacflex import kpi
from hvacflex.control.plan_linearisation import plan_affine_shift, plan_input_scale
from hvacflex.control.problem_builder import PlanContext, _meter_fit, _power_coefficients
from hvacflex.fleet import bound as fleet_bound
from hvacflex.fleet.agent import BuildingAgent, BuildingGroup
from hvacflex.fleet.centralised import StackedLP, stacked_lp
from hvacflex.fleet.schema import load_fleet_document
from hvacflex.opt import RMPCProblem, StepLinearisation
from hvacflex.opt.solve import solve_lp
from hvacflex.sim.closed_loop import ClosedLoop

Plan = tuple[np.ndarray, np.ndarray, np.ndarray]
"""One building's plan: flows (T, m) [kg/s], zone temperatures (T + 1, m) from now [°C],
power (T,) [kW]."""
BLOCKS = ((0, 7), (7, 10), (10, 17), (17, 24))
ALLOWANCE_KELVIN_HOURS_PER_DAY = 0.5
"""Issue 60's allowance over each building's bound [K·h per building-day]."""


def along(problem: RMPCProblem, agent: BuildingAgent, temps_degc: np.ndarray) -> RMPCProblem:
    """``problem`` (the fixed-T₀ one) with every step's model and power rows taken at the
    zone temperatures ``temps_degc`` (T, m) [°C] (:mod:`hvacflex.control.plan_linearisation`)."""
    contract = agent.controller.contract
    scale = plan_input_scale(contract.model, temps_degc)
    affine = np.asarray(problem.affine_term, dtype=float)
    if np.any(contract.model.flow_ref_kg_s):
        affine = affine + plan_affine_shift(contract.model, scale)
    assert agent._inputs is not None, "begin_step() first"
    forecast = agent.controller.fleet_inputs(agent._inputs).forecast
    p0, p, _ = _power_coefficients(
        contract,
        PlanContext(problem.x0),
        forecast,
        problem.d_forecast,
        problem.u_min,
        problem.y_min,
        temps_degc,
    )
    return dataclasses.replace(
        problem,
        step_linearisation=StepLinearisation(input_scale=scale),
        affine_term=affine,
        power_offset_kw=p0,
        power_coeff_kw_per_kg_s=p,
    )


def plans_of(stacked: StackedLP, x: np.ndarray, problems: Sequence[RMPCProblem]) -> list[Plan]:
    """Every building's plan in the stacked LP's solution ``x``."""
    out = []
    for problem, (offset, layout) in zip(problems, stacked.layouts, strict=True):
        states = x[np.asarray(layout.plan.x) + offset]
        zone = np.vstack([problem.c_matrix @ problem.x0, states @ problem.c_matrix.T])
        out.append(
            (x[np.asarray(layout.plan.u) + offset], zone, x[np.asarray(layout.plan.power) + offset])
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleet", type=Path, required=True)
    parser.add_argument("--bound", type=Path, required=True, help="bound.csv of `fleet bound`")
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--days", type=float, default=5.0)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--damping",
        type=float,
        default=0.0,
        help="weight in [0, 1) of the temperatures a round was taken at in the next one's",
    )
    parser.add_argument("--max-excursion", type=float, default=1.0)
    args = parser.parse_args()
    if not 0.0 <= args.damping < 1.0:
        parser.error(f"--damping {args.damping} is outside [0, 1)")
    fleet, document = load_fleet_document(args.fleet)
    bound_kelvin_hours = pd.read_csv(args.bound)["discomfort_kelvin_hours"].to_numpy()
    allowed = bound_kelvin_hours + ALLOWANCE_KELVIN_HOURS_PER_DAY * args.days
    model = fleet_bound.run_model(fleet, document, args.start, args.days)
    steps = model.p_min_kw.shape[1]
    dt_h = model.problems[0].dt_h
    settings = fleet_bound.run_settings(fleet, args.start, args.days)
    indices = list(range(len(fleet.buildings)))
    group = BuildingGroup(document, indices, settings)
    group.begin_step()
    metered = [a.name for a in group.agents if _meter_fit(a.controller.contract.building)]
    if metered:
        parser.error(
            f"{', '.join(metered)} plan on a power model fitted to a meter, whose power rows "
            "follow the plan's flows, not its temperatures: this script re-linearises the "
            "design curves only"
        )
    fixed = [agent.problem for agent in group.agents]

    def unlimited(problems: list[RMPCProblem]) -> list[Plan] | None:
        priced = [fleet_bound.priced_only(p) for p in problems]
        stacked = stacked_lp(priced, np.full(steps, np.inf))
        result = stacked.solve()
        return plans_of(stacked, result.x, priced) if result.status.ok else None

    def least_energy(problems: list[RMPCProblem]) -> list[Plan] | None:
        lp = fleet_bound._comfort_lp(  # the LP of least_energy_for_comfort, solved here for x
            dataclasses.replace(model, problems=tuple(problems)), args.max_excursion
        )
        s = lp.stacked
        cost = np.asarray(lp.energy.toarray()).ravel() + fleet_bound.LEAST_ENERGY_TIE_BREAK * s.cost
        result = solve_lp(
            cost,
            sparse.vstack([s.matrix, lp.discomfort]).tocsr(),
            np.append(s.row_lower, np.full(allowed.size, -np.inf)),
            np.append(s.row_upper, allowed),
            s.col_lower,
            s.col_upper,
        )
        return plans_of(s, result.x, lp.problems) if result.status.ok else None

    def meter(plans: list[Plan], tag: str) -> None:
        replay_group = BuildingGroup(document, indices, settings)
        rows, powers = [], []
        for agent, (flow, zone, power) in zip(replay_group.agents, plans, strict=True):
            loop = ClosedLoop(agent.setup, PlanReplay(flow, zone[1:], power))
            while loop.k < steps:
                loop.step()
            frame = loop.frame()
            rows.append(
                (agent.name, power.sum() * dt_h, kpi.energy_kwh(frame),
                 kpi.total_discomfort_kelvin_hours(frame) / args.days)
            )  # fmt: skip
            powers.append(frame["power_kw"])
        table = pd.DataFrame(
            rows, columns=["building", "planned_kwh", "metered_kwh", "plant_kelvin_hours_per_day"]
        )
        fleet_kw = pd.concat(powers, axis=1).sum(axis=1)
        hours = pd.DatetimeIndex(fleet_kw.index).hour
        blocks = [
            round(float(fleet_kw[(hours >= a) & (hours < z)].sum() * dt_h)) for a, z in BLOCKS
        ]
        by_block = " / ".join(f"{b:,}" for b in blocks)
        print(
            f"{tag}: planned {table.planned_kwh.sum():,.0f} kWh, metered "
            f"{table.metered_kwh.sum():,.0f} kWh ({by_block} by block), on the plants "
            f"{table.plant_kelvin_hours_per_day.mean():.3f} K·h per building-day open loop"
        )
        print(table.round(3).to_string(index=False), flush=True)

    cases: tuple[tuple[str, Callable[[list[RMPCProblem]], list[Plan] | None]], ...] = (
        ("unlimited", unlimited),
        ("least energy", least_energy),
    )
    for name, solve in cases:
        problems, taken_at = list(fixed), None
        for round_ in range(args.rounds + 1):
            plans = solve(problems)
            if plans is None:
                print(f"{name}, round {round_}: no plan (the LP has no optimum: the bound file "
                      "of other days, or the excursion cap too tight)", flush=True)  # fmt: skip
                break
            energy = sum(power.sum() * dt_h for _, _, power in plans)
            print(f"{name}, round {round_}: planned {energy:,.1f} kWh", flush=True)
            if round_ in (0, args.rounds):
                meter(plans, f"{name}, round {round_}")
            temps = [0.5 * (zone[:-1] + zone[1:]) for _, zone, _ in plans]  # each step's mean
            if taken_at is not None:
                temps = [
                    args.damping * old + (1.0 - args.damping) * new
                    for old, new in zip(taken_at, temps, strict=True)
                ]
                pairs = zip(taken_at, temps, strict=True)
                moved = max(float(np.abs(new - old).max()) for old, new in pairs)
                print(f"  the next round's temperatures move by up to {moved:.2f} K", flush=True)
            taken_at = temps
            problems = [
                along(p, agent, t) for p, agent, t in zip(fixed, group.agents, temps, strict=True)
            ]


if __name__ == "__main__":
    main()
