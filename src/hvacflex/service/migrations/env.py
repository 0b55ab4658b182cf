"""Alembic environment: runs on the connection :func:`hvacflex.service.db.migrate` passes."""

from __future__ import annotations

from alembic import context

from hvacflex.service.db import Base

connection = context.config.attributes.get("connection")
if connection is None:
    raise RuntimeError("run the migrations through hvacflex.service.db.migrate(engine)")
context.configure(connection=connection, target_metadata=Base.metadata)
with context.begin_transaction():
    context.run_migrations()
