"""Settings of an evaluation server."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from dressmeup.errors import InputError


@dataclass(frozen=True)
class ServerConfig:
    """Where a server keeps its state and what it accepts.

    Attributes
    ----------
    root : the server's folder: ``server.db`` (SQLite default), ``uploads/`` (archives as
        received), ``submissions/<id>/`` (unpacked), ``results/<id>/`` (scores),
        ``published/<id>/`` (the public copies of published results) and ``site/`` (the
        public pages). The private parts of the editions live wherever the admin keeps
        them (``server add-edition --private``); nothing under them is ever served.
    database : SQLAlchemy URL (default ``sqlite:///<root>/server.db``;
        ``postgresql+psycopg://user:password@host/db`` for PostgreSQL).
    daily_limit : accepted submissions per team, edition and UTC day.
    max_upload_mb : largest upload (the archive as sent).
    max_unpacked_mb : largest total size of an unpacked submission.
    max_members : most files in a submission archive.
    workers : scoring worker processes (local executor).
    executor, scheduler : ``local`` (default) or ``dask`` with an optional scheduler address.
    poll_seconds : how often the scorer looks for queued submissions.
    score_in_process : score in the server's own process (for debugging) instead of in
        its scoring process: requests then wait while a submission is scored.
    """

    root: Path
    database: str | None = None
    daily_limit: int = 3
    max_upload_mb: int = 512
    max_unpacked_mb: int = 4096
    max_members: int = 100_000
    workers: int = 1
    executor: str = "local"
    scheduler: str | None = None
    poll_seconds: float = 1.0
    score_in_process: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "root", Path(self.root))
        for name in ("daily_limit", "max_upload_mb", "max_unpacked_mb", "max_members",
                     "workers"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise InputError(f"server setting {name}: expected an integer >= 1, got {v!r}")
        if self.executor not in ("local", "dask"):
            raise InputError(f"server setting executor: 'local' or 'dask', got "
                             f"{self.executor!r}")
        if not (0.01 <= float(self.poll_seconds) <= 60):
            raise InputError(f"server setting poll_seconds: between 0.01 and 60, got "
                             f"{self.poll_seconds!r}")

    @property
    def database_url(self) -> str:
        """The SQLAlchemy URL of the database."""
        return self.database or f"sqlite:///{(self.root / 'server.db').resolve()}"

    def folder(self, name: str) -> Path:
        """``root/name``, created when missing."""
        p = self.root / name
        p.mkdir(parents=True, exist_ok=True)
        return p

    @classmethod
    def from_env(cls, root: str | os.PathLike, **kw) -> ServerConfig:
        """A config whose database defaults to ``$DRESSMEUP_SERVER_DATABASE`` when set."""
        kw.setdefault("database", os.environ.get("DRESSMEUP_SERVER_DATABASE") or None)
        return cls(Path(root), **kw)
