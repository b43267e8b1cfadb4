"""The server's operations, independent of HTTP: accept a submission, list, publish,
withdraw (used by the API and the command line)."""

from __future__ import annotations

import json
import secrets
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from sqlalchemy import func, select

from dressmeup.bench.boards.escape import one_line_problem, safe_url
from dressmeup.bench.scoring.validate import validate_submission
from dressmeup.errors import InputError
from dressmeup.server import pages
from dressmeup.server.config import ServerConfig
from dressmeup.server.db import EditionRow, Submission, Team, make_engine, migrate, sessions
from dressmeup.server.editions import add_edition
from dressmeup.server.scoring import Scorer, result_folder, submission_folder
from dressmeup.server.uploads import Upload, unpack


class NotFound(InputError):
    """An edition, submission or team the caller may not see (or that does not exist)."""


class LimitReached(InputError):
    """The team's submissions for this edition and day are used up."""


@dataclass
class Rejected(InputError):
    """A submission the validator refused: every problem, in words."""

    problems: list[str] = field(default_factory=list)

    def __str__(self) -> str:
        return "the submission is invalid:\n  " + "\n  ".join(self.problems)


class EvaluationServer:
    """A server's state: its database (migrated on start), folders, scorer thread and the
    public pages held in memory (:class:`~dressmeup.server.pages.PageCache`)."""

    def __init__(self, config: ServerConfig) -> None:
        self.config = config
        config.root.mkdir(parents=True, exist_ok=True)
        migrate(config.database_url)
        self.engine = make_engine(config.database_url)
        self.sessions = sessions(self.engine)
        self.scorer: Scorer | None = None
        self.pages = pages.PageCache(config)

    # ------------------------------------------------------------------ scorer
    def start(self) -> None:
        """Start the background scorer (it first settles what a killed server left)."""
        if self.scorer is None:
            self.scorer = Scorer(self.config, self.sessions, on_scored=self._scored)
            self.scorer.start()

    def stop(self) -> None:
        """Stop the scorer after its current submission."""
        if self.scorer is not None:
            self.scorer.stop()
            self.scorer.join(timeout=600)
            self.scorer = None
        self.engine.dispose()

    def _scored(self, sub_id: str) -> None:
        with self.sessions() as s:
            published = s.get(Submission, sub_id).published
        if published:
            self.rebuild_pages()

    def rebuild_pages(self) -> int:
        """Rebuild the public pages and drop the cached ones; returns the results shown."""
        try:
            return pages.rebuild(self.config, self.sessions)
        finally:
            self.pages.invalidate()

    def add_edition(self, name: str, private: str | Path) -> EditionRow:
        """Score edition ``name`` from its private part (see
        :func:`~dressmeup.server.editions.add_edition`); the public pages are rebuilt."""
        with self.sessions() as s:
            row = add_edition(s, name, private)
        self.rebuild_pages()
        return row

    # -------------------------------------------------------------- submissions
    def accept(self, team: Team, edition: str, upload: Upload) -> Submission:
        """Unpack, validate and queue an upload.

        Raises
        ------
        NotFound
            The edition is not scored here.
        LimitReached
            The team used its daily submissions for the edition.
        Rejected
            The validator's problems (nothing is kept).
        InputError
            An unsafe or oversized archive.
        """
        try:
            return self._accept(team, edition, upload)
        finally:
            upload.path.unlink(missing_ok=True)

    def _accept(self, team: Team, edition: str, upload: Upload) -> Submission:
        cfg = self.config
        with self.sessions() as s:
            ed = s.get(EditionRow, edition) if isinstance(edition, str) else None
            if ed is None:
                raise NotFound(f"edition {edition!r} is not scored on this server; GET "
                               "/api/editions lists those that are")
            day = pages.utcnow().strftime("%Y-%m-%d")
            used = s.scalar(select(func.count()).select_from(Submission).where(
                Submission.team_id == team.id, Submission.edition == ed.name,
                Submission.day == day))
            if used >= cfg.daily_limit:
                raise LimitReached(f"team {team.name} has used its {cfg.daily_limit} "
                                   f"submissions to {ed.name} for {day} (UTC); try tomorrow")
            private = ed.private_root
        sub_id = secrets.token_hex(16)
        folder = submission_folder(cfg, sub_id)
        try:
            unpack(upload.path, folder, cfg.max_members, cfg.max_unpacked_mb << 20)
            report = validate_submission(folder, edition, private)
            if not report.ok:
                raise Rejected(_public_problems(report, private))
            info = json.loads((folder / "submission.json").read_text(encoding="utf-8"))
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        with self.sessions() as s:
            sub = Submission(id=sub_id, team_id=team.id, edition=edition, day=day,
                             status="queued", error="", upload_sha256=upload.sha256,
                             method=str(info.get("method", ""))[:200], attempts=0,
                             published=False, public_method="", paper_url="", description="")
            s.add(sub)
            s.commit()
        if self.scorer is not None:
            self.scorer.wake.set()
        return sub

    def mine(self, team: Team) -> list[Submission]:
        """The team's submissions, newest first."""
        with self.sessions() as s:
            return list(s.scalars(select(Submission).where(Submission.team_id == team.id)
                                  .order_by(Submission.created_at.desc())))

    def get(self, team: Team, sub_id: str) -> Submission:
        """One of the team's submissions.

        Raises
        ------
        NotFound
            No such submission, or another team's (the same answer for both).
        """
        with self.sessions() as s:
            sub = s.get(Submission, sub_id) if isinstance(sub_id, str) else None
            if sub is None or sub.team_id != team.id:
                raise NotFound(f"no submission {sub_id!r} of team {team.name}")
            return sub

    def result(self, team: Team, sub_id: str) -> dict:
        """The summary of a scored submission of the team (the server's paths left out)."""
        sub = self.get(team, sub_id)
        if sub.status != "scored":
            raise NotFound(f"submission {sub_id} is {sub.status}, not scored")
        summary = json.loads((result_folder(self.config, sub_id) / "summary.json").read_text(
            encoding="utf-8"))
        summary.get("dataset", {}).pop("root", None)
        summary.pop("submission", None)
        summary.get("provenance", {}).pop("host", None)
        return summary

    def publish(self, team: Team, sub_id: str, method: str, paper_url: str = "",
                description: str = "") -> Submission:
        """Publish a scored result under a method name, with a paper link and description.

        Raises
        ------
        InputError
            Not scored, an empty, overlong or multi-line name, a link that is not http(s), a
            description over 2,000 characters.
        """
        sub = self.get(team, sub_id)
        if sub.status != "scored":
            raise InputError(f"submission {sub_id} is {sub.status}: only scored results can "
                             "be published")
        method = (method or "").strip()
        if not method or len(method) > 100:
            raise InputError("method: give a name of 1-100 characters")
        problem = one_line_problem(method, "method")
        if problem:
            raise InputError(problem)
        if paper_url and not safe_url(paper_url):
            raise InputError("paper_url: give an http(s) link")
        if len(description or "") > 2000:
            raise InputError("description: at most 2,000 characters")
        with self.sessions() as s:
            row = s.get(Submission, sub_id)
            row.published, row.public_method = True, method
            row.paper_url, row.description = paper_url or "", description or ""
            s.commit()
        self.rebuild_pages()
        return self.get(team, sub_id)

    def withdraw(self, team: Team, sub_id: str) -> Submission:
        """Take a published result off the public pages."""
        self.get(team, sub_id)
        with self.sessions() as s:
            s.get(Submission, sub_id).published = False
            s.commit()
        self.rebuild_pages()
        return self.get(team, sub_id)


def _public_problems(report, private: str) -> list[str]:
    """The validator's problems, one line each (``kind: item: message``), with the
    server's private paths taken out."""
    out = []
    for p in report.problems:
        line = f"{p.kind}: {(p.item_id + ': ') if p.item_id else ''}{p.message}"
        out.append(line.replace(str(Path(private)), "<edition data>"))
    return out
