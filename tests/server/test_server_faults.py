"""The evaluation server under faults: killed while scoring (kill -9), a scoring process
dying, the database refusing writes, the disk full. Every accepted submission is scored
exactly once; a refused write leaves no half-written row or file."""

from __future__ import annotations

import errno
import importlib.util
import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402
from sqlalchemy import select  # noqa: E402
from sqlalchemy.exc import OperationalError  # noqa: E402

from dressmeup.server import scoring  # noqa: E402
from dressmeup.server.accounts import add_team  # noqa: E402
from dressmeup.server.app import create_app  # noqa: E402
from dressmeup.server.config import ServerConfig  # noqa: E402
from dressmeup.server.db import Submission  # noqa: E402
from dressmeup.server.editions import add_edition  # noqa: E402
from dressmeup.server.service import EvaluationServer  # noqa: E402

_spec = importlib.util.spec_from_file_location("server_fixtures",
                                               Path(__file__).resolve().parent / "conftest.py")
fx = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fx)
EDITION = fx.EDITION


def _setup(root: Path, private: Path) -> str:
    srv = EvaluationServer(ServerConfig(root))
    with srv.sessions() as s:
        token = add_team(s, "lab")[1]
        add_edition(s, EDITION, private)
    srv.engine.dispose()
    return token


def _start(root: Path, port: int) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "dressmeup", "serve", "--root",
                             str(root), "--port", str(port)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    for _ in range(300):
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/api/editions", timeout=1)
            return proc
        except OSError:
            time.sleep(0.1)
    proc.kill()
    raise AssertionError("the server did not start")


def _get(port: int, path: str, token: str) -> dict:
    req = urllib.request.Request(f"http://127.0.0.1:{port}{path}",
                                 headers={"Authorization": f"Bearer {token}"})
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.loads(r.read())


def test_killed_while_scoring_then_scored_exactly_once(tiny_parts, submission, tmp_path):
    _, _, private, _ = tiny_parts
    root = tmp_path / "srv"
    token = _setup(root, private)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = _start(root, port)
    try:
        req = urllib.request.Request(
            f"http://127.0.0.1:{port}/api/submissions?edition={EDITION}",
            data=fx.zip_folder(submission), method="POST",
            headers={"Authorization": f"Bearer {token}"})
        with urllib.request.urlopen(req, timeout=60) as r:
            sub_id = json.loads(r.read())["id"]
        t0 = time.monotonic()
        while _get(port, f"/api/submissions/{sub_id}", token)["status"] != "scoring":
            assert time.monotonic() - t0 < 60, "never started scoring"
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        assert not (root / "results" / sub_id / "summary.json").exists()
        proc = _start(root, port)
        t0 = time.monotonic()
        while (st := _get(port, f"/api/submissions/{sub_id}", token))["status"] not in (
                "scored", "failed"):
            assert time.monotonic() - t0 < 300
            time.sleep(0.2)
        assert st["status"] == "scored", st
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    srv = EvaluationServer(ServerConfig(root))
    with srv.sessions() as s:
        subs = list(s.scalars(select(Submission)))
    assert len(subs) == 1 and subs[0].attempts == 2          # the killed attempt, the one
    assert [p.name for p in (root / "results").iterdir()] == [sub_id]
    assert not [p for p in (root / "results").iterdir() if p.name.startswith(".")]


def test_recovery_keeps_a_result_written_before_the_kill(tiny_parts, tmp_path):
    """Killed after the result was written but before the row said so: scored, not
    scored again."""
    _, _, private, _ = tiny_parts
    root = tmp_path / "srv"
    _setup(root, private)
    srv = EvaluationServer(ServerConfig(root))
    with srv.sessions() as s:
        team_id = s.scalar(select(Submission.team_id)) or 1
        for sid, done in (("a" * 32, True), ("b" * 32, False)):
            s.add(Submission(id=sid, team_id=team_id, edition=EDITION, day="2026-12-04",
                             status="scoring", error="", upload_sha256="0" * 64, method="m",
                             attempts=1, published=False, public_method="", paper_url="",
                             description=""))
            res = root / "results" / sid
            res.mkdir(parents=True)
            if done:
                (res / "summary.json").write_text("{}")
        s.commit()
    assert scoring.recover(srv.config, srv.sessions) == 1
    with srv.sessions() as s:
        assert s.get(Submission, "a" * 32).status == "scored"
        assert s.get(Submission, "b" * 32).status == "queued"
    assert not (root / "results" / ("b" * 32)).exists()


