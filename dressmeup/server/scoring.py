"""The background scorer: every accepted submission scored exactly once, across restarts.

A submission moves ``queued`` -> ``scoring`` -> ``scored`` | ``failed``. The scorer claims
one queued submission at a time with a conditional update (only one claimant wins), scores
it with the toolkit's own :func:`~dressmeup.bench.scoring.score.score_submission` into
``results/<id>`` (written in a hidden folder and renamed into place: a result either exists
whole or not at all), then records ``scored``. On start, :func:`recover` settles what a
killed server left: a ``scoring`` submission whose result exists is ``scored``; one without
goes back to ``queued`` (its earlier attempt produced nothing), so nothing is lost and
nothing is scored twice. A scoring worker that dies mid-item is retried once, then the
submission is ``failed`` with the reason in words.

Scoring runs in the server's scoring process (:class:`ScoringProcess`, spawned on the first
submission; it starts the configured executor's workers itself), so that the process
answering requests never holds its interpreter lock for a submission's geometry.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import shutil
import threading
import traceback
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

from sqlalchemy import select, update
from sqlalchemy.orm import sessionmaker

from dressmeup.bench.scoring.score import score_submission
from dressmeup.errors import DressmeupError
from dressmeup.executors import make_executor
from dressmeup.executors.local import die_with_parent
from dressmeup.server.config import ServerConfig
from dressmeup.server.db import EditionRow, Submission, utcnow

log = logging.getLogger(__name__)
#: tries of one submission whose scoring process died
MAX_ATTEMPTS = 2


def result_folder(config: ServerConfig, sub_id: str) -> Path:
    """Where a submission's result lives."""
    return config.root / "results" / sub_id


def submission_folder(config: ServerConfig, sub_id: str) -> Path:
    """Where a submission's unpacked files live."""
    return config.root / "submissions" / sub_id


def recover(config: ServerConfig, sessions: sessionmaker) -> int:
    """Settle the submissions a killed server left ``scoring``; returns how many were
    re-queued."""
    requeued = 0
    with sessions() as s:
        for sub in s.scalars(select(Submission).where(Submission.status == "scoring")):
            res = result_folder(config, sub.id)
            if (res / "summary.json").is_file():
                sub.status, sub.scored_at = "scored", sub.scored_at or utcnow()
            else:
                shutil.rmtree(res, ignore_errors=True)
                sub.status = "queued"
                requeued += 1
        s.commit()
    return requeued


def claim(sessions: sessionmaker) -> str | None:
    """Claim the oldest queued submission (``queued`` -> ``scoring``); None when none."""
    with sessions() as s:
        for sub_id in s.scalars(select(Submission.id).where(Submission.status == "queued")
                                .order_by(Submission.created_at, Submission.id).limit(5)):
            won = s.execute(update(Submission).where(Submission.id == sub_id,
                                                     Submission.status == "queued")
                            .values(status="scoring", attempts=Submission.attempts + 1))
            s.commit()
            if won.rowcount == 1:
                return sub_id
    return None


def score_one(config: ServerConfig, sessions: sessionmaker, sub_id: str,
              score: Callable = score_submission, executor=None) -> str:
    """Score a claimed submission and record the outcome; returns the new status."""
    with sessions() as s:
        sub = s.get(Submission, sub_id)
        ed = s.get(EditionRow, sub.edition)
        edition, private, attempts = sub.edition, ed.private_root, sub.attempts
    out = result_folder(config, sub_id)
    shutil.rmtree(out, ignore_errors=True)
    status, error = "scored", ""
    try:
        score(submission_folder(config, sub_id), edition, private, out, executor=executor,
              show_progress=False)
    except DressmeupError as exc:
        status, error = "failed", str(exc)
    except Exception as exc:  # noqa: BLE001 - any failure is recorded in words
        name = exc.name if isinstance(exc, ScoringError) else type(exc).__name__
        died = "BrokenProcessPool" in name or "died" in str(exc)
        if died and attempts < MAX_ATTEMPTS:
            status = "queued"
            error = f"a scoring process died ({name}); retried"
        else:
            status = "failed"
            error = ("a scoring process died twice; the submission may crash the scorer"
                     if died else f"internal error while scoring: {name}: {exc}")
            log.error("scoring %s failed:\n%s", sub_id,
                      exc.trace if isinstance(exc, ScoringError) else traceback.format_exc())
    with sessions() as s:
        sub = s.get(Submission, sub_id)
        sub.status, sub.error = status, error[:4000]
        if status == "scored":
            sub.scored_at = utcnow()
        s.commit()
    return status


