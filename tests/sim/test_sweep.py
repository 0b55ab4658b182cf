from dataclasses import replace
from pathlib import Path

import pandas as pd
import pytest

from hvacflex.config import preset, with_overrides
from hvacflex.errors import ConfigError, MissingExtraError
from hvacflex.sim.sweep import (
    DASHBOARD_ADDRESS,
    SweepClock,
    close_dask,
    expand_grid,
    outcomes_table,
    parse_param,
    quiet_dask_logs,
    relative_cost,
    run_sweep,
)


def test_parse_param_values() -> None:
    assert parse_param("peak_price_sgd_per_kw=0.5,1,2") == ("peak_price_sgd_per_kw", [0.5, 1, 2])
    assert parse_param("controller.reserve=true,false")[1] == [True, False]
    with pytest.raises(ConfigError, match="NAME=V1"):
        parse_param("peak_price_sgd_per_kw")


def test_grid_is_the_product_and_validated() -> None:
    base = preset("rmpc-ppp", days=1.0)
    jobs = expand_grid(base, {"peak_price_sgd_per_kw": [1.0, 2.0], "seed": [1, 2, 3]})
    assert len(jobs) == 6
    assert {cfg.controller.peak_price_sgd_per_kw for _, cfg in jobs} == {1.0, 2.0}
    with pytest.raises(ConfigError):
        expand_grid(base, {"peak_price_sgd_per_kw": [-1.0]})


def test_a_failing_job_does_not_lose_the_others(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    base = preset("thermostat", start="2014-03-03", days=0.25)
    jobs = expand_grid(base, {"building": ["office5", "no-such-building"]})
    done = []
    outcomes = run_sweep(jobs, tmp_path, n_workers=2, on_done=done.append, progress=True)
    assert len(done) == 2
    printed = capfd.readouterr()
    assert "sweep" in printed.out and "2/2" in printed.out and "1 failed" in printed.out
    assert " - WARNING - " not in printed.err  # no stray Dask warnings (its errors show)
    ok, failed = outcomes
    assert ok.ok and ok.summary is not None and ok.summary["steps"] == 12
    assert not failed.ok and "no-such-building" in (failed.error or "")
    table = outcomes_table(outcomes)
    assert list(table["status"]) == ["ok", "failed"]
    # finished runs are cached: a second sweep re-uses the results
    again = run_sweep(jobs[:1], tmp_path, n_workers=1)
    assert again[0].summary is not None
    assert pd.Series(again[0].summary).equals(pd.Series(ok.summary))  # NaN: no such periods
    assert again[0].cached and not ok.cached
    assert list(outcomes_table(again)["cached"]) == [True]
    # --fresh simulates again
    fresh = run_sweep(jobs[:1], tmp_path, n_workers=1, fresh=True)
    assert fresh[0].ok and not fresh[0].cached


@pytest.mark.parametrize("workers", [1, 2])
def test_without_dask_jobs_run_on_local_processes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, workers: int
) -> None:
    """Without the dask extra a sweep runs in this process (one worker) or on a
    concurrent.futures pool; a failing job is reported, the others finish."""
    import hvacflex.sim.sweep as sweep

    monkeypatch.setattr(sweep, "has_extra", lambda extra: extra != "dask")
    monkeypatch.setattr(sweep, "start_local_dask", None)  # any use of Dask fails
    base = preset("thermostat", start="2014-03-03", days=0.25)
    jobs = expand_grid(base, {"building": ["office5", "no-such-building"]})
    done: list[str] = []
    outcomes = run_sweep(jobs, tmp_path, n_workers=workers, on_done=lambda o: done.append(o.label))
    assert len(done) == 2
    ok, failed = outcomes
    assert ok.ok and ok.summary is not None and ok.summary["steps"] == 12
    assert not failed.ok and "no-such-building" in (failed.error or "")
    again = run_sweep(jobs[:1], tmp_path, n_workers=workers)
    assert sweep.backend(None, workers) == ("this process" if workers == 1 else "2 local processes")
    assert again[0].cached and again[0].summary is not None
    assert again[0].summary["energy_kwh"] == ok.summary["energy_kwh"]


