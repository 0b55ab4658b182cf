"""The service's tables (SQLAlchemy 2) and its database: SQLite by default, PostgreSQL by URL.

The schema is created and upgraded by the Alembic migrations shipped in
``hvacflex/service/migrations`` (run by :func:`migrate` when the service starts); the ORM
classes here mirror them.
"""

from __future__ import annotations

import os
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy import (
    Boolean,
    DateTime,
    Float,
    ForeignKey,
    Integer,
    LargeBinary,
    String,
    Text,
    UniqueConstraint,
    create_engine,
    event,
)
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.exc import ArgumentError, NoSuchModuleError, SQLAlchemyError
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, sessionmaker

from hvacflex.errors import InputError

DEFAULT_DB_URL = "sqlite:///hvacflex-service.db"
"""An SQLite file in the working folder (embedded, no set-up)."""
DB_URL_HINT = "use sqlite:///FILE or postgresql+psycopg://USER:PASSWORD@HOST:PORT/DB"
PRIVATE_FILE_MODE = 0o600
"""Mode of the files the service creates that hold secrets (the SQLite file, key files)."""

MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"

POOL_SIZE = 40
"""Connections an engine keeps open once opened (SQLite files and PostgreSQL): one for each
of the server's request threads (anyio's threadpool: 40 by default). A connection used
beyond the pool is closed when returned; with 10 kept, a loaded server opened and closed
six connections a second (each a new PostgreSQL backend and its password exchange) while
reads waited for it."""
POOL_MAX_OVERFLOW = 20
"""Connections opened beyond :data:`POOL_SIZE` when all are in use (the planner's threads
wait for their own). 60 in all stays under PostgreSQL's default ``max_connections`` (100);
a planning process opens only the few it uses."""


def utcnow() -> datetime:
    """Now, timezone-aware UTC."""
    return datetime.now(UTC)


class Base(DeclarativeBase):
    """Declarative base of the service tables."""


class ApiKey(Base):
    """An API key: the secret is stored only as a salted scrypt hash."""

    __tablename__ = "api_keys"
    key_id: Mapped[str] = mapped_column(String(32), primary_key=True)
    role: Mapped[str] = mapped_column(String(16))
    building_id: Mapped[str | None] = mapped_column(String(64), nullable=True)
    salt_hex: Mapped[str] = mapped_column(String(64))
    hash_hex: Mapped[str] = mapped_column(String(128))
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    revoked: Mapped[bool] = mapped_column(Boolean, default=False)


class BuildingRow(Base):
    """A registered building: its description and scenario settings as received."""

    __tablename__ = "buildings"
    building_id: Mapped[str] = mapped_column(String(64), primary_key=True)
    description_json: Mapped[str] = mapped_column(Text)
    scenario_json: Mapped[str] = mapped_column(Text)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    created_by: Mapped[str] = mapped_column(String(32))


