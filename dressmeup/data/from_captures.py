"""Capture sessions -> dataset samples: the dataset builder's assembly loop.

For each session: fuse (``dressmeup.fusion``) -> extract, UV-map and texture the garments
(``dressmeup.extraction``) -> find the body (registration, an external fit, or a synthetic
session's ground truth) -> write one dataset sample per garment with
:class:`~dressmeup.data.writer.DatasetWriter`. A session that fails is recorded and skipped;
a re-run skips the samples already in the dataset, so an interrupted build resumes.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.errors import DressmeupError

log = logging.getLogger(__name__)

BODY_SOURCES = ("auto", "register", "session", "ground-truth", "none")


@dataclass
class BuildReport:
    """What :func:`build_dataset_from_sessions` did.

    Attributes
    ----------
    written, skipped : numbers of samples written now and already present.
    failed : (session folder, error message) for every session that failed.
    failures_path : ``ROOT/build-failures.json`` when any session failed, else None.
    """

    written: int = 0
    skipped: int = 0
    failed: list[tuple[str, str]] = field(default_factory=list)
    failures_path: Path | None = None


def find_sessions(paths: Iterable[str | Path]) -> list[Path]:
    """Expand ``paths`` into session folders (a folder with session.json or rig.json, or the
    session folders directly inside a given folder). Missing paths are kept so that they are
    reported as failed sessions."""
    out: list[Path] = []
    for p in map(Path, paths):
        if (p / "session.json").is_file() or (p / "rig.json").is_file():
            out.append(p)
        elif p.is_dir():
            subs = sorted(q for q in p.iterdir()
                          if (q / "session.json").is_file() or (q / "rig.json").is_file())
            out.extend(subs if subs else [p])
        else:
            out.append(p)
    return out


def body_for_session(session: Any, vertices: np.ndarray, faces: np.ndarray, source: str = "auto",
                     body_model: str = "anny") -> tuple[Any, np.ndarray | None, str]:
    """Find the body under a fused scan.

    Parameters
    ----------
    session : an opened capture session (``dressmeup.capture.session.open_session``).
    vertices : (n, 3) float64 fused scan vertices; faces : (m, 3) int64.
    source : ``register`` (fit ``body_model`` to the scan), ``session`` (SESSION/body.npz, an
        external fit in the rig frame), ``ground-truth`` (a synthetic session's true body; the
        samples are then written in its frame), ``none``, or ``auto`` (those in that order).
    body_model : body model name for registration.

    Returns
    -------
    (BodyParams or None, (4, 4) transform to apply to written meshes or None, source used).
    """
    if source not in BODY_SOURCES:
        raise ValueError(f"source: expected one of {BODY_SOURCES}, got {source!r}")
    modes = ["register", "session", "ground-truth", "none"] if source == "auto" else [source]
    errors = []
    for mode in modes:
        if mode == "register":
            from dressmeup.body.registration import register as register_body

            return register_body((vertices, faces), body_model), None, "register"
        if mode == "session":
            p = session.root / "body.npz"
            if p.is_file():
                from dressmeup.body import BodyParams

                return BodyParams.load(p), None, "session"
            errors.append(f"{p} absent")
        if mode == "ground-truth":
            gt = session.root / "ground_truth"
            if (gt / "body.npz").is_file():
                from dressmeup.body import BodyParams
                from dressmeup.capture.synthetic import load_ground_truth

                T = load_ground_truth(session.root).subject_to_world
                return BodyParams.load(gt / "body.npz"), np.linalg.inv(T), "ground-truth"
            errors.append(f"{gt / 'body.npz'} absent")
        if mode == "none":
            return None, None, "none"
    raise ValueError(f"no body for {session.root}: " + "; ".join(errors))


def build_dataset_from_sessions(sessions: Sequence[str | Path], out: str | Path, *,
                                fusion_config: Any = None, extraction_config: Any = None,
                                body: str = "auto", body_model: str = "anny",
                                split: str = "train", name: str = "captured") -> BuildReport:
    """Fuse, extract and register every session into the dataset at ``out``.

    Parameters
    ----------
    sessions : session folders, or folders containing sessions (see :func:`find_sessions`).
    out : dataset root (created, or resumed when it exists).
    fusion_config : ``dressmeup.fusion.pipeline.FusionConfig`` (default settings when None).
    extraction_config : ``dressmeup.extraction.pipeline.ExtractionConfig`` (defaults when None).
    body, body_model : see :func:`body_for_session`.
    split : split of the garments written; name : dataset name in dataset.json.

    Returns
    -------
    BuildReport. Failed sessions are also listed in ``out/build-failures.json``.
    """
    from dressmeup.capture.session import open_session
    from dressmeup.data import layout
    from dressmeup.data.writer import DatasetWriter
    from dressmeup.extraction.pipeline import ExtractionConfig, extract_garments
    from dressmeup.fusion.pipeline import FusionConfig, fuse_session
    from dressmeup.io.atomic import atomic_write_text
    from dressmeup.progress import progress

    folders = find_sessions(sessions)
    if not folders:
        raise ValueError("sessions: no session folder given")
    fusion_config = fusion_config or FusionConfig()
    extraction_config = extraction_config or ExtractionConfig()
    writer = DatasetWriter(out, {"name": name, "source": "dressmeup build-dataset",
                                 "body_model": body_model})
    report = BuildReport()
    for sdir in progress(folders, desc="sessions", total=len(folders)):
        try:
            session = open_session(sdir)
            info = session.info
            ids = [layout.make_sample_id(info.subject_id, g.id, info.pose_id) for g in info.garments]
            if ids and all(writer.has_sample(i) for i in ids):
                report.skipped += len(ids)
                continue
            result = fuse_session(session, fusion_config)
            ex = extract_garments(result, info, extraction_config)
            params, T, body_src = body_for_session(session, result.vertices, result.faces,
                                                   body, body_model)

            def tf(V: np.ndarray, T: np.ndarray | None = T) -> np.ndarray:
                return V if T is None else V @ T[:3, :3].T + T[:3, 3]

            for g, sid in zip(ex.garments, ids, strict=True):
                if writer.has_sample(sid):
                    report.skipped += 1
                    continue
                garment = ((tf(g.vertices), g.faces) if g.uv is None
                           else (tf(g.vertices), g.faces, g.uv, g.uv_faces))
                writer.add_sample(subject_id=info.subject_id, garment_id=g.info.id,
                                  pose_id=info.pose_id, category=g.info.category,
                                  garment_type=g.info.garment_type or g.info.category,
                                  split=split, garment=garment, body=params,
                                  scan=(tf(result.vertices), result.faces), texture=g.texture,
                                  sample_id=sid)
                report.written += 1
            log.info("%s: %d garment(s), labels from %s, body from %s", sdir, len(ex.garments),
                     ex.method, body_src)
        except Exception as exc:  # noqa: BLE001 - one bad session must not stop the build
            msg = (str(exc) if isinstance(exc, (DressmeupError, ValueError, OSError))
                   else f"{type(exc).__name__}: {exc}")
            report.failed.append((str(sdir), msg))
            log.warning("build-dataset: skipped session %s: %s", sdir, msg)
    writer.finalize()
    if report.failed:
        report.failures_path = Path(out) / "build-failures.json"
        atomic_write_text(report.failures_path, json.dumps(
            [{"session": s, "error": e} for s, e in report.failed], indent=2) + "\n")
    return report