def test_a_scheduler_without_dask_is_refused_with_the_install_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import importlib.util

    import hvacflex.sim.sweep as sweep

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "dask" else real(name)
    )
    base = preset("thermostat", start="2014-03-03", days=0.25)
    with pytest.raises(MissingExtraError, match=r'pip install -e "\.\[dask\]"'):
        run_sweep([({}, base)], tmp_path, scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(MissingExtraError, match="--scheduler"):
        sweep.check_scheduler("tcp://127.0.0.1:8786")
    assert not (tmp_path / "runs").exists()


def test_longest_jobs_start_first(tmp_path: Path) -> None:
    week = preset("rmpc", days=7.0)
    assert relative_cost(preset("rmpc-feedback", days=7.0)) > relative_cost(week)
    assert relative_cost(preset("rmpc", days=365.0)) > relative_cost(week)
    assert relative_cost(preset("rmpc-ppp", days=7.0)) > relative_cost(week)  # the peak priced
    thermostat = preset("thermostat", days=7.0)  # no LP: a peak price costs it nothing more
    priced = with_overrides(thermostat, {"controller.peak_price_sgd_per_kw": 1.5})
    assert relative_cost(priced) == relative_cost(thermostat)
    feedback = preset("rmpc-feedback", days=7.0)  # its peak-priced year was the cheaper one
    assert relative_cost(preset("rmpc-feedback-ppp", days=7.0)) == relative_cost(feedback)
    assert relative_cost(preset("thermostat", days=28.0)) < relative_cost(week)
    short = preset("thermostat", start="2014-03-03", days=0.25)
    jobs = [({"days": 0.25}, short), ({"days": 0.5}, replace(short, days=0.5))]
    done: list[dict[str, float]] = []
    outcomes = run_sweep(jobs, tmp_path, n_workers=1, on_done=lambda o: done.append(o.params))
    assert done == [{"days": 0.5}, {"days": 0.25}]  # one worker: the longer one ran first
    assert [o.params for o in outcomes] == [{"days": 0.25}, {"days": 0.5}]  # order of jobs
    assert [o.summary["steps"] for o in outcomes if o.summary] == [12, 24]
    assert all(o.cpu_s is not None and o.cpu_s > 0 for o in outcomes)  # each job's own CPU


def test_quiet_dask_logs_here_and_for_the_workers() -> None:
    import logging

    import dask

    quiet_dask_logs()
    assert logging.getLogger("distributed").getEffectiveLevel() == logging.ERROR
    assert dask.config.get("logging.distributed") == "error"


class _Recorder:
    """A stand-in Dask client or cluster that records the calls made to it."""

    def __init__(self, calls: list[str], name: str, fail_run: bool = False) -> None:
        self.calls, self.name, self.fail_run = calls, name, fail_run

    def run(self, function: object, callback_timeout: float | None = None) -> None:
        assert callback_timeout is not None and 0 < callback_timeout <= 30  # never waits forever
        self.calls.append(f"{self.name}.run")
        if self.fail_run:
            raise OSError("worker gone")

    def close(self) -> None:
        self.calls.append(f"{self.name}.close")


@pytest.mark.parametrize("fail_run", [False, True])
def test_close_dask_silences_owned_workers_first_and_always_closes(fail_run: bool) -> None:
    calls: list[str] = []
    client = _Recorder(calls, "client", fail_run)
    close_dask(client, _Recorder(calls, "cluster"))
    assert calls == ["client.run", "client.close", "cluster.close"]
    calls.clear()
    close_dask(client, None)  # a cluster hvacflex did not start: its workers are left alone
    assert calls == ["client.close"]


def test_close_dask_silences_the_workers_of_a_real_cluster() -> None:
    """The bounded wait goes to Dask (``Client.sync``), not to the silencing function: a
    keyword Dask did not take would reach the function, fail and leave the workers loud."""
    import logging

    from distributed import Client, LocalCluster

    distributed_log = logging.getLogger("distributed")
    level = distributed_log.level
    cluster = LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=DASHBOARD_ADDRESS
    )
    try:
        close_dask(Client(cluster), cluster)  # in-process worker: its loggers are these
        assert distributed_log.level == logging.CRITICAL
    finally:
        distributed_log.setLevel(level)


def test_start_local_dask_closes_its_cluster_when_the_client_fails(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import dask.distributed

    from hvacflex.sim.sweep import start_local_dask

    closed: list[bool] = []

    class _Cluster:
        def __init__(self, **kwargs: object) -> None:
            assert kwargs["threads_per_worker"] == 1 and kwargs["processes"] is True

        def close(self) -> None:
            closed.append(True)

    def _refuse(cluster: object) -> None:
        raise OSError("scheduler unreachable")

    monkeypatch.setattr(dask.distributed, "LocalCluster", _Cluster)
    monkeypatch.setattr(dask.distributed, "Client", _refuse)
    with pytest.raises(OSError, match="unreachable"):
        start_local_dask(2)
    assert closed == [True]  # no worker processes left behind


def test_the_clock_weighs_jobs_by_cost_and_gives_no_eta_before_a_real_run(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import hvacflex.sim.sweep as sweep

    now = [100.0]
    monkeypatch.setattr(sweep.time, "perf_counter", lambda: now[0])
    clock = SweepClock([1.0, 1.0, 2.0])
    now[0] = 101.0
    assert clock.finished(1.0, cached=True) == (1.0, None)  # cached: nothing to scale by
    now[0] = 111.0
    elapsed, eta = clock.finished(1.0, cached=False)  # 1 cost unit ran in 11 s, 2 are left
    assert elapsed == 11.0 and eta == pytest.approx(22.0)
    now[0] = 131.0
    assert clock.finished(2.0, cached=False) == (31.0, 0.0)


def test_a_local_cluster_does_not_warn_when_port_8787_is_busy() -> None:
    import socket
    import warnings

    from hvacflex.sim.sweep import start_local_dask

    busy = socket.socket()
    busy.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        busy.bind(("127.0.0.1", 8787))
        busy.listen()
    except OSError:
        pass  # already busy: as good
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cluster, client = start_local_dask(1)
            close_dask(client, cluster)
        assert [str(w.message) for w in caught if "8787" in str(w.message)] == []
    finally:
        busy.close()
