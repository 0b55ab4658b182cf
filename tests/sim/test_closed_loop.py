"""Closed-loop simulation: wiring, robustness against NMPC, checkpoints, determinism."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from hvacflex import kpi
from hvacflex.building.hvac import affine_power_model
from hvacflex.config import preset, scaled_uncertainty, with_overrides
from hvacflex.paths import buildings_dir
from hvacflex.sim.closed_loop import (
    ClosedLoop,
    band_at_period_end_degc,
    setpoint_actuation_degc,
)
from hvacflex.sim.plant import Actuation, Disturbance, Observation
from hvacflex.sim.run import RunInterrupted, run_simulation
from hvacflex.sim.run_files import CHECKPOINT_FILE, read_results
from hvacflex.sim.setup import prepare

START = "2014-03-03"  # a Monday


class LinearPlant:
    """The controller's own model as the plant (perfect model), with its affine power: a test
    double of :class:`hvacflex.sim.plant.Plant`."""

    can_snapshot = True
    actuations = ("flow",)

    def __init__(self, model: object, power_kw: Callable[[int, np.ndarray], float]) -> None:
        self.m = model
        self.power_kw = power_kw
        self.zone_names = tuple(model.zone_names)  # type: ignore[attr-defined]
        self.zone_rows = model.c.argmax(axis=1)  # type: ignore[attr-defined]
        self.x = np.zeros(0)
        self.k = 0

    def reset(self, initial_temp_degc: float) -> Observation:
        self.x = np.full(self.m.a.shape[0], initial_temp_degc)  # type: ignore[attr-defined]
        self.k = 0
        return self._observe(self.x, np.zeros(len(self.zone_names)), float("nan"))

    def step(self, actuation: Actuation, disturbance: Disturbance, dt_s: float) -> Observation:
        m, flow = self.m, np.asarray(actuation.flow_kg_s)
        x = m.a @ self.x + m.b @ flow + m.e @ disturbance.d + m.g  # type: ignore[attr-defined]
        observation = self._observe(x, flow, self.power_kw(self.k, flow))
        self.x, self.k = x, self.k + 1
        return observation

    def _observe(self, x: np.ndarray, flow: np.ndarray, power_kw: float) -> Observation:
        zones = x[self.zone_rows]
        return Observation(zones, zones, x.copy(), flow, power_kw, float("nan"), float("nan"))

    def get_state(self) -> dict[str, Any]:
        return {"x": self.x.copy(), "k": self.k}

    def set_state(self, state: dict[str, Any]) -> None:
        self.x, self.k = state["x"].copy(), state["k"]


def test_perfect_model_closed_loop_cost_is_the_sum_of_first_step_costs() -> None:
    cfg = with_overrides(
        preset("nmpc", start=START, days=1.0),
        # the plant below is the LP's own design-curve power model (not office5's fitted one)
        {"realisation.mode": "zero", "activation.mode": "never", "power_model": "design"},
    )
    setup = prepare(cfg)
    model = setup.model
    t_ref = setup.linearisation_temp_degc
    outdoor = next(i for i, ch in enumerate(model.channels) if ch.kind == "outdoor_temp")
    exo = setup.exogenous
    damper = setup.building.hvac.outdoor_air_open_at(exo.occupied)

    def affine_power(k: int, flow: np.ndarray) -> float:
        p0, p = affine_power_model(
            setup.building.hvac,
            exo.disturbances[k : k + 1, outdoor],
            exo.outdoor_humidity_ratio_kg_per_kg[k : k + 1],
            t_ref,
            latent_gain_w=exo.occupant_latent_w[k : k + 1],
            flow_min_kg_s=setup.building.hvac.flow_min_at(exo.occupied[k : k + 1]),
            damper_open=damper[k : k + 1],  # the plant's damper schedule, as the LP's
        )
        return float(p0[0] + p[0] @ flow)

    loop = ClosedLoop(setup, plant=LinearPlant(model, affine_power))
    while loop.k < loop.steps:
        loop.step()
    frame = loop.frame()
    first_step_cost = float(
        (frame["planned_power_kw"] * frame["energy_price_sgd_per_mwh"]).sum() * 0.5 / 1000
    )
    assert not frame["fallback"].any()
    assert kpi.energy_cost_sgd(frame) == pytest.approx(first_step_cost, rel=1e-9)
    # the plan's first step is what the (perfect) plant does: comfort holds
    assert kpi.total_discomfort_kelvin_hours(frame) < 1e-6
    served = frame.filter(like="temp_served_").to_numpy()
    realised = frame[[c.replace("served", "end") for c in frame.filter(like="temp_served_")]]
    assert np.allclose(served, realised.to_numpy(), atol=1e-8)


@pytest.fixture(scope="module")
def uniform_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, pd.DataFrame]:
    """NMPC and RMPC for three days under errors drawn uniformly in a ±10 % box."""
    out = tmp_path_factory.mktemp("uniform")
    frames = {}
    for name in ("nmpc", "rmpc"):
        cfg = scaled_uncertainty(preset(name, start=START, days=3.0), 0.1)
        frames[name] = run_simulation(cfg, out / name, progress=False).frame
    return frames


def test_rmpc_keeps_comfort_under_uniform_errors_and_costs_more(
    uniform_runs: dict[str, pd.DataFrame],
) -> None:
    nmpc, rmpc = uniform_runs["nmpc"], uniform_runs["rmpc"]
    assert kpi.total_discomfort_kelvin_hours(nmpc) > 0.0
    assert kpi.total_discomfort_kelvin_hours(rmpc) < 0.01
    assert kpi.energy_cost_sgd(rmpc) > kpi.energy_cost_sgd(nmpc)


def test_rmpc_keeps_comfort_where_nmpc_does_not_at_the_hot_corner(tmp_path: Path) -> None:
    """Every forecast error at its hottest corner: NMPC runs over the band, RMPC does not."""
    discomfort = {}
    for name in ("nmpc", "rmpc"):
        cfg = scaled_uncertainty(
            with_overrides(
                preset(name, start=START, days=2.0), {"realisation.mode": "worst-upper"}
            ),
            0.1,
        )
        frame = run_simulation(cfg, tmp_path / name, progress=False).frame
        discomfort[name] = kpi.total_discomfort_kelvin_hours(frame)
    assert discomfort["nmpc"] > 1.0
    assert discomfort["rmpc"] < 0.01 * discomfort["nmpc"]


def test_same_realised_disturbances_for_every_controller(
    uniform_runs: dict[str, pd.DataFrame],
) -> None:
    w_cols = [c for c in uniform_runs["nmpc"].columns if c.startswith("w_")]
    assert w_cols
    np.testing.assert_array_equal(
        uniform_runs["nmpc"][w_cols].to_numpy(), uniform_runs["rmpc"][w_cols].to_numpy()
    )


def test_rmpc_keeps_comfort_when_reserve_is_always_activated(tmp_path: Path) -> None:
    # the paper's whole-horizon model holds for any activation pattern, even "always";
    # a reserve price near the energy price, so that reserve is worth offering
    cfg = with_overrides(
        preset("paper-rmpc", start=START, days=2.0),
        {"activation.mode": "always", "data.reserve_price_scale": 150.0},
    )
    frame = run_simulation(cfg, tmp_path, progress=False).frame
    assert frame["il_activated"].all()
    assert frame["reserve_kw"].sum() > 0
    assert kpi.total_discomfort_kelvin_hours(frame) < 0.5


def test_resume_from_checkpoint_gives_identical_results(tmp_path: Path) -> None:
    cfg = with_overrides(
        preset("rmpc-ppp", start=START, days=2.0),
        {"activation.mode": "stress"},  # one IL event every weekday
    )
    # the uninterrupted run restarts its solver warm at the same checkpoints (every 24
    # steps) as the interrupted one, which stops on one of them: equal bit for bit
    whole = run_simulation(cfg, tmp_path / "whole", progress=False, checkpoint_every=24).frame
    first = run_simulation(
        cfg, tmp_path / "split", progress=False, checkpoint_every=24, stop_after_steps=48
    )
    assert (tmp_path / "split" / CHECKPOINT_FILE).is_file()
    assert len(first.frame) == 48
    second = run_simulation(cfg, tmp_path / "split", progress=False, checkpoint_every=24)
    assert second.resumed_from_step == 48
    # the speed is over the steps this call simulated, like the per-part times
    ms_per_step = sum(v for k, v in second.summary.items() if k.startswith("time_"))
    assert second.summary["steps_per_s"] == pytest.approx(1e3 / ms_per_step)
    pd.testing.assert_frame_equal(
        whole.drop(columns="solve_time_s"),
        second.frame.drop(columns="solve_time_s"),
        check_exact=True,
    )
    assert not (tmp_path / "split" / CHECKPOINT_FILE).exists()


def _one_blas_thread() -> dict[str, str]:
    """The killed run's environment: this one with one BLAS thread, as in a Dask worker,
    while this process resumes it with as many as it has (the model must not round
    differently)."""
    return {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def _wait_for_checkpoint(out: Path, poll_s: float, timeout_s: float = 120.0) -> None:
    """Until the run writing to ``out`` has written its first checkpoint, or ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not (out / CHECKPOINT_FILE).exists() and time.monotonic() < deadline:
        time.sleep(poll_s)


