"""NMPC vs RMPC under forecast errors the controller does not know (issue 26,
docs/explanation/forecast.md).

The plant sees the weather file and stochastic occupancy (seeded); the controller sees the
statistical weather forecast fitted on the 28 days before the run and the schedule's gains.

1. A training run (``nmpc``, seed 1) on the training days gives the one-step prediction
   errors; the calibrated box is sized on the training days at quantile q.
2. On the test days, for each seed: ``nmpc``, ``rmpc`` (the default ±5 % / ±0.5 K box) and
   ``rmpc`` with the calibrated box, under the realistic errors; then the stress case — an
   extra correlated (AR(1)) error outside the box, ±30 % of solar and internal gains and
   ±1.5 K outdoor — for ``nmpc`` and both ``rmpc``.
3. The calibrated box's coverage, per channel over every lead of the horizon (seed of the
   first run): in sample (training days), out of sample (test days), and the default box's
   out of sample; the model-error term's on the calibrated RMPC's test runs (all seeds).

Markdown tables go to stdout (copied into ``docs/explanation/forecast.md``)::

    python scripts/forecast_study.py --out results/forecast_study
"""

from __future__ import annotations

import argparse
import statistics
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hvacflex.config import ScenarioConfig, preset
from hvacflex.data.calibration import coverage, forecast_errors, model_error_coverage
from hvacflex.data.uncertainty import DEFAULT_UNCERTAINTY
from hvacflex.results import PREDICTION_ERROR
from hvacflex.sim.run import run_simulation
from hvacflex.sim.setup import prepare

REALISTIC: dict[str, Any] = {
    "forecast": {"weather": "statistical"},
    "realisation": {"occupancy": "stochastic", "mode": "zero"},
}
STRESS_REALISATION: dict[str, Any] = {
    "occupancy": "stochastic",
    "mode": "ar1",
    "box_relative": {"solar": 0.3, "internal_gain": 0.3},
    "box_absolute": {"outdoor_temp": 1.5},
}
KPIS = ("net_cost_sgd", "discomfort_kelvin_hours", "violation_share", "max_violation_k")


def _train_config(args: argparse.Namespace) -> ScenarioConfig:
    return preset("nmpc", start=args.train_start, days=args.train_days, seed=1, **REALISTIC)


def _scenarios(
    args: argparse.Namespace, seed: int, train_results: Path
) -> dict[str, ScenarioConfig]:
    last = pd.Timestamp(args.train_start) + pd.Timedelta(days=args.train_days - 1)
    calibrate = {
        "train": f"{args.train_start}..{last:%Y-%m-%d}",
        "quantile": args.quantile,
        "prediction_errors": str(train_results),
    }
    common = {"start": args.start, "days": args.days, "seed": seed}
    out: dict[str, ScenarioConfig] = {}
    for case, realisation in (
        ("realistic", REALISTIC["realisation"]),
        ("stress", STRESS_REALISATION),
    ):
        forecast = REALISTIC["forecast"]
        out[f"{case}/nmpc"] = preset("nmpc", **common, forecast=forecast, realisation=realisation)
        out[f"{case}/rmpc-default-box"] = preset(
            "rmpc", **common, forecast=forecast, realisation=realisation
        )
        out[f"{case}/rmpc-calibrated"] = preset(
            "rmpc",
            **common,
            forecast=forecast,
            realisation=realisation,
            uncertainty={"calibrate": calibrate},
        )
    return out


