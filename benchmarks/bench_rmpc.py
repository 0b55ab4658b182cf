"""Benchmark the RMPC LP: warm-started solver vs cold solve vs a CVXPY rebuild (issue 5).

Run::

    python benchmarks/bench_rmpc.py                       # synthetic 5-zone office (n=25)
    python benchmarks/bench_rmpc.py --building buildings/office5.toml

It prints one table of per-step times over consecutive, time-shifted receding-horizon
problems (N = 48, Δt = 30 min):

1. ``RMPCSolver.solve`` warm-started from the previous optimal basis rotated by one step
   (``--steps`` consecutive receding-horizon steps, default 200: x0, d̂, σ, prices, bands and
   the power coefficients p_k all move by one step each time, as in the closed loop);
   (1b) the same steps warm-started from the previous basis as is (``time_shift=False``);
2. a cold solve (``solve_rmpc``: build the LP, pass it to HiGHS, solve from scratch);
3. the same LP written in CVXPY (vectorised) and rebuilt every step, HiGHS backend;
4. the bare HiGHS ``run()`` inside (1), so ``(1) − (4)`` is our per-step overhead (updates of
   costs/bounds/coefficients and extraction of the solution).

Targets (issue 5): (3)/(1) ≥ 12 and (1) − (4) ≤ 1 ms. This is a script, not a timed test.

The synthetic building has the default building's size: 5 zones + 20 wall nodes (n = 25),
m = 5 zone flows, nd = 11 disturbances (outdoor temperature, 5 solar planes, 5 zone gains),
ny = 5 zone temperatures, from a random stable Metzler RC network with realistic
capacitances (zone 8–15 MJ/K, walls 20–80 MJ/K) and conductances (50–1500 W/K), linearised as
DESIGN §1 (VAV term about ṁ_min and T₀ = 23 °C) and discretised by ZOH.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import statistics
import time
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from hvacflex.opt import RMPCProblem, RMPCSolver, solve_rmpc
from hvacflex.opt.reference import solve_reference
from hvacflex.opt.testing import zoh_discretise

FloatArray = NDArray[np.float64]

CP_AIR_J_PER_KG_K = 1006.0
DT_S = 1800.0
HORIZON = 48
SUPPLY_TEMP_DEGC = 13.0
LINEARISATION_TEMP_DEGC = 23.0
OUTDOOR_AIR_FRACTION = 0.2
COP = 4.5
ZONE_AREA_M2 = 250.0
CVXPY_REL_TOL = 1e-6  # the warm optimum must equal the CVXPY reference's to this (relative)


@dataclasses.dataclass
class Model:
    """Discrete affine model and HVAC data for the benchmark."""

    a: FloatArray
    b: FloatArray
    e: FloatArray
    g: FloatArray
    c: FloatArray
    kinds: list[str]  # per disturbance channel: outdoor_temp, solar, internal_gain, ...
    flow_min_kg_s: FloatArray
    flow_max_kg_s: FloatArray
    power: Callable[[FloatArray], tuple[FloatArray, FloatArray]]  # T_out (N,) -> p0, p


def synthetic_office(seed: int = 0) -> Model:
    """Random stable 5-zone RC network of the default building's size (see module doc)."""
    rng = np.random.default_rng(seed)
    zones, walls_per_zone = 5, 4
    n = zones * (1 + walls_per_zone)
    nd = 1 + 5 + zones
    cap = np.empty(n)
    cap[:zones] = rng.uniform(8e6, 1.5e7, zones)  # zone air + furniture [J/K]
    cap[zones:] = rng.uniform(2e7, 8e7, n - zones)  # wall layers [J/K]
    conductance = np.zeros((n, n))  # [W/K]
    outdoor = np.zeros(n)  # [W/K] to outdoor air
    e_cont = np.zeros((n, nd))  # heat input per disturbance unit [W per unit]
    for z in range(zones):
        outer, inner, partition, slab = (zones + walls_per_zone * z + i for i in range(4))
        perimeter = z < 4
        conductance[z, inner] = rng.uniform(300, 1500)
        conductance[inner, outer] = rng.uniform(200, 800)
        conductance[z, partition] = rng.uniform(300, 1500)
        conductance[z, slab] = rng.uniform(500, 1500)
        conductance[slab, (z + 1) % zones] = rng.uniform(50, 200)
        outdoor[outer] = rng.uniform(100, 300) if perimeter else rng.uniform(20, 60)
        outdoor[z] = rng.uniform(50, 200) if perimeter else 20.0  # windows + infiltration
        plane = 1 + (z if perimeter else 4)  # N, E, S, W walls; core gets the roof plane
        e_cont[outer, plane] = rng.uniform(0.4, 0.7) * rng.uniform(40, 80)  # α A_wall
        if perimeter:
            e_cont[z, plane] = rng.uniform(0.25, 0.45) * rng.uniform(20, 45)  # SHGC A_win
        e_cont[z, 6 + z] = 1.0  # internal gain [W]
    conductance = np.maximum(conductance, conductance.T)
    for z in range(4):  # partitions shared with the core
        partition = zones + walls_per_zone * z + 2
        conductance[partition, 4] = conductance[4, partition] = rng.uniform(200, 800)
    e_cont[:, 0] = outdoor
    flow_min = np.full(zones, 0.3)
    flow_max = np.full(zones, 3.0)
    a_cont = conductance - np.diag(conductance.sum(axis=1) + outdoor)
    a_cont[np.arange(zones), np.arange(zones)] -= flow_min * CP_AIR_J_PER_KG_K
    b_cont = np.zeros((n, zones))
    b_cont[np.arange(zones), np.arange(zones)] = CP_AIR_J_PER_KG_K * (
        SUPPLY_TEMP_DEGC - LINEARISATION_TEMP_DEGC
    )
    g_cont = np.zeros(n)
    g_cont[:zones] = flow_min * CP_AIR_J_PER_KG_K * LINEARISATION_TEMP_DEGC
    a_cont /= cap[:, None]
    b_cont /= cap[:, None]
    e_cont /= cap[:, None]
    g_cont /= cap
    m = zones
    a, b, e, g = zoh_discretise(a_cont, b_cont, e_cont, g_cont, DT_S)
    c = np.zeros((zones, n))
    c[np.arange(zones), np.arange(zones)] = 1.0

    def power(t_out: FloatArray) -> tuple[FloatArray, FloatArray]:
        sensible = CP_AIR_J_PER_KG_K * (
            (1 - OUTDOOR_AIR_FRACTION) * LINEARISATION_TEMP_DEGC
            + OUTDOOR_AIR_FRACTION * t_out
            - SUPPLY_TEMP_DEGC
        )
        latent_w_per_kg_s = OUTDOOR_AIR_FRACTION * 2.45e6 * 0.008  # humid outdoor air
        p = np.repeat(((sensible + latent_w_per_kg_s) / COP / 1000 + 0.35)[:, None], m, axis=1)
        return np.full(t_out.shape, 0.5), p

    return Model(
        a=a,
        b=b,
        e=e,
        g=g,
        c=c,
        kinds=["outdoor_temp"] + ["solar"] * 5 + ["internal_gain"] * zones,
        flow_min_kg_s=flow_min,
        flow_max_kg_s=flow_max,
        power=power,
    )