def test_a_dying_scoring_process_is_retried_once_then_failed(tiny_parts, tmp_path):
    _, _, private, _ = tiny_parts
    root = tmp_path / "srv"
    _setup(root, private)
    srv = EvaluationServer(ServerConfig(root))
    with srv.sessions() as s:
        s.add(Submission(id="c" * 32, team_id=1, edition=EDITION, day="2026-12-04",
                         status="queued", error="", upload_sha256="0" * 64, method="m",
                         attempts=0, published=False, public_method="", paper_url="",
                         description=""))
        s.commit()

    def dies(*_a, **_k):
        raise BrokenProcessPool("A process in the process pool was terminated abruptly")

    for expected in ("queued", "failed"):
        sid = scoring.claim(srv.sessions)
        assert sid == "c" * 32
        assert scoring.score_one(srv.config, srv.sessions, sid, score=dies) == expected
    with srv.sessions() as s:
        sub = s.get(Submission, "c" * 32)
        assert sub.attempts == 2 and "died twice" in sub.error


def test_a_database_that_refuses_writes_answers_503_and_keeps_nothing(tiny_parts, submission,
                                                                      tmp_path, monkeypatch):
    _, _, private, _ = tiny_parts
    root = tmp_path / "srv"
    token = _setup(root, private)
    srv = EvaluationServer(ServerConfig(root))
    with TestClient(create_app(srv)) as c:
        import sqlalchemy.orm

        real = sqlalchemy.orm.Session.commit

        def readonly(self):
            if any(isinstance(o, Submission) for o in self.new):
                raise OperationalError("INSERT", {}, Exception("attempt to write a readonly "
                                                               "database"))
            return real(self)

        monkeypatch.setattr(sqlalchemy.orm.Session, "commit", readonly)
        r = c.post(f"/api/submissions?edition={EDITION}",
                   headers={"Authorization": f"Bearer {token}"},
                   content=fx.zip_folder(submission))
        monkeypatch.setattr(sqlalchemy.orm.Session, "commit", real)
        assert r.status_code == 503 and "nothing was recorded" in r.json()["detail"]
        assert c.get("/api/submissions", headers={"Authorization": f"Bearer {token}"}
                     ).json() == []
    assert not list((root / "uploads").iterdir())


def test_a_full_disk_answers_507_and_keeps_nothing(tiny_parts, submission, tmp_path,
                                                   monkeypatch):
    _, _, private, _ = tiny_parts
    root = tmp_path / "srv"
    token = _setup(root, private)
    srv = EvaluationServer(ServerConfig(root))
    from dressmeup.server import uploads

    def full(*_a, **_k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(uploads, "unpack", full)
    monkeypatch.setattr("dressmeup.server.service.unpack", full)
    with TestClient(create_app(srv)) as c:
        r = c.post(f"/api/submissions?edition={EDITION}",
                   headers={"Authorization": f"Bearer {token}"},
                   content=fx.zip_folder(submission))
        assert r.status_code == 507 and "disk is full" in r.json()["detail"]
        assert c.get("/api/submissions", headers={"Authorization": f"Bearer {token}"}
                     ).json() == []
    assert not list((root / "uploads").iterdir())
    assert not (root / "submissions").exists() or not list((root / "submissions").iterdir())


def test_the_scoring_process_scores_refuses_and_comes_back_after_dying(tiny_parts, submission,
                                                                       tmp_path):
    """Scoring runs in one spawned process: a result is written, a submission's fault comes
    back as its message (its exception class takes a report, not a message), and a killed
    process is reported as died, then started again."""
    _, _, private, _ = tiny_parts
    proc = scoring.ScoringProcess(ServerConfig(tmp_path / "srv"))
    try:
        proc(submission, EDITION, private, tmp_path / "out")
        assert (tmp_path / "out" / "summary.json").is_file()
        (tmp_path / "empty").mkdir()
        with pytest.raises(scoring.DressmeupError) as err:
            proc(tmp_path / "empty", EDITION, private, tmp_path / "out2")
        assert not isinstance(err.value, scoring.ScoringError) and str(err.value)
        pid, = [p.pid for p in proc._pool._processes.values()]
        os.kill(pid, signal.SIGKILL)
        time.sleep(1.0)
        with pytest.raises(scoring.ScoringError) as died:
            proc(submission, EDITION, private, tmp_path / "out3")
        assert died.value.name == "BrokenProcessPool"
        proc(submission, EDITION, private, tmp_path / "out4")
        first, again = (json.loads((tmp_path / o / "summary.json").read_text())
                        for o in ("out", "out4"))
        assert again["metrics"] == first["metrics"] and again["counts"] == first["counts"]
    finally:
        proc.close()
