"""Submissions: a folder with ``submission.json`` and one file per item (docs/spec.md section 4).

::

    SUBMISSION/
      submission.json          task, edition, method, authors, url, hardware,
                               runtime_per_sample_s (mean seconds per item)
      <item_id>.npz            retarget: vertices (n, 3) float; also .ply / .obj accepted
      ...

Method authors write one with :func:`write_submission`::

    from dressmeup.bench import write_submission
    write_submission("subs/mymethod", {"S01-G01-P0__to__S01-G01-P1": verts, ...},
                     edition="synth-retarget-v2", method="MyMethod", authors="A. Author",
                     url="https://example.org", hardware="1x CPU", runtime_per_sample_s=0.8)
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.boards.escape import one_line_problem
from dressmeup.bench.edition import Edition, load_edition
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_dir, atomic_path, atomic_write_text
from dressmeup.io.hashing import sha256_file
from dressmeup.io.jsonio import parse_json_file, schema_problems

SUBMISSION_JSON = "submission.json"
REQUIRED_FIELDS = ("task", "edition", "method", "authors", "url", "hardware",
                   "runtime_per_sample_s")
ITEM_ID_RE = re.compile(r"^[A-Za-z0-9_-]+$")


@dataclass
class SubmissionInfo:
    """The fields of ``submission.json``.

    Attributes
    ----------
    task : the edition's task (``retarget``, ``uvparam``, ...).
    edition : the edition name the submission answers.
    method : method name shown in leaderboards.
    authors : authors (free text).
    url : paper or code URL (may be empty).
    hardware : what it ran on (``"1x Intel i7 CPU"``).
    runtime_per_sample_s : mean wall time per item in seconds.
    extra : any further fields (kept, not checked).
    """

    task: str
    edition: str
    method: str
    authors: str
    url: str
    hardware: str
    runtime_per_sample_s: float
    extra: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (``extra`` merged at the top level)."""
        d = asdict(self)
        extra = d.pop("extra") or {}
        return {**d, **extra}


def info_problems(data: Any) -> list[str]:
    """Every problem of a parsed ``submission.json`` (missing fields, wrong types)."""
    if not isinstance(data, dict):
        return [f"{SUBMISSION_JSON} must hold a JSON object, got {type(data).__name__}"]
    problems = []
    missing = [k for k in REQUIRED_FIELDS if k not in data]
    if missing:
        problems.append(f"{SUBMISSION_JSON} is missing fields: {', '.join(missing)}")
    for key in ("task", "edition", "method"):
        if key in data and (not isinstance(data[key], str) or not data[key].strip()):
            problems.append(f"{SUBMISSION_JSON}: {key!r} must be a non-empty string, "
                            f"got {data[key]!r}")
    method = data.get("method")
    if isinstance(method, str) and method.strip():
        problem = one_line_problem(method, f"{SUBMISSION_JSON}: 'method'")
        if problem:
            problems.append(problem)
    for key in ("authors", "url", "hardware"):
        if key in data and not isinstance(data[key], (str, list)):
            problems.append(f"{SUBMISSION_JSON}: {key!r} must be a string, got {data[key]!r}")
    if "runtime_per_sample_s" in data:
        rt = data["runtime_per_sample_s"]
        if rt is not None and (not isinstance(rt, (int, float)) or isinstance(rt, bool)
                               or not np.isfinite(rt) or rt < 0):
            problems.append(f"{SUBMISSION_JSON}: 'runtime_per_sample_s' must be a number of "
                            f"seconds >= 0 (or null when unknown), got {rt!r}")
    return problems


def read_info(folder: str | os.PathLike) -> tuple[dict[str, Any] | None, list[str]]:
    """Read ``submission.json``; return (data or None, problems)."""
    path = Path(folder) / SUBMISSION_JSON
    if not path.is_file():
        return None, [f"{SUBMISSION_JSON} is missing (fields: {', '.join(REQUIRED_FIELDS)})"]

    try:
        data = parse_json_file(path)
    except (OSError, InputError) as exc:
        return None, [f"{SUBMISSION_JSON} cannot be read: {exc}"]
    problems = info_problems(data) or schema_problems(data, "submission", SUBMISSION_JSON)
    return (data if isinstance(data, dict) else None), problems


def submission_files(folder: str | os.PathLike) -> list[Path]:
    """Every file of a submission except ``submission.json`` and hidden files, sorted."""
    folder = Path(folder)
    return sorted(p for p in folder.iterdir()
                  if p.name != SUBMISSION_JSON and not p.name.startswith("."))


