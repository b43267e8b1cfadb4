"""Submission validation: report every problem at once, before any scoring starts."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.scoring.submission import ITEM_ID_RE, read_info, submission_files
from dressmeup.bench.tasks import Item, Task, get_task
from dressmeup.errors import InputError

#: Problem kinds, in report order.
KINDS = ("dataset", "metadata", "missing", "extra", "duplicate", "size", "unreadable",
         "invalid")


@dataclass
class Problem:
    """One problem of a submission.

    Attributes
    ----------
    kind : one of :data:`KINDS`.
    message : what is wrong and, where useful, what to do.
    item_id : the item concerned (None for folder-level problems).
    path : the file concerned, if any.
    """

    kind: str
    message: str
    item_id: str | None = None
    path: str | None = None

    def __str__(self) -> str:
        where = f"{self.item_id}: " if self.item_id else ""
        return f"[{self.kind}] {where}{self.message}"


@dataclass
class ValidationReport:
    """Result of :func:`validate_submission`.

    Attributes
    ----------
    edition : the edition validated against.
    problems : every problem found (empty when valid).
    items : the items the edition expects.
    files : item id -> the submission file that answers it.
    info : parsed ``submission.json`` (or None).
    dataset : dataset info (root, name, version, manifest_sha256).
    """

    edition: Edition
    problems: list[Problem] = field(default_factory=list)
    items: list[Item] = field(default_factory=list)
    files: dict[str, Path] = field(default_factory=dict)
    info: dict[str, Any] | None = None
    dataset: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when no problem was found."""
        return not self.problems

    def summary(self, max_per_kind: int | None = None) -> str:
        """Human-readable report: one line per problem, grouped by kind, with counts."""
        if self.ok:
            return (f"submission is valid for edition {self.edition.name} "
                    f"({len(self.items)} items)")
        lines = [f"submission is INVALID for edition {self.edition.name}: "
                 f"{len(self.problems)} problem(s)"]
        for kind in KINDS:
            probs = [p for p in self.problems if p.kind == kind]
            if not probs:
                continue
            lines.append(f"{kind} ({len(probs)}):")
            shown = probs if max_per_kind is None else probs[:max_per_kind]
            lines += [f"  - {(p.item_id + ': ') if p.item_id else ''}{p.message}"
                      for p in shown]
            if len(shown) < len(probs):
                lines.append(f"  ... and {len(probs) - len(shown)} more")
        return "\n".join(lines)


def validate_submission(submission: str | os.PathLike, edition: str | os.PathLike | Edition,
                        data_root: str | os.PathLike) -> ValidationReport:
    """Check a submission folder against an edition and its dataset; collect every problem.

    Checks: the dataset matches the edition's pin; ``submission.json`` exists with every
    field, names the edition and its task; every expected item has exactly one file (missing,
    extra and duplicate ids); files over the edition's size limit; each file readable, with
    the right array shapes and vertex counts, finite values and faces in range (task rules).

    Parameters
    ----------
    submission : the submission folder.
    edition : edition name, path or object.
    data_root : the dataset (or mesh set) root the edition is scored on.

    Returns
    -------
    ValidationReport (``report.ok`` is False when any problem was found).

    Raises
    ------
    InputError
        When ``submission`` is not a folder or the edition cannot be loaded.
    """
    ed = load_edition(edition)
    return check_submission(submission, ed, get_task(ed.task), data_root)


def check_submission(submission: str | Path, ed: Edition, task: Task,
                     data_root: str | Path) -> ValidationReport:
    """:func:`validate_submission` for an edition and its task already loaded (scoring loads
    them once and passes them down)."""
    sub = Path(submission)
    if not sub.is_dir():
        raise InputError(f"submission {sub} is not a folder (expected submission.json plus one "
                         "file per item)")
    report = ValidationReport(edition=ed)
    _check_dataset(report, task, Path(data_root))
    _check_info(report, sub)
    by_id = _files_by_id(report, sub, tuple(task.file_suffixes))
    _check_answers(report, task, by_id)
    order = {k: i for i, k in enumerate(KINDS)}
    report.problems.sort(key=lambda p: (order.get(p.kind, 99), p.item_id or ""))
    return report


