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

from dressmeup.body import BodyParams
from dressmeup.body.registration import register as register_body
from dressmeup.capture.session import open_session
from dressmeup.capture.synthetic import load_ground_truth
from dressmeup.data import layout
from dressmeup.data.writer import DatasetWriter
from dressmeup.errors import DressmeupError, InputError
from dressmeup.executors import LocalExecutor, in_order, require_shared
from dressmeup.extraction.pipeline import ExtractionConfig, extract_garments
from dressmeup.fusion.pipeline import FusionConfig, fuse_session, reuse_scan
from dressmeup.io.atomic import atomic_write_text
from dressmeup.progress import progress

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
        raise InputError(f"source: expected one of {BODY_SOURCES}, got {source!r}")
    modes = ["register", "session", "ground-truth", "none"] if source == "auto" else [source]
    errors = []
    for mode in modes:
        if mode == "register":
            return register_body((vertices, faces), body_model), None, "register"
        if mode == "session":
            p = session.root / "body.npz"
            if p.is_file():
                return BodyParams.load(p), None, "session"
            errors.append(f"{p} absent")
        if mode == "ground-truth":
            gt = session.root / "ground_truth"
            if (gt / "body.npz").is_file():
                T = load_ground_truth(session.root).subject_to_world
                return BodyParams.load(gt / "body.npz"), np.linalg.inv(T), "ground-truth"
            errors.append(f"{gt / 'body.npz'} absent")
        if mode == "none":
            return None, None, "none"
    raise InputError(f"no body for {session.root}: " + "; ".join(errors))


def build_session(job: dict[str, Any]) -> dict[str, Any]:
    """One build job (runs on a worker): fuse, extract and find the body of one session.

    Parameters
    ----------
    job : ``{"session": folder, "fusion": FusionConfig, "extraction": ExtractionConfig,
        "body": body source, "body_model": name}``.

    Returns
    -------
    dict with ``subject_id``, ``pose_id``, ``garments`` (list of dicts: ``id``, ``category``,
    ``garment_type``, ``mesh`` = ``(V (n,3) float64, F (m,3) int64[, uv (k,2), uv_faces])``
    in the output frame, ``texture`` (h,w,3) uint8 or None), ``scan`` = ``(V, F)``, ``body``
    (BodyParams or None), ``labels_from`` and ``body_source``.
    """
    session = open_session(job["session"])
    info = session.info
    scan_dir = job.get("scan_dir")
    if scan_dir:  # the scan 'dressmeup fuse' already made (with its refined calibration)
        result = reuse_scan(session, scan_dir, job["fusion"])
        fusion_done = f"reused {scan_dir}"
    else:
        result = fuse_session(session, job["fusion"])
        fusion_done = ("fused, extrinsics refined (kept where residuals fell)" if job["fusion"].refine
                       else "fused without ICP refinement")
    ex = extract_garments(result, info, job["extraction"])
    params, T, body_src = body_for_session(session, result.vertices, result.faces,
                                           job["body"], job["body_model"])

    def tf(V: np.ndarray) -> np.ndarray:
        return V if T is None else V @ T[:3, :3].T + T[:3, 3]

    garments = [{"id": g.info.id, "category": g.info.category,
                 "garment_type": g.info.garment_type or g.info.category,
                 "mesh": ((tf(g.vertices), g.faces) if g.uv is None
                          else (tf(g.vertices), g.faces, g.uv, g.uv_faces)),
                 "texture": g.texture} for g in ex.garments]
    return {"subject_id": info.subject_id, "pose_id": info.pose_id, "garments": garments,
            "scan": (tf(result.vertices), result.faces), "body": params,
            "labels_from": ex.method, "body_source": body_src, "fusion": fusion_done}


def _failure(exc: BaseException) -> str:
    return (str(exc) if isinstance(exc, (DressmeupError, ValueError, OSError))
            else f"{type(exc).__name__}: {exc}")


