"""Run a scenario's closed loop (:class:`hvacflex.sim.closed_loop.ClosedLoop`) to its folder:
results, summary, checkpoints, resume and the re-use of finished results.

A run checkpoints every ``checkpoint_every`` steps (its restart points: the solver restarts
there from its stored basis, interrupted or not), in the data-only format of
:mod:`hvacflex.state`: the plant state, the step index, the sampler's and sensors' RNG
states, the control step's state (LP basis, previous plan, filter, IL events, commitments,
meter history), the period history and the rows so far. Interrupted (Ctrl-C), it keeps the
last restart point; started again with the same configuration, it resumes from there,
replays the periods after it, and ends with results identical to an uninterrupted run, bit
for bit.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex import version
from hvacflex.config import ScenarioConfig
from hvacflex.errors import ConfigError
from hvacflex.paths import check_output_dir
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.plants import plant_summary
from hvacflex.sim.progress import progress_bar
from hvacflex.sim.run_files import (
    CHECKPOINT_FILE,
    CONFIG_FILE,
    RESULTS_FILE,
    SUMMARY_FILE,
    check_checkpoint_code,
    check_out_dir,
    load_checkpoint,
    read_results,
    read_summary,
    refuse_old_checkpoint,
    run_key,
    write_results,
    write_summary,
)
from hvacflex.sim.setup import prepare
from hvacflex.version import atomic_write_text

DEFAULT_CHECKPOINT_EVERY = 336
"""Steps between checkpoints (one week of 30-min periods)."""

ProgressCallback = Callable[[int, int], None]


@dataclass(frozen=True)
class RunResult:
    """A finished closed-loop run.

    Attributes
    ----------
    out_dir : the run's folder (results, summary, config).
    frame : one row per period (schema in ``docs/reference/results.md``).
    summary : KPIs (see :mod:`hvacflex.kpi`).
    resumed_from_step : the checkpoint step the run resumed from, or None.
    cached : True when the results were already there and nothing was simulated.
    """

    out_dir: Path
    frame: pd.DataFrame
    summary: dict[str, float]
    resumed_from_step: int | None = None
    cached: bool = False

    @property
    def results_path(self) -> Path:
        return self.out_dir / RESULTS_FILE

    @property
    def results(self) -> pd.DataFrame:
        """The results table, ``frame`` (one row per period;
        ``docs/explanation/architecture.md``)."""
        return self.frame


class RunInterrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C (or SIGTERM turned into it): where it was, and the period its
    checkpoint resumes from (None: no restart point yet, the run starts again from its first
    period)."""

    def __init__(self, period: int, checkpoint_period: int | None, out_dir: Path) -> None:
        super().__init__(period)
        self.period = period
        self.checkpoint_period = checkpoint_period
        self.out_dir = out_dir

    def message(self) -> str:
        """What the user reads: where the run stopped, its checkpoint, how to resume."""
        if self.checkpoint_period is None:
            kept = "no checkpoint yet (the first is written at the first restart point)"
        else:
            kept = f"checkpoint at period {self.checkpoint_period} in {self.out_dir}"
        return (
            f"interrupted at period {self.period}: {kept}; run the same command again to "
            "resume (the periods after the checkpoint are replayed, so the results equal an "
            "uninterrupted run's bit for bit)"
        )