def building_model(path: str) -> Model:
    """The linear model of a building description (needs ``hvacflex.building``)."""
    from hvacflex.building.discretize import linearize
    from hvacflex.building.hvac import affine_power_model
    from hvacflex.building.io import load_building

    building = load_building(path)
    lm = linearize(building, dt_s=DT_S, linearisation_temp_degc=LINEARISATION_TEMP_DEGC)
    hvac = building.hvac

    def power(t_out: FloatArray) -> tuple[FloatArray, FloatArray]:
        p0, p = affine_power_model(hvac, t_out, np.full(t_out.shape, 0.018), 23.0)
        return np.asarray(p0), np.asarray(p)

    return Model(
        a=np.asarray(lm.a),
        b=np.asarray(lm.b),
        e=np.asarray(lm.e),
        g=np.asarray(lm.g),
        c=np.asarray(lm.c),
        kinds=[channel.kind for channel in lm.channels],
        flow_min_kg_s=np.asarray(hvac.flow_min_kg_s, dtype=float),
        flow_max_kg_s=np.asarray(hvac.flow_max_kg_s, dtype=float),
        power=power,
    )


def exogenous_series(model: Model, steps: int, seed: int) -> dict[str, FloatArray]:
    """Synthetic half-hourly forecasts: weather, gains, prices, comfort bands."""
    rng = np.random.default_rng(seed)
    hour = (np.arange(steps) * DT_S / 3600.0) % 24.0
    day = np.arange(steps) * DT_S // 86400
    office = (hour >= 8) & (hour < 18) & (day % 7 < 5)
    daylight = np.clip(np.sin((hour - 7.0) / 12.0 * np.pi), 0.0, None)
    nd = model.e.shape[1]
    d = np.zeros((steps, nd))
    sigma = np.zeros((steps, nd))
    solar_peak = iter(rng.uniform(150, 450, nd))
    zones = model.c.shape[0]
    for channel, kind in enumerate(model.kinds):
        if kind in ("outdoor_temp", "ground_temp"):
            d[:, channel] = 27.5 + 3.5 * np.sin((hour - 9.0) / 24.0 * 2 * np.pi)
            sigma[:, channel] = 1.0
        elif kind == "solar":
            d[:, channel] = next(solar_peak) * daylight
            sigma[:, channel] = 0.2 * d[:, channel]
        else:  # internal gain [W]
            gain = ZONE_AREA_M2 * (30.0 * office + 3.0)
            d[:, channel] = gain
            sigma[:, channel] = 0.2 * gain
    usep = 110 + 30 * np.sin((hour - 8) / 24 * 2 * np.pi) + rng.gamma(2.0, 5.0, steps)
    usep[rng.random(steps) < 0.03] *= 4.0  # spikes
    reserve = np.clip(2.5 + 0.02 * (usep - 120) + rng.normal(0, 0.3, steps), 0.0, None)
    y_min = np.where(office, 23.0, 20.0)[:, None] * np.ones(zones)
    y_max = np.where(office, 26.0, 30.0)[:, None] * np.ones(zones)
    return dict(d=d, sigma=sigma, usep=usep, reserve=reserve, y_min=y_min, y_max=y_max)