def _lead_errors(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """Errors and forecasts (S, nd) of every forecast of a scenario's run, every lead."""
    setup = prepare(config)
    horizon = config.controller.horizon_steps
    return forecast_errors(
        setup.forecaster, setup.exogenous.disturbances, range(config.steps), horizon
    )


def _coverage_rows(
    config: ScenarioConfig, frames: list[pd.DataFrame], args: argparse.Namespace
) -> list[str]:
    """Markdown rows: the calibrated box's coverage in sample (training days) and out of
    sample (test days), and the default box's out of sample."""
    setup = prepare(config)
    assert setup.calibration is not None
    channels = setup.model.channels
    test = _lead_errors(config)
    out_of_sample = coverage(*test, setup.box, channels)
    default_box = coverage(*test, DEFAULT_UNCERTAINTY, channels)
    training = replace(
        config, start=args.train_start, days=float(args.train_days),
        uncertainty=replace(config.uncertainty, calibrate=None),
    )  # fmt: skip
    in_sample = coverage(*_lead_errors(training), setup.box, channels)
    rows = []
    for i, ch in enumerate(channels):
        relative = setup.box.channel_relative.get(ch.name)
        absolute = setup.box.channel_absolute.get(ch.name, 0.0)
        size = f"±{absolute:.3g}"
        if relative is not None:
            size = f"±({100 * relative:.0f} % · d̂ + {absolute:.3g})"
        rows.append(
            f"| {ch.name} | {size} | {100 * in_sample[i]:.1f} % | {100 * out_of_sample[i]:.1f} % "
            f"| {100 * default_box[i]:.1f} % |"
        )
    zones = setup.zone_names
    errors = {
        z: np.concatenate([f[PREDICTION_ERROR.name(z)].to_numpy() for f in frames]) for z in zones
    }
    covered = model_error_coverage(errors, setup.calibration.model_error_k)
    for z in zones:
        rows.append(
            f"| model error {z} [K/step] | ±{setup.calibration.model_error_k[z]:.3f} | | "
            f"{100 * covered[z]:.1f} % | |"
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("results/forecast_study"))
    parser.add_argument("--start", default="2014-03-03")
    parser.add_argument("--days", type=float, default=3.0)
    parser.add_argument("--train-start", default="2014-02-24")
    parser.add_argument("--train-days", type=int, default=5)
    parser.add_argument("--quantile", type=float, default=0.95)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    args = parser.parse_args()

    train = run_simulation(_train_config(args), args.out / "train-nmpc", progress=False)
    train_results = train.results_path
    table: dict[str, list[dict[str, float]]] = {}
    frames: dict[str, list[pd.DataFrame]] = {}
    for seed in args.seeds:
        for name, config in _scenarios(args, seed, train_results).items():
            run = run_simulation(config, args.out / name / f"seed{seed}", progress=False)
            table.setdefault(name, []).append(run.summary)
            frames.setdefault(name, []).append(run.frame)
            print(f"done {name} seed {seed}", flush=True)

    seeds = ", ".join(str(s) for s in args.seeds)
    print(f"\n### NMPC vs RMPC, {args.start} + {args.days:g} days, mean over seeds {seeds}\n")
    print(
        "| case | controller | net cost [SGD] | discomfort [K·h] | violated steps "
        "| max violation [K] |"
    )
    print("|---|---|---|---|---|---|")
    for name, summaries in table.items():
        case, controller = name.split("/")
        means = [statistics.fmean(s[k] for s in summaries) for k in KPIS]
        spread = statistics.pstdev(s["discomfort_kelvin_hours"] for s in summaries)
        print(
            f"| {case} | {controller} | {means[0]:.2f} | {means[1]:.2f} ± {spread:.2f} | "
            f"{100 * means[2]:.1f} % | {means[3]:.2f} |"
        )
    first = _scenarios(args, args.seeds[0], train_results)["realistic/rmpc-calibrated"]
    print(
        f"\n### Calibrated box (q = {args.quantile}), coverage on the test days, "
        f"seed {args.seeds[0]}\n"
    )
    print("| channel | half-width | in sample | out of sample | default box, out of sample |")
    print("|---|---|---|---|---|")
    for row in _coverage_rows(first, frames["realistic/rmpc-calibrated"], args):
        print(row)


if __name__ == "__main__":
    main()
