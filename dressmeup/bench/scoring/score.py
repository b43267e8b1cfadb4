"""Scoring: validate a submission, score every item in parallel, write a result folder."""

from __future__ import annotations

import datetime as _dt
import os
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow.parquet as pq

from dressmeup import __version__
from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.scoring.provenance import environment
from dressmeup.bench.scoring.results import (
    RESULT_SCHEMA,
    RESULT_SCHEMA_VERSION,
    check_out_dir,
    summarise,
    write_result,
)
from dressmeup.bench.scoring.submission import submission_hash
from dressmeup.bench.scoring.validate import ValidationReport, check_submission
from dressmeup.bench.tasks import Task, get_task
from dressmeup.bench.tasks.base import STATUS_ERROR
from dressmeup.bench.tasks.common import other_data_reason
from dressmeup.data import layout
from dressmeup.data.integrity import verify_checksums, verify_listed_files
from dressmeup.data.parts import part_of, withheld_message
from dressmeup.errors import InputError
from dressmeup.executors import Executor, LocalExecutor, require_shared
from dressmeup.io.tables import read_frame, table_size
from dressmeup.progress import progress

if TYPE_CHECKING:  # pragma: no cover - annotations only
    import pandas as pd


class InvalidSubmissionError(InputError):
    """Scoring refused: the submission has problems (``.report`` lists them all)."""

    def __init__(self, report: ValidationReport) -> None:
        super().__init__(report.summary(max_per_kind=20))
        self.report = report


@dataclass
class ScoreResult:
    """What :func:`score_submission` wrote.

    Attributes
    ----------
    path : the result folder.
    summary : the summary dict (as in ``summary.json``; NaN instead of null).
    table : per-item rows.
    """

    path: Path
    summary: dict[str, Any]
    table: pd.DataFrame


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def score_submission(submission: str | os.PathLike, edition: str | os.PathLike | Edition,
                     data_root: str | os.PathLike, out: str | os.PathLike, *,
                     executor: Executor | None = None, workers: int | None = None,
                     show_progress: bool | None = None,
                     allow_other_data: bool = False) -> ScoreResult:
    """Validate then score a submission; write ``out/`` (per-sample Parquet + summary JSON).

    Parameters
    ----------
    submission : submission folder (``submission.json`` + one file per item).
    edition : edition name, path or object.
    data_root : the dataset root the edition is scored on.
    out : result folder to create; must not exist or be empty (never overwritten).
    executor : where jobs run (default :class:`LocalExecutor` with ``workers``).
    workers : worker processes for the default executor (default: every core).
    show_progress : progress bar on stderr (default: unless ``DRESSMEUP_NO_PROGRESS``).
    allow_other_data : score data whose manifest differs from the edition's
        ``dataset.expected_manifest_sha256`` anyway; the result is marked
        ``"comparable": false`` (with ``"not_comparable_reason"``) and every leaderboard shows
        it unranked as "not comparable".

    Returns
    -------
    ScoreResult

    Raises
    ------
    InvalidSubmissionError
        When validation finds any problem (nothing is scored, nothing is written).
    InputError
        When ``out`` already holds anything, or the data is not the edition's pinned data
        (see ``allow_other_data``).
    dressmeup.data.integrity.ChecksumError
        When a dataset file the items read differs from the manifest's sha256.
    """

    t_start = time.perf_counter()
    started = _now()
    out = check_out_dir(out)
    ed = load_edition(edition)
    task = get_task(ed.task)
    report, other_data = _admit(submission, ed, task, data_root, allow_other_data)
    report.dataset["files_verified"] = _verify_data(Path(data_root), report.items)
    sub_hash = submission_hash(submission)
    jobs = task.jobs(ed, Path(data_root), report.files, report.items,
                     show_progress=show_progress)
    executor = executor or LocalExecutor(workers)
    # a distributed executor checks that its workers see what the jobs read
    require_shared(executor, data_root, submission, *_job_folders(jobs))
    rows = _score_jobs(executor, task, jobs, f"scoring {ed.name}", show_progress)
    table = _to_table(rows, list(ed.metrics), list(task.extra_columns))
    stats = summarise(table, list(ed.metrics), list(task.extra_columns),
                      unit_columns=task.unit_columns)
    info = report.info or {}
    summary: dict[str, Any] = {
        "schema": RESULT_SCHEMA,
        "schema_version": RESULT_SCHEMA_VERSION,
        "task": ed.task,
        "edition": {"name": ed.name, "version": ed.version, "hash": ed.hash,
                    "source": ed.source},
        "method": dict(info),
        "dataset": dict(report.dataset),
        "submission": {"path": str(Path(submission).resolve()), "sha256": sub_hash},
        "units": {"distances": "m", "chamfer": "m^2 when squared", "ratios": "fraction"},
        **stats,
        "provenance": _provenance(ed, report, sub_hash, executor, started, t_start),
    }
    if other_data:
        summary["comparable"] = False
        summary["not_comparable_reason"] = other_data
    path = write_result(out, table, summary, ed.to_dict())
    return ScoreResult(path=path, summary=summary, table=table)