def problem_at(
    model: Model, series: dict[str, FloatArray], step: int, x0: FloatArray
) -> RMPCProblem:
    window = slice(step, step + HORIZON)
    d = series["d"][window]
    p0, p = model.power(d[:, 0])
    return RMPCProblem(
        a_matrix=model.a,
        b_matrix=model.b,
        e_matrix=model.e,
        c_matrix=model.c,
        affine_term=model.g,
        x0=x0,
        d_forecast=d,
        d_sigma=series["sigma"][window],
        energy_price_sgd_per_mwh=series["usep"][window],
        reserve_price_sgd_per_mwh=series["reserve"][window],
        peak_price_sgd_per_kw=1.5,
        power_offset_kw=p0,
        power_coeff_kw_per_kg_s=p,
        u_min=model.flow_min_kg_s,
        u_max=model.flow_max_kg_s,
        y_min=series["y_min"][window],
        y_max=series["y_max"][window],
        reserve_mask=np.ones(model.b.shape[1], dtype=bool),
        comfort_penalty_sgd_per_kelvin_hour=100.0,
        dt_h=DT_S / 3600.0,
    )


def cvxpy_solve(prob: RMPCProblem) -> tuple[float, float]:
    """The same LP in CVXPY (:func:`hvacflex.opt.reference.solve_reference`, vectorised,
    written from the definition), built and solved with HiGHS: (time [s], objective [SGD],
    tie-break included)."""
    tick = time.perf_counter()
    reference = solve_reference(prob)
    if reference.status != "optimal":
        raise RuntimeError(f"CVXPY: {reference.status}")
    return time.perf_counter() - tick, reference.objective_sgd


def machine() -> str:
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as handle:
            for line in handle:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    import highspy

    version = str(highspy.Highs().version())
    return (
        f"{cpu}, nproc={os.cpu_count()}, Python {platform.python_version()}, "
        f"highspy/HiGHS {version}, numpy {np.__version__}"
    )


