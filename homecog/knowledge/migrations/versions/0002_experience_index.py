"""An index of the experience log by kind and user, for the history of corrections.

Revision ID: 0002
Revises: 0001
"""

from __future__ import annotations

from alembic import op

revision = "0002"
down_revision = "0001"


def upgrade() -> None:
    op.create_index("ix_experiences_kind_user_id", "experiences", ["kind", "user", "id"])


def downgrade() -> None:
    op.drop_index("ix_experiences_kind_user_id", table_name="experiences")
