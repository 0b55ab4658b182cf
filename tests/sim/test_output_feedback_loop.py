"""Closed loop with output feedback (Kalman) and trajectory linearisation (issue 15)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.config import load_config, preset, with_overrides
from hvacflex.errors import ConfigError
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.run import run_simulation
from hvacflex.sim.run_files import CHECKPOINT_FILE
from hvacflex.sim.setup import prepare

HOT_START = "2014-05-05"


def _run(**overrides: object) -> ClosedLoop:
    cfg = with_overrides(preset("rmpc", start=HOT_START, days=2.0), dict(overrides))
    loop = ClosedLoop(prepare(cfg))
    while loop.k < loop.steps:
        loop.step()
    return loop


@pytest.fixture(scope="module")
def fixed_and_trajectory() -> tuple[dict[str, float], dict[str, float]]:
    from hvacflex import kpi

    fixed = kpi.summary(_run().frame())
    trajectory = kpi.summary(_run(**{"controller.linearisation": "trajectory"}).frame())
    return fixed, trajectory


def test_trajectory_cuts_the_prediction_error_by_at_least_ten_percent(
    fixed_and_trajectory: tuple[dict[str, float], dict[str, float]],
) -> None:
    fixed, trajectory = fixed_and_trajectory
    assert fixed["prediction_error_rms_k"] > 0.05  # the fixed model's error is real
    assert trajectory["prediction_error_rms_k"] <= 0.9 * fixed["prediction_error_rms_k"]
    assert trajectory["prediction_error_max_k"] < fixed["prediction_error_max_k"]
    assert trajectory["fallback_count"] == 0


def test_kalman_from_toml_runs_and_keeps_comfort(tmp_path: Path) -> None:
    path = tmp_path / "scenario.toml"
    path.write_text(
        'preset = "rmpc"\nstart = "2014-05-05"\ndays = 1\n'
        '[controller]\nlinearisation = "trajectory"\n'
        '[estimation]\nmode = "kalman"\nmeasurement_noise_k = 0.15\n',
        encoding="utf-8",
    )
    cfg = load_config(path)
    assert cfg.estimation.mode == "kalman" and cfg.estimation.measurement_noise_k == 0.15
    loop = ClosedLoop(prepare(cfg))
    estimates = []
    while loop.k < loop.steps:
        x = loop.x.copy()
        loop.step()
        state = loop.controller.get_state()["estimator"]["state"]
        estimates.append(x - state.x_degc)
    frame = loop.frame()
    late = np.array(estimates[12:])
    assert float(np.sqrt(np.mean(late**2))) < 0.15  # all nodes from zone air only
    assert not frame["fallback"].any()
    from hvacflex import kpi

    summary = kpi.summary(frame)
    assert summary["max_violation_k"] <= 1e-6  # the estimation margin covers the filter
    assert np.isfinite(summary["prediction_error_rms_k"])


def test_bad_estimation_settings_are_config_errors(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text('[estimation]\nmode = "magic"\n', encoding="utf-8")
    with pytest.raises(ConfigError):
        load_config(path)
    path.write_text("[estimation]\nmeasurement_noise_k = -0.1\n", encoding="utf-8")
    with pytest.raises(ConfigError):
        load_config(path)


def test_output_feedback_preset_resumes_identically(tmp_path: Path) -> None:
    cfg = preset("rmpc-output-feedback", start=HOT_START, days=0.5)
    whole = run_simulation(cfg, tmp_path / "whole", progress=False).frame
    run_simulation(cfg, tmp_path / "split", progress=False, checkpoint_every=5, stop_after_steps=11)
    assert (tmp_path / "split" / CHECKPOINT_FILE).is_file()
    second = run_simulation(cfg, tmp_path / "split", progress=False, checkpoint_every=5)
    assert second.resumed_from_step == 10  # the last restart point: 11 is replayed
    assert np.isfinite(second.summary["prediction_error_rms_k"])  # summary.json and `kpi`
    assert second.summary["prediction_error_max_k"] >= second.summary["prediction_error_rms_k"]
    pd.testing.assert_frame_equal(
        whole.drop(columns="solve_time_s"), second.frame.drop(columns="solve_time_s")
    )


def test_filter_steps_through_locked_il_events() -> None:
    """Locked event periods do not ask the MPC, but the filter must still measure and
    predict with the curtailed flow the plant ran (else its estimate drifts by a period)."""
    cfg = preset(
        "rmpc-output-feedback",
        start=HOT_START,
        days=1.0,
        **{"activation.mode": "random", "activation.events_per_year": 3000.0},
    )
    loop = ClosedLoop(prepare(cfg))
    errors, locked = [], 0
    while loop.k < loop.steps:
        x = loop.x.copy()
        loop.step()
        state = loop.controller.get_state()
        locked += int(state["held"])
        errors.append(x - state["estimator"]["state"].x_degc)
    frame = loop.frame()
    assert locked > 0  # some periods ran a locked event plan
    # every locked period is activated, and so is each event's first (planned) period
    # (``il_curtailed`` counts only periods with reserve offered since issue 25)
    assert frame["il_activated"].sum() > locked
    late = np.array(errors[12:])
    assert float(np.sqrt(np.mean(late**2))) < 0.2
    assert np.isfinite(frame.filter(like="prediction_error_").to_numpy()).all()
