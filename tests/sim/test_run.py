"""run_simulation's own logic: the checkpoint interval, RunResult and RunInterrupted.

(The closed loop's runs, resumes and caches are tested in tests/sim/test_closed_loop.py.)"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hvacflex.config import preset
from hvacflex.errors import ConfigError
from hvacflex.sim.run import DEFAULT_CHECKPOINT_EVERY, RunInterrupted, RunResult, run_simulation
from hvacflex.sim.run_files import RESULTS_FILE


def test_checkpoint_interval_is_checked_before_any_work(tmp_path: Path) -> None:
    config = preset("thermostat", start="2014-05-05", days=1.0)
    with pytest.raises(ConfigError, match="≥ 1 step"):
        run_simulation(config, tmp_path / "run", checkpoint_every=0, progress=False)
    assert not (tmp_path / "run").exists()
    assert DEFAULT_CHECKPOINT_EVERY == 7 * 48  # one week of 30-min periods


def test_run_result_points_at_its_results(tmp_path: Path) -> None:
    frame = pd.DataFrame({"power_kw": [1.0, 2.0]})
    result = RunResult(tmp_path, frame, {"energy_kwh": 1.5})
    assert result.results_path == tmp_path / RESULTS_FILE
    assert result.results is frame and not result.cached


def test_interrupted_message_says_where_and_how_to_resume(tmp_path: Path) -> None:
    none_yet = RunInterrupted(5, None, tmp_path).message()
    assert "interrupted at period 5" in none_yet and "no checkpoint yet" in none_yet
    kept = RunInterrupted(400, 336, tmp_path).message()
    assert f"checkpoint at period 336 in {tmp_path}" in kept and "run the same command" in kept
