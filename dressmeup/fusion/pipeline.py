"""The fusion pipeline: session frames -> filtered depth -> (refinement) -> TSDF -> cleaned scan.

Every step reads the camera each frame carries (``RGBDFrame.camera``); a rig is consulted
once, at the entry, only when the caller asks to fuse with another calibration.
"""

from __future__ import annotations

import json
import logging
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.capture.frame import RGBDFrame, frame_camera, with_rig_cameras
from dressmeup.capture.rig import Rig, load_rig, save_rig
from dressmeup.capture.session import Session, open_session
from dressmeup.errors import InputError
from dressmeup.fusion.cleanup import CleanupConfig, cleanup_mesh
from dressmeup.fusion.consistency import ConsistencyConfig, ConsistencyReport, depth_consistency
from dressmeup.fusion.filtering import DepthFilterConfig, filter_depth, undistort_frame
from dressmeup.fusion.icp import ICPConfig
from dressmeup.fusion.refine import ICPReport, refine_extrinsics
from dressmeup.fusion.tsdf import integrate_tsdf
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.jsonable import json_default
from dressmeup.io.jsonio import read_json
from dressmeup.io.ply import write_ply

__all__ = [
    "FusionConfig", "FusionResult", "prepare_frames", "fuse_frames", "fuse_session",
    "save_scan", "load_scan"
]

log = logging.getLogger(__name__)


@dataclass
class FusionConfig:
    """Everything the fusion pipeline can be told.

    Attributes
    ----------
    voxel_size : float, TSDF voxel size in metres.
    trunc_voxels : float, TSDF truncation in voxels.
    min_weight : float, a voxel is meshed when at least this many fused frames observed it
        (measured a depth within the truncation band around it); 1: every voxel any frame
        saw, so surface seen by a single view is kept. Several frames of one camera count
        one each.
    refine : bool, refine the extrinsics before fusing (:mod:`dressmeup.fusion.refine`:
        multiway ICP whose proposals are kept only where they lower view-to-view residuals,
        within bounds and a time limit). Off by default: a good calibration or a tracker's
        poses are kept as they are without spending the time; turn it on for a drifted rig.
    device : ``"cpu"`` or ``"cuda[:N]"``.
    filter : DepthFilterConfig
    icp : ICPConfig
    cleanup : CleanupConfig or None (None: keep the raw TSDF mesh).
    consistency : ConsistencyConfig or None, how each camera's depth is checked against the
        other cameras' before fusing (a warning names an inconsistent camera); None: no check.
    frames : list of frame indices to fuse, or None for all frames of the session.
    """

    voxel_size: float = 0.004
    trunc_voxels: float = 5.0
    min_weight: float = 1.0
    refine: bool = False
    device: str = "cpu"
    filter: DepthFilterConfig = field(default_factory=DepthFilterConfig)
    icp: ICPConfig = field(default_factory=ICPConfig)
    cleanup: CleanupConfig | None = field(default_factory=CleanupConfig)
    consistency: ConsistencyConfig | None = field(default_factory=ConsistencyConfig)
    frames: list[int] | None = None


@dataclass
class FusionResult:
    """A fused scan.

    Attributes
    ----------
    vertices : (n, 3) float64, faces : (m, 3) int64, colors : (n, 3) uint8.
    rig : Rig, the calibration used (refined when ICP ran): one camera per serial of the
        fused frames (a camera with several frames: the camera of its first frame).
    frames : list of RGBDFrame, the undistorted, filtered frames that were fused, each
        carrying the camera it was fused with.
    timings : dict of step -> seconds.
    icp : ICPReport or None.
    consistency : ConsistencyReport or None, each camera's depth against the other cameras'
        (with the cameras fused with).
    """

    vertices: np.ndarray
    faces: np.ndarray
    colors: np.ndarray
    rig: Rig
    frames: list[RGBDFrame]
    timings: dict[str, float] = field(default_factory=dict)
    icp: ICPReport | None = None
    consistency: ConsistencyReport | None = None