class Measurement(Base):
    """A building's measurement at the start of one period (one per building + period)."""

    __tablename__ = "measurements"
    __table_args__ = (UniqueConstraint("building_id", "period", name="uq_measurement_period"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    building_id: Mapped[str] = mapped_column(ForeignKey("buildings.building_id"), index=True)
    period: Mapped[int] = mapped_column(Integer)
    body_json: Mapped[str] = mapped_column(Text)
    body_sha256: Mapped[str] = mapped_column(String(64))
    previous_power_kw: Mapped[float | None] = mapped_column(Float, nullable=True)
    received_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Signal(Base):
    """An operator signal: ``prices``, ``peak_price`` or ``feeder_limit`` (append-only)."""

    __tablename__ = "signals"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    kind: Mapped[str] = mapped_column(String(32), index=True)
    body_json: Mapped[str] = mapped_column(Text)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Activation(Base):
    """An IL activation start or end, for one building or (``building_id`` NULL) all."""

    __tablename__ = "activations"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    building_id: Mapped[str | None] = mapped_column(String(64), nullable=True, index=True)
    event: Mapped[str] = mapped_column(String(8))
    time_utc: Mapped[str] = mapped_column(String(40))
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class PlanRow(Base):
    """A stored plan; a new revision supersedes the earlier ones of the same period."""

    __tablename__ = "plans"
    __table_args__ = (
        UniqueConstraint("building_id", "period", "revision", name="uq_plan_revision"),
    )
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    building_id: Mapped[str] = mapped_column(ForeignKey("buildings.building_id"), index=True)
    period: Mapped[int] = mapped_column(Integer)
    revision: Mapped[int] = mapped_column(Integer)
    trigger: Mapped[str] = mapped_column(String(16))
    status: Mapped[str] = mapped_column(String(32))
    fallback: Mapped[bool] = mapped_column(Boolean)
    objective_sgd: Mapped[float | None] = mapped_column(Float, nullable=True)
    payload_json: Mapped[str] = mapped_column(Text)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class ControllerState(Base):
    """What a building's controller needs to continue warm-started, and its IL event state
    (:meth:`hvacflex.sim.step.ControlStep.get_state` in the data-only format of
    :mod:`hvacflex.state`: never unpickled; a pickle of an older hvacflex is refused)."""

    __tablename__ = "controller_state"
    building_id: Mapped[str] = mapped_column(ForeignKey("buildings.building_id"), primary_key=True)
    period: Mapped[int] = mapped_column(Integer)
    state: Mapped[bytes] = mapped_column(LargeBinary)
    updated_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class ServiceClock(Base):
    """The service clock set by the operator (one row; an accelerated or replayed clock)."""

    __tablename__ = "service_clock"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    time_utc: Mapped[str] = mapped_column(String(40))


class AuditEntry(Base):
    """One mutating request: who, when, what (method, path, status, body digest + head)."""

    __tablename__ = "audit"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    key_id: Mapped[str | None] = mapped_column(String(32), nullable=True)
    role: Mapped[str | None] = mapped_column(String(16), nullable=True)
    method: Mapped[str] = mapped_column(String(8))
    path: Mapped[str] = mapped_column(String(512))
    status_code: Mapped[int] = mapped_column(Integer)
    body_sha256: Mapped[str] = mapped_column(String(64))
    body_head: Mapped[str] = mapped_column(Text)


class OpenAdrEvent(Base):
    """An OpenADR event a VEN (``serve openadr-ven``) answered: its latest version, the opt,
    the activation runs it posted and the reserve each activated building offered
    (:mod:`hvacflex.service.openadr_store`)."""

    __tablename__ = "openadr_events"
    __table_args__ = (UniqueConstraint("ven_name", "event_id", name="uq_openadr_event"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    ven_name: Mapped[str] = mapped_column(String(128), index=True)
    event_id: Mapped[str] = mapped_column(String(128))
    modification_number: Mapped[int] = mapped_column(Integer)
    event_status: Mapped[str] = mapped_column(String(16))
    opt: Mapped[str] = mapped_column(String(8))
    reason: Mapped[str] = mapped_column(Text)
    runs_json: Mapped[str] = mapped_column(Text)
    offers_json: Mapped[str] = mapped_column(Text)
    settled: Mapped[bool] = mapped_column(Boolean, default=False)
    updated_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class OpenAdrSettlement(Base):
    """One activated period of an OpenADR dispatch, settled against metered power
    (:mod:`hvacflex.settlement`, pre-event baseline) [kW]."""

    __tablename__ = "openadr_settlements"
    __table_args__ = (
        UniqueConstraint(
            "ven_name", "event_id", "building_id", "period_start", name="uq_openadr_settlement"
        ),
    )
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    ven_name: Mapped[str] = mapped_column(String(128), index=True)
    event_id: Mapped[str] = mapped_column(String(128))
    building_id: Mapped[str] = mapped_column(String(64))
    period_start: Mapped[str] = mapped_column(String(40))
    reserve_kw: Mapped[float] = mapped_column(Float)
    metered_kw: Mapped[float | None] = mapped_column(Float, nullable=True)
    baseline_kw: Mapped[float | None] = mapped_column(Float, nullable=True)
    delivered_kw: Mapped[float] = mapped_column(Float)
    shortfall_kw: Mapped[float] = mapped_column(Float)
    settled_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


def db_text(value: str) -> str:
    """``value`` as text every database stores alike: a NUL (which PostgreSQL's text
    refuses) as the four characters ``\\x00``, a lone surrogate (not UTF-8) as its escape
    (``\\ud800`` for U+D800);
    any other text unchanged (JSON made by :func:`json.dumps` never changes)."""
    if "\x00" in value:
        value = value.replace("\x00", "\\x00")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        value = value.encode("utf-8", "backslashreplace").decode("utf-8")
    return value


def bytes_as_text(data: bytes) -> str:
    """Bytes a client sent as :func:`db_text`: UTF-8 decoded, every byte that is not UTF-8
    as ``\\xHH`` and every NUL as ``\\x00``, so the text shows what was sent."""
    return db_text(data.decode("utf-8", "backslashreplace"))


def _db_parameters(value: Any) -> Any:
    """Every string in a statement's parameters (a dict, a sequence or a list of them, by
    the driver's style) as :func:`db_text`."""
    if isinstance(value, str):
        return db_text(value)
    if isinstance(value, dict):
        return {name: _db_parameters(v) for name, v in value.items()}
    if isinstance(value, list | tuple):
        return type(value)(_db_parameters(v) for v in value)
    return value


def make_engine(url: str = DEFAULT_DB_URL) -> Engine:
    """An engine for ``url``; SQLite gets WAL, ``synchronous=FULL`` (a committed write
    survives a crash) and a busy timeout, and may be used from the server's threads. Every
    string a statement carries (stored or compared) goes through :func:`db_text`, so text
    is stored, and found again, the same way on SQLite and PostgreSQL. The pool holds
    :data:`POOL_SIZE` + :data:`POOL_MAX_OVERFLOW` connections (one per server thread)."""
    kwargs: dict[str, Any] = {}
    is_sqlite = url.startswith("sqlite")
    if is_sqlite:
        kwargs["connect_args"] = {"check_same_thread": False, "timeout": 30}
    if not is_sqlite or sqlite_file(url) is not None:  # in-memory SQLite has its own pool
        kwargs.update(pool_size=POOL_SIZE, max_overflow=POOL_MAX_OVERFLOW)
    engine = create_engine(url, **kwargs)

    @event.listens_for(engine, "before_cursor_execute", retval=True)
    def _safe_text(
        _connection: Any,
        _cursor: Any,
        statement: str,
        parameters: Any,
        _context: Any,
        _executemany: bool,
    ) -> tuple[str, Any]:
        return statement, _db_parameters(parameters)

    if is_sqlite:

        @event.listens_for(engine, "connect")
        def _pragmas(dbapi_connection: Any, _record: Any) -> None:
            cursor = dbapi_connection.cursor()
            cursor.execute("PRAGMA journal_mode=WAL")
            cursor.execute("PRAGMA synchronous=FULL")
            cursor.execute("PRAGMA foreign_keys=ON")
            cursor.close()

    return engine


def sqlite_file(url: str) -> Path | None:
    """The file of an SQLite URL (None for another database or an in-memory one)."""
    parsed = make_url(url)
    if parsed.get_backend_name() != "sqlite" or parsed.database in (None, "", ":memory:"):
        return None
    return Path(parsed.database)


def create_private_file(path: Path) -> None:
    """Create ``path`` empty with mode 0600 unless it exists (never widens an existing one)."""
    try:
        descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, PRIVATE_FILE_MODE)
    except FileExistsError:
        return
    os.close(descriptor)


def open_database(url: str = DEFAULT_DB_URL) -> Engine:
    """An engine on ``url``, migrated to the newest schema, checked before any work starts.

    A new SQLite file is created with mode 0600 (it holds the key hashes and the audit).

    Raises
    ------
    InputError : the URL is malformed, names an unknown dialect or driver, an SQLite file in
        a missing folder or a file that is not an SQLite database, or a server that does not
        answer (field ``db``; the message carries the driver's reason, never a traceback).
    """
    try:
        parsed = make_url(url)
        engine = make_engine(url)
    except (ArgumentError, NoSuchModuleError, ValueError) as exc:
        raise InputError(
            f"not a database URL this service can use ({exc})",
            field="db",
            value=url,
            hint=DB_URL_HINT,
        ) from None
    except ImportError as exc:
        raise InputError(
            f"the database driver is not installed ({exc})",
            field="db",
            value=url,
            hint='for PostgreSQL: pip install "psycopg[binary]"',
        ) from None
    path = sqlite_file(url)
    if path is not None:
        if not path.parent.is_dir():
            raise InputError(
                "the folder of the SQLite file does not exist",
                field="db",
                value=url,
                hint=f"create {path.parent} first, or choose another file",
            )
        if path.is_dir():
            raise InputError("names a folder, not a file", field="db", value=url, hint=DB_URL_HINT)
        create_private_file(path)
    try:
        migrate(engine)
    except SQLAlchemyError as exc:
        engine.dispose()
        reason = str(getattr(exc, "orig", None) or exc).strip().splitlines()[0]
        what = "an SQLite database" if path is not None else "a database server"
        raise InputError(
            f"cannot open the database ({reason})",
            field="db",
            value=parsed.render_as_string(hide_password=True),
            hint=f"check that it is {what} this user may write and that it is running",
        ) from None
    return engine


def migrate(engine: Engine) -> None:
    """Bring the database to the newest schema with the shipped Alembic migrations."""
    from alembic import command
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    with engine.begin() as connection:
        cfg.attributes["connection"] = connection
        command.upgrade(cfg, "head")


def session_factory(engine: Engine) -> sessionmaker[Any]:
    """Sessions bound to ``engine`` that keep loaded attributes after commit."""
    return sessionmaker(engine, expire_on_commit=False)


def read_session_factory(engine: Engine) -> sessionmaker[Any]:
    """Sessions for reads only, each statement in its own (autocommit) transaction: no
    ``BEGIN`` and ``ROLLBACK`` round trips around a read (on PostgreSQL a key check and a
    plan read are 2–3 round trips instead of 7). Never write through them."""
    return sessionmaker(
        engine.execution_options(isolation_level="AUTOCOMMIT"), expire_on_commit=False
    )