def _provenance(ed: Edition, report: ValidationReport, sub_hash: str, executor: Executor,
                started: str, t_start: float) -> dict[str, Any]:
    """What produced the result: toolkit, edition, data and submission hashes, times, host,
    executor."""
    return {
        "toolkit": "dressmeup", "toolkit_version": __version__,
        "edition_hash": ed.hash,
        "manifest_sha256": report.dataset.get("manifest_sha256"),
        "submission_sha256": sub_hash,
        "started_utc": started, "finished_utc": _now(),
        "duration_s": round(time.perf_counter() - t_start, 3),
        **environment(),  # host, platform, python
        "executor": getattr(executor, "name", type(executor).__name__),
        "workers": getattr(executor, "workers", None),
    }


def _admit(submission, ed: Edition, task: Task, data_root,
           allow_other_data: bool) -> tuple[ValidationReport, str | None]:
    """Refuse before any work: a public part (no ground truth), an invalid submission, data
    other than the edition's pin unless allowed. Returns the validation report and the reason
    the data is not the pinned data (None when it is)."""
    if part_of(data_root) == "public":
        raise InputError(withheld_message(data_root, "the ground truth"))
    report = check_submission(submission, ed, task, data_root)
    if not report.ok:
        raise InvalidSubmissionError(report)
    other_data = other_data_reason(ed, report.dataset or {}, data_root)
    if other_data and not allow_other_data:
        raise InputError(f"{other_data}. Regenerate the data (dressmeup.runs.build_data) "
                         "on a supported machine, or pass --allow-other-data to score it anyway "
                         "as 'not comparable'")
    return report, other_data


def _score_jobs(executor: Executor, task: Task, jobs: list[dict], desc: str,
                show_progress: bool | None) -> list[dict[str, Any]]:
    """One row per job, in job order: the task's scores with the item's ids (the unit
    columns of the bootstrap: subject, session, garment), or an error row."""
    rows: list[dict[str, Any]] = []
    bar = progress(executor.run(task.score_job, jobs), desc=desc, total=len(jobs),
                   disable=None if show_progress is None else not show_progress)
    for i, res in bar:
        if isinstance(res, BaseException):
            job = jobs[i]
            msg = "".join(traceback.format_exception_only(type(res), res)).strip()
            rows.append({"sample_id": job["item_id"], "category": job["category"],
                         **{k: v for k, v in job.get("meta", {}).items() if k != "data_root"},
                         "status": STATUS_ERROR, "error": msg[:2000], "note": "",
                         "seconds": float("nan")})
        else:
            for key, value in jobs[i].get("meta", {}).items():
                if key != "data_root" and not key.endswith("_path"):
                    res.setdefault(key, value)
            rows.append(res)
    return rows


def _verify_data(data_root: Path, items: list[Any]) -> int:
    """sha256 of every manifest file of the samples the items name (refuse on mismatch).

    Items name their samples by id (the item id or a string in ``meta``); a data root
    without a manifest (a task not scored on a dataset) has nothing to verify.
    """
    if not (data_root / layout.MANIFEST).is_file():
        return 0
    ids = set()
    for it in items:
        ids.add(str(it.item_id))
        ids.update(v for v in (getattr(it, "meta", None) or {}).values() if isinstance(v, str))
    table_size(data_root / layout.MANIFEST, "manifest")  # bounded and readable first
    columns = set(pq.read_schema(data_root / layout.MANIFEST).names)
    if "sample_id" not in columns and {"mesh_id", "path", "sha256"} <= columns:  # a mesh set
        rows = read_frame(data_root / layout.MANIFEST, "manifest").to_dict("records")
        return verify_listed_files(data_root, [r for r in rows if r["mesh_id"] in ids],
                                   "mesh_id", "path", "sha256")
    return verify_checksums(data_root, ids)


def _job_folders(jobs: list[dict[str, Any]]) -> list[str]:
    """The folders of every file a job reads (``*_path`` fields: predictions, posed bodies in
    the toolkit cache, ...): a worker on another machine must see them too."""
    return sorted({str(Path(v).parent) for job in jobs for k, v in job.items()
                   if k.endswith("_path") and isinstance(v, str) and v})


def _to_table(rows: list[dict[str, Any]], metrics: list[str], extra: list[str]) -> pd.DataFrame:
    """Rows -> DataFrame with a fixed column order, sorted by sample id."""
    # heavy: pandas
    import pandas as pd

    front = ["sample_id", "category"]
    table = pd.DataFrame(rows)
    for col in (*metrics, *extra):
        if col not in table:
            table[col] = np.nan
        table[col] = table[col].astype(np.float64)
    for col in ("status", "error", "note"):
        if col not in table:
            table[col] = ""
        table[col] = table[col].fillna("").astype(str)
    if "seconds" not in table:
        table["seconds"] = np.nan
    ids = [c for c in table.columns if c not in (*front, *metrics, *extra, "status", "error",
                                                  "note", "seconds")]
    cols = [*front, *ids, *metrics, *extra, "status", "error", "note", "seconds"]
    table = table[cols].sort_values("sample_id", kind="stable").reset_index(drop=True)
    return table
