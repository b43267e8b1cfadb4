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
"""

from __future__ import annotations

import json
import os
import shutil
import threading
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