def run_simulation(
    config: ScenarioConfig,
    out_dir: str | Path,
    *,
    progress: bool = True,
    checkpoint_every: int = DEFAULT_CHECKPOINT_EVERY,
    resume: bool = True,
    stop_after_steps: int | None = None,
    on_step: ProgressCallback | None = None,
    on_resume: Callable[[int], None] | None = None,
) -> RunResult:
    """Run (or resume, or re-use) a closed-loop simulation and write its results.

    Checkpoints are written every ``checkpoint_every`` steps: the **restart points**, where
    the controller restarts its solver from the stored basis (:meth:`ClosedLoop.
    save_checkpoint`) whether or not the run is ever resumed. An interrupted or stopped run
    keeps the last restart point as its checkpoint (its periods after it are replayed on
    resume), so a resumed run equals the uninterrupted one bit for bit: restarting the
    solver at the interruption instead would let HiGHS settle on other optimal vertices
    than the run that kept its factorisation. A controller without live solver state (a
    rule) checkpoints where it stops (:attr:`ClosedLoop.resumable_anywhere`).

    Parameters
    ----------
    config : the scenario.
    out_dir : folder for ``results.parquet``, ``summary.json``, ``config.json`` and the
        checkpoint.
    progress : show a progress bar (steps/s, ETA).
    checkpoint_every : steps between checkpoints (restart points).
    resume : resume from a checkpoint of the same configuration, and re-use finished results
        of the same inputs (:func:`run_key`) and code (:func:`hvacflex.version.code_version`).
        A checkpoint of the same configuration written by other code is refused.
    stop_after_steps : stop once this many steps are done, as an interruption would; the run
        is then resumable from its last restart point. For tests and batch schedulers.
    on_step : called with (steps done, total steps) after each step (and its checkpoint).
    on_resume : called with the period the run resumes from, before its first step.

    Raises
    ------
    RunInterrupted : Ctrl-C; the checkpoint is the last restart point.
    """
    from hvacflex.kpi import summary as kpi_summary

    if checkpoint_every < 1:
        raise ConfigError("must be ≥ 1 step", field="checkpoint_every", value=checkpoint_every)

    out = check_output_dir(Path(out_dir), "out_dir")
    check_out_dir(out, config, fresh=not resume)  # another configuration's run is refused
    checkpoint_path = out / CHECKPOINT_FILE
    if resume:
        refuse_old_checkpoint(out)
        cached = _cached_result(out, config)
        if cached is not None:
            return cached
    stored_state = _matching_checkpoint(checkpoint_path, config) if resume else None
    if not resume:
        checkpoint_path.unlink(missing_ok=True)  # a fresh run's restart points are its own
    loop = ClosedLoop(prepare(config))
    try:
        resumed_from: int | None = None
        if stored_state is not None:
            loop.set_state(stored_state)
            resumed_from = loop.k
            if on_resume is not None:
                on_resume(resumed_from)
        atomic_write_text(out / CONFIG_FILE, json.dumps(config.to_dict(), indent=2))
        last = loop.steps if stop_after_steps is None else min(loop.steps, stop_after_steps)
        try:
            with progress_bar(progress, config.name, loop.steps, loop.k) as advance:
                while loop.k < last:
                    loop.step()
                    advance()
                    if loop.k % checkpoint_every == 0 and loop.k < loop.steps:
                        loop.save_checkpoint(checkpoint_path)
                    if on_step is not None:
                        on_step(loop.k, loop.steps)
        except KeyboardInterrupt as exc:
            if loop.resumable_anywhere:
                loop.save_checkpoint(checkpoint_path)
            kept = _checkpoint_period(checkpoint_path)
            raise RunInterrupted(loop.k, kept, out) from exc
    finally:
        close = getattr(loop.plant, "close", None)
        if close is not None:  # an emulator's run ends with the loop
            close()
    if loop.k < loop.steps:
        if loop.resumable_anywhere:
            loop.save_checkpoint(checkpoint_path)
        frame = loop.frame()
        return RunResult(out, frame, kpi_summary(frame), resumed_from_step=resumed_from)
    return _finish(loop, out, config, resumed_from)


def _checkpoint_period(path: Path) -> int | None:
    """The period the checkpoint at ``path`` resumes from (None: none)."""
    if not path.is_file():
        return None
    return int(load_checkpoint(path)["k"])


def _cached_result(out: Path, config: ScenarioConfig) -> RunResult | None:
    """The finished results of the same inputs and code in ``out``, or None."""
    results_path = out / RESULTS_FILE
    if not results_path.is_file():
        return None
    frame, stored = read_results(results_path)
    same_code = stored["version"] == version.code_version()
    if stored["run_key"] == run_key(config) and same_code and (out / SUMMARY_FILE).is_file():
        return RunResult(out, frame, read_summary(out / SUMMARY_FILE), cached=True)
    return None


def _matching_checkpoint(path: Path, config: ScenarioConfig) -> dict[str, Any] | None:
    """The checkpoint at ``path`` if it belongs to ``config`` (written by this code), else
    None (a checkpoint of another configuration: the run starts afresh over it)."""
    if not path.is_file():
        return None
    stored = load_checkpoint(path)
    if stored["config_hash"] != run_key(config):
        return None
    check_checkpoint_code(stored, path)
    return stored


def _finish(
    loop: ClosedLoop, out: Path, config: ScenarioConfig, resumed_from: int | None
) -> RunResult:
    """Write the results and the summary of a finished run, and drop its checkpoint."""
    from hvacflex.kpi import summary as kpi_summary

    frame = loop.frame()
    write_results(frame, out / RESULTS_FILE, config)
    summary: dict[str, Any] = {**kpi_summary(frame), **plant_summary(config.plant)}
    # timing_s covers only the steps simulated by this call (it is not checkpointed)
    steps_timed = loop.k - (resumed_from or 0)
    summary["steps_per_s"] = _steps_per_second(loop, steps_timed)
    for part, seconds in loop.timing_s.items():
        summary[f"time_{part}_ms_per_step"] = 1e3 * seconds / max(steps_timed, 1)
    write_summary(out / SUMMARY_FILE, summary)
    (out / CHECKPOINT_FILE).unlink(missing_ok=True)
    return RunResult(out, frame, summary, resumed_from_step=resumed_from)


def _steps_per_second(loop: ClosedLoop, steps_timed: int) -> float:
    """Steps per second of wall time over the ``steps_timed`` steps ``loop.timing_s`` covers."""
    total = sum(loop.timing_s.values())
    return steps_timed / total if total > 0 else float("nan")