def prepare_frames(frames: list[RGBDFrame], config: DepthFilterConfig | None = None) -> list[RGBDFrame]:
    """Undistort and filter each frame with the camera it carries (pinhole model afterwards).

    Parameters
    ----------
    frames : list of RGBDFrame, each carrying its camera (``Session.load_frames`` does;
        :func:`~dressmeup.capture.frame.with_rig_cameras` attaches another calibration).
    config : DepthFilterConfig

    Returns
    -------
    list of RGBDFrame (new objects; the inputs stay untouched), depth in metres.

    Raises
    ------
    InputError when a frame carries no camera.
    """
    out = []
    for fr in frames:
        cam = frame_camera(fr)
        und = undistort_frame(fr, cam)
        out.append(replace(und, depth=filter_depth(und.depth, config, cam), camera=cam))
    return out


def _fused_rig(frames: list[RGBDFrame], layout: Rig | None) -> Rig:
    """The rig of the fused frames: their cameras (first frame per serial), ``layout``'s
    name, up, target and reference."""
    cams: dict[str, Any] = {}
    for fr in frames:
        cams.setdefault(fr.serial, frame_camera(fr))
    if layout is None:
        return Rig(cameras=list(cams.values()), name="fused")
    return layout.with_cameras(list(cams.values()))


