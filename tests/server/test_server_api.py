"""The evaluation server through its HTTP API: accounts, editions, submitting, scoring bit
for bit like ``dressmeup score``, publishing, and every bad input answered with a clear 4xx
(nothing written outside the server's folders, nothing shown unescaped)."""

from __future__ import annotations

import importlib.util
import io
import json
import tarfile
import time
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

from fastapi.testclient import TestClient  # noqa: E402

from dressmeup.bench.scoring.score import score_submission  # noqa: E402
from dressmeup.errors import InputError  # noqa: E402
from dressmeup.server.accounts import add_team, revoke_team, token_sha256  # noqa: E402
from dressmeup.server.app import create_app  # noqa: E402
from dressmeup.server.config import ServerConfig  # noqa: E402
from dressmeup.server.db import Team  # noqa: E402
from dressmeup.server.editions import add_edition  # noqa: E402
from dressmeup.server.service import EvaluationServer  # noqa: E402

_spec = importlib.util.spec_from_file_location("server_fixtures",
                                               Path(__file__).resolve().parent / "conftest.py")
fx = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fx)
EDITION = fx.EDITION


def make_server(root: Path, private: Path, database: str | None = None, **kw):
    """A server with one edition and two teams; returns (server, {team: token})."""
    srv = EvaluationServer(ServerConfig(root, database=database, poll_seconds=0.1, **kw))
    tokens = {}
    with srv.sessions() as s:
        for name in ("lab-a", "lab-b"):
            tokens[name] = add_team(s, name)[1]
        add_edition(s, EDITION, private)
    return srv, tokens


def wait(client, token, sub_id, timeout=300):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        st = client.get(f"/api/submissions/{sub_id}", headers=auth(token)).json()
        if st["status"] in ("scored", "failed"):
            return st
        time.sleep(0.2)
    raise AssertionError(f"submission {sub_id} not scored in {timeout} s")


def auth(token):
    return {"Authorization": f"Bearer {token}"}


@pytest.fixture(scope="module")
def scored_server(tiny_parts, submission, tmp_path_factory):
    """A running server with the rigid baseline submitted and scored."""
    _, _, private, _ = tiny_parts
    root = tmp_path_factory.mktemp("srv")
    srv, tokens = make_server(root, private, daily_limit=3)
    with TestClient(create_app(srv)) as client:
        r = client.post(f"/api/submissions?edition={EDITION}", headers=auth(tokens["lab-a"]),
                        content=fx.zip_folder(submission))
        assert r.status_code == 201, r.text
        sub_id = r.json()["id"]
        st = wait(client, tokens["lab-a"], sub_id)
        assert st["status"] == "scored", st
        yield {"client": client, "server": srv, "tokens": tokens, "id": sub_id,
               "root": root}


def test_tokens_are_stored_as_hashes_and_revocable(tmp_path):
    srv = EvaluationServer(ServerConfig(tmp_path / "s"))
    with srv.sessions() as s:
        team, token = add_team(s, "lab")
        row = s.get(Team, team.id)
        assert row.token_sha256 == token_sha256(token) and token not in row.token_sha256
        with pytest.raises(InputError, match="exists"):
            add_team(s, "lab")
        with pytest.raises(InputError, match="team name"):
            add_team(s, "<script>")
        revoke_team(s, "lab")
    with TestClient(create_app(srv)) as c:
        assert c.get("/api/submissions", headers=auth(token)).status_code == 401
    raw = (tmp_path / "s" / "server.db").read_bytes()
    assert token.encode() not in raw


def test_an_edition_needs_its_private_part(tiny_parts, tmp_path):
    _, public, private, _ = tiny_parts
    srv = EvaluationServer(ServerConfig(tmp_path / "s"))
    with srv.sessions() as s:
        with pytest.raises(InputError, match="public part"):
            add_edition(s, EDITION, public)
        with pytest.raises(InputError, match="unknown edition"):
            add_edition(s, "no-such-edition", private)
        assert add_edition(s, EDITION, private).name == EDITION


def test_scores_are_those_of_dressmeup_score_bit_for_bit(scored_server, tiny_parts,
                                                        submission, tmp_path):
    ed, _, private, other = tiny_parts
    res = scored_server["root"] / "results" / scored_server["id"]
    mine = score_submission(submission, ed, private, tmp_path / "res", workers=1,
                            show_progress=False, allow_other_data=other)
    a = pd.read_parquet(res / "per_sample.parquet")
    for m in ed.metrics:
        assert np.array_equal(a[m].to_numpy(), mine.table[m].to_numpy()), m
    summary = scored_server["client"].get(
        f"/api/submissions/{scored_server['id']}/result",
        headers=auth(scored_server["tokens"]["lab-a"])).json()
    assert summary["metrics"]["p2s"]["mean"] == mine.summary["metrics"]["p2s"]["mean"]
    assert "root" not in summary.get("dataset", {})           # no server paths leak


