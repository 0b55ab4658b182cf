"""A real server (``hvacflex serve`` on 127.0.0.1): replay equals simulate; kill -9 and
restart loses no acknowledged write and plans with the same objectives.

Both run on SQLite and PostgreSQL (``make_db_url``). The replays of one more feature each (a
filter, the similar-days baseline) read and write the database as the first does, so they run
on SQLite only (:data:`ON_SQLITE`)."""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from service_fixtures import SERVE, START, Server, free_port, operator_key_for, stored_plans

from hvacflex.config import preset, with_overrides
from hvacflex.errors import InputError
from hvacflex.results import RESULTS_FILENAME as RESULTS_FILE
from hvacflex.service.replay import (
    Client,
    RemoteControl,
    RemoteController,
    ServiceError,
    registration,
    replay,
)
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.plant import Actuation, Disturbance, Observation, RCPlant
from hvacflex.sim.run import run_simulation
from hvacflex.sim.run_files import read_results
from hvacflex.sim.setup import prepare

ON_SQLITE = pytest.mark.parametrize("make_db_url", ["sqlite"], indirect=True)
"""A replay test run on the service's SQLite database only (see the module's note)."""
DAYS = 1.0
KILL_AFTER_PLANS = 34
"""Plans acknowledged before the kill: the scenario's IL event runs over periods 33–38, so
the server is killed during the event."""
SETTINGS = {"seed": 9, "activation.mode": "stress", "activation.duration_steps": 6}
"""``stress`` activations (one every weekday, 08:00–18:00 starts) up to 6 periods long: with
seed 9 the day's event covers periods 33–38 (16:30–19:30; curtailed with reserve offered in
33–34), longer than D = 4, so the event start, its locked periods, a period beyond the model
and the recovery are all compared."""


def _config() -> Any:
    """``rmpc`` (IL event model, D = 4, R = 2) with one IL event on the day."""
    return with_overrides(preset("rmpc", start=START, days=DAYS), SETTINGS)


