"""Shared fixtures: paths to the shipped data and building files, a headless Chromium, and a
fabricated closed-loop results frame following docs/reference/results.md."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from hvacflex.paths import buildings_dir, data_dir


@pytest.fixture(scope="session", autouse=True)
def _private_data_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """The disk cache of derived data (hvacflex.data.cache) in a folder of this test session,
    not the user's ~/.cache (subprocesses inherit it)."""
    import os

    from hvacflex.data.cache import CACHE_DIR_ENV

    before = os.environ.get(CACHE_DIR_ENV)
    os.environ[CACHE_DIR_ENV] = str(tmp_path_factory.mktemp("hvacflex-cache"))
    yield
    if before is None:
        os.environ.pop(CACHE_DIR_ENV, None)
    else:
        os.environ[CACHE_DIR_ENV] = before


@pytest.fixture(autouse=True)
def _environment_restored() -> Iterator[None]:
    """Each test's changes to ``os.environ`` undone after it: Dask's ``LocalCluster`` sets
    ``OMP_NUM_THREADS``, ``PYTHONHASHSEED`` and others in the calling process, which the
    subprocesses of later tests would inherit."""
    import os

    before = dict(os.environ)
    yield
    if os.environ != before:
        os.environ.clear()
        os.environ.update(before)


@pytest.fixture(scope="session")
def shared_data_dir() -> Path:
    return data_dir()


@pytest.fixture(scope="session")
def shipped_buildings_dir() -> Path:
    return buildings_dir()


CHROMIUM_PATHS = ("/usr/bin/chromium", "/usr/bin/chromium-browser")
"""Debian's chromium (.ci/run installs it); Playwright drives it, no browser download."""


@pytest.fixture(scope="module")
def chromium() -> Iterator[Any]:
    """A headless Chromium (Playwright ``Browser``) on Debian's binary; the test is skipped
    where neither the binary nor the ``playwright`` package is installed."""
    import shutil

    sync_api = pytest.importorskip("playwright.sync_api")
    found = [path for path in CHROMIUM_PATHS if shutil.which(path)]
    if not found:
        pytest.skip("no chromium binary (apt-get install -y chromium)")
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=found[0], headless=True, args=["--no-sandbox", "--disable-gpu"]
        )
        yield browser
        browser.close()


TZ = "Asia/Singapore"
ZONES = ("north", "core")


def fabricate_results(
    *,
    start: str = "2014-03-03",
    days: float = 2.0,
    zones: tuple[str, ...] = ZONES,
    seed: int = 0,
    power_scale: float = 1.0,
    temp_offset_k: float = 0.0,
    predictions: bool = True,
) -> pd.DataFrame:
    """A plausible results frame: office-hours load, a USEP-like price, reserve offered while
    the load is up, IL activated in a few periods, curtailed ≥ served temperatures and the worst
    IL event 0.1 K above curtailed."""
    rng = np.random.default_rng(seed)
    n = round(days * 48)
    index = pd.date_range(start, periods=n, freq="30min", tz=TZ, name="time")
    hour = np.asarray(index.hour + index.minute / 60.0, dtype=float)
    occupied = (hour >= 8) & (hour < 18) & np.asarray(index.day_of_week < 5)
    price = 120.0 + 60.0 * np.sin(np.pi * (hour - 6.0) / 12.0).clip(0) + rng.normal(0, 5, n)
    power_kw = power_scale * np.where(occupied, 20.0, 5.0) + rng.uniform(0, 2, n)
    reserve_kw = np.where(occupied, 3.0, 0.0)
    il = np.zeros(n, dtype=bool)
    il[np.flatnonzero(occupied)[::7]] = True
    lower = np.where(occupied, 23.0, 20.0)
    upper = np.where(occupied, 26.0, 30.0)
    frame: dict[str, object] = {
        "energy_price_sgd_per_mwh": price,
        "reserve_price_sgd_per_mwh": 2.5 + rng.exponential(0.5, n),
        "peak_price_sgd_per_kw": 0.0,
        "power_kw": np.where(il, power_kw - reserve_kw, power_kw),
        "power_served_kw": power_kw,
        "power_curtailed_kw": power_kw - reserve_kw,
        "reserve_kw": reserve_kw,
        "il_activated": il,
    }
    for i, zone in enumerate(zones):
        served = np.where(occupied, 25.0, 27.0) + 0.2 * i + temp_offset_k + rng.normal(0, 0.1, n)
        curtailed = served + np.where(occupied, 0.4, 0.0)
        frame[f"flow_{zone}_kg_s"] = np.where(occupied, 1.0, 0.2)
        frame[f"reserve_flow_{zone}_kg_s"] = np.where(occupied, 0.2, 0.0)
        end = np.where(il, curtailed, served)
        frame[f"temp_{zone}_degc"] = np.roll(end, 1)
        frame[f"temp_end_{zone}_degc"] = end
        if predictions:
            frame[f"temp_served_{zone}_degc"] = served
            frame[f"temp_curtailed_{zone}_degc"] = curtailed
            frame[f"event_worst_{zone}_degc"] = curtailed + 0.1
        frame[f"comfort_lower_{zone}_degc"] = lower
        frame[f"comfort_upper_{zone}_degc"] = upper
    frame |= {
        "d_outdoor_temp": 30.0,
        "w_outdoor_temp": rng.uniform(-1, 1, n),
        "solve_status": "optimal",
        "solve_time_s": rng.uniform(0.005, 0.02, n),
        "fallback": False,
        "planned_slack_max_k": 0.0,
        "delta_max_k": 0.6,
    }
    return pd.DataFrame(frame, index=index)


@pytest.fixture
def make_results() -> Callable[..., pd.DataFrame]:
    """The :func:`fabricate_results` factory."""
    return fabricate_results


@pytest.fixture(scope="session")
def identified_model() -> Any:
    """A two-zone identified model with a plenum boundary node (the model-file format's and the
    closed loop's tests)."""
    from hvacflex.identify.greybox import GreyBoxParameters
    from hvacflex.identify.model_file import AirSystem, BoundaryNode, IdentifiedModel, PowerModel

    zone = np.array(
        [
            [800.0, 3.0e4, 0.05, 0.8, 0.03, 3.0, 6.0, 0.0, 2.0, 0.5, 0.0, 1.5, 0.4],
            [1200.0, 6.0e4, 0.08, 1.2, 0.05, 5.0, 8.0, 1.0, 0.0, 0.0, 3.0, 2.5, -0.2],
        ]
    )
    parameters = GreyBoxParameters(
        zone,
        np.array([[0, 1]], dtype=np.int64),
        np.array([0.3]),
        boundaries=1,
        boundary_couplings=np.array([[0, 0], [1, 0]], dtype=np.int64),
        boundary_ua_kw_per_k=np.array([0.5, 0.25]),
    )
    return IdentifiedModel(
        name="identified from trend.csv",
        zones=("space1_1", "space2_1"),
        energyplus_zones=("SPACE1-1", "Space2-1"),
        parameters=parameters,
        power=PowerModel(base_kw=1.0, kw_per_kw_cooling=0.3, kw_per_k_outdoor=0.05),
        provenance={"data": "trend.csv", "train": "2014-03-03..2014-03-17"},
        air=AirSystem(13.5, (0.0, 0.05), (0.6, 0.9), (0.1, 0.2), (22.5, 23.0)),
        boundaries=("PLENUM-1",),
        boundary_nodes=(BoundaryNode(300.0, 0.02, 1.5, 0.4, 25.5),),
    )
