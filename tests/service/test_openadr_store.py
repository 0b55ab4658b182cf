"""The VEN's record: events and settlement in the service's database layer (Alembic), and
the settlement of activated periods against metered power (hand-computed)."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest
from alembic import command
from alembic.config import Config
from sqlalchemy import create_engine, inspect, text

from hvacflex.service.db import MIGRATIONS_DIR
from hvacflex.service.openadr_store import (
    ActivationRun,
    EventRecord,
    VenStore,
    building_periods,
    settle_building,
)

T = pd.Timestamp("2014-03-03T09:00+08:00")
HALF = pd.Timedelta(minutes=30)


def _t(j: int) -> pd.Timestamp:
    return T + j * HALF


def test_an_event_record_survives_a_new_store_on_the_same_database(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'ven.db'}"
    store = VenStore.open(url, "site-1")
    run = ActivationRun(_t(1), _t(3), ("b1", "b2"))
    record = EventRecord("d1", 2, "far", "optIn", "b3 not activated", (run,), {"b1": {"x": 1.5}})
    store.save(record)
    store.save(EventRecord("p1", 0, "far", "optOut", "USD"))
    store.engine.dispose()
    again = VenStore.open(url, "site-1")
    assert again.get("d1") == record
    assert [r.event_id for r in again.events()] == ["d1", "p1"]
    assert [r.event_id for r in again.unsettled()] == ["d1"]  # p1 activated nothing
    assert VenStore.open(url, "site-2").get("d1") is None  # one record per VEN name
    newer = EventRecord("d1", 3, "cancelled", "optIn")
    again.save(newer)
    assert again.get("d1") == newer and len(again.events()) == 2


def test_a_run_lists_its_periods_and_a_building_its_activated_ones() -> None:
    runs = (ActivationRun(_t(1), _t(3), ("b1",)), ActivationRun(_t(2), _t(5), ("b1", "b2")))
    assert runs[0].periods() == [_t(1), _t(2)]
    assert building_periods(runs, "b1") == [_t(1), _t(2), _t(3), _t(4)]
    assert building_periods(runs, "b2") == [_t(2), _t(3), _t(4)]


def test_settlement_against_the_pre_event_baseline_by_hand() -> None:
    # two runs, 09:30–10:30 and 11:30; metered 50 kW at 09:00 and 11:00 (the baselines)
    periods = [_t(1), _t(2), _t(5)]
    metered = {_t(0): 50.0, _t(1): 46.0, _t(2): 51.0, _t(4): 50.0, _t(5): 47.0}
    reserve = {_t(1): 3.0, _t(2): 3.0, _t(5): 2.0}
    rows = settle_building("b1", periods, reserve, metered)
    assert [r.period_start for r in rows] == periods
    assert [r.baseline_kw for r in rows] == [50.0, 50.0, 50.0]
    assert [r.delivered_kw for r in rows] == [4.0, 0.0, 3.0]  # max(0, 50 − metered)
    assert [r.shortfall_kw for r in rows] == [0.0, 3.0, 0.0]  # max(0, offer − delivered)
    # no meter reading in the period, or none before the run: nothing shown delivered
    missing = settle_building("b1", [_t(1), _t(4)], {_t(1): 3.0, _t(4): 3.0}, {_t(0): 50.0})
    assert math.isnan(missing[0].metered_kw) and missing[0].delivered_kw == 0.0
    assert math.isnan(missing[1].baseline_kw) and missing[1].shortfall_kw == 3.0
    assert settle_building("b1", [], reserve, metered) == []


def test_the_migration_adds_the_ven_tables_to_a_service_database_of_0001(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_engine(url)
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    with engine.begin() as connection:
        cfg.attributes["connection"] = connection
        command.upgrade(cfg, "0001")
        connection.execute(
            text(
                "INSERT INTO signals (kind, body_json, created_at) "
                "VALUES ('peak_price', '{}', '2026-12-01')"
            )
        )
    assert "openadr_events" not in inspect(engine).get_table_names()
    engine.dispose()
    store = VenStore.open(url, "site-1")  # migrates to the newest schema
    tables = set(inspect(store.engine).get_table_names())
    assert {"openadr_events", "openadr_settlements", "signals"} <= tables
    with store.engine.connect() as connection:
        assert connection.execute(text("SELECT count(*) FROM signals")).scalar() == 1
        version = connection.execute(text("SELECT version_num FROM alembic_version")).scalar()
    assert version == "0002"
    store.engine.dispose()


@pytest.mark.parametrize("name", ["openadr_events", "openadr_settlements"])
def test_the_orm_tables_match_the_migration(tmp_path: Path, name: str) -> None:
    from hvacflex.service.db import Base

    store = VenStore.open(f"sqlite:///{tmp_path / 'ven.db'}", "site-1")
    migrated = {c["name"] for c in inspect(store.engine).get_columns(name)}
    assert migrated == set(Base.metadata.tables[name].columns.keys())
    store.engine.dispose()