def _fuse(frames: list[RGBDFrame], layout: Rig | None, cfg: FusionConfig) -> FusionResult:
    """Fuse frames with the cameras they carry (``layout``: name, up, target, reference)."""
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    prepared = prepare_frames(frames, cfg.filter)
    timings["filter"] = time.perf_counter() - t0
    report = None
    if cfg.refine:
        t0 = time.perf_counter()
        firsts: dict[str, RGBDFrame] = {}
        for fr in prepared:
            firsts.setdefault(fr.serial, fr)
        reference = layout.reference if layout is not None else None
        cams, report = refine_extrinsics(list(firsts.values()), cfg.icp, reference)
        prepared = [replace(f, camera=cams[f.serial]) for f in prepared]
        timings["icp"] = time.perf_counter() - t0
    consistency = None
    if cfg.consistency is not None:
        t0 = time.perf_counter()
        consistency = depth_consistency(prepared, cfg.consistency)
        for serial in consistency.outliers:
            log.warning("camera %s: its depth lies %.1f mm from the other cameras' depth (median over the "
                        "cameras %.1f mm); check its intrinsics and pose", serial,
                        consistency.median_mm[serial], consistency.reference_mm)
        timings["consistency"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    V, F, C = integrate_tsdf(prepared, cfg.voxel_size, cfg.trunc_voxels, depth_max=cfg.filter.max_depth,
                             min_weight=cfg.min_weight, device=cfg.device)
    timings["tsdf"] = time.perf_counter() - t0
    if cfg.cleanup is not None:
        t0 = time.perf_counter()
        V, F, C = cleanup_mesh(V, F, C, cfg.cleanup)
        timings["cleanup"] = time.perf_counter() - t0
    return FusionResult(V, F, C, _fused_rig(prepared, layout), prepared, timings, report, consistency)


def fuse_frames(frames: list[RGBDFrame], rig: Rig | None = None, config: FusionConfig | None = None
                ) -> FusionResult:
    """Fuse raw frames into one coloured mesh.

    Parameters
    ----------
    frames : list of RGBDFrame (any number per camera; the first frame of each camera is used
        for refinement), each carrying its camera unless ``rig`` is given.
    rig : Rig or None. None: every frame is fused with the camera it carries. A rig: the
        calibration to fuse with instead (each frame takes the rig's camera of its serial),
        and the name, up, target and reference camera of the result's rig.
    config : FusionConfig

    Returns
    -------
    FusionResult
    """
    cfg = config or FusionConfig()
    if rig is not None:
        frames = with_rig_cameras(frames, rig)
    return _fuse(frames, rig, cfg)


def fuse_session(session: Session | str | os.PathLike, config: FusionConfig | None = None) -> FusionResult:
    """Fuse a capture session (all its frames, or ``config.frames``).

    The frames carry the session's cameras; the session's rig gives the result's rig its
    name, up, target and reference camera.

    Parameters
    ----------
    session : Session or a session folder (validated on opening).
    config : FusionConfig

    Returns
    -------
    FusionResult
    """
    cfg = config or FusionConfig()
    if not isinstance(session, Session):
        session = open_session(session)
    idx = cfg.frames if cfg.frames is not None else list(range(session.info.n_frames))
    frames = [fr for i in idx for fr in session.load_frames(i)]
    return _fuse(frames, session.rig, cfg)


def save_scan(result: FusionResult, out_dir: str | os.PathLike, extra: dict[str, Any] | None = None) -> Path:
    """Write a fused scan folder: ``scan.ply`` (coloured), ``rig.json`` (used calibration),
    ``fusion.json`` (timings, ICP report, per-camera depth consistency, counts, ``extra``)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_ply(out / "scan.ply", result.vertices, result.faces, result.colors)
    save_rig(result.rig, out / "rig.json")
    info = {"vertices": int(len(result.vertices)), "faces": int(len(result.faces)),
            "timings_s": result.timings,
            "icp": None if result.icp is None else result.icp.as_dict(),
            "depth_consistency": None if result.consistency is None else result.consistency.as_dict(),
            **(extra or {})}
    atomic_write_text(out / "fusion.json", json.dumps(info, indent=2, default=json_default) + "\n")
    return out


def reuse_scan(session: Session | str | os.PathLike, scan_dir: str | os.PathLike,
               config: FusionConfig | None = None) -> FusionResult:
    """A :class:`FusionResult` from a scan folder that ``dressmeup fuse`` wrote for
    ``session`` (its ``scan.ply`` and refined ``rig.json``), without fusing again: the
    session's frames are prepared with that rig, for garment extraction.

    Raises
    ------
    InputError
        When ``scan_dir`` was fused from another session (``fusion.json`` says which).
    FileNotFoundError
        When ``scan_dir`` holds no ``scan.ply``.
    """

    cfg = config or FusionConfig()
    if not isinstance(session, Session):
        session = open_session(session)
    scan_dir = Path(scan_dir)
    meta = read_json(scan_dir / "fusion.json") if (scan_dir / "fusion.json").is_file() else {}
    made_from = meta.get("session") if isinstance(meta, dict) else None
    if made_from and Path(made_from).resolve() != Path(session.root).resolve():
        raise InputError(f"{scan_dir}: fused from session {made_from}, not {session.root}")
    V, F, C = load_scan(scan_dir)
    rig = load_rig(scan_dir / "rig.json") if (scan_dir / "rig.json").is_file() else session.rig
    idx = cfg.frames if cfg.frames is not None else list(range(session.info.n_frames))
    frames = [fr for i in idx for fr in session.load_frames(i)]
    prepared = prepare_frames(with_rig_cameras(frames, rig), cfg.filter)
    if C is None:
        C = np.full((len(V), 3), 200, np.uint8)
    return FusionResult(V, F, C, rig, prepared, {"reused": 0.0}, None)


def load_scan(scan_dir: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read ``scan.ply`` of a scan folder: (V (n,3) float64, F (m,3) int64, colors (n,3) uint8 or None)."""
    # heavy: trimesh (~0.7 s to import)
    import trimesh

    p = Path(scan_dir) / "scan.ply"
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no fused scan here (run 'dressmeup fuse' first)")
    m = trimesh.load(str(p), process=False, force="mesh")
    vc = getattr(m.visual, "vertex_colors", None)
    C = None if vc is None or len(vc) != len(m.vertices) else np.asarray(vc)[:, :3].astype(np.uint8)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64), C
