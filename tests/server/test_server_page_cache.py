"""The public pages served from memory: a strong ETag, ``304`` on ``If-None-Match``, one
disk read per file and site generation, and a new generation after every rebuild (by this
process or another) or edition registration. A server with no edition is enough."""

from __future__ import annotations

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

from fastapi.testclient import TestClient  # noqa: E402

from dressmeup.server import pages, service  # noqa: E402
from dressmeup.server.app import create_app  # noqa: E402
from dressmeup.server.config import ServerConfig  # noqa: E402
from dressmeup.server.service import EvaluationServer  # noqa: E402


@pytest.fixture
def live(tmp_path):
    srv = EvaluationServer(ServerConfig(tmp_path / "srv", poll_seconds=0.1))
    with TestClient(create_app(srv)) as client:
        yield srv, client


def _index(text: str, monkeypatch) -> None:
    """Make the next rebuild write ``text`` as the (empty) site's index."""
    monkeypatch.setattr(pages, "EMPTY_INDEX", f"<!DOCTYPE html><title>x</title><p>{text}</p>")


def _first_site(srv, c, monkeypatch) -> str:
    """Rebuild the site with the index "first"; the ETag its index is served with."""
    _index("first", monkeypatch)
    srv.rebuild_pages()
    return c.get("/leaderboard/").headers["etag"]


def _serves(c, etag: str, text: str) -> None:
    """The index is a new page (a ``200`` to a reader holding ``etag``) showing ``text``."""
    r = c.get("/leaderboard/", headers={"If-None-Match": etag})
    assert r.status_code == 200 and text in r.text and r.headers["etag"] != etag


def test_etag_and_not_modified(live, monkeypatch):
    srv, c = live
    before = c.get("/leaderboard/")             # nothing published, no site yet
    assert before.status_code == 200 and "No result" in before.text and before.headers["etag"]
    _index("first", monkeypatch)
    srv.rebuild_pages()
    r = c.get("/leaderboard/")
    etag = r.headers["etag"]
    assert r.status_code == 200 and "first" in r.text
    assert etag.startswith('"') and etag.endswith('"') and etag != before.headers["etag"]
    assert r.headers["cache-control"] == "no-cache"
    assert r.headers["content-type"].startswith("text/html")
    for header in (etag, f"W/{etag}", f'"other", {etag}', "*"):
        nm = c.get("/leaderboard/", headers={"If-None-Match": header})
        assert nm.status_code == 304 and nm.content == b"", header
        assert nm.headers["etag"] == etag
    other = c.get("/leaderboard/", headers={"If-None-Match": '"not-it"'})
    assert other.status_code == 200 and other.text == r.text
    assert c.get("/leaderboard/index.html").headers["etag"] == etag


def test_pages_come_from_memory_until_a_rebuild(live, monkeypatch):
    srv, c = live
    _index("first", monkeypatch)
    srv.rebuild_pages()
    first = c.get("/leaderboard/")
    reads = srv.pages.reads
    for _ in range(5):
        assert c.get("/leaderboard/").text == first.text
    assert srv.pages.reads == reads                     # no disk read for a cached page
    # the file changed under the server: still the bytes of this generation
    (srv.config.root / "site" / "index.html").write_text("changed on disk")
    assert c.get("/leaderboard/").text == first.text
    # a publish rebuilds the site: the next request has the new page and a new ETag
    _index("second", monkeypatch)
    srv.rebuild_pages()
    second = c.get("/leaderboard/", headers={"If-None-Match": first.headers["etag"]})
    assert second.status_code == 200 and "second" in second.text
    assert second.headers["etag"] != first.headers["etag"]
    assert srv.pages.reads == reads + 1


def test_a_rebuild_by_another_process_is_seen(live, monkeypatch):
    srv, c = live
    etag = _first_site(srv, c, monkeypatch)
    _index("from the command line", monkeypatch)
    pages.rebuild(srv.config, srv.sessions)      # not through this server: no invalidate()
    _serves(c, etag, "from the command line")


def test_registering_an_edition_invalidates(live, monkeypatch):
    srv, c = live
    etag = _first_site(srv, c, monkeypatch)
    registered = []
    monkeypatch.setattr(service, "add_edition",
                        lambda session, name, private: registered.append(name) or name)
    _index("after the edition", monkeypatch)
    srv.add_edition("some-edition", srv.config.root)
    assert registered == ["some-edition"]
    _serves(c, etag, "after the edition")


def test_only_files_inside_the_site(live, monkeypatch):
    srv, c = live
    _index("first", monkeypatch)
    srv.rebuild_pages()
    (srv.config.root / "secret.txt").write_text("secret")
    for path in ("/leaderboard/missing.html", "/leaderboard/../secret.txt",
                 "/leaderboard/%2e%2e/secret.txt", "/leaderboard/..%2fsecret.txt",
                 "/leaderboard/../server.db"):
        assert c.get(path).status_code == 404, path


def test_cache_keeps_within_its_byte_budget(tmp_path, monkeypatch):
    cfg = ServerConfig(tmp_path / "srv")
    srv = EvaluationServer(cfg)
    _index("x" * 500, monkeypatch)
    srv.rebuild_pages()
    site = cfg.root / "site"
    (site / "big.bin").write_bytes(b"\0" * 4000)
    cache = pages.PageCache(cfg, max_bytes=2000)
    assert cache.get("big.bin").body == b"\0" * 4000
    assert cache.get("big.bin") is not None and cache.reads == 2     # too big: not kept
    assert cache.get("") is not None and cache.get("") is not None and cache.reads == 3
    assert cache.get("big.bin").media_type == "application/octet-stream"
    srv.engine.dispose()