def test_a_team_sees_only_its_own_submissions(scored_server):
    c, tokens, sub_id = scored_server["client"], scored_server["tokens"], scored_server["id"]
    assert [s["id"] for s in c.get("/api/submissions", headers=auth(tokens["lab-a"])).json()] \
        == [sub_id]
    assert c.get("/api/submissions", headers=auth(tokens["lab-b"])).json() == []
    for path in (f"/api/submissions/{sub_id}", f"/api/submissions/{sub_id}/result"):
        assert c.get(path, headers=auth(tokens["lab-b"])).status_code == 404
    r = c.post(f"/api/submissions/{sub_id}/publish", headers=auth(tokens["lab-b"]),
               json={"method": "stolen"})
    assert r.status_code == 404


@pytest.mark.parametrize("header", [None, "Bearer dmu_forged", "Basic abc", "Bearer " + "x" * 500])
def test_missing_or_forged_tokens_are_refused(scored_server, header):
    headers = {"Authorization": header} if header else {}
    assert scored_server["client"].get("/api/submissions", headers=headers).status_code == 401


def test_published_results_reach_the_public_pages_escaped(scored_server):
    c, tokens, sub_id = scored_server["client"], scored_server["tokens"], scored_server["id"]
    evil = "<script>alert(1)</script>Rigid"
    r = c.post(f"/api/submissions/{sub_id}/publish", headers=auth(tokens["lab-a"]),
               json={"method": evil, "paper_url": "https://example.org/paper",
                     "description": "<img src=x onerror=alert(2)>"})
    assert r.status_code == 200 and r.json()["published"]
    index = c.get("/leaderboard/")
    assert index.status_code == 200 and "<script>alert(1)" not in index.text
    assert "&lt;script&gt;alert(1)&lt;/script&gt;Rigid" in index.text
    pages = list((scored_server["root"] / "site").rglob("*.html"))
    assert pages and not any("<script>alert" in p.read_text() for p in pages)
    assert not list((scored_server["root"] / "site").rglob("*.png")) or all(
        "per_" in p.name or "_edition" in p.name
        for p in (scored_server["root"] / "site").rglob("*.png"))   # no item pictures
    assert not list((scored_server["root"] / "site").rglob("*-3d.js"))   # nor 3D views
    bad = c.post(f"/api/submissions/{sub_id}/publish", headers=auth(tokens["lab-a"]),
                 json={"method": "x", "paper_url": "javascript:alert(1)"})
    assert bad.status_code == 400 and "http" in bad.json()["detail"]
    assert c.post(f"/api/submissions/{sub_id}/withdraw",
                  headers=auth(tokens["lab-a"])).json()["published"] is False
    assert "Rigid" not in c.get("/leaderboard/").text
    assert c.get("/leaderboard/../server.db").status_code == 404
    assert c.get("/leaderboard/%2e%2e/server.db").status_code == 404


def test_publishing_changes_the_pages_etag(scored_server):
    """A cached page answers 304 to its ETag until a publish or withdrawal changes it."""
    c, tokens, sub_id = scored_server["client"], scored_server["tokens"], scored_server["id"]
    before = c.get("/leaderboard/").headers["etag"]
    assert c.get("/leaderboard/", headers={"If-None-Match": before}).status_code == 304
    r = c.post(f"/api/submissions/{sub_id}/publish", headers=auth(tokens["lab-a"]),
               json={"method": "Cached rigid"})
    assert r.status_code == 200
    new = c.get("/leaderboard/", headers={"If-None-Match": before})
    assert new.status_code == 200 and "Cached rigid" in new.text
    assert new.headers["etag"] != before
    assert c.get("/leaderboard/", headers={"If-None-Match": new.headers["etag"]}
                 ).status_code == 304
    c.post(f"/api/submissions/{sub_id}/withdraw", headers=auth(tokens["lab-a"]))
    gone = c.get("/leaderboard/", headers={"If-None-Match": new.headers["etag"]})
    assert gone.status_code == 200 and "Cached rigid" not in gone.text


def _tar(members: list[tuple[tarfile.TarInfo, bytes | None]]) -> bytes:
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as t:
        for info, data in members:
            t.addfile(info, io.BytesIO(data) if data is not None else None)
    return buf.getvalue()


def _bad_uploads(submission: Path) -> dict[str, tuple[bytes, int, str]]:
    """name -> (body, expected status, a word of the answer)."""
    out: dict[str, tuple[bytes, int, str]] = {}
    good = fx.zip_folder(submission)
    out["empty"] = (b"", 400, "empty")
    out["junk"] = (b"not an archive" * 10, 400, "zip nor a tar")
    slip = tarfile.TarInfo("../../escaped.txt")
    slip.size = 3
    out["path outside"] = (_tar([(slip, b"abc")]), 400, "leave the submission folder")
    link = tarfile.TarInfo("submission.json")
    link.type, link.linkname = tarfile.SYMTYPE, "/etc/passwd"
    out["symlink"] = (_tar([(link, None)]), 400, "not a regular file")
    many = io.BytesIO()
    with zipfile.ZipFile(many, "w") as z:
        for i in range(60):
            z.writestr(f"f{i}.npz", b"")
    out["too many members"] = (many.getvalue(), 413, "at most")
    bomb = io.BytesIO()
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("big.npz", b"\0" * (3 << 20))
    out["zip bomb"] = (bomb.getvalue(), 413, "MB")
    z2 = io.BytesIO(good)
    with zipfile.ZipFile(z2, "a") as z:
        z.writestr("extra-item.npz", b"123")
    out["invalid submission"] = (z2.getvalue(), 422, "")
    return out


