"""Initial schema: keys, buildings, measurements, signals, activations, plans, controller
state, clock and audit.

Revision ID: 0001
Revises:
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None

_TS = sa.DateTime(timezone=True)


def upgrade() -> None:
    op.create_table(
        "api_keys",
        sa.Column("key_id", sa.String(32), primary_key=True),
        sa.Column("role", sa.String(16), nullable=False),
        sa.Column("building_id", sa.String(64), nullable=True),
        sa.Column("salt_hex", sa.String(64), nullable=False),
        sa.Column("hash_hex", sa.String(128), nullable=False),
        sa.Column("created_at", _TS, nullable=False),
        sa.Column("revoked", sa.Boolean(), nullable=False),
    )
    op.create_table(
        "buildings",
        sa.Column("building_id", sa.String(64), primary_key=True),
        sa.Column("description_json", sa.Text(), nullable=False),
        sa.Column("scenario_json", sa.Text(), nullable=False),
        sa.Column("created_at", _TS, nullable=False),
        sa.Column("created_by", sa.String(32), nullable=False),
    )
    op.create_table(
        "measurements",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column(
            "building_id", sa.String(64), sa.ForeignKey("buildings.building_id"), nullable=False
        ),
        sa.Column("period", sa.Integer(), nullable=False),
        sa.Column("body_json", sa.Text(), nullable=False),
        sa.Column("body_sha256", sa.String(64), nullable=False),
        sa.Column("previous_power_kw", sa.Float(), nullable=True),
        sa.Column("received_at", _TS, nullable=False),
        sa.UniqueConstraint("building_id", "period", name="uq_measurement_period"),
    )
    op.create_index("ix_measurements_building_id", "measurements", ["building_id"])
    op.create_table(
        "signals",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("kind", sa.String(32), nullable=False),
        sa.Column("body_json", sa.Text(), nullable=False),
        sa.Column("created_at", _TS, nullable=False),
    )
    op.create_index("ix_signals_kind", "signals", ["kind"])
    op.create_table(
        "activations",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("building_id", sa.String(64), nullable=True),
        sa.Column("event", sa.String(8), nullable=False),
        sa.Column("time_utc", sa.String(40), nullable=False),
        sa.Column("created_at", _TS, nullable=False),
    )
    op.create_index("ix_activations_building_id", "activations", ["building_id"])
    op.create_table(
        "plans",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column(
            "building_id", sa.String(64), sa.ForeignKey("buildings.building_id"), nullable=False
        ),
        sa.Column("period", sa.Integer(), nullable=False),
        sa.Column("revision", sa.Integer(), nullable=False),
        sa.Column("trigger", sa.String(16), nullable=False),
        sa.Column("status", sa.String(32), nullable=False),
        sa.Column("fallback", sa.Boolean(), nullable=False),
        sa.Column("objective_sgd", sa.Float(), nullable=True),
        sa.Column("payload_json", sa.Text(), nullable=False),
        sa.Column("created_at", _TS, nullable=False),
        sa.UniqueConstraint("building_id", "period", "revision", name="uq_plan_revision"),
    )
    op.create_index("ix_plans_building_id", "plans", ["building_id"])
    op.create_table(
        "controller_state",
        sa.Column(
            "building_id",
            sa.String(64),
            sa.ForeignKey("buildings.building_id"),
            primary_key=True,
        ),
        sa.Column("period", sa.Integer(), nullable=False),
        sa.Column("state", sa.LargeBinary(), nullable=False),
        sa.Column("updated_at", _TS, nullable=False),
    )
    op.create_table(
        "service_clock",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("time_utc", sa.String(40), nullable=False),
    )
    op.create_table(
        "audit",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("at", _TS, nullable=False),
        sa.Column("key_id", sa.String(32), nullable=True),
        sa.Column("role", sa.String(16), nullable=True),
        sa.Column("method", sa.String(8), nullable=False),
        sa.Column("path", sa.String(512), nullable=False),
        sa.Column("status_code", sa.Integer(), nullable=False),
        sa.Column("body_sha256", sa.String(64), nullable=False),
        sa.Column("body_head", sa.Text(), nullable=False),
    )


def downgrade() -> None:
    for table in (
        "audit",
        "service_clock",
        "controller_state",
        "plans",
        "activations",
        "signals",
        "measurements",
        "buildings",
        "api_keys",
    ):
        op.drop_table(table)
