"""Checksums of a dataset's files against its manifest.

Scoring verifies the sha256 of every dataset file it will read before it starts, so a
ground-truth file modified after the build (an accident, or casual tampering) stops the run
instead of silently changing the scores that a summary then attributes to the pinned data.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from dressmeup.data import layout
from dressmeup.data.manifest import HASH_OF, PATH_COLUMNS, read_manifest
from dressmeup.errors import InputError
from dressmeup.io.hashing import sha256_file


class ChecksumError(InputError):
    """Dataset files differ from the sha256 recorded in the manifest (``.problems`` lists them)."""

    def __init__(self, root: Path, problems: list[str]) -> None:
        shown = problems[:20]
        more = f"\n  ... and {len(problems) - 20} more" if len(problems) > 20 else ""
        super().__init__(
            f"dataset {root}: {len(problems)} file(s) do not match the manifest's sha256 "
            "(modified or damaged after the build; rebuild the data or restore the files):\n  "
            + "\n  ".join(shown) + more)
        self.problems = problems


def verify_listed_files(root: str | os.PathLike, rows: Iterable[dict], id_col: str,
                        path_col: str, hash_col: str) -> int:
    """Recompute the sha256 of files listed in ``rows`` (dicts with an id, a path relative to
    ``root`` and its sha256), for tables other than a dataset manifest (e.g. a mesh set).

    Returns the number of files verified; raises :class:`ChecksumError` on any mismatch.
    """

    root = Path(root)
    problems: list[str] = []
    n = 0
    for r in rows:
        rel, want = r.get(path_col), r.get(hash_col)
        if rel is None:
            continue
        full = layout.resolve_inside(root, rel, path_col)
        if not full.is_file():
            problems.append(f"{r.get(id_col)}: {rel} is missing")
        elif not want or sha256_file(full) != want:
            problems.append(f"{r.get(id_col)}: {rel} sha256 differs from the manifest's "
                            f"{hash_col}")
        n += 1
    if problems:
        raise ChecksumError(root, problems)
    return n


def verify_checksums(root: str | os.PathLike, sample_ids: Iterable[str] | None = None,
                     columns: Iterable[str] = PATH_COLUMNS) -> int:
    """Recompute the sha256 of the dataset files of ``sample_ids`` (default: all samples).

    Parameters
    ----------
    root : dataset root (holds ``manifest.parquet``).
    sample_ids : samples whose files are checked; ids absent from the manifest are ignored.
    columns : manifest path columns to check (default: every file of a sample).

    Returns
    -------
    The number of files verified.

    Raises
    ------
    ChecksumError
        When any file is missing, lacks a recorded checksum, or differs from it.
    InputError
        When the manifest is unreadable.
    """

    root = Path(root)
    table = read_manifest(root / layout.MANIFEST)
    wanted = None if sample_ids is None else set(sample_ids)
    problems: list[str] = []
    n = 0
    for r in table.to_pylist():
        sid = r.get("sample_id")
        if wanted is not None and sid not in wanted:
            continue
        for col in columns:
            rel = r.get(col)
            if rel is None:
                continue
            full = layout.resolve_inside(root, rel, col)
            want = r.get(HASH_OF[col])
            if not full.is_file():
                problems.append(f"sample {sid}: {rel} ({col}) is missing")
            elif not want:
                problems.append(f"sample {sid}: {rel} has no {HASH_OF[col]} in the manifest")
            elif sha256_file(full) != want:
                problems.append(f"sample {sid}: {rel} sha256 differs from the manifest's "
                                f"{HASH_OF[col]}")
            n += 1
    if problems:
        raise ChecksumError(root, problems)
    return n