def _check_dataset(report: ValidationReport, task: Task, data_root: Path) -> None:
    """The dataset matches the edition's pin; the edition's items listed from it."""
    ed, add = report.edition, report.problems.append
    dataset_info, ds_problems = task.dataset_problems(ed, data_root)
    report.dataset = dataset_info
    for msg in ds_problems:
        add(Problem("dataset", msg))
    if not ds_problems:
        try:
            report.items = task.items(ed, data_root)
        except (InputError, FileNotFoundError, ValueError, KeyError) as exc:
            add(Problem("dataset", f"cannot list the edition's items from {data_root}: {exc}"))


def _check_info(report: ValidationReport, sub: Path) -> None:
    """``submission.json``: every field, and the edition and task it names."""
    ed, add = report.edition, report.problems.append
    info, info_probs = read_info(sub)
    report.info = info
    for msg in info_probs:
        add(Problem("metadata", msg))
    if info is not None:
        if isinstance(info.get("task"), str) and info["task"] != ed.task:
            add(Problem("metadata", f"submission.json task is {info['task']!r}, edition "
                                    f"{ed.name} is a {ed.task!r} edition"))
        if isinstance(info.get("edition"), str) and info["edition"] != ed.name:
            add(Problem("metadata", f"submission.json edition is {info['edition']!r}, "
                                    f"validating against {ed.name!r}"))


def _files_by_id(report: ValidationReport, sub: Path,
                 suffixes: tuple[str, ...]) -> dict[str, list[Path]]:
    """Item id -> the plain files named ``<id><suffix>`` in ``sub``; anything else (links out
    of the folder, FIFOs, folders, other names) is a problem."""
    add = report.problems.append
    by_id: dict[str, list[Path]] = {}
    sub_root = sub.resolve()
    for p in submission_files(sub):
        if p.is_symlink() and not p.resolve().is_relative_to(sub_root):
            add(Problem("unreadable", f"{p.name} is a symbolic link leaving the submission "
                                      f"folder (to {p.resolve()}); copy the file in",
                        path=str(p)))
            continue
        if not p.is_dir() and not p.is_file():  # a FIFO would block every read forever
            add(Problem("unreadable", f"{p.name} is not a regular file (FIFO, socket or "
                                      "device); store plain files", path=str(p)))
            continue
        if p.is_dir():
            add(Problem("extra", f"unexpected folder {p.name}/", path=str(p)))
            continue
        suffix = p.suffix.lower()
        stem = p.name[: -len(suffix)] if suffix else p.name
        if suffix not in suffixes:
            add(Problem("extra", f"unexpected file {p.name} (expected <id>"
                                 f"{'|'.join(suffixes)})", path=str(p)))
            continue
        if not ITEM_ID_RE.match(stem):
            add(Problem("extra", f"file {p.name}: id {stem!r} uses characters other than "
                                 "letters, digits, '-' and '_'", path=str(p)))
            continue
        by_id.setdefault(stem, []).append(p)
    return by_id


def _check_answers(report: ValidationReport, task: Task, by_id: dict[str, list[Path]]) -> None:
    """One file per expected item (missing, extra, duplicate), under the size limit, and each
    file as the task's rules want it; fills ``report.files``."""
    ed, items, add = report.edition, report.items, report.problems.append
    suffixes = tuple(task.file_suffixes)
    expected = {it.item_id: it for it in items}
    if items:
        missing = [i for i in expected if i not in by_id]
        for item_id in missing:
            add(Problem("missing", f"no file for this item (expected {item_id}{suffixes[0]})",
                        item_id=item_id))
        for item_id in sorted(set(by_id) - set(expected)):
            add(Problem("extra", f"{by_id[item_id][0].name} is not an item of edition "
                                 f"{ed.name}", item_id=item_id, path=str(by_id[item_id][0])))
    limit = ed.size_limit_bytes
    for item_id, paths in sorted(by_id.items()):
        if items and item_id not in expected:
            continue
        if len(paths) > 1:
            add(Problem("duplicate", f"several files answer this item: "
                                     f"{', '.join(p.name for p in paths)} (keep one)",
                        item_id=item_id))
            continue
        path = paths[0]
        size = path.stat().st_size
        if size > limit:
            add(Problem("size", f"{path.name} is {size / 2**20:.1f} MB, over the edition's "
                                f"limit of {limit / 2**20:.0f} MB", item_id=item_id,
                        path=str(path)))
            continue
        report.files[item_id] = path
        if item_id in expected:
            for msg in task.check_file(path, expected[item_id], ed):
                kind = "unreadable" if msg.startswith("unreadable") else "invalid"
                add(Problem(kind, f"{path.name}: {msg}", item_id=item_id, path=str(path)))