@pytest.fixture(scope="module")
def simulated_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``simulate`` of the replayed scenario (once for both databases)."""
    root = tmp_path_factory.mktemp("simulate")
    return run_simulation(_config(), root, progress=False, resume=False).out_dir


@pytest.fixture(scope="module")
def reference(
    tmp_path_factory: pytest.TempPathFactory,
    make_db_url: Callable[[str], str],
    simulated_dir: Path,
) -> Iterator[dict[str, Any]]:
    """An uninterrupted replay of one day and ``simulate`` of the same scenario."""
    root = tmp_path_factory.mktemp("replay")
    server = Server(make_db_url("ref"), free_port())
    server.start()
    try:
        key = operator_key_for(server.db_url)
        started = time.perf_counter()
        result = replay(server.url, key, _config(), root / "replay", building_id="ref")
        replay_s = time.perf_counter() - started
    finally:
        server.stop()
    yield {
        "replay": result,
        "replay_s": replay_s,
        "simulate_dir": simulated_dir,
        "replay_dir": root / "replay",
    }


def _comparable(frame: pd.DataFrame) -> pd.DataFrame:
    return frame.drop(columns=["solve_time_s"])


def test_replay_writes_the_files_of_simulate_and_equals_it(reference: dict[str, Any]) -> None:
    for name in ("results.parquet", "summary.json", "config.json"):
        assert (reference["replay_dir"] / name).is_file(), name
    replayed, meta_r = read_results(reference["replay_dir"] / RESULTS_FILE)
    simulated, meta_s = read_results(reference["simulate_dir"] / RESULTS_FILE)
    assert meta_r["config_hash"] == meta_s["config_hash"]
    assert len(replayed) == round(DAYS * 48)
    pd.testing.assert_frame_equal(
        _comparable(replayed), _comparable(simulated), check_exact=False, rtol=1e-9, atol=1e-9
    )
    assert not replayed["fallback"].any()
    # the day has an IL event: its start, locked periods (no solve), beyond D, recovery
    assert replayed["il_curtailed"].any() and replayed["il_beyond_model"].any()
    assert replayed.loc[replayed["il_curtailed"], "reserve_kw"].sum() > 0
    assert (replayed["solve_status"] == "event-plan").any()
    assert (replayed["il_event_window"] & ~replayed["il_curtailed"]).any()  # recovery
    roles = {plan["il_role"] for plan in reference["replay"].plans}
    assert {"served", "event-start", "event-locked", "beyond-model"} <= roles
    summary = reference["replay"].summary
    assert summary["energy_kwh"] == pytest.approx(float(simulated["power_kw"].sum()) * 0.5)


def test_kill9_and_restart_continue_from_the_database(
    reference: dict[str, Any], tmp_path: Path, make_db_url: Callable[[str], str]
) -> None:
    server = Server(make_db_url("killed"), free_port())
    server.start()
    acknowledged: list[dict[str, Any]] = []
    outcome: dict[str, Any] = {}
    try:
        key = operator_key_for(server.db_url)

        def play() -> None:
            try:
                replay(server.url, key, _config(), tmp_path / "first", building_id="kill",
                       on_plan=acknowledged.append)  # fmt: skip
            except (ServiceError, InputError, OSError) as exc:  # InputError: unreachable
                outcome["error"] = exc

        thread = threading.Thread(target=play)
        thread.start()
        deadline = time.monotonic() + 120
        while len(acknowledged) < KILL_AFTER_PLANS and time.monotonic() < deadline:
            time.sleep(0.01)
        server.kill9()  # mid-run: a request may be in flight
        thread.join(timeout=120)
        assert "error" in outcome, "the replay should have lost its server"
        killed_at = len(acknowledged)
        assert KILL_AFTER_PLANS <= killed_at < round(DAYS * 48)

        # every acknowledged plan is in the database, unchanged
        stored = stored_plans(server.db_url)
        for plan in acknowledged:
            assert stored[("kill", plan["period"], plan["revision"])] == plan["objective_sgd"]

        server.start()
        building_key = _building_key(server)
        result = replay(server.url, key, _config(), tmp_path / "second", building_id="kill",
                        building_key=building_key)  # fmt: skip
    finally:
        server.stop()

    ref_plans = reference["replay"].plans
    assert len(result.plans) == len(ref_plans)
    # periods already planned come back as stored; the rest are planned after the restart
    for before, after in zip(acknowledged, result.plans, strict=False):
        assert after["revision"] == before["revision"]
        assert after["objective_sgd"] == before["objective_sgd"]
    objectives = np.array([p["objective_sgd"] for p in result.plans], dtype=float)
    expected = np.array([p["objective_sgd"] for p in ref_plans], dtype=float)
    np.testing.assert_allclose(objectives, expected, rtol=1e-7, atol=1e-6)
    restarted, _ = read_results(tmp_path / "second" / RESULTS_FILE)
    uninterrupted, _ = read_results(reference["replay_dir"] / RESULTS_FILE)
    pd.testing.assert_frame_equal(
        _comparable(restarted), _comparable(uninterrupted), check_exact=False, rtol=1e-7,
        atol=1e-6,
    )  # fmt: skip


def _building_key(server: Server) -> str:
    """A new key for building ``kill`` (the registration's key went with the client)."""
    out = subprocess.run(
        [
            *SERVE,
            "key",
            "create",
            "--role",
            "building",
            "--building",
            "kill",
            "--db",
            server.db_url,
        ],
        check=True,
        capture_output=True,
        text=True,
        timeout=120,
    )
    return out.stdout.strip().splitlines()[-1]


class CoilAtLimitPlant(RCPlant):
    """The RC network, read as an outside emulator reads it: zone air only, and supply air
    1.5 K warmer than the model's (a coil at its limit), so the air delivers less cooling
    than the decided flow at the model's supply temperature."""

    def __init__(self, building: Any) -> None:
        super().__init__(building)
        self.supply_temp_degc = float(building.hvac.supply_temp_degc) + 1.5

    def step(self, actuation: Actuation, disturbance: Disturbance, dt_s: float) -> Observation:
        observed = super().step(actuation, disturbance, dt_s)
        supply = np.full(len(observed.zone_temp_degc), self.supply_temp_degc)
        return replace(observed, node_temp_degc=None, supply_temp_degc=supply)


@ON_SQLITE
def test_replay_equals_simulate_with_a_filter_on_a_plant_whose_air_delivers_otherwise(
    make_db_url: Callable[[str], str],
) -> None:
    """The Kalman filter predicts with the delivered cooling (``ClosedLoop._delivered_input``);
    in the service it arrives with the next measurement (``previous_delivered_flow_kg_s``),
    both through the period's inputs (``PeriodInputs.delivered_flow_kg_s``)."""
    config = with_overrides(
        preset("nmpc", start=f"{START}T09:00", days=0.125), {"estimation.mode": "kalman"}
    )
    setup = prepare(config)
    local = ClosedLoop(setup, plant=CoilAtLimitPlant(setup.building))
    while local.k < local.steps:
        local.step()
    server = Server(make_db_url("coil"), free_port())
    server.start()
    try:
        operator = Client(server.url, operator_key_for(server.db_url))
        key = str(operator.call("POST", "/v1/buildings", registration(config, "coil"))["key"])
        remote = RemoteController(Client(server.url, key), "coil")
        control = RemoteControl(remote, operator, setup.model.c.argmax(axis=1))
        plant = CoilAtLimitPlant(setup.building)
        played = ClosedLoop(prepare(config), plant=plant, control=control)
        posted: list[Any] = []
        while played.k < played.steps:
            remote.previous_power_kw = (
                None if played.k == 0 else float(played.frame()["power_kw"].iloc[-1])
            )
            posted.append(played.history.delivered_before_kg_s(played.k))
            played.step()
    finally:
        server.stop()
    assert posted[0] is None and all(flow is not None for flow in posted[1:])
    decided = local.frame()[[f"flow_{z}_kg_s" for z in setup.zone_names]].to_numpy()
    assert np.all(np.asarray(posted[1:]) < decided[:-1] - 1e-3)  # less than decided
    pd.testing.assert_frame_equal(
        _comparable(played.frame()), _comparable(local.frame()), check_exact=False, rtol=1e-9,
        atol=1e-9,
    )  # fmt: skip


@ON_SQLITE
def test_a_replay_with_the_similar_days_baseline_equals_simulate(
    tmp_path: Path, make_db_url: Callable[[str], str]
) -> None:
    """The service builds the baselines from the metered power the building posted
    (:class:`~hvacflex.sim.history.PeriodHistory` from its rows), as ``simulate`` does from
    its plant: a Monday and a Tuesday morning under ``similar-days`` (Tuesday's offers are
    sized to Monday's metered power) with stress activations plan the same."""
    config = with_overrides(
        preset("rmpc", start=START, days=1.5),
        {**SETTINGS, "reserve.il_baseline": "similar-days"},
    )
    server = Server(make_db_url("similar"), free_port())
    server.start()
    try:
        replay(
            server.url,
            operator_key_for(server.db_url),
            config,
            tmp_path / "replay",
            building_id="sd",
        )
    finally:
        server.stop()
    simulated = run_simulation(config, tmp_path / "simulate", progress=False, resume=False)
    replayed, _ = read_results(tmp_path / "replay" / RESULTS_FILE)
    pd.testing.assert_frame_equal(
        _comparable(replayed),
        _comparable(simulated.frame),
        check_exact=False,
        check_freq=False,
        rtol=1e-9,
        atol=1e-9,
    )
    tuesday = simulated.frame.iloc[48:]
    assert (tuesday["reserve_kw"] > 0).any() and tuesday["il_activated"].any()