def submission_hash(folder: str | os.PathLike) -> str:
    """sha256 over the sorted (name, sha256 of bytes) of every file, ``submission.json``
    included: any change to a prediction or to the metadata changes it."""

    folder = Path(folder)
    h = hashlib.sha256()
    files = submission_files(folder)
    if (folder / SUBMISSION_JSON).is_file():
        files = sorted([*files, folder / SUBMISSION_JSON])
    for p in files:
        if p.is_file():
            h.update(p.name.encode("utf-8") + b"\0" + sha256_file(p).encode("ascii") + b"\n")
    return h.hexdigest()


def write_submission(out: str | os.PathLike, predictions: Mapping[str, Any], *,
                     edition: str | Any, method: str, authors: str = "", url: str = "",
                     hardware: str = "", runtime_per_sample_s: float | None = None,
                     task: str | None = None, extra: Mapping[str, Any] | None = None,
                     overwrite: bool = False) -> Path:
    """Write a submission folder from in-memory predictions.

    Parameters
    ----------
    out : the submission folder (created; must be empty unless ``overwrite``).
    predictions : item id -> prediction. ``retarget``: ``vertices (n, 3) float`` (an array)
        or a dict of arrays (e.g. ``{"vertices": V}``); ``uvparam``: a dict with ``uv (k, 2)``
        and ``uv_faces (m, 3)`` (and optionally ``chart_ids (m,)``, ``seconds``). Each is
        written to ``<item_id>.npz`` (float arrays as float64 for vertices/uv).
    edition : edition name, path or :class:`~dressmeup.bench.edition.Edition`; its name and
        task go into ``submission.json``.
    method, authors, url, hardware, runtime_per_sample_s : ``submission.json`` fields.
    task : overrides the edition's task (only for editions not loadable here).
    extra : further ``submission.json`` fields.
    overwrite : allow writing into a non-empty folder (files of the same ids are replaced).

    Returns
    -------
    The folder path.

    Raises
    ------
    InputError
        Invalid item id, a prediction that is not an array/dict of arrays, a method name
        that is not one line, or a non-empty folder without ``overwrite``.
    """
    problem = one_line_problem(method, "method") if isinstance(method, str) else None
    if problem:
        raise InputError(problem)

    if isinstance(edition, Edition):
        ed_name, ed_task = edition.name, edition.task
    else:
        try:
            ed = load_edition(edition)
            ed_name, ed_task = ed.name, ed.task
        except InputError:
            if task is None:
                raise
            ed_name, ed_task = str(edition), task
    out = check_submission_out(out, overwrite, flag="overwrite=True")
    with atomic_dir(out, merge=overwrite) as tmp:
        _write_predictions(tmp, predictions)
        info = SubmissionInfo(task=task or ed_task, edition=ed_name, method=method,
                              authors=authors, url=url, hardware=hardware,
                              runtime_per_sample_s=(None if runtime_per_sample_s is None
                                                    else float(runtime_per_sample_s)),
                              extra=dict(extra) if extra else None)
        atomic_write_text(tmp / SUBMISSION_JSON, json.dumps(info.to_dict(), indent=2) + "\n")
    return out


def check_submission_out(out: str | os.PathLike, overwrite: bool = False,
                         flag: str = "--overwrite") -> Path:
    """Refuse a submission folder that is a file, or non-empty without ``overwrite``.

    Call it before the work (a CLI passes ``flag="--overwrite"`` so the message names the
    option the user can give). Returns ``out`` as a Path.

    Raises
    ------
    InputError
        ``out`` is a file, or a non-empty folder and ``overwrite`` is false.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"submission folder {out} is an existing file; choose a folder path")
    if out.is_dir() and any(out.iterdir()) and not overwrite:
        raise InputError(f"submission folder {out} is not empty; choose a new folder or pass "
                         f"{flag}")
    return out


def _write_predictions(out: Path, predictions: Mapping[str, Any]) -> None:
    """Write one ``<item_id>.npz`` per prediction into ``out``."""

    for item_id, pred in predictions.items():
        if not isinstance(item_id, str) or not ITEM_ID_RE.match(item_id):
            raise InputError(f"predictions: item id {item_id!r} must use letters, digits, "
                             "'-' and '_'")
        if isinstance(pred, Mapping):
            arrays = {k: np.asarray(v) for k, v in pred.items()}
        elif isinstance(pred, np.ndarray) or hasattr(pred, "__array__"):
            arrays = {"vertices": np.asarray(pred)}
        else:
            raise InputError(f"predictions[{item_id!r}]: expected an array or a dict of arrays, "
                             f"got {type(pred).__name__}")
        for key in ("vertices", "uv"):
            if key in arrays and np.issubdtype(arrays[key].dtype, np.floating):
                arrays[key] = arrays[key].astype(np.float64)
        if any(a.dtype == object for a in arrays.values()):
            raise InputError(f"predictions[{item_id!r}]: object arrays cannot be stored "
                             "without pickle")
        with atomic_path(out / f"{item_id}.npz") as tmp:
            np.savez(tmp, **arrays)
