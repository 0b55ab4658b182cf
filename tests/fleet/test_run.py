"""Fleet runs: results columns, the feeder limit, the bid settlement, resume, worker loss."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

import hvacflex
from hvacflex.data.market import synthetic_reserve_prices
from hvacflex.fleet.envelope import DURATIONS_MIN, ENVELOPE_COLUMNS, ENVELOPE_FILE
from hvacflex.fleet.generate import generate_fleet, write_fleet
from hvacflex.fleet.kpi import fleet_summary, load_fleet_results
from hvacflex.fleet.run import CHECKPOINT_FILE, live_workers, run_fleet

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
    # the bid is settled against the minimum: nothing paid below it, the bid itself above it
    below = frame["fleet_bid_kw"] < 100.0
    assert not frame.loc[below, "bid_accepted"].any()
    assert np.all(frame.loc[below, "settled_reserve_kw"] == 0.0)
    accepted = frame["bid_accepted"]
    assert np.all(frame.loc[accepted, "settled_reserve_kw"] == frame.loc[accepted, "fleet_bid_kw"])
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
    # the uninterrupted run restarts its buildings' solvers from their bases at the same
    # checkpoints (every 2 steps) as the interrupted one, which stopped after one: equal bit
    # for bit, the wall times aside
    fresh = run_fleet(
        small_fleet, tmp_path / "fresh", start=START, days=DAYS, workers=0, checkpoint_every=2
    )
    timings = ["coordination_time_s", "step_time_s"]
    pd.testing.assert_frame_equal(
        fresh.frame.drop(columns=timings),
        frame.drop(columns=timings),
        check_exact=True,
        check_freq=False,
    )
    pd.testing.assert_frame_equal(
        pd.read_parquet(tmp_path / "fresh" / "buildings.parquet").drop(columns="solve_time_s"),
        pd.read_parquet(out / "buildings.parquet").drop(columns="solve_time_s"),
        check_exact=True,
    )
    # the envelope: every step × 30/60/120 min, carried across the resume
    envelope = pd.read_csv(out / ENVELOPE_FILE)
    assert list(envelope.columns) == list(ENVELOPE_COLUMNS)
    assert len(envelope) == 8 * len(DURATIONS_MIN)
    assert list(envelope["duration_min"][:3]) == list(DURATIONS_MIN)
    kept = envelope["buildings"] > 0  # rows summing at least one comfort-keeping building
    assert envelope["buildings"].between(0, 3).all()
    assert np.all(envelope["min_power_kw"][kept] <= envelope["max_power_kw"][kept])
    assert envelope.loc[~kept, ["min_power_kw", "max_power_kw"]].isna().all().all()
    pd.testing.assert_frame_equal(envelope, pd.read_csv(tmp_path / "fresh" / ENVELOPE_FILE))


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


SCHEDULER_WORKERS = 2
SCHEDULER_START_S = 180
"""How long the scheduler and its workers may take to start on a loaded machine [s]."""


@pytest.fixture
def tcp_scheduler() -> Iterator[str]:
    """A Dask scheduler and two single-threaded workers started apart from the test, as a
    cluster's are (``dask scheduler`` / ``dask worker`` processes on loopback); its
    ``tcp://`` address."""
    from dask.distributed import Client

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ)
    source = str(Path(hvacflex.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (source, env.get("PYTHONPATH", "")) if p)
    module = [sys.executable, "-m"]
    quiet = {"env": env, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    processes = [
        subprocess.Popen(
            [
                *module,
                "distributed.cli.dask_scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--no-dashboard",
            ],
            **quiet,
        )
    ]
    try:
        processes += [
            subprocess.Popen(
                [
                    *module,
                    "distributed.cli.dask_worker",
                    address,
                    "--nthreads",
                    "1",
                    "--no-dashboard",
                    "--no-nanny",
                ],
                **quiet,
            )
            for _ in range(SCHEDULER_WORKERS)
        ]
        with Client(address, timeout=SCHEDULER_START_S) as client:
            client.wait_for_workers(SCHEDULER_WORKERS, timeout=SCHEDULER_START_S)
        yield address
    finally:
        for process in reversed(processes):
            process.terminate()
        for process in processes:
            try:  # a worker may still be closing its connections to the scheduler
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def test_a_fleet_runs_on_a_tcp_scheduler_started_apart(
    small_fleet: Path, tmp_path: Path, tcp_scheduler: str
) -> None:
    """``fleet simulate --scheduler tcp://…``: the buildings are split over the cluster's
    two workers (one group each), the run ends, and the cluster it did not start is left
    running with its workers."""
    from dask.distributed import Client

    placed: list[list[str]] = []

    def where(k: int, groups: Any) -> None:
        placed.append(list(groups.workers))

    result = run_fleet(
        small_fleet, tmp_path, start=START, days=2 / 48, scheduler=tcp_scheduler, on_step=where
    )
    assert len(result.frame) == 2 and result.recoveries == 0
    assert all(len(set(w)) == SCHEDULER_WORKERS for w in placed)
    assert all(w.startswith("tcp://127.0.0.1:") for w in placed[0])
    frame = result.frame
    assert np.all(frame["planned_fleet_power_kw"] <= frame["feeder_limit_kw"] + 1e-6)
    assert np.all(np.isfinite(frame["fleet_power_kw"]))
    with Client(tcp_scheduler, timeout=30) as client:
        assert len(live_workers(client)) == SCHEDULER_WORKERS


@pytest.fixture(scope="module")
def activated_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three buildings under a limit that does not bind (a fleet at a binding limit has no
    room to curtail, docs/guide/fleet.md), the synthetic reserve price at the fleet file's
    ``[data] reserve_price_scale = 200`` SGD/MWh (the calibrated 48.5 also sells at 12:00
    today; the scale is checked in the prices the run records), any bid accepted, IL
    activated by the grid operator at 12:00 and 12:30 (a file schedule)."""
    folder = tmp_path_factory.mktemp("activated")
    times = pd.date_range("2014-03-03 10:00", periods=6, freq="30min", tz="Asia/Singapore")
    pd.DataFrame({"time": [t.isoformat() for t in times], "activated": [0, 0, 0, 0, 1, 1]}).to_csv(
        folder / "activations.csv", index=False
    )
    doc = generate_fleet(3, 3, feeder_limit_kw=200.0, min_bid_mw=0.0)
    doc["data"] = {"reserve_price_scale": 200.0}
    doc["activation"] = {"mode": "file", "file": "activations.csv"}
    return write_fleet(doc, folder / "fleet.toml")


def test_activation_is_settled_against_metered_fleet_power(
    activated_fleet: Path, tmp_path: Path
) -> None:
    result = run_fleet(activated_fleet, tmp_path, start="2014-03-03T10:00", days=6 / 48, workers=0)
    frame = result.frame
    accepted = bool(frame["bid_accepted"].iloc[4])
    # an activation reaches the fleet only through an accepted bid of its first period
    assert frame["il_activated"].tolist() == [False] * 4 + [accepted] * 2
    assert accepted, "the fleet offered no reserve at 12:00: the test needs a bid"
    assert frame["fleet_reserve_kw"].iloc[4] > 0
    # the fleet sells, is paid for and settled on its bid (checked on the fleet's meter)
    assert frame["settled_reserve_kw"].iloc[4] == frame["fleet_bid_kw"].iloc[4] > 0
    # the feeder guarantee holds during the event (locked buildings keep their power)
    assert np.all(frame["planned_fleet_power_kw"] <= frame["feeder_limit_kw"] + 1e-3)
    # pre-event baseline: the metered fleet power of 11:30, held over the event
    power = frame["fleet_power_kw"].to_numpy()
    baseline = frame["il_baseline_power_kw"].to_numpy()
    np.testing.assert_allclose(baseline[4:], power[3])
    assert np.all(np.isnan(baseline[:4]))
    delivered = frame["il_delivered_kw"].to_numpy()
    np.testing.assert_allclose(delivered[4:], np.maximum(power[3] - power[4:], 0))
    settled = frame["settled_reserve_kw"].to_numpy()
    np.testing.assert_allclose(
        frame["il_shortfall_kw"].iloc[4:], np.maximum(settled[4:] - delivered[4:], 0)
    )
    # every building is settled too: its own rows carry the activation
    buildings = pd.read_parquet(tmp_path / "buildings.parquet")
    per_building = buildings.groupby(level=0)["il_activated"].all()
    assert per_building.tolist() == frame["il_activated"].tolist()
    assert "il_delivered_kw" in buildings
    assert result.summary["il_activated_steps"] == 2.0
    _check_building_settlement(tmp_path, frame, buildings, result.summary)
    # the fleet file's [data] reserve_price_scale prices the reserve of the one market
    synthetic = synthetic_reserve_prices(
        frame["energy_price_sgd_per_mwh"], seed=3, scale_sgd_per_mwh=200.0
    )
    np.testing.assert_allclose(frame["reserve_price_sgd_per_mwh"], synthetic.to_numpy())


def _check_building_settlement(
    out: Path, frame: pd.DataFrame, buildings: pd.DataFrame, summary: dict[str, float]
) -> None:
    """The fleet's offer is Σ of the buildings' visible offers; an accepted, activated bid
    is dispatched by those shares and each building is settled on its own meter against
    its own pre-event baseline (the metered power of 11:30), capped at its share."""
    offers = pd.read_csv(out / "offers.csv")
    assert offers["building"].nunique() == 3 and len(offers) == 3 * len(frame)
    table = offers.pivot(index="time", columns="building")
    np.testing.assert_allclose(table["offer_kw"].sum(axis=1), frame["fleet_offer_kw"], atol=1e-9)
    assert frame["fleet_bid_kw"].iloc[4] == frame["fleet_offer_kw"].iloc[4] > 0
    share = table["dispatched_kw"].to_numpy()
    accepted = frame["bid_accepted"].to_numpy() & frame["il_activated"].to_numpy()
    np.testing.assert_allclose(share, np.where(accepted[:, None], table["offer_kw"], 0.0))
    np.testing.assert_allclose(share.sum(axis=1), frame["il_dispatched_kw"])
    power = buildings.pivot(columns="building", values="power_kw")[table["offer_kw"].columns]
    metered = power.to_numpy()
    expected = np.where(
        accepted[:, None], np.minimum(np.maximum(metered[3] - metered, 0.0), share), 0.0
    )
    np.testing.assert_allclose(table["delivered_kw"].to_numpy(), expected, atol=1e-9)
    np.testing.assert_allclose(frame["il_delivered_buildings_kw"], expected.sum(axis=1))
    assert summary["delivery_ratio"] == pytest.approx(expected.sum() / share.sum())
    assert summary["office_periods"] == 6 and summary["min_bid_kw"] == 0.0


def test_a_fleet_read_by_the_caller_is_not_read_again(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``fleet simulate`` reads its file once: ``run_fleet`` takes what the CLI loaded."""
    import hvacflex.fleet.schema as fleet_schema

    loaded = fleet_schema.load_fleet_document(small_fleet)
    assert loaded[1] == fleet_schema.read_toml(small_fleet, what="fleet")  # paths as written

    def no_second_read(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("the fleet file was read again")

    monkeypatch.setattr(fleet_schema, "read_toml", no_second_read)
    result = run_fleet(
        small_fleet, tmp_path, start=START, days=1 / 48, workers=0, resume=False, loaded=loaded
    )
    assert len(result.frame) == 1


class _SlowFuture:
    """An actor future that times out ``waits`` times before it answers."""

    def __init__(self, waits: int) -> None:
        self.waits = waits

    def result(self, timeout: float) -> str:
        if self.waits:
            self.waits -= 1
            raise TimeoutError
        return "done"


class _SlowGroup:
    def __init__(self, waits: int) -> None:
        self.waits = waits

    def ping(self) -> _SlowFuture:
        return _SlowFuture(self.waits)


class _Cluster:
    """A client of a cluster of ``workers``, whose cached scheduler info lists none of them
    (as Dask's client holds it between its periodic refreshes, which ask for totals only)."""

    def __init__(self, workers: list[str]) -> None:
        self.workers = workers

    def nthreads(self) -> dict[str, int]:
        return {w: 1 for w in self.workers}

    def scheduler_info(self) -> dict[str, Any]:
        return {"n_workers": len(self.workers), "workers": {}}


class _Silent:
    """A client whose scheduler does not answer (a comm timeout on a loaded machine)."""

    def nthreads(self) -> dict[str, int]:
        raise OSError("Timed out trying to connect")


def test_a_slow_group_call_is_waited_for_while_its_worker_is_there() -> None:
    """A call slower than its timeout (a cold step of many buildings on a loaded machine)
    is waited for while the worker is still in the cluster; a lost worker fails the step
    at once; a call that never answers fails after ``ACTOR_MAX_WAITS`` timeouts."""
    from hvacflex.fleet import run as fleet_run

    groups = object.__new__(fleet_run._Groups)
    groups.client, groups.workers, groups.indices = _Cluster(["w0"]), ["w0"], [[0, 1]]
    groups.groups = [_SlowGroup(3)]
    assert groups.call("ping") == ["done"]  # the worker is there, whatever the cache says
    groups.groups = [_SlowGroup(fleet_run.ACTOR_MAX_WAITS)]
    with pytest.raises(TimeoutError):
        groups.call("ping")
    groups.groups, groups.client = [_SlowGroup(1)], _Cluster([])
    with pytest.raises(fleet_run.WorkerLostError):
        groups.call("ping")
    # a scheduler that does not answer proves no loss: the call is waited for
    groups.groups, groups.client = [_SlowGroup(2)], _Silent()
    assert groups.call("ping") == ["done"]


SHORT: dict[str, Any] = {"start": "2014-03-03 10:00", "days": 2 / 48, "workers": 0}
"""Two steps in process: enough to compare two runs."""


def test_the_envelope_switched_off_leaves_the_run_as_it_was(tmp_path: Path) -> None:
    """``envelope = false`` skips the envelope's LPs: no envelope.csv, every other result as
    with it on (the envelope only reports)."""
    doc = generate_fleet(2, 5, feeder_limit_kw=80.0, min_bid_mw=0.1)
    on = run_fleet(write_fleet(doc, tmp_path / "on.toml"), tmp_path / "on", **SHORT)
    doc["envelope"] = False
    off = run_fleet(write_fleet(doc, tmp_path / "off.toml"), tmp_path / "off", **SHORT)
    assert (tmp_path / "on" / ENVELOPE_FILE).is_file()
    assert not (tmp_path / "off" / ENVELOPE_FILE).exists()
    timings = ["coordination_time_s", "step_time_s"]
    pd.testing.assert_frame_equal(
        off.frame.drop(columns=timings), on.frame.drop(columns=timings), check_exact=True
    )
    pd.testing.assert_frame_equal(
        pd.read_parquet(tmp_path / "off" / "buildings.parquet").drop(columns="solve_time_s"),
        pd.read_parquet(tmp_path / "on" / "buildings.parquet").drop(columns="solve_time_s"),
        check_exact=True,
    )


def test_each_step_plans_against_the_windows_it_sees(tmp_path: Path) -> None:
    from hvacflex.fleet.run import _feeder_timeline, step_planning_kw
    from hvacflex.fleet.schema import load_fleet

    doc = generate_fleet(1, 1, feeder_limit_kw=float("inf"))
    doc["feeder_limits"] = [{"start": "10:00", "end": "17:00", "limit_kw": 50.0}]
    doc["feeder_margin"] = 0.1
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    index, _, planning = _feeder_timeline(fleet, "2014-03-03", 2, 48)
    evening = 34  # 17:00 on Monday: the 24-h horizon reaches Tuesday's window
    np.testing.assert_array_equal(
        step_planning_kw(fleet, planning, index, evening, 48), planning[evening : evening + 48]
    )
    assert np.isfinite(planning[evening : evening + 48]).sum() == 14
    doc["window_lookahead_h"] = 10.0
    fleet = load_fleet(write_fleet(doc, tmp_path / "f.toml"))
    assert np.isinf(step_planning_kw(fleet, planning, index, evening, 48)).all()
    for k in (0, 20, 48):  # from midnight on the window's day: all of it, at 0.9 × 50 kW
        seen = step_planning_kw(fleet, planning, index, k, 48)
        np.testing.assert_allclose(seen, planning[k : k + 48])
        assert np.min(seen) == pytest.approx(45.0)
    seen = step_planning_kw(fleet, planning, index, 33, 48)  # 16:30: today's last period only
    assert seen[0] == pytest.approx(45.0) and np.isinf(seen[1:]).all()


def test_the_guard_holds_the_limit_in_force_and_the_plans_its_margin(
    tmp_path: Path, guard_limits: Any
) -> None:
    """With ``feeder_margin`` m the plans hold to (1 − m) × the limit and the guard to the
    limit itself: the margin is headroom for the power model's error, which the guard does
    not take away by cutting at the planning limit."""
    import hvacflex.fleet.run as fleet_run

    doc = generate_fleet(3, 3, feeder_limit_kw=110.0, min_bid_mw=0.1)
    doc["coordination"]["max_iterations"] = 6
    doc["feeder_margin"] = 0.1
    guarded_at = guard_limits(fleet_run)
    path = write_fleet(doc, tmp_path / "fleet.toml")
    result = run_fleet(path, tmp_path / "run", start="2014-03-03 08:00", days=2 / 48, workers=0)
    assert guarded_at == [110.0, 110.0]
    assert np.all(result.frame["feeder_limit_kw"] == 110.0)
    planned = result.frame["planned_fleet_power_kw"]
    assert np.all(planned <= 99.0 + 1e-5) and planned.max() == pytest.approx(99.0)  # it binds
