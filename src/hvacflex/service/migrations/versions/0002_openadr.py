"""The OpenADR VEN's record: the events it answered and the settlement of its dispatches.

Revision ID: 0002
Revises: 0001
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None

_TS = sa.DateTime(timezone=True)


def upgrade() -> None:
    op.create_table(
        "openadr_events",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("ven_name", sa.String(128), nullable=False),
        sa.Column("event_id", sa.String(128), nullable=False),
        sa.Column("modification_number", sa.Integer(), nullable=False),
        sa.Column("event_status", sa.String(16), nullable=False),
        sa.Column("opt", sa.String(8), nullable=False),
        sa.Column("reason", sa.Text(), nullable=False),
        sa.Column("runs_json", sa.Text(), nullable=False),
        sa.Column("offers_json", sa.Text(), nullable=False),
        sa.Column("settled", sa.Boolean(), nullable=False),
        sa.Column("updated_at", _TS, nullable=False),
        sa.UniqueConstraint("ven_name", "event_id", name="uq_openadr_event"),
    )
    op.create_index("ix_openadr_events_ven_name", "openadr_events", ["ven_name"])
    op.create_table(
        "openadr_settlements",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("ven_name", sa.String(128), nullable=False),
        sa.Column("event_id", sa.String(128), nullable=False),
        sa.Column("building_id", sa.String(64), nullable=False),
        sa.Column("period_start", sa.String(40), nullable=False),
        sa.Column("reserve_kw", sa.Float(), nullable=False),
        sa.Column("metered_kw", sa.Float(), nullable=True),
        sa.Column("baseline_kw", sa.Float(), nullable=True),
        sa.Column("delivered_kw", sa.Float(), nullable=False),
        sa.Column("shortfall_kw", sa.Float(), nullable=False),
        sa.Column("settled_at", _TS, nullable=False),
        sa.UniqueConstraint(
            "ven_name", "event_id", "building_id", "period_start", name="uq_openadr_settlement"
        ),
    )
    op.create_index("ix_openadr_settlements_ven_name", "openadr_settlements", ["ven_name"])


def downgrade() -> None:
    op.drop_table("openadr_settlements")
    op.drop_table("openadr_events")