class ScoringError(Exception):
    """An error of the scoring process that is not the submission's fault, as text: the
    exception's class ``name``, its message and the process's traceback ``trace``."""

    def __init__(self, name: str, message: str, trace: str = "") -> None:
        super().__init__(message)
        self.name, self.trace = name, trace

    def __reduce__(self):
        return type(self), (self.name, str(self), self.trace)


#: the scoring process's executor, built on its first submission: (settings, executor)
_EXECUTOR: list[Any] = []


def _score_here(args: tuple) -> tuple[str, str, str, str]:
    """In the scoring process: score one submission; ``("scored", "", "", "")``,
    ``("failed", name, message, "")`` (the submission's fault) or ``("error", name,
    message, traceback)``. Outcomes are plain strings: an exception whose constructor
    takes other arguments than its message would not cross the process boundary."""
    submission, edition, private, out, settings = args
    try:
        if not _EXECUTOR or _EXECUTOR[0] != settings:
            _EXECUTOR[:] = [settings, make_executor(*settings, default_workers=1)]
        score_submission(submission, edition, private, out, executor=_EXECUTOR[1],
                         show_progress=False)
    except DressmeupError as exc:
        return "failed", type(exc).__name__, str(exc), ""
    except Exception as exc:  # noqa: BLE001 - reported to the server in words
        return "error", type(exc).__name__, str(exc), traceback.format_exc()
    return "scored", "", "", ""


def _init_scoring_process(parent_pid: int) -> None:
    die_with_parent(parent_pid)


class ScoringProcess:
    """The server's scoring process: ``proc(submission, edition, private, out, executor=,
    show_progress=)`` scores as :func:`~dressmeup.bench.scoring.score.score_submission` does,
    in one spawned process kept between submissions (started again after it died).

    Raises
    ------
    DressmeupError
        The submission's fault (the message of the scoring process's error).
    ScoringError
        Anything else; ``BrokenProcessPool`` when the process died.
    """

    def __init__(self, config: ServerConfig) -> None:
        self.settings = (config.executor, config.workers, config.scheduler)
        self._pool: ProcessPoolExecutor | None = None

    def __call__(self, submission: Path, edition: str, private: Any, out: Path,
                 executor: Any = None, show_progress: bool = False) -> None:
        if self._pool is None:
            self._pool = ProcessPoolExecutor(
                1, mp_context=multiprocessing.get_context("spawn"),
                initializer=_init_scoring_process, initargs=(os.getpid(),))
        try:
            kind, name, message, trace = self._pool.submit(
                _score_here, (submission, edition, private, out, self.settings)).result()
        except BrokenProcessPool as exc:
            self.close()
            raise ScoringError("BrokenProcessPool", f"the scoring process died ({exc})") from exc
        if kind == "failed":
            raise DressmeupError(message)
        if kind == "error":
            raise ScoringError(name, message, trace)

    def close(self) -> None:
        """End the scoring process (after its current submission)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


class Scorer(threading.Thread):
    """A daemon thread scoring queued submissions one at a time until :meth:`stop`.

    ``on_scored(sub_id)`` is called after each success (the server rebuilds its pages when
    a published result changes)."""

    def __init__(self, config: ServerConfig, sessions: sessionmaker,
                 on_scored: Callable[[str], None] | None = None) -> None:
        super().__init__(name="dressmeup-scorer", daemon=True)
        self.config, self.sessions, self.on_scored = config, sessions, on_scored
        self._halt = threading.Event()
        self.wake = threading.Event()
        if config.score_in_process:
            self.score: Callable = score_submission
            self.executor = make_executor(config.executor, config.workers, config.scheduler,
                                          default_workers=1)
        else:
            self.score, self.executor = ScoringProcess(config), None

    def stop(self) -> None:
        """Ask the thread to end after the current submission."""
        self._halt.set()
        self.wake.set()

    def run(self) -> None:
        try:
            self._loop()
        finally:
            if isinstance(self.score, ScoringProcess):
                self.score.close()

    def _loop(self) -> None:
        recover(self.config, self.sessions)
        while not self._halt.is_set():
            sub_id = claim(self.sessions)
            if sub_id is None:
                self.wake.wait(self.config.poll_seconds)
                self.wake.clear()
                continue
            status = score_one(self.config, self.sessions, sub_id, score=self.score,
                               executor=self.executor)
            if status == "scored" and self.on_scored is not None:
                try:
                    self.on_scored(sub_id)
                except Exception:  # noqa: BLE001 - pages are rebuilt on the next change
                    log.exception("rebuilding the pages after %s failed", sub_id)
