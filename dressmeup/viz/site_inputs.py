"""Finding what a report page needs beyond the result folder: the submission folder it was
scored from (still hashing to the recorded sha256) and the dataset root (by manifest sha256).
Each finder returns ``(path, "")`` or ``(None, the sentence the page shows)``."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from dressmeup.bench.scoring.submission import read_info, submission_hash
from dressmeup.bench.tasks.common import manifest_sha256
from dressmeup.errors import InputError


def find_submission(result: Any, search: Sequence[str | os.PathLike]) -> tuple[Path | None, str]:
    """The submission folder a result was scored from, or None and the reason.

    Looks in ``search`` (submission folders or folders of them) for the recorded folder
    name or the method name, then at the path recorded in the result; the folder must
    still hash to the recorded sha256.
    """
    rec = result.summary.get("submission", {})
    recorded = Path(rec.get("path", "")) if rec.get("path") else None
    cands: list[Path] = []
    for d in map(Path, search):
        if (d / "submission.json").is_file():
            cands.append(d)
        elif d.is_dir():
            cands += sorted(p.parent for p in d.glob("*/submission.json"))
    match = None
    for c in cands:
        if recorded is not None and (c.resolve() == recorded.resolve()
                                     or c.name == recorded.name):
            match = c
            break
    if match is None:
        for c in cands:
            info, _ = read_info(c)
            if info and str(info.get("method")) == result.method:
                match = c
                break
    if match is None and recorded is not None and (recorded / "submission.json").is_file():
        match = recorded
    if match is None:
        where = f"{recorded}" if recorded else "(no path recorded)"
        given = (" nor in " + ", ".join(str(s) for s in search)) if search else \
            " (no --submissions folder given)"
        return None, (f"the submission folder {where} is gone{given}, so there are no "
                      "pictures of its predictions")
    if rec.get("sha256") and submission_hash(match) != rec["sha256"]:
        return None, (f"the submission folder {match} changed since it was scored (its "
                      "sha256 differs), so its files are not the scored predictions: no "
                      "pictures")
    return match, ""


def find_data_root(result: Any, roots: Sequence[str | os.PathLike]) -> tuple[Path | None, str]:
    """The dataset root a result was scored on (matched by manifest sha256), or None and
    the reason."""
    want = result.manifest_hash
    recorded = result.summary.get("dataset", {}).get("root")
    for r in [*map(Path, roots), *([Path(recorded)] if recorded else [])]:
        try:
            if manifest_sha256(r) == want:
                return r, ""
        except InputError:
            continue
    return None, (f"no dataset with manifest {str(want)[:12]} was found (recorded root "
                  f"{recorded}; give it with --data), so there are no pictures")
