"""Result folders: per-sample Parquet + summary JSON with provenance.

::

    RESULTS/
      per_sample.parquet   one row per item: sample_id, category, each metric (SI units:
                           metres, m² for squared Chamfer, ratios in [0, 1]), status
                           ("ok" / "error"), error, note, seconds, task-specific ids
      summary.json         schema "dressmeup-result/3" (``schema_version`` 3): means/std
                           and 95 % bootstrap intervals (``ci95``, over the factors the
                           items share, see dressmeup.bench.scoring.intervals) per metric, per category
                           and per track (``per_track``, when rows carry ``track``), counts,
                           ``comparable`` (False when scored on other data), the method
                           (submission.json), edition name/version/hash and its full config,
                           dataset manifest hash, submission hash, toolkit version, time, host
      edition.json         the edition config used (for re-scoring)

``summary.json`` is written last: a folder without it is an interrupted run. Scoring refuses
a folder that already holds anything, so a result is never overwritten.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dressmeup.bench.scoring.intervals import LEVEL, METHOD, N_RESAMPLES, SEED, crossed_bootstrap
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_dir, atomic_write_text, only_temp_files
from dressmeup.io.jsonio import parse_json_file, validate_json
from dressmeup.io.tables import read_frame

if TYPE_CHECKING:  # pragma: no cover - annotations only
    import pandas as pd

RESULT_SCHEMA = "dressmeup-result/3"
#: Integer version of :data:`RESULT_SCHEMA` (stored as ``schema_version``).
RESULT_SCHEMA_VERSION = 3
#: Result schemas this toolkit reads. ``/1`` results have no intervals and no tracks;
#: ``/2`` intervals resampled one unit column; ``/3`` every factor the items share.
#: Leaderboards recompute intervals from ``per_sample.parquet`` whatever the schema.
READABLE_SCHEMAS = ("dressmeup-result/1", "dressmeup-result/2", "dressmeup-result/3")
PER_SAMPLE = "per_sample.parquet"
SUMMARY = "summary.json"
EDITION_JSON = "edition.json"


@dataclass
class Result:
    """A loaded result folder.

    Attributes
    ----------
    path : the folder.
    summary : the parsed ``summary.json``.
    table : the per-sample table (pandas), or None when not loaded.
    """

    path: Path
    summary: dict[str, Any]
    table: pd.DataFrame | None = None

    @property
    def method(self) -> str:
        """Method name from the submission metadata."""
        return str(self.summary.get("method", {}).get("method", self.path.name))

    @property
    def edition_hash(self) -> str:
        """Hash of the edition the result was scored with."""
        return self.summary["edition"]["hash"]

    @property
    def schema_version(self) -> int:
        """1 for ``dressmeup-result/1`` (no intervals, no tracks), 2 for ``/2``, ..."""
        return int(str(self.summary.get("schema", "/1")).rsplit("/", 1)[-1] or 1)

    @property
    def comparable(self) -> bool:
        """False when the result was scored on data other than the edition pins
        (``--allow-other-data``); such results are marked "not comparable" in tables."""
        return bool(self.summary.get("comparable", True))

    @property
    def manifest_hash(self) -> str | None:
        """sha256 of the dataset manifest the result was scored on."""
        return self.summary.get("dataset", {}).get("manifest_sha256")


def check_out_dir(out: str | os.PathLike) -> Path:
    """Refuse an output folder that already holds anything (results are never overwritten).

    Raises
    ------
    InputError
        When ``out`` exists and is a non-empty folder or a file.
    """

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"results folder {out} is an existing file; choose a new --out folder")
    # a folder holding only hidden temporary files (a run killed by an older toolkit) is empty
    if out.exists() and not only_temp_files(out):
        raise InputError(f"results folder {out} already exists and is not empty: scoring "
                         "never overwrites results; choose a new --out folder")
    return out


def stats(values: np.ndarray) -> dict[str, Any]:
    """``{"mean", "std", "n"}`` over the finite values (population std; None when n = 0)."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"mean": None, "std": None, "n": 0}
    return {"mean": float(v.mean()), "std": float(v.std()), "n": int(v.size)}


def metric_stats(values: np.ndarray, factors: dict[str, np.ndarray] | None = None
                 ) -> dict[str, Any]:
    """:func:`stats` plus, when ``factors`` are given, the 95 % interval over them
    (:func:`~dressmeup.bench.scoring.intervals.crossed_bootstrap`: ``ci95`` [lo, hi], ``levels``,
    ``df``, ``distinct_resamples``, ``degenerate``)."""

    out = stats(values)
    if factors and out["n"]:
        iv = crossed_bootstrap(values, factors)
        if iv is not None:
            out.update(iv.to_dict())
    return out


def _group_stats(sub: pd.DataFrame, metrics: list[str], units: Sequence[str]
                 ) -> dict[str, Any]:
    factors = {c: sub[c].to_numpy() for c in units}
    return {m: metric_stats(sub[m].to_numpy(), factors) if m in sub else stats(np.array([]))
            for m in metrics}


