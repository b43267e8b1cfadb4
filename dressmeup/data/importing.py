"""Import a published dataset (CLOTH3D, 4D-DRESS, THuman2.x) into a DressMeUp-style folder.

The adapters (:mod:`dressmeup.data.adapters`) read the published layouts lazily; this module
writes their samples through :class:`~dressmeup.data.writer.DatasetWriter` (atomic, resumable,
sha256 per file), assigns splits by garment, and reports what was found and skipped. A run
that finds no sample is an error, never a silent success; so is a sample in other units than
the rest (a scan in millimetres among scans in metres), found by the same extent rule as the
metrics use (:func:`dressmeup.metrics.report.scale_mismatch`).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.data import adapters
from dressmeup.data.splits import split_by_garment
from dressmeup.data.writer import DatasetWriter
from dressmeup.errors import InputError
from dressmeup.metrics.report import scale_mismatch
from dressmeup.progress import progress

KINDS = ("cloth3d", "4ddress", "thuman")
BODY_FAMILY = {"cloth3d": "smpl", "4ddress": "smpl", "thuman": "smplx"}
SPLITS = ("by-garment", "train", "val", "test")


@dataclass
class ImportResult:
    """What :func:`import_dataset` did.

    Attributes
    ----------
    root : the dataset folder written.
    written : samples written now; resumed : samples already there (a re-run).
    summary : the adapter's report (counts per subject/garment/frame, skipped and why).
    sample_ids : every sample id of the import, in order.
    """

    root: Path
    written: int
    resumed: int
    summary: str
    sample_ids: list[str]


def read_published(kind: str, root: str | os.PathLike, *, frames: list | None = None,
                   stride: int = 10, smplx: str | os.PathLike | None = None,
                   gender: str | None = None, convention: str = "auto",
                   smpl_model_path: str | os.PathLike | None = None):
    """Open a published dataset with its adapter (see :data:`KINDS`); returns the
    :class:`~dressmeup.data.adapters.SampleCollection`."""

    root = Path(root)
    if not root.is_dir():
        raise InputError(f"{root}: not a folder (the {kind} dataset root)")
    if kind == "cloth3d":
        return adapters.read_cloth3d(root, frames=frames, stride=stride,
                                     smpl_model_path=smpl_model_path)
    if kind == "4ddress":
        return adapters.read_4ddress(root, frames=None if frames is None else
                                     [str(f) for f in frames], gender=gender)
    if kind == "thuman":
        return adapters.read_thuman(root, smplx, gender=gender or "male", convention=convention)
    raise InputError(f"dataset kind: expected one of {KINDS}, got {kind!r}")


def import_dataset(kind: str, root: str | os.PathLike, out: str | os.PathLike, *,
                   split: str = "by-garment", seed: int = 0, with_body: bool = True,
                   progress_bar: bool = True, log: Callable[[str], Any] | None = None,
                   **read_kw: Any) -> ImportResult:
    """Read a published dataset and write it as a DressMeUp-style dataset.

    Parameters
    ----------
    kind : ``cloth3d``, ``4ddress`` or ``thuman``.
    root : the published dataset's folder (for THuman: the scans folder; pass the fits with
        ``smplx=``).
    out : dataset folder to write (resumed when it holds the same import).
    split : ``by-garment`` (stratified by category, 60/20/20, seeded) or one split for all.
    seed : split seed.
    with_body : write the body parameters (needs the user's SMPL files for CLOTH3D, whose
        root joint is computed from the shape).
    read_kw : passed to :func:`read_published` (``frames``, ``stride``, ``smplx``, ``gender``,
        ``convention``, ``smpl_model_path``).

    Raises
    ------
    InputError : zero samples found (the message carries the adapter's report), a bad split,
        a sample in other units than the first one written or a garment in other units than
        its scan (:func:`check_units`; the samples before it are written, a re-run resumes).
    MissingModelError : CLOTH3D bodies without the SMPL file (use ``with_body=False`` or give
        ``smpl_model_path``).
    """

    if split not in SPLITS:
        raise InputError(f"split: expected one of {SPLITS}, got {split!r}")
    coll = read_published(kind, root, **read_kw)
    samples = coll.samples()
    summary = coll.report.summary(samples)
    if not samples:
        raise InputError(f"no samples found in {root} as {kind}; nothing written.\n{summary}")
    if split == "by-garment":
        cats = {s.garment_id: s.category for s in samples}
        assign = split_by_garment(sorted(cats), seed=seed, categories=cats,
                                  strategy="stratified")
    else:
        assign = {s.garment_id: split for s in samples}
    info = {"name": f"{kind}-import", "source": {"dataset": kind, "root": str(Path(root))},
            "body_model": BODY_FAMILY[kind] if with_body else None,
            "split": {"strategy": split, "seed": seed},
            "import_notes": list(coll.report.notes)}
    writer = DatasetWriter(out, info)
    written = resumed = 0
    reference: tuple[str, np.ndarray] | None = None  # the first sample written: its units
    for s in progress(samples, desc=f"import {kind}", disable=None if progress_bar else True):
        if writer.has_sample(s.sample_id):
            resumed += 1
            continue
        g = s.garment()
        texture = g.texture_image if g.texture_image is not None else g.texture_path
        garment = (g.vertices, g.faces) if g.uv is None else (g.vertices, g.faces, g.uv,
                                                               g.uv_faces)
        scan = s.scan()
        this = check_units(s, g.vertices, scan, reference)
        reference = reference or this
        writer.add_sample(subject_id=s.subject_id, garment_id=s.garment_id, pose_id=s.pose_id,
                          category=s.category, garment_type=s.garment_type,
                          split=assign[s.garment_id], garment=garment,
                          body=s.body() if with_body else None, scan=scan,
                          texture=texture, sample_id=s.sample_id)
        written += 1
    root_out = writer.finalize()
    if log is not None:
        log(summary)
    return ImportResult(Path(root_out), written, resumed, summary,
                        [s.sample_id for s in samples])


def _source(sample: Any) -> str:
    """How messages name a sample: its id and the file it was read from."""
    path = sample.row.get("scan_path") or sample.row.get("garment_path")
    return f"sample {sample.sample_id}" + (f" ({path})" if path else "")


def check_units(sample: Any, garment_vertices: np.ndarray, scan: Any,
                reference: tuple[str, np.ndarray] | None) -> tuple[str, np.ndarray]:
    """Check that one imported sample is in the same units as its scan and the import.

    Parameters
    ----------
    sample : the adapter's sample (its id and source file name the messages).
    garment_vertices : (n, 3) float garment vertices.
    scan : ``(V (k, 3), F)`` of the sample's scan, or None.
    reference : ``(name, (r, 3) vertices)`` of the sample every other one is compared with
        (the first written), or None to compare nothing across samples.

    Returns
    -------
    ``(name, vertices)`` of this sample (its scan, else its garment): the reference for the
    next ones.

    Raises
    ------
    InputError
        The garment spans more than :data:`~dressmeup.metrics.report.UNIT_RATIO` times its
        scan or the reference, or less than its inverse (e.g. millimetres against metres).
    """
    name = _source(sample)
    own = np.asarray(garment_vertices if scan is None else scan[0], float)
    problem = None
    if scan is not None:
        problem = scale_mismatch(garment_vertices, own, f"garment of {name}", "its scan")
    if problem is None and reference is not None:
        problem = scale_mismatch(own, reference[1], name, reference[0])
    if problem is not None:
        raise InputError(f"{problem[0].upper()}{problem[1:]}; convert it to metres and import "
                         "again")
    return name, own