def test_bad_uploads_get_clear_4xx_and_leave_nothing(tiny_parts, submission, tmp_path):
    _, _, private, _ = tiny_parts
    root = tmp_path / "srv"
    srv, tokens = make_server(root, private, max_members=50, max_unpacked_mb=2,
                              max_upload_mb=1)
    with TestClient(create_app(srv)) as c:
        h = auth(tokens["lab-a"])
        for name, (body, code, word) in _bad_uploads(submission).items():
            r = c.post(f"/api/submissions?edition={EDITION}", headers=h, content=body)
            assert r.status_code == code, (name, r.status_code, r.text)
            if code == 422:
                assert r.json()["problems"] and all(isinstance(p, str)
                                                    for p in r.json()["problems"])
            else:
                assert word in r.json()["detail"], (name, r.json())
        r = c.post(f"/api/submissions?edition={EDITION}", headers=h, content=b"x" * (2 << 20))
        assert r.status_code == 413
        r = c.post("/api/submissions?edition=no-such-edition", headers=h,
                   content=fx.zip_folder(submission))
        assert r.status_code == 404 and "not scored on this server" in r.json()["detail"]
        assert c.get("/api/submissions", headers=h).json() == []      # none was accepted
    assert not (tmp_path / "escaped.txt").exists() and not (root.parent / "escaped.txt").exists()
    assert not list((root / "submissions").iterdir())
    assert not list((root / "uploads").iterdir())


def test_the_daily_limit_is_enforced(tiny_parts, submission, tmp_path):
    _, _, private, _ = tiny_parts
    srv, tokens = make_server(tmp_path / "srv", private, daily_limit=2)
    with TestClient(create_app(srv)) as c:
        body = fx.zip_folder(submission)
        codes = [c.post(f"/api/submissions?edition={EDITION}", headers=auth(tokens["lab-a"]),
                        content=body).status_code for _ in range(3)]
        assert codes == [201, 201, 429]
        other = c.post(f"/api/submissions?edition={EDITION}", headers=auth(tokens["lab-b"]),
                       content=body)
        assert other.status_code == 201                      # per team


def test_the_api_is_described_by_openapi(scored_server):
    spec = scored_server["client"].get("/openapi.json").json()
    assert "/api/submissions" in spec["paths"] and "post" in spec["paths"]["/api/submissions"]


def test_team_page_renders_values_as_text(scored_server):
    page = scored_server["client"].get("/team").text
    assert "textContent" in page and "innerHTML" not in page


def test_submit_command_round_trip(scored_server, submission, monkeypatch):
    """``dressmeup submit`` packs and uploads a folder (through the test client's transport)."""
    from dressmeup.server import client as cl

    c = scored_server["client"]

    def fake_request(req, timeout=600):
        body = req.data.read() if hasattr(req.data, "read") else (req.data or b"")
        r = c.request(req.get_method(), req.full_url.split("://", 1)[1].split("/", 1)[1]
                      .join(["/", ""]), headers=dict(req.header_items()), content=body)
        if r.status_code == 422:
            return r.json()
        if r.status_code >= 400:
            raise InputError(f"the server answered {r.status_code}: {r.json()['detail']}")
        return r.json()

    monkeypatch.setattr(cl, "_request", fake_request)
    ans = cl.submit(submission, EDITION, "http://testserver", scored_server["tokens"]["lab-b"])
    assert ans["status"] == "queued"
    state = json.loads(json.dumps(cl.wait_for("http://testserver",
                                              scored_server["tokens"]["lab-b"], ans["id"],
                                              timeout=300, every=0.2)))
    assert state["status"] == "scored"


def test_the_same_flow_on_postgresql(postgres_url, tiny_parts, submission, tmp_path):
    _, _, private, _ = tiny_parts
    srv, tokens = make_server(tmp_path / "srv", private, database=postgres_url)
    with TestClient(create_app(srv)) as c:
        r = c.post(f"/api/submissions?edition={EDITION}", headers=auth(tokens["lab-a"]),
                   content=fx.zip_folder(submission))
        assert r.status_code == 201, r.text
        assert wait(c, tokens["lab-a"], r.json()["id"])["status"] == "scored"
        assert c.get("/api/submissions", headers=auth(tokens["lab-b"])).json() == []
