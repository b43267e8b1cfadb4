"""Checks a leaderboard makes before it trusts a result folder.

Threat model: accidents and casual tampering (a hand-edited ``summary.json`` or
``edition.json``), not a determined forger who rewrites every file consistently.

- Every mean, std and count in ``summary.json`` (overall, per category and, for
  ``dressmeup-result/2``, per track) is recomputed from ``per_sample.parquet``; a summary
  that disagrees is refused.
- ``edition.json`` must hash to the edition hash the summary records.
- A result naming a shipped edition must carry that edition's hash; an edition given as a
  path (a custom edition) is allowed and reported as custom.
- Comparability is recomputed from the data pin (:func:`comparability`): a result whose
  dataset manifest is not the one the edition pins is not comparable, whatever its summary
  says.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dressmeup.bench.edition import edition_from_dict, list_editions, load_edition
from dressmeup.bench.scoring.results import EDITION_JSON, PER_SAMPLE, SUMMARY, Result, stats
from dressmeup.errors import InputError
from dressmeup.io.jsonio import parse_json_file
from dressmeup.io.tables import read_frame

#: relative tolerance of a recomputed mean/std (the toolkit's own summaries agree exactly)
RTOL = 1e-9


@dataclass
class EditionCheck:
    """What :func:`check_edition` found: ``custom`` is True for an edition not shipped with
    the toolkit (then ``source`` says where it came from)."""

    custom: bool
    source: str


def _close(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return a is None and b is None
    try:
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        return False
    if not (math.isfinite(a) and math.isfinite(b)):
        return False
    return abs(a - b) <= RTOL * max(abs(a), abs(b)) + 1e-15


def _check_group(where: str, claimed: Any, rows, metrics: list[str], problems: list[str]
                 ) -> None:
    if not isinstance(claimed, dict):
        problems.append(f"{where}: expected an object of metric statistics")
        return
    for m in metrics:
        c = claimed.get(m)
        if not isinstance(c, dict):
            problems.append(f"{where}: metric {m!r} missing")
            continue
        got = stats(rows[m].to_numpy()) if m in rows else stats(np.array([]))
        if int(c.get("n") or 0) != got["n"]:
            problems.append(f"{where}: {m} n = {c.get('n')} but per_sample has {got['n']} "
                            "finite values")
        for key in ("mean", "std"):
            if not _close(c.get(key), got[key]):
                problems.append(f"{where}: {m} {key} = {c.get(key)!r} but per_sample gives "
                                f"{got[key]!r}")


def check_summary(result: Result) -> list[str]:
    """Recompute a result's summary statistics from its per-sample table.

    Returns
    -------
    One line per disagreement (empty: the summary matches its table).
    """
    where = result.path / SUMMARY
    table = result.table
    if table is None:
        path = result.path / PER_SAMPLE
        if not path.is_file():
            return [f"{where}: {PER_SAMPLE} is missing, so the summary cannot be checked"]

        try:
            table = read_frame(path, "per-item table")
        except InputError as exc:
            return [str(exc)]
    s = result.summary
    metrics = list((s.get("metrics") or {}).keys())
    problems: list[str] = []
    if "status" not in table or "category" not in table:
        return [f"{result.path / PER_SAMPLE}: lacks the status/category columns"]
    ok = table[table["status"] == "ok"]
    counts = s.get("counts") or {}
    want = {"items": len(table), "ok": len(ok), "failed": len(table) - len(ok)}
    for k, v in want.items():
        if counts.get(k) != v:
            problems.append(f"{where}: counts.{k} = {counts.get(k)!r} but per_sample has {v}")
    _check_group(f"{where} metrics", s.get("metrics"), ok, metrics, problems)
    groups = [("per_category", "category")]
    if "track" in table:
        groups.append(("per_track", "track"))
    for key, col in groups:
        claimed = s.get(key) or {}
        present = sorted(table[col].dropna().astype(str).unique())
        if sorted(claimed) != present:
            problems.append(f"{where}: {key} lists {sorted(claimed)} but per_sample has "
                            f"{present}")
            continue
        for name in present:
            sub_all = table[table[col].astype(str) == name]
            sub = ok[ok[col].astype(str) == name]
            g = claimed[name] if isinstance(claimed[name], dict) else {}
            if g.get("items") != len(sub_all) or g.get("failed") != len(sub_all) - len(sub):
                problems.append(f"{where}: {key}.{name} item counts disagree with per_sample")
            _check_group(f"{where} {key}.{name}", g.get("metrics"), sub, metrics, problems)
    return problems


def check_edition(result: Result) -> tuple[EditionCheck, list[str]]:
    """Check ``edition.json`` against the summary's edition hash and the shipped editions.

    Returns
    -------
    (EditionCheck, problems)
    """

    ed_info = result.summary.get("edition") or {}
    name, claimed = str(ed_info.get("name", "")), str(ed_info.get("hash", ""))
    path = result.path / EDITION_JSON
    problems: list[str] = []
    if path.is_file():
        try:
            ed = edition_from_dict(parse_json_file(path), source=str(path))
        except (OSError, ValueError) as exc:
            return EditionCheck(False, str(path)), [f"{path}: unreadable edition ({exc})"]
        if ed.hash != claimed:
            problems.append(f"{path}: hashes to {ed.hash[:12]}... but {SUMMARY} records "
                            f"{claimed[:12]}...: edition.json was edited after scoring")
        if ed.name != name:
            problems.append(f"{path}: names edition {ed.name!r} but {SUMMARY} says {name!r}")
    elif name not in list_editions():
        problems.append(f"{result.path}: {EDITION_JSON} is missing and {name!r} is not a "
                        "shipped edition")
    if name in list_editions():
        shipped = load_edition(name)
        if shipped.hash != claimed:
            problems.append(f"{result.path}: names the shipped edition {name} but its hash "
                            f"{claimed[:12]}... is not {name}'s ({shipped.hash[:12]}...): "
                            "re-score with the shipped edition, or give a custom edition "
                            "another name")
        return EditionCheck(False, shipped.source), problems
    return EditionCheck(True, str(ed_info.get("source") or path)), problems


def verify_results(results: Sequence[Result]) -> EditionCheck:
    """Verify every result (summary against its table, edition against its hash).

    Returns
    -------
    The :class:`EditionCheck` of the first result (all share one edition hash).

    Raises
    ------
    InputError
        Listing every problem of every result.
    """
    problems: list[str] = []
    checks = []
    for r in results:
        problems += check_summary(r)
        chk, p = check_edition(r)
        problems += p
        checks.append(chk)
    if problems:
        raise InputError("results that do not verify cannot join a leaderboard (re-score "
                         "them with 'dressmeup score'):\n  " + "\n  ".join(problems))
    return checks[0] if checks else EditionCheck(False, "")


def comparability(result: Result, edition: Any) -> tuple[bool, str | None]:
    """Whether ``result`` was scored on the data ``edition`` pins, and why not.

    A summary marked not comparable stays so; one marked comparable is checked against the
    edition's pinned manifest (``expected_manifest_sha256`` of a generated edition,
    ``manifest_sha256`` of a real one).
    """
    if not result.comparable:
        return False, str(result.summary.get("not_comparable_reason") or "scored on other data")
    pin = edition.dataset
    want = pin.expected_manifest_sha256 if pin.kind == "generated" else pin.manifest_sha256
    got = result.manifest_hash
    if want and got != want:
        return False, (f"scored on data with manifest {str(got)[:12]}..., not the "
                       f"{want[:12]}... edition {edition.name} pins (its summary claims "
                       "otherwise)")
    return True, None
