"""The server's tables and their migrations.

Three tables: ``teams`` (name, the sha256 of the API token, revocation time), ``editions``
(name, edition hash, where the private part lives) and ``submissions`` (who sent what for
which edition, its state ``queued`` / ``scoring`` / ``scored`` / ``failed`` with the failure
in words, where its files and result are, and what the team chose to publish). The schema
is created and upgraded by Alembic (:func:`migrate`, migrations in
``dressmeup/server/migrations``); the same code runs on SQLite (the default, a file beside
the server's data) and on PostgreSQL.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from alembic import command
from alembic.config import Config
from sqlalchemy import (
    Boolean,
    DateTime,
    ForeignKey,
    Integer,
    String,
    Text,
    create_engine,
    event,
)
from sqlalchemy.engine import Engine
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, sessionmaker

STATES = ("queued", "scoring", "scored", "failed")


def utcnow() -> dt.datetime:
    """The current UTC time (timezone-aware)."""
    return dt.datetime.now(dt.timezone.utc)


class Base(DeclarativeBase):
    """Declarative base of the server's tables."""


class Team(Base):
    """A team: its name and the sha256 of its API token (the token itself is shown once)."""

    __tablename__ = "teams"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    token_sha256: Mapped[str] = mapped_column(String(64), unique=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    revoked_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True),
                                                           nullable=True)


class EditionRow(Base):
    """An edition the server scores, and where its private part is."""

    __tablename__ = "editions"
    name: Mapped[str] = mapped_column(String(100), primary_key=True)
    edition_hash: Mapped[str] = mapped_column(String(64))
    private_root: Mapped[str] = mapped_column(Text)
    added_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Submission(Base):
    """One accepted upload and its scoring."""

    __tablename__ = "submissions"
    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    team_id: Mapped[int] = mapped_column(ForeignKey("teams.id"), index=True)
    edition: Mapped[str] = mapped_column(ForeignKey("editions.name"), index=True)
    day: Mapped[str] = mapped_column(String(10), index=True)    # UTC date, for the limit
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    status: Mapped[str] = mapped_column(String(16), default="queued", index=True)
    error: Mapped[str] = mapped_column(Text, default="")
    upload_sha256: Mapped[str] = mapped_column(String(64))
    method: Mapped[str] = mapped_column(String(200))
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    scored_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True),
                                                          nullable=True)
    published: Mapped[bool] = mapped_column(Boolean, default=False)
    public_method: Mapped[str] = mapped_column(String(200), default="")
    paper_url: Mapped[str] = mapped_column(String(500), default="")
    description: Mapped[str] = mapped_column(Text, default="")


def make_engine(url: str) -> Engine:
    """An engine for ``url``; SQLite connections use WAL and a busy timeout, so the API and
    the scorer thread share the file."""
    if url.startswith("sqlite"):
        engine = create_engine(url, connect_args={"check_same_thread": False, "timeout": 30},
                               pool_pre_ping=True)

        @event.listens_for(engine, "connect")
        def _pragmas(conn, _record):  # noqa: ANN001 - SQLAlchemy's callback signature
            cur = conn.cursor()
            cur.execute("PRAGMA journal_mode=WAL")
            cur.execute("PRAGMA foreign_keys=ON")
            cur.close()

        return engine
    return create_engine(url, pool_pre_ping=True)


def sessions(engine: Engine) -> sessionmaker:
    """A session factory bound to ``engine`` (objects stay readable after commit)."""
    return sessionmaker(engine, expire_on_commit=False)


def alembic_config(url: str) -> Config:
    """The Alembic configuration of the server's migrations for database ``url``."""
    cfg = Config()
    cfg.set_main_option("script_location", str(Path(__file__).resolve().parent / "migrations"))
    cfg.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    return cfg


def migrate(url: str) -> None:
    """Create or upgrade the database at ``url`` to the current schema."""
    command.upgrade(alembic_config(url), "head")