def test_killed_run_resumes_from_its_last_checkpoint(tmp_path: Path) -> None:
    out = tmp_path / "killed"
    args = [
        sys.executable, "-m", "hvacflex.cli", "simulate", "--scenario", "rmpc",
        "--start", START, "--days", "2", "--out", str(out), "--quiet",
        "--checkpoint-every", "10",
    ]  # fmt: skip
    proc = subprocess.Popen(
        args, env=_one_blas_thread(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    _wait_for_checkpoint(out, poll_s=0.1)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert (out / CHECKPOINT_FILE).exists(), "no checkpoint was written before the kill"
    cfg = preset("rmpc", start=START, days=2.0)
    resumed = run_simulation(cfg, out, progress=False, checkpoint_every=10)
    assert resumed.resumed_from_step is not None and resumed.resumed_from_step > 0
    # the uninterrupted run restarts its solver from the basis at the same checkpoints (a
    # HiGHS handle restarted from a basis and one that kept its factorisation can end on
    # plans 1e-8 kW apart): equal bit for bit
    whole = run_simulation(cfg, tmp_path / "w", progress=False, checkpoint_every=10)
    pd.testing.assert_frame_equal(
        whole.frame.drop(columns="solve_time_s"),
        resumed.frame.drop(columns="solve_time_s"),
        check_exact=True,
    )


def _kill_and_resume(tmp_path: Path, rng: np.random.Generator, every: int) -> int:
    """Start ``simulate`` (rmpc, one day, a checkpoint every ``every`` steps), kill it with
    SIGKILL a random time after its first checkpoint, resume; the step it resumed from."""
    out = tmp_path / f"killed-{rng.integers(1 << 30)}"
    args = [
        sys.executable, "-m", "hvacflex.cli", "simulate", "--scenario", "rmpc",
        "--start", START, "--days", "1", "--out", str(out), "--quiet",
        "--checkpoint-every", str(every),
    ]  # fmt: skip
    proc = subprocess.Popen(
        args, env=_one_blas_thread(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    _wait_for_checkpoint(out, poll_s=0.05)
    time.sleep(float(rng.uniform(0.0, 0.4)))  # the day runs ≈ 50 steps/s on an idle core
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    cfg = preset("rmpc", start=START, days=1.0)
    if not (out / CHECKPOINT_FILE).exists():  # it finished before the kill
        return -1
    resumed = run_simulation(cfg, out, progress=False, checkpoint_every=every)
    whole = run_simulation(cfg, tmp_path / "whole", progress=False, checkpoint_every=every)
    columns = [c for c in whole.frame.columns if c != "solve_time_s"]
    pd.testing.assert_frame_equal(
        resumed.frame[columns], whole.frame[columns], check_exact=True, check_freq=False
    )
    assert resumed.resumed_from_step is not None
    return resumed.resumed_from_step


def test_kills_at_random_steps_resume_bit_identical(tmp_path: Path) -> None:
    """A killed run resumes from its last periodic checkpoint; the uninterrupted run
    restarts its solver warm at the same steps, so the results are equal bit for bit."""
    rng = np.random.default_rng(11)
    steps = [_kill_and_resume(tmp_path, rng, every=4) for _ in range(2)]
    assert any(k > 0 for k in steps)


class _Killed(BaseException):
    """Stands in for SIGKILL in-process: no handler runs, the disk keeps what it had."""


def _stop_at(period: int, error: BaseException) -> Callable[[int, int], None]:
    def on_step(done: int, total: int) -> None:
        if done == period:
            raise error

    return on_step


def _sigint_as_at_a_terminal() -> None:
    """In the child, before exec: SIGINT's default action, as at a terminal. A shell that
    runs the tests in the background ignores SIGINT, and an ignored signal stays ignored
    across exec (Python then installs no KeyboardInterrupt handler)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@contextlib.contextmanager
def _interruptible_child(args: list[str], stderr: Any) -> Iterator[subprocess.Popen[str]]:
    """``args`` run as a child that takes SIGINT as at a terminal, its stdout a text pipe,
    killed on the way out if it still runs (a failed or timed-out step must not leave a
    week's simulation running on CI's cores)."""
    proc = subprocess.Popen(
        args,
        stdout=subprocess.PIPE,
        stderr=stderr,
        text=True,
        preexec_fn=_sigint_as_at_a_terminal,
    )
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("stop", ["sigint", "sigkill"])
def test_ten_interruptions_at_random_periods_resume_bit_identical(
    tmp_path: Path, stop: str
) -> None:
    """Ctrl-C (KeyboardInterrupt) or a kill (nothing runs after it) at 10 random periods of
    an rmpc half-day with IL events (08:00–20:00: office hours, the activation, the end of
    occupancy): each resumed run equals the uninterrupted one in every column but
    ``solve_time_s``, bit for bit — it resumes from the last restart point and replays the
    periods after it."""
    every = 5
    cfg = with_overrides(
        preset("rmpc", start=f"{START}T08:00", days=0.5), {"activation.mode": "stress"}
    )
    whole = run_simulation(cfg, tmp_path / "whole", progress=False, checkpoint_every=every)
    assert whole.frame["il_activated"].any()  # the half-day holds its activation
    columns = [c for c in whole.frame.columns if c != "solve_time_s"]
    rng = np.random.default_rng(17 if stop == "sigint" else 23)
    for i, period in enumerate(rng.choice(np.arange(1, cfg.steps), size=10, replace=False)):
        out = tmp_path / f"{stop}-{i}"
        error: BaseException = KeyboardInterrupt() if stop == "sigint" else _Killed()
        with pytest.raises(type(error)) as caught:
            run_simulation(
                cfg, out, progress=False, checkpoint_every=every, on_step=_stop_at(period, error)
            )
        restart = (int(period) // every) * every
        if stop == "sigint":
            assert isinstance(caught.value, RunInterrupted)
            assert caught.value.period == period
            assert caught.value.checkpoint_period == (restart or None)
            assert "checkpoint" in caught.value.message()
        resumed_at: list[int] = []
        resumed = run_simulation(
            cfg, out, progress=False, checkpoint_every=every, on_resume=resumed_at.append
        )
        assert resumed_at == ([restart] if restart else [])
        pd.testing.assert_frame_equal(
            resumed.frame[columns], whole.frame[columns], check_exact=True, check_freq=False
        )


def test_ctrl_c_says_where_its_checkpoint_is_and_the_resume_says_where_it_resumed(
    tmp_path: Path,
) -> None:
    """``simulate`` interrupted by SIGINT prints a line naming its checkpoint and how to
    resume (exit 130); the same command again first prints "resumed from period N". A week,
    so that the run is still going when the signal comes after its first checkpoint,
    whatever the machine's load (a day could finish first); the resumed run is stopped once
    it has said where it resumed."""
    out = tmp_path / "interrupted"
    args = [
        sys.executable, "-m", "hvacflex.cli", "simulate", "--scenario", "rmpc",
        "--start", START, "--days", "7", "--out", str(out), "--quiet",
        "--checkpoint-every", "4", "--no-report",
    ]  # fmt: skip
    with _interruptible_child(args, stderr=subprocess.STDOUT) as proc:
        _wait_for_checkpoint(out, poll_s=0.05)
        proc.send_signal(signal.SIGINT)
        printed, _ = proc.communicate(timeout=120)
    assert proc.returncode == 130, printed
    assert "checkpoint at period" in printed and "run the same command again" in printed
    assert "Traceback" not in printed
    errors = tmp_path / "resumed.err"
    with (
        errors.open("w") as stderr,
        _interruptible_child(args, stderr=stderr) as again,
    ):
        assert again.stdout is not None
        first = again.stdout.readline()  # rich flushes each line
        again.send_signal(signal.SIGINT)
        again.communicate(timeout=120)
    assert first.startswith("resumed from period "), (first, errors.read_text())


@pytest.mark.slow
def test_twenty_kills_resume_bit_identical(tmp_path: Path) -> None:
    rng = np.random.default_rng(29)
    steps = [_kill_and_resume(tmp_path, rng, every=3) for _ in range(20)]
    assert sum(k > 0 for k in steps) >= 15, steps


def test_same_seed_same_results_other_seed_other_disturbances(tmp_path: Path) -> None:
    cfg = preset("nmpc", start=START, days=0.5)
    one = run_simulation(cfg, tmp_path / "1", progress=False).frame
    two = run_simulation(cfg, tmp_path / "2", progress=False).frame
    pd.testing.assert_frame_equal(
        one.drop(columns="solve_time_s"), two.drop(columns="solve_time_s")
    )
    other = run_simulation(replace(cfg, seed=7), tmp_path / "3", progress=False).frame
    assert not np.allclose(one.filter(like="w_").to_numpy(), other.filter(like="w_").to_numpy())


def test_results_file_carries_config_and_is_reused(tmp_path: Path) -> None:
    cfg = preset("thermostat", start=START, days=0.5)
    first = run_simulation(cfg, tmp_path, progress=False)
    frame, meta = read_results(first.results_path)
    assert meta["config"]["controller"]["kind"] == "thermostat"
    assert meta["config_hash"] == cfg.config_hash()
    assert meta["version"]
    assert len(frame) == cfg.steps
    again = run_simulation(cfg, tmp_path, progress=False)
    assert again.cached


def test_billing_period_mode_only_pays_to_raise_the_months_peak(tmp_path: Path) -> None:
    """With the month's peak so far as a floor, shaving below it is worth nothing."""
    cost = {}
    for mode in ("horizon", "billing-period"):
        cfg = with_overrides(
            preset("rmpc-ppp", start=START, days=2.0),
            # the LP's billing modes alone: the in-period guard acts on the plant's meter.
            # Without the night margin. With the 0.5 K margin (measured 2026-12-06 on the
            # code of 1067dca) billing-period meters 0.56 % more energy cost than horizon
            # (120.54 against 119.87 SGD, the same 41.5 kW peak): from 18:30 on the first day
            # its plan holds the west zone below the lowered night bound with flows of
            # 0.003–0.06 kg/s, which the LP's fan secant prices at 0.0–0.3 kW and the plant
            # meters at 0.9–1.1 kW (the fan's static-pressure floor, which an affine row
            # cannot see); horizon mode's plan, a near-tie vertex of its own LP, waits until
            # 23:00. The inequality below holds for the LP's objectives, not for the meter's
            # cost of such ties; with margin 0 both modes run alike on these two days.
            {
                "controller.billing_mode": mode,
                "controller.peak_guard": "off",
                "controller.unoccupied_plan_margin_k": 0.0,
            },
        )
        frame = run_simulation(cfg, tmp_path / mode, progress=False).frame
        assert not frame["fallback"].any()
        cost[mode] = kpi.energy_cost_sgd(frame)
    # 1e-4 relative, not 1e-6 absolute: with the LP's pull-down cap (issue 55 item 3 (a))
    # the runs of the two modes part, billing-period metering 119.93333 against 119.93273
    # SGD (5e-6 relative, measured 2026-12-06). Not traced; the cap in force is the
    # previous plan's peak, which differs between the modes, and a near-tie metered as
    # above is the likely cause
    assert cost["billing-period"] <= cost["horizon"] * (1.0 + 1e-4)


def test_billing_period_mode_stops_shaving_below_a_sunk_peak() -> None:
    """A month's peak already above anything the plan reaches makes the PPP charge sunk in
    billing-period mode: the controller stops shaving and buys cheaper energy; horizon mode
    ignores the month's peak and keeps shaving. Identical runs would mean the mode is ignored.
    φ = 10 SGD/kW: with the part-load chiller and outdoor air by need, the plant draws
    36–42 kW at the ventilation flows alone, and at the preset's 1.5 SGD/kW shaving this
    day's peak costs more energy than it saves (both modes plan alike).
    """
    frames = {}
    for mode in ("horizon", "billing-period"):
        cfg = with_overrides(
            preset("rmpc-ppp", start=START, days=1.0),
            {
                "controller.billing_mode": mode,
                "activation.mode": "never",
                "controller.peak_price_sgd_per_kw": 10.0,
            },
        )
        loop = ClosedLoop(prepare(cfg))
        loop.history.opening_peak_kw = 100.0  # far above the plant's peak (≈ 30–40 kW)
        while loop.k < loop.steps:
            loop.step()
        frames[mode] = loop.frame()
        assert not frames[mode]["fallback"].any()
    horizon, billing = frames["horizon"], frames["billing-period"]
    planned_gap_kw = (horizon["planned_power_kw"] - billing["planned_power_kw"]).abs()
    assert planned_gap_kw.max() > 1.0
    assert kpi.energy_cost_sgd(billing) < kpi.energy_cost_sgd(horizon) - 0.1
    assert kpi.peak_power_kw(billing) > kpi.peak_power_kw(horizon) + 0.1


def test_editing_the_building_file_invalidates_cached_results(tmp_path: Path) -> None:
    building = tmp_path / "mine.toml"
    building.write_text((buildings_dir() / "office5.toml").read_text())
    cfg = with_overrides(preset("thermostat", start=START, days=0.25), {"building": str(building)})
    assert run_simulation(cfg, tmp_path / "run", progress=False).cached is False
    assert run_simulation(cfg, tmp_path / "run", progress=False).cached is True
    building.write_text(building.read_text().replace("cop = 4.2", "cop = 4.0"))
    assert run_simulation(cfg, tmp_path / "run", progress=False).cached is False


def test_results_of_other_code_are_not_reused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.version as version

    cfg = preset("thermostat", start=START, days=0.25)
    first = run_simulation(cfg, tmp_path, progress=False)
    assert read_results(first.results_path)[1]["version"] == version.code_version()
    assert run_simulation(cfg, tmp_path, progress=False).cached
    monkeypatch.setattr(version, "code_version", lambda: "9.9.9+src.otherotherot")
    again = run_simulation(cfg, tmp_path, progress=False)
    assert not again.cached
    assert read_results(again.results_path)[1]["version"] == "9.9.9+src.otherotherot"


def test_a_checkpoint_of_other_code_is_refused_naming_both_versions(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.version as version
    from hvacflex.errors import StoredStateError

    cfg = preset("thermostat", start=START, days=0.5)
    ours = version.code_version()
    run_simulation(cfg, tmp_path, progress=False, stop_after_steps=10)
    assert (tmp_path / CHECKPOINT_FILE).is_file()
    monkeypatch.setattr(version, "code_version", lambda: "9.9.9+src.otherotherot")
    with pytest.raises(StoredStateError) as caught:
        run_simulation(cfg, tmp_path, progress=False)
    message = str(caught.value)
    assert ours in message and "9.9.9+src.otherotherot" in message
    assert "--fresh" in message and CHECKPOINT_FILE in message
    fresh = run_simulation(cfg, tmp_path, progress=False, resume=False)
    assert fresh.resumed_from_step is None and len(fresh.frame) == cfg.steps


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def test_a_truncated_checkpoint_or_results_file_gives_a_clear_error(tmp_path: Path) -> None:
    from hvacflex.errors import StoredStateError

    cfg = preset("thermostat", start=START, days=0.5)
    run_simulation(cfg, tmp_path / "ckpt", progress=False, stop_after_steps=10)
    _truncate(tmp_path / "ckpt" / CHECKPOINT_FILE)
    with pytest.raises(StoredStateError, match=r"not a readable checkpoint.*--fresh"):
        run_simulation(cfg, tmp_path / "ckpt", progress=False)

    done = run_simulation(cfg, tmp_path / "done", progress=False)
    _truncate(done.results_path)
    with pytest.raises(StoredStateError, match=r"not a readable results file.*--fresh"):
        run_simulation(cfg, tmp_path / "done", progress=False)
    # --fresh (resume=False) does not read the damaged file and writes a whole one
    again = run_simulation(cfg, tmp_path / "done", progress=False, resume=False)
    assert len(read_results(again.results_path)[0]) == cfg.steps

    (tmp_path / "done" / "summary.json").write_text('{"steps": 2')
    with pytest.raises(StoredStateError, match="not a readable summary file"):
        run_simulation(cfg, tmp_path / "done", progress=False)


def test_results_record_the_controllers_forecast_and_its_realised_error() -> None:
    cfg = preset(
        "nmpc",
        start="2014-03-03",
        days=3 / 48,
        forecast={"weather": "statistical", "train_days": 7},
        realisation={"occupancy": "stochastic", "mode": "zero"},
    )
    loop = ClosedLoop(prepare(cfg))
    for _ in range(3):
        loop.step()
    frame = loop.frame()
    names = [ch.name for ch in loop.setup.model.channels]
    d_hat = frame[[f"d_{n}" for n in names]].to_numpy()
    w = frame[[f"w_{n}" for n in names]].to_numpy()
    for k in range(3):
        np.testing.assert_allclose(d_hat[k], loop.setup.forecaster.forecast(k, 2).disturbances[0])
    # the plant saw the data: forecast + error = the data (no extra draw with mode "zero")
    np.testing.assert_allclose(d_hat + w, loop.setup.exogenous.disturbances[:3], rtol=1e-12)
    assert np.abs(w).max() > 0.0
    # the weather's outdoor humidity, the moisture term's input for a power fit on the meter
    np.testing.assert_array_equal(
        frame["outdoor_humidity_ratio_kg_per_kg"].to_numpy(),
        loop.setup.exogenous.outdoor_humidity_ratio_kg_per_kg[:3],
    )
    assert (frame["outdoor_humidity_ratio_kg_per_kg"] > 0.005).all()


def test_the_peak_guard_sheds_toward_the_band_at_the_periods_end(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The guard's upper bound is the plan's: the tighter of the bands of periods k and
    k + 1 (control/plan_band.band_at_period_ends), so the period before occupancy
    does not shed toward the 30 °C night bound (issue 55 review). With period k's band
    alone the guards of the pre-occupancy periods would carry the night bound."""
    cfg = with_overrides(
        preset("rmpc-ppp", start=START, days=0.5),  # to noon: occupancy starts at 08:00
        {"activation.mode": "never", "controller.peak_guard": "on"},
    )
    seen: list[tuple[int, np.ndarray]] = []
    actuation = ClosedLoop._actuation

    def spy(self: ClosedLoop, decision: Any, *, curtailed: bool) -> Actuation:
        if self._period_guard is not None:
            seen.append((self.k, np.array(self._period_guard.comfort_upper_degc)))
        return actuation(self, decision, curtailed=curtailed)

    monkeypatch.setattr(ClosedLoop, "_actuation", spy)
    loop = ClosedLoop(prepare(cfg))
    upper = loop.setup.exogenous.comfort_upper_degc
    while loop.k < loop.steps:
        loop.step()
    assert seen
    for k, guard_upper in seen:
        np.testing.assert_allclose(guard_upper, np.minimum(upper[k], upper[k + 1]))
    # the check discriminates: some guarded period's own band is wider than its end's
    assert any((upper[k] > upper[k + 1]).any() for k, _ in seen)


def test_the_setpoint_actuation_clips_to_the_band_at_the_periods_end() -> None:
    """The setpoints are clipped to the band the peak guard sheds toward and the plan keeps:
    the tighter of periods k and k + 1. Where the band tightens (occupancy starts) it is the
    next period's; where it widens (occupancy ends) it stays period k's. With period k's band
    alone, a pre-occupancy zone would be handed the night bound."""
    exo = prepare(preset("rmpc", start=START, days=1)).exogenous
    occupied = exo.occupied.astype(bool)
    opens = int(np.flatnonzero(~occupied[:-1] & occupied[1:])[0])  # last period before
    closes = int(np.flatnonzero(occupied[:-1] & ~occupied[1:])[0])  # last occupied period
    lower, upper = exo.comfort_lower_degc, exo.comfort_upper_degc
    assert (upper[opens] > upper[opens + 1]).all() and (lower[opens] < lower[opens + 1]).all()
    end_lower, end_upper = band_at_period_end_degc(exo, opens)
    np.testing.assert_array_equal(end_lower, lower[opens + 1])
    np.testing.assert_array_equal(end_upper, upper[opens + 1])
    end_lower, end_upper = band_at_period_end_degc(exo, closes)
    np.testing.assert_array_equal(end_lower, lower[closes])
    np.testing.assert_array_equal(end_upper, upper[closes])
    # the last period of the data: its own band
    last = len(exo.index) - 1
    np.testing.assert_array_equal(band_at_period_end_degc(exo, last)[1], upper[last])

    m = upper.shape[1]
    planned = np.linspace(lower[opens].min() - 1.0, upper[opens].max() + 1.0, m)
    planned[0] = np.nan  # no plan: the upper bound
    idle = np.zeros(m, dtype=bool)
    idle[-1] = True
    end_lower, end_upper = band_at_period_end_degc(exo, opens)
    setpoint = setpoint_actuation_degc(planned, idle, end_lower, end_upper)
    expected = np.clip(planned, end_lower, end_upper)
    expected[0] = end_upper[0]
    expected[-1] = end_upper[-1]  # idle: the occupied upper bound, not the night one
    np.testing.assert_array_equal(setpoint, expected)
    own_band = setpoint_actuation_degc(planned, idle, lower[opens], upper[opens])
    assert own_band[-1] == upper[opens][-1] > setpoint[-1]  # the difference the helper makes