def build_dataset_from_sessions(sessions: Sequence[str | Path], out: str | Path, *,
                                fusion_config: Any = None, extraction_config: Any = None,
                                body: str = "auto", body_model: str = "anny",
                                split: str = "train", name: str = "captured",
                                executor: Any = None,
                                scans: str | Path | None = None) -> BuildReport:
    """Fuse, extract and register every session into the dataset at ``out``.

    Parameters
    ----------
    sessions : session folders, or folders containing sessions (see :func:`find_sessions`).
    out : dataset root (created, or resumed when it exists).
    fusion_config : ``dressmeup.fusion.pipeline.FusionConfig`` (default settings when None).
    extraction_config : ``dressmeup.extraction.pipeline.ExtractionConfig`` (defaults when None).
    body, body_model : see :func:`body_for_session`.
    split : split of the garments written; name : dataset name in dataset.json.
    scans : folder of scans made by ``dressmeup fuse`` (``SCANS/<session folder name>/``
        holding ``scan.ply``); a session whose scan is there is not fused again. Sessions
        without one are fused with ``fusion_config`` (default: ``FusionConfig()``, refinement
        off, as in ``dressmeup fuse``). What was
        done per session is recorded in ``dataset.json`` under ``build``.
    executor : where the per-session jobs (:func:`build_session`) run
        (:mod:`dressmeup.executors`; default: one after the other in this process). This
        process writes every sample, in session order, so the dataset is the same whatever
        the executor.

    Returns
    -------
    BuildReport. Failed sessions are also listed in ``out/build-failures.json``.
    """
    folders = find_sessions(sessions)
    if not folders:
        raise InputError("sessions: no session folder given")
    fusion_config = fusion_config or FusionConfig()
    extraction_config = extraction_config or ExtractionConfig()
    writer = DatasetWriter(out, {"name": name, "source": "dressmeup build-dataset",
                                 "body_model": None if body == "none" else body_model})
    # a resumed build keeps the records of the sessions earlier runs built
    earlier = writer.previous_info.get("build")
    built: dict[str, dict[str, Any]] = dict((earlier or {}).get("sessions") or {}) \
        if isinstance(earlier, dict) else {}
    settings = {"refine": bool(fusion_config.refine), "voxel_size": fusion_config.voxel_size}
    report = BuildReport()
    todo = _sessions_to_build(folders, writer, report)
    for sdir, _ in todo:  # built again now: recorded again when (and if) it succeeds
        built.pop(Path(sdir).name, None)

    def record() -> dict[str, Any]:
        return {"fusion": settings, "body": body, "sessions": dict(sorted(built.items()))}

    executor = executor or LocalExecutor(1)
    require_shared(executor, *(s for s, _ in todo))
    jobs = [{"session": str(sdir), "fusion": fusion_config, "extraction": extraction_config,
             "body": body, "body_model": body_model, "scan_dir": _scan_of(scans, sdir)}
            for sdir, _ in todo]
    done = progress(executor.run(build_session, jobs), desc="sessions", total=len(jobs))
    for i, res in in_order(done):
        sdir, ids = todo[i]
        try:
            if isinstance(res, BaseException):
                raise res
            # the session's record is persisted before its samples: a build killed at any
            # point resumes with the records of every session it had finished
            built[Path(sdir).name] = {"scan": res["fusion"], "body": res["body_source"],
                                      "labels": res["labels_from"], "fusion": settings}
            writer.update_info(build=record())
            _write_samples(writer, res, ids, split, report)
            log.info("%s: %d garment(s), %s, labels from %s, body from %s", sdir,
                     len(res["garments"]), res["fusion"], res["labels_from"],
                     res["body_source"])
        except Exception as exc:  # noqa: BLE001 - one bad session must not stop the build
            built.pop(Path(sdir).name, None)
            report.failed.append((str(sdir), _failure(exc)))
            log.warning("build-dataset: skipped session %s: %s", sdir, _failure(exc))
    writer.finalize(build=record())
    rank = {str(s): k for k, s in enumerate(folders)}
    report.failed.sort(key=lambda f: rank.get(f[0], len(rank)))  # in the order given
    if report.failed:
        report.failures_path = Path(out) / "build-failures.json"
        atomic_write_text(report.failures_path, json.dumps(
            [{"session": s, "error": e} for s, e in report.failed], indent=2) + "\n")
    return report


def _sessions_to_build(folders: list[Path], writer: DatasetWriter,
                       report: BuildReport) -> list[tuple[Path, list[str]]]:
    """``(session folder, its sample ids)`` of the sessions with a sample still to write;
    sessions already written count as skipped, unreadable ones as failed."""
    todo: list[tuple[Path, list[str]]] = []
    for sdir in folders:
        try:
            info = open_session(sdir).info
            ids = [layout.make_sample_id(info.subject_id, g.id, info.pose_id)
                   for g in info.garments]
        except Exception as exc:  # noqa: BLE001 - one bad session must not stop the build
            report.failed.append((str(sdir), _failure(exc)))
            log.warning("build-dataset: skipped session %s: %s", sdir, _failure(exc))
            continue
        if ids and all(writer.has_sample(i) for i in ids):
            report.skipped += len(ids)
        else:
            todo.append((sdir, ids))
    return todo


def _scan_of(scans: str | Path | None, sdir: Path) -> str | None:
    """``SCANS/<session folder name>`` when it holds a ``scan.ply``, else None."""
    cand = Path(scans) / Path(sdir).name if scans else None
    return str(cand) if cand is not None and (cand / "scan.ply").is_file() else None


def _write_samples(writer: DatasetWriter, res: dict[str, Any], ids: list[str], split: str,
                   report: BuildReport) -> None:
    """One sample per garment of a built session (:func:`build_session`'s result), skipping
    those already in the dataset."""
    for g, sid in zip(res["garments"], ids, strict=True):
        if writer.has_sample(sid):
            report.skipped += 1
            continue
        writer.add_sample(subject_id=res["subject_id"], garment_id=g["id"],
                          pose_id=res["pose_id"], category=g["category"],
                          garment_type=g["garment_type"], split=split,
                          garment=g["mesh"], body=res["body"], scan=res["scan"],
                          texture=g["texture"], sample_id=sid)
        report.written += 1
