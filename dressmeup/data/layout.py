"""The on-disk layout of a DressMeUp-style dataset (docs/spec.md section 3).

::

    ROOT/
      dataset.json                       name, version, licence, units, body model, ...
      manifest.parquet                   one row per sample (see :mod:`dressmeup.data.manifest`)
      samples/<subject>/<garment>/<pose>/
          garment.ply (+ garment.png)    the garment mesh (per-corner UVs) and texture
          scan.ply                       the clothed person (optional)
          body.npz                       registered body parameters

Ids use only letters, digits, ``-`` and ``_``; every path stored in the manifest is relative
to ROOT, uses ``/`` and must stay inside ROOT.
"""

from __future__ import annotations

import functools
import os
import re
from pathlib import Path, PurePosixPath

from dressmeup.errors import InputError

DATASET_JSON = "dataset.json"
MANIFEST = "manifest.parquet"
SAMPLES_DIR = "samples"
GARMENT_FILE = "garment.ply"
TEXTURE_FILE = "garment.png"  # dressmeup.io.mesh names the texture after the mesh
SCAN_FILE = "scan.ply"
BODY_FILE = "body.npz"

ID_PATTERN = re.compile(r"^[A-Za-z0-9_-]+$")


def check_id(value: str, name: str = "id") -> str:
    """Return ``value`` if it is a valid id (letters, digits, ``-``, ``_``), else raise.

    Parameters
    ----------
    value : the id to check.
    name : the argument name used in the error message.

    Raises
    ------
    InputError
        When ``value`` is empty, not a string, or contains another character.
    """
    if not isinstance(value, str) or not ID_PATTERN.match(value):
        raise InputError(
            f"{name} must use only letters, digits, '-' and '_' (e.g. 'S01-G03-P2'); got {value!r}"
        )
    return value


def make_sample_id(subject_id: str, garment_id: str, pose_id: str) -> str:
    """The default sample id ``<subject>-<garment>-<pose>`` (e.g. ``S01-G03-P2``)."""
    return "-".join(check_id(v, n) for v, n in ((subject_id, "subject_id"),
                                                 (garment_id, "garment_id"),
                                                 (pose_id, "pose_id")))


def sample_dir(subject_id: str, garment_id: str, pose_id: str) -> str:
    """Relative (posix) folder of one sample: ``samples/<subject>/<garment>/<pose>``."""
    check_id(subject_id, "subject_id")
    check_id(garment_id, "garment_id")
    check_id(pose_id, "pose_id")
    return f"{SAMPLES_DIR}/{subject_id}/{garment_id}/{pose_id}"


@functools.lru_cache(maxsize=32)
def _real_root(root: str) -> str:
    """The real path of a dataset root (cached: a manifest resolves one path per file)."""
    return os.path.realpath(root)


def resolve_inside(root: str | os.PathLike, rel: str, name: str = "path") -> Path:
    """Resolve a manifest path ``rel`` against ``root`` and refuse it if it escapes ROOT.

    Parameters
    ----------
    root : dataset root folder.
    rel : a relative posix path as stored in the manifest.
    name : field name used in the error message.

    Returns
    -------
    The absolute path (symlinks resolved).

    Raises
    ------
    InputError
        When ``rel`` is absolute, contains ``..`` segments, resolves outside ``root``, or
        passes through a symbolic link loop.
    """
    if not isinstance(rel, str) or not rel:
        raise InputError(f"{name}: expected a non-empty relative path, got {rel!r}")
    pure = PurePosixPath(rel)
    if pure.is_absolute() or rel.startswith("\\") or re.match(r"^[A-Za-z]:", rel):
        raise InputError(f"{name}: path {rel!r} is absolute; manifest paths are relative to ROOT")
    if ".." in pure.parts or "\\" in rel:
        raise InputError(f"{name}: path {rel!r} escapes the dataset root")
    try:  # os.path: the same resolution as pathlib, several times faster per row
        root_abs = _real_root(os.path.abspath(os.fspath(root)))
        full = os.path.realpath(os.path.join(root_abs, *pure.parts), strict=False)
    except (RuntimeError, OSError) as exc:
        raise InputError(f"{name}: path {rel!r} cannot be resolved under {root} ({exc}): a "
                         "symbolic link loop?") from exc
    if full != root_abs and not full.startswith(root_abs.rstrip(os.sep) + os.sep):
        raise InputError(f"{name}: path {rel!r} resolves outside the dataset root "
                         f"({full})")
    return Path(full)