def stats_ms(values: list[float]) -> str:
    ms = sorted(v * 1000 for v in values)
    p95 = ms[min(len(ms) - 1, int(0.95 * len(ms)))]
    return f"{statistics.median(ms):9.2f} {statistics.fmean(ms):9.2f} {p95:9.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--building", help="building TOML (uses hvacflex.building)")
    parser.add_argument("--steps", type=int, default=200, help="warm-started steps")
    parser.add_argument("--cold-steps", type=int, default=30, help="steps solved cold")
    parser.add_argument("--cvxpy-steps", type=int, default=10, help="steps rebuilt in CVXPY")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--no-unshifted",
        dest="unshifted",
        action="store_false",
        help="skip (1b), the warm start from the unrotated basis",
    )
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.cold_steps, args.cvxpy_steps = 4, 2, 2

    model = building_model(args.building) if args.building else synthetic_office(args.seed)
    series = exogenous_series(model, args.steps + HORIZON, args.seed)
    rng = np.random.default_rng(args.seed + 1)
    x0 = np.full(model.a.shape[0], 24.0)
    problems: list[RMPCProblem] = []
    build_times: list[float] = []
    solver: RMPCSolver | None = None
    unshifted: RMPCSolver | None = None
    warm, bare, overhead, iterations, statuses, slack_steps = [], [], [], [], [], 0
    warm_unshifted, iterations_unshifted = [], []
    solutions = []
    for step in range(args.steps):
        tick = time.perf_counter()
        prob = problem_at(model, series, step, x0)
        build_times.append(time.perf_counter() - tick)
        if solver is None:
            solver = RMPCSolver(prob)
            unshifted = RMPCSolver(prob, time_shift=False) if args.unshifted else None
        sol = solver.solve(prob)
        if unshifted is not None:
            other = unshifted.solve(prob)
            if step > 0:
                warm_unshifted.append(other.solve_time_s)
                iterations_unshifted.append(other.simplex_iterations)
        problems.append(prob)
        solutions.append(sol)
        statuses.append(sol.status.value)
        if step > 0:  # the first solve is cold
            warm.append(sol.solve_time_s)
            bare.append(sol.highs_time_s)
            overhead.append(sol.solve_time_s - sol.highs_time_s)
            iterations.append(sol.simplex_iterations)
        slack_steps += int(sol.slack[0].max() > 1e-6) if sol.ok else 0
        u0 = sol.u[0] if sol.ok else model.flow_max_kg_s
        w0 = rng.uniform(-1, 1, prob.nd) * prob.d_sigma[0]
        x0 = model.a @ x0 + model.b @ u0 + model.e @ (prob.d_forecast[0] + w0) + model.g

    picks = np.linspace(0, args.steps - 1, args.cold_steps).astype(int)
    cold, cold_bare, cold_iter = [], [], []
    for index in picks:
        tick = time.perf_counter()
        sol = solve_rmpc(problems[index])
        cold.append(time.perf_counter() - tick)
        cold_bare.append(sol.highs_time_s)
        cold_iter.append(sol.simplex_iterations)
        assert abs(sol.objective_sgd - solutions[index].objective_sgd) < 1e-6 * max(
            1.0, abs(sol.objective_sgd)
        )
    cvx, cvx_gap = [], []
    for index in np.linspace(0, args.steps - 1, args.cvxpy_steps).astype(int):
        elapsed, value = cvxpy_solve(problems[index])
        cvx.append(elapsed)
        ours = solutions[index]
        mine = ours.objective_sgd + ours.tie_break_sgd
        cvx_gap.append(abs(value - mine) / max(1.0, abs(mine)))

    assert solver is not None
    prob = problems[0]
    print(f"machine: {machine()}")
    print(
        f"problem: n={prob.n} m={prob.m} nd={prob.nd} ny={prob.ny} N={prob.horizon}; "
        f"LP {solver.num_cols} columns, {solver.num_rows} rows, {solver.num_nonzeros} nonzeros"
    )
    print(
        f"steps: {args.steps} ({statuses.count('optimal')} optimal), first-step slack > 0 in "
        f"{slack_steps}; max δ {max(s.delta.max() for s in solutions):.2f} K; "
        f"CVXPY max relative |Δobjective| {max(cvx_gap):.2e}"
    )
    print()
    print(f"{'per step [ms]':52s} {'median':>9s} {'mean':>9s} {'p95':>9s}")
    print(f"{'(1) RMPCSolver.solve, warm start (rotated basis)':52s} {stats_ms(warm)}")
    if warm_unshifted:
        print(f"{'(1b) warm start from the unrotated basis':52s} {stats_ms(warm_unshifted)}")
    print(f"{'(2) solve_rmpc, cold (build LP + solve)':52s} {stats_ms(cold)}")
    print(f"{'(3) CVXPY rebuild + HiGHS':52s} {stats_ms(cvx)}")
    print(f"{'(4) bare HiGHS run() inside (1)':52s} {stats_ms(bare)}")
    print(f"{'    bare HiGHS run() inside (2)':52s} {stats_ms(cold_bare)}")
    print(f"{'overhead (1) − (4)':52s} {stats_ms(overhead)}")
    print(f"{'RMPCProblem construction + validation':52s} {stats_ms(build_times)}")
    print(
        f"simplex iterations: warm median {statistics.median(iterations):.0f} "
        f"(mean {statistics.fmean(iterations):.0f}), cold median "
        f"{statistics.median(cold_iter):.0f}"
        + (
            f", unrotated warm median {statistics.median(iterations_unshifted):.0f} "
            f"(mean {statistics.fmean(iterations_unshifted):.0f})"
            if iterations_unshifted
            else ""
        )
    )
    speedup_cvx = statistics.median(cvx) / statistics.median(warm)
    speedup_cold = statistics.median(cold) / statistics.median(warm)
    over = statistics.median(overhead) * 1000
    print(
        f"ratios (medians): CVXPY/warm = {speedup_cvx:.1f}x (target ≥ 12), "
        f"cold/warm = {speedup_cold:.1f}x, overhead = {over:.2f} ms (target ≤ 1)"
    )
    if max(cvx_gap) > CVXPY_REL_TOL:
        raise RuntimeError(f"CVXPY and hvacflex disagree on the optimum ({max(cvx_gap):.1e})")
    if statuses.count("optimal") != len(statuses):
        raise RuntimeError(f"{len(statuses) - statuses.count('optimal')} warm solves not optimal")
    print(
        f"checks passed: every warm solve optimal, cold = warm on {len(cold)} steps, "
        f"CVXPY = warm on {len(cvx)} steps"
    )


if __name__ == "__main__":
    main()
