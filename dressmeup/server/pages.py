"""The public leaderboard pages: the report site of the published results.

When a team publishes or withdraws a result, every public page is rebuilt from the
published results with :func:`dressmeup.viz.site.write_site` (intervals, separation,
per-method pages and charts, recomputed from each result's per-item table) into a new
folder ``sites/<n>``; the link ``site`` then points at it (one atomic rename), so a reader
never sees half a site.

What the public pages show of test items: each method's per-item figures (item id,
category, track, metric values), never a picture. The site's usual best/worst pictures
render the ground truth beside the prediction; on a server that would publish the
withheld answers (and a method's predictions are the author's, not ours to show), so the
server writes none (``images_per_side=0``). The published copy of a result names the
method, paper link and description the team gave, and drops the server's paths.

Between rebuilds the pages are served from memory (:class:`PageCache`) with a strong ETag,
so a reader that sends ``If-None-Match`` gets ``304 Not Modified`` without the body.
"""

from __future__ import annotations

import hashlib
import json
import mimetypes
import os
import shutil
import threading
from dataclasses import dataclass
from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import sessionmaker

from dressmeup.io.atomic import atomic_dir, atomic_write_text
from dressmeup.server.config import ServerConfig
from dressmeup.server.db import Submission, Team, utcnow
from dressmeup.server.scoring import result_folder
from dressmeup.viz.site import write_site

_LOCK = threading.Lock()
EMPTY_INDEX = """<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">
<title>Leaderboards</title></head><body><h1>Leaderboards</h1>
<p>No result has been published yet.</p></body></html>
"""


def public_copy(config: ServerConfig, sub: Submission, team: Team) -> Path:
    """Write the published copy of a result (``published/<id>/``) and return it."""
    src = result_folder(config, sub.id)
    dest = config.root / "published" / sub.id
    shutil.rmtree(dest, ignore_errors=True)
    dest.mkdir(parents=True)
    for name in ("per_sample.parquet", "edition.json"):
        shutil.copyfile(src / name, dest / name)
    summary = json.loads((src / "summary.json").read_text(encoding="utf-8"))
    summary["method"] = {"method": sub.public_method or sub.method, "authors": team.name,
                         "url": sub.paper_url, "description": sub.description,
                         "runtime_per_sample_s": summary.get("method", {}).get(
                             "runtime_per_sample_s")}
    summary.get("dataset", {}).pop("root", None)
    summary.pop("submission", None)
    summary.get("provenance", {}).pop("host", None)
    atomic_write_text(dest / "summary.json", json.dumps(summary, indent=2) + "\n")
    return dest


def rebuild(config: ServerConfig, sessions: sessionmaker) -> int:
    """Rebuild ``site/`` from every published scored result; returns how many."""
    with _LOCK, sessions() as s:
        pubs = list(s.execute(select(Submission, Team).join(Team, Submission.team_id == Team.id)
                              .where(Submission.published.is_(True),
                                     Submission.status == "scored")
                              .order_by(Submission.id)))
        copies = [public_copy(config, sub, team) for sub, team in pubs]
        keep = {p.name for p in copies}
        pub_root = config.root / "published"
        if pub_root.is_dir():
            for old in pub_root.iterdir():
                if old.name not in keep:
                    shutil.rmtree(old, ignore_errors=True)
        sites = config.folder("sites")
        stamp = f"{len(list(sites.iterdir())):06d}-{utcnow().strftime('%Y%m%dT%H%M%S%f')}"
        with atomic_dir(sites / stamp) as tmp:
            if copies:
                write_site(copies, tmp, images_per_side=0)
            else:
                (tmp / "index.html").write_text(EMPTY_INDEX, encoding="utf-8")
        # readers follow the link: swapping it is one atomic rename; the previous site stays
        # until the next rebuild so that a reader that resolved it can finish
        link = config.root / "site"
        tmp_link = config.root / ".site-link"
        tmp_link.unlink(missing_ok=True)
        tmp_link.symlink_to(Path("sites") / stamp)
        previous = link.resolve() if link.is_symlink() else None
        os.replace(tmp_link, link)
        for old in sorted(sites.iterdir()):
            if old.name != stamp and (previous is None or old.resolve() != previous):
                shutil.rmtree(old, ignore_errors=True)
        return len(copies)


@dataclass(frozen=True)
class CachedPage:
    """One public file held in memory: its bytes, media type and strong ETag (the quoted
    sha256 of the bytes, first 32 hex digits)."""

    body: bytes
    media_type: str
    etag: str


def site_generation(config: ServerConfig) -> str | None:
    """What the public site is now: the folder the ``site`` link points at (a new one after
    every rebuild, by this process or another); None before the first rebuild."""
    try:
        return os.readlink(config.root / "site")
    except OSError:
        return None


def _page(body: bytes, media_type: str) -> CachedPage:
    return CachedPage(body, media_type, '"' + hashlib.sha256(body).hexdigest()[:32] + '"')


class PageCache:
    """The public pages served from memory between rebuilds.

    A file is read from disk once per site generation (:func:`site_generation`): a rebuild
    -- a result published, withdrawn or re-scored, an edition registered -- points the
    ``site`` link at a new folder, and the next request sees the new generation and drops
    every cached page. :meth:`invalidate` drops them at once (the rebuilds of this process
    call it). Files above ``max_bytes`` in total are served from disk, not kept.
    """

    def __init__(self, config: ServerConfig, max_bytes: int = 64 << 20) -> None:
        self.config = config
        self.max_bytes = max_bytes
        self._lock = threading.Lock()
        self._generation: str | None = None
        self._pages: dict[str, CachedPage] = {}
        self._bytes = 0
        self.reads = 0          # files read from disk (the tests count them)

    def invalidate(self) -> None:
        """Drop every cached page (the next request reads the current site)."""
        with self._lock:
            self._pages, self._bytes, self._generation = {}, 0, None

    def get(self, path: str) -> CachedPage | None:
        """The page at ``path`` inside the site (``""`` or a folder: its ``index.html``), or
        None when there is no such file inside it."""
        gen = site_generation(self.config)
        with self._lock:
            if gen != self._generation:
                self._pages, self._bytes, self._generation = {}, 0, gen
            hit = self._pages.get(path)
        if hit is not None:
            return hit
        page = self._read(path, gen)
        if page is not None:
            with self._lock:
                if (self._generation == gen and path not in self._pages
                        and self._bytes + len(page.body) <= self.max_bytes):
                    self._pages[path] = page
                    self._bytes += len(page.body)
        return page

    def _read(self, path: str, gen: str | None) -> CachedPage | None:
        self.reads += 1
        if gen is None:
            return _page(EMPTY_INDEX.encode(), "text/html")
        base = (self.config.root / gen).resolve() if not os.path.isabs(gen) \
            else Path(gen).resolve()
        target = (base / (path or "index.html")).resolve()
        if target.is_dir():
            target = target / "index.html"
        if base not in target.parents or not target.is_file():
            return None
        try:
            body = target.read_bytes()
        except FileNotFoundError:       # a rebuild removed it meanwhile
            return None
        return _page(body, mimetypes.guess_type(target.name)[0] or "application/octet-stream")


def etag_matches(if_none_match: str | None, etag: str) -> bool:
    """Whether an ``If-None-Match`` header names ``etag`` (weak comparison, ``*`` matches)."""
    if not if_none_match:
        return False
    tags = [t.strip() for t in if_none_match.split(",")]
    return "*" in tags or etag in (t[2:] if t.startswith("W/") else t for t in tags)