def factors_of(table: pd.DataFrame, unit_columns: Sequence[str]) -> tuple[str, ...]:
    """The task's factor columns that ``table`` has (older results lack some)."""
    return tuple(c for c in unit_columns if c in table)


def summarise(table: pd.DataFrame, metrics: list[str], extra: list[str],
              unit_columns: Sequence[str] = ()) -> dict[str, Any]:
    """Means, intervals and per-category / per-track means of ``metrics`` over OK rows.

    Parameters
    ----------
    table : per-item rows (``status``, ``category``, metric columns, optional ``track``).
    metrics, extra : ranked metric columns and unranked extra columns.
    unit_columns : the factors the items share (task ``UNIT_COLUMNS``), resampled together
        by the bootstrap; none present: no intervals.
    """

    ok = table[table["status"] == "ok"] if len(table) else table
    unit = factors_of(table, unit_columns)
    out: dict[str, Any] = {
        "counts": {"items": int(len(table)), "ok": int(len(ok)),
                   "failed": int(len(table) - len(ok))},
        "metrics": _group_stats(ok, metrics, unit),
        "extra": {c: stats(ok[c].to_numpy()) for c in extra if c in ok},
        "per_category": {},
    }
    if unit:
        out["bootstrap"] = {"factors": list(unit),
                            "levels": {c: int(ok[c].nunique()) if len(ok) else 0
                                       for c in unit},
                            "resamples": N_RESAMPLES, "seed": SEED, "level": LEVEL,
                            "method": METHOD}
    for cat in sorted(table["category"].unique()) if len(table) else []:
        sub_all = table[table["category"] == cat]
        sub = ok[ok["category"] == cat]
        out["per_category"][str(cat)] = {
            "items": int(len(sub_all)), "failed": int(len(sub_all) - len(sub)),
            "metrics": _group_stats(sub, metrics, unit),
        }
    if "track" in table and len(table):
        out["per_track"] = {}
        for track in sorted(table["track"].dropna().astype(str).unique()):
            sub_all = table[table["track"].astype(str) == track]
            sub = ok[ok["track"].astype(str) == track]
            out["per_track"][track] = {
                "items": int(len(sub_all)), "failed": int(len(sub_all) - len(sub)),
                "metrics": _group_stats(sub, metrics, unit),
            }
    return out


def _json_clean(obj: Any) -> Any:
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {str(k): _json_clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_clean(v) for v in obj]
    if isinstance(obj, np.generic):
        return _json_clean(obj.item())
    return obj


def write_result(out: str | os.PathLike, table: pd.DataFrame, summary: dict[str, Any],
                 edition_dict: dict[str, Any]) -> Path:
    """Write a result folder (Parquet, edition, then summary last; all atomic).

    Raises
    ------
    InputError
        When ``out`` already holds anything.
    """

    out = check_out_dir(out)
    # built in a hidden sibling and renamed into place: a killed run leaves no folder behind
    with atomic_dir(out) as tmp:
        table.to_parquet(tmp / PER_SAMPLE, index=False)
        atomic_write_text(tmp / EDITION_JSON, json.dumps(edition_dict, indent=2) + "\n")
        atomic_write_text(tmp / SUMMARY, json.dumps(_json_clean(summary), indent=2,
                                                    allow_nan=False) + "\n")
    return out


def load_result(path: str | os.PathLike, table: bool = True) -> Result:
    """Load a result folder (or its ``summary.json``).

    Raises
    ------
    InputError
        Not a result folder, an interrupted run (no summary), or an unreadable summary.
    """
    path = Path(path)
    folder = path.parent if path.name == SUMMARY else path
    summary_path = folder / SUMMARY
    if not summary_path.is_file():
        hint = (" (interrupted run: per_sample.parquet without summary.json)"
                if (folder / PER_SAMPLE).is_file() else "")
        raise InputError(f"{folder} is not a result folder: {SUMMARY} not found{hint}")

    summary = parse_json_file(summary_path)
    if not isinstance(summary, dict):
        raise InputError(f"{summary_path}: a JSON {type(summary).__name__}, expected the "
                         "result summary object that 'dressmeup score' writes")
    if summary.get("schema") in READABLE_SCHEMAS:
        validate_json(summary, "result", str(summary_path))
    if summary.get("schema") not in READABLE_SCHEMAS:
        raise InputError(f"{summary_path}: schema {summary.get('schema')!r} is not one of "
                         f"{', '.join(READABLE_SCHEMAS)} (a newer toolkit wrote it? "
                         "upgrade dressmeup)")
    df = read_frame(folder / PER_SAMPLE, "per-item table") \
        if table and (folder / PER_SAMPLE).is_file() else None
    return Result(path=folder, summary=summary, table=df)
