"""The service's runtime (``hvacflex.service.runtime``): the metered history a plan sees is
kept in memory and read incrementally, and equals the history rebuilt from every row; with
``freeze_heap`` a building's objects leave the garbage collector's full passes once built."""

from __future__ import annotations

import gc
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from service_fixtures import registration
from sqlalchemy import update

from hvacflex.service.db import BuildingRow, Measurement, open_database, session_factory
from hvacflex.service.runtime import MeteredHistory, Runtime
from hvacflex.service.schemas import RegisterBuilding
from hvacflex.sim.history import PeriodHistory

STEPS = 6


def _history() -> PeriodHistory:
    index = pd.date_range("2014-03-03", periods=STEPS, freq="30min", tz="Asia/Singapore")
    return PeriodHistory.empty(index, STEPS)


def _add(sessions: Callable[..., object], period: int, power_kw: float | None) -> None:
    with sessions() as session, session.begin():  # type: ignore[attr-defined]
        session.add(
            Measurement(
                building_id="h1",
                period=period,
                body_json="{}",
                body_sha256=f"{period:064d}",
                previous_power_kw=power_kw,
            )
        )


def test_the_metered_history_reads_only_new_rows_and_equals_a_rebuild(
    tmp_path: Path,
) -> None:
    sessions = session_factory(open_database(f"sqlite:///{tmp_path}/h.db"))
    with sessions() as session, session.begin():
        session.add(
            BuildingRow(
                building_id="h1", description_json="{}", scenario_json="{}", created_by="test"
            )
        )
    metered = MeteredHistory(_history())
    _add(sessions, 0, None)  # the first period reports no power before it
    _add(sessions, 1, 12.5)
    with sessions() as session:
        history = metered.read(session, "h1")
    np.testing.assert_array_equal(history.power_kw[:2], [12.5, np.nan])
    _add(sessions, 2, 14.0)
    _add(sessions, 4, 9.0)  # period 3's measurement never came: period 2's power stays NaN
    with sessions() as session:
        # a row read before is not read again (changed here behind its back to prove it)
        session.execute(
            update(Measurement).where(Measurement.period == 1).values(previous_power_kw=99.0)
        )
        session.commit()
        history = metered.read(session, "h1")
    np.testing.assert_array_equal(history.power_kw, [12.5, 14.0, np.nan, 9.0, np.nan, np.nan])
    assert metered.last_id == 4
    rebuilt = MeteredHistory(_history())  # from scratch: every row, the changed one too
    with sessions() as session:
        fresh = rebuilt.read(session, "h1").power_kw
    np.testing.assert_array_equal(fresh, [99.0, 14.0, np.nan, 9.0, np.nan, np.nan])


@pytest.fixture
def unfrozen() -> Iterator[None]:
    """Whatever a test froze is handed back to the garbage collector after it."""
    gc.unfreeze()
    yield
    gc.unfreeze()


@pytest.mark.usefixtures("unfrozen")
@pytest.mark.parametrize("freeze", [False, True])
def test_a_building_built_is_frozen_out_of_full_collections_only_when_asked(
    tmp_path: Path, freeze: bool
) -> None:
    sessions = session_factory(open_database(f"sqlite:///{tmp_path / 'f.db'}"))
    runtime = Runtime(sessions, freeze_heap=freeze)
    body = RegisterBuilding.model_validate(registration("f1"))
    with sessions() as session, session.begin():
        built = runtime.register(session, "f1", body.building, body.scenario, "operator")
    frozen_after_register = gc.get_freeze_count()
    assert (frozen_after_register > 0) == freeze
    if freeze:  # the building's own objects are among the frozen: no full pass visits them
        assert all(o is not built for o in gc.get_objects(generation=2))
    runtime.evict("f1")
    gc.unfreeze()
    with sessions() as session:
        runtime.get(session, "f1")  # rebuilt from the database, as after a restart
    assert (gc.get_freeze_count() > 0) == freeze
