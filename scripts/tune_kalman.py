"""Tune the Kalman filter's process noise on a replay of a closed loop against the plant.

Runs the robust MPC (full state, fixed linearisation) on office5 for ``--days`` from
``--start`` against the nonlinear plant, records the true node temperatures, the applied
flows, the forecast disturbances and their box, then replays the filter of
:mod:`hvacflex.control.estimation` on zone-air measurements with uniform noise
±``--noise`` K for every pair of process-noise standard deviations (nodes q_x, offsets
q_s) on a grid, and prints the RMS estimation error (all nodes, and zone air) after a
6-hour burn-in. The best pair (lowest all-node RMS) is frozen by hand in
``hvacflex.control.estimation`` and recorded in ``docs/explanation/estimation.md``.

    python scripts/tune_kalman.py --start 2014-05-05 --days 2
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

from hvacflex import results as schema
from hvacflex.config import preset
from hvacflex.control import estimation as est
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.setup import prepare

GRID_K = (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5)
BURN_IN_STEPS = 12


def record(start: str, days: float) -> dict[str, np.ndarray]:
    """True states (T+1, n), flows (T, m), forecast d̂ (T, nd) and σ (T, nd) of one run."""
    loop = ClosedLoop(prepare(preset("rmpc", start=start, days=days)))
    states = [loop.x.copy()]
    while loop.k < loop.steps:
        loop.step()
        states.append(loop.x.copy())
    frame = loop.frame()
    setup = loop.setup
    zones, channels = setup.zone_names, setup.model.channels
    flows = frame[schema.FLOW.names(zones)].to_numpy()
    d_hat = frame[schema.FORECAST_DISTURBANCE.names(c.name for c in channels)].to_numpy()
    sigma = setup.box.sigma(d_hat, channels)
    return {"x": np.array(states), "u": flows, "d": d_hat, "sigma": sigma}


def replay(
    data: dict[str, np.ndarray], model: est.StepModel, config: est.KalmanConfig, seed: int
) -> tuple[float, float]:
    """RMS estimation error [K] over all nodes and over the zone air nodes."""
    rng = np.random.default_rng(seed)
    a = config.measurement_noise_k
    x_true = data["x"]
    m = model.c.shape[0]

    def measure(x: np.ndarray) -> np.ndarray:
        return model.c @ x + rng.uniform(-a, a, m)

    y = measure(x_true[0])
    state = est.kalman_update(est.initial_state(y, model, config), y, model, config)
    errors = [x_true[0] - state.x_degc]
    for k in range(len(data["u"])):
        y = measure(x_true[k + 1])
        state = est.kalman_step(
            state, model, data["u"][k], data["d"][k], data["sigma"][k], y, config
        )
        errors.append(x_true[k + 1] - state.x_degc)
    late = np.array(errors[BURN_IN_STEPS:])
    return float(np.sqrt(np.mean(late**2))), float(np.sqrt(np.mean((late @ model.c.T) ** 2)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--start", default="2014-05-05")
    parser.add_argument("--days", type=float, default=2.0)
    parser.add_argument("--noise", type=float, default=est.DEFAULT_MEASUREMENT_NOISE_K)
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args()
    setup = prepare(preset("rmpc", start=args.start, days=args.days))
    data = record(args.start, args.days)
    model = setup.model
    print(f"replay {args.start} + {args.days} d, noise ±{args.noise} K, {args.seeds} seeds")
    print(f"{'q_node_k':>9} {'q_offset_k':>10} {'rms_nodes_k':>11} {'rms_zones_k':>11}")
    results = []
    for q_x, q_s in itertools.product(GRID_K, GRID_K):
        cfg = est.KalmanConfig(
            measurement_noise_k=args.noise, process_noise_node_k=q_x, process_noise_offset_k=q_s
        )
        runs = [replay(data, model, cfg, seed) for seed in range(args.seeds)]
        nodes, zones = (float(np.mean(v)) for v in zip(*runs, strict=True))
        results.append((nodes, zones, q_x, q_s))
        print(f"{q_x:9.3f} {q_s:10.3f} {nodes:11.4f} {zones:11.4f}")
    best = min(results)
    print(
        f"best: q_node_k={best[2]} q_offset_k={best[3]} rms_nodes={best[0]:.4f} K "
        f"rms_zones={best[1]:.4f} K"
    )


if __name__ == "__main__":
    main()
