"""The service database's text: NUL and text that is not UTF-8 stored, and found again, the
same way on SQLite and PostgreSQL (every test on both where PostgreSQL is set up)."""

from __future__ import annotations

import json
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import select

from hvacflex.service.db import (
    POOL_MAX_OVERFLOW,
    POOL_SIZE,
    Signal,
    bytes_as_text,
    db_text,
    make_engine,
    open_database,
    read_session_factory,
    session_factory,
)


@pytest.mark.parametrize(
    ("text", "stored"),
    [
        ("plain", "plain"),
        ("a\x00b", "a\\x00b"),
        ("\x00\x00", "\\x00\\x00"),
        ("lone \ud800 surrogate", "lone \\ud800 surrogate"),
        ("é 中 ✓", "é 中 ✓"),
        (json.dumps({"x": "\x00\ud800"}), json.dumps({"x": "\x00\ud800"})),  # JSON: unchanged
    ],
)
def test_db_text_escapes_only_what_a_database_refuses(text: str, stored: str) -> None:
    assert db_text(text) == stored
    assert "\x00" not in db_text(text)
    db_text(text).encode("utf-8")  # never raises


def test_bytes_as_text_shows_every_byte_that_is_not_utf8() -> None:
    assert bytes_as_text(b"\x00\xff garbage") == "\\x00\\xff garbage"
    assert bytes_as_text(b"\xff\xfe{}") == "\\xff\\xfe{}"
    assert bytes_as_text("é".encode()) == "é"
    assert bytes_as_text("é".encode()[:1]) == "\\xc3"  # a character cut by the head's limit


def test_text_with_nul_is_stored_and_found_alike(make_db_url: Callable[[str], str]) -> None:
    engine = open_database(make_db_url("text"))
    try:
        sessions = session_factory(engine)
        with sessions() as session, session.begin():
            session.add(Signal(kind="k\x00", body_json="\x00\ud800"))
        with sessions() as session:
            found = session.scalars(select(Signal).where(Signal.kind == "k\x00")).one()
            assert (found.kind, found.body_json) == ("k\\x00", "\\x00\\ud800")
    finally:
        engine.dispose()


def _in_transaction(session: Any) -> bool:
    """Whether the session's database connection is inside a transaction (the driver's own
    view: sqlite3's ``in_transaction``, psycopg's transaction status)."""
    raw = session.connection().connection.dbapi_connection
    if hasattr(raw, "in_transaction"):
        return bool(raw.in_transaction)
    return int(raw.info.transaction_status) != 0  # psycopg: 0 = IDLE


def test_a_read_session_holds_no_transaction_and_sees_each_commit(
    make_db_url: Callable[[str], str],
) -> None:
    engine = open_database(make_db_url("reads"))
    sessions, reads = session_factory(engine), read_session_factory(engine)
    with reads() as reader:
        with sessions() as writer, writer.begin():
            writer.add(Signal(kind="k", body_json="{}"))
        assert reader.scalars(select(Signal.kind)).all() == ["k"]
        assert not _in_transaction(reader)  # no BEGIN before, nothing to roll back after
        with sessions() as writer, writer.begin():
            writer.add(Signal(kind="l", body_json="{}"))
        assert reader.scalars(select(Signal.kind)).all() == ["k", "l"]  # no snapshot held
    with sessions() as ordinary:  # the control: on PostgreSQL an ordinary session opens
        ordinary.scalars(select(Signal.kind)).all()  # one (sqlite3 only before a write)
        assert _in_transaction(ordinary) == (engine.dialect.name == "postgresql")
    engine.dispose()


ANYIO_THREADS = 40
"""anyio's default threadpool: at most this many requests use the database at once."""


def test_the_pool_holds_a_connection_for_every_server_thread(tmp_path: Path) -> None:
    """SQLAlchemy's default pool (5 + 10) made twenty readers and ten writers queue for a
    connection (``pool_timeout``) on PostgreSQL: the pool now outnumbers the threads, and
    keeps a connection for each of them once opened."""
    assert POOL_SIZE + POOL_MAX_OVERFLOW > ANYIO_THREADS
    postgres = make_engine("postgresql+psycopg://u:p@127.0.0.1:1/none")  # never connects
    assert postgres.pool.size() == POOL_SIZE  # type: ignore[attr-defined]
    engine = make_engine(f"sqlite:///{tmp_path / 'pool.db'}")
    with ExitStack() as stack:
        held = [stack.enter_context(engine.connect()) for _ in range(ANYIO_THREADS + 1)]
        assert engine.pool.checkedout() == len(held)  # type: ignore[attr-defined]
    # every thread's connection is kept for the next request (none closed and opened anew)
    assert engine.pool.checkedin() >= ANYIO_THREADS  # type: ignore[attr-defined]
    assert make_engine("sqlite://").pool.__class__.__name__ != "QueuePool"  # in memory
