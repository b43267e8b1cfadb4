"""The first schema: teams, editions, submissions.

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


def upgrade() -> None:
    """Create the three tables."""
    op.create_table(
        "teams",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(100), nullable=False, unique=True),
        sa.Column("token_sha256", sa.String(64), nullable=False, unique=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("revoked_at", sa.DateTime(timezone=True), nullable=True),
    )
    op.create_table(
        "editions",
        sa.Column("name", sa.String(100), primary_key=True),
        sa.Column("edition_hash", sa.String(64), nullable=False),
        sa.Column("private_root", sa.Text(), nullable=False),
        sa.Column("added_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_table(
        "submissions",
        sa.Column("id", sa.String(32), primary_key=True),
        sa.Column("team_id", sa.Integer(), sa.ForeignKey("teams.id"), nullable=False),
        sa.Column("edition", sa.String(100), sa.ForeignKey("editions.name"), nullable=False),
        sa.Column("day", sa.String(10), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("error", sa.Text(), nullable=False),
        sa.Column("upload_sha256", sa.String(64), nullable=False),
        sa.Column("method", sa.String(200), nullable=False),
        sa.Column("attempts", sa.Integer(), nullable=False),
        sa.Column("scored_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("published", sa.Boolean(), nullable=False),
        sa.Column("public_method", sa.String(200), nullable=False),
        sa.Column("paper_url", sa.String(500), nullable=False),
        sa.Column("description", sa.Text(), nullable=False),
    )
    for col in ("team_id", "edition", "day", "status"):
        op.create_index(f"ix_submissions_{col}", "submissions", [col])


def downgrade() -> None:
    """Drop the three tables."""
    op.drop_table("submissions")
    op.drop_table("editions")
    op.drop_table("teams")
