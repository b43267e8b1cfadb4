"""The fusion pipeline: session frames -> filtered depth -> (ICP) -> TSDF -> cleaned scan."""

from __future__ import annotations

import json
import logging
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.capture.rig import Rig, load_rig, save_rig
from dressmeup.capture.session import RGBDFrame, Session, open_session
from dressmeup.errors import InputError
from dressmeup.fusion.cleanup import CleanupConfig, cleanup_mesh
from dressmeup.fusion.filtering import DepthFilterConfig, filter_depth, undistort_frame
from dressmeup.fusion.icp import ICPConfig, ICPReport, refine_extrinsics
from dressmeup.fusion.tsdf import integrate_tsdf
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.jsonable import json_default
from dressmeup.io.mesh import write_ply  # re-exported: its home is io.mesh

__all__ = ["FusionConfig", "FusionResult", "prepare_frames", "fuse_frames", "fuse_session",
           "save_scan", "load_scan", "write_ply"]

log = logging.getLogger(__name__)


@dataclass
class FusionConfig:
    """Everything the fusion pipeline can be told.

    Attributes
    ----------
    voxel_size : float, TSDF voxel size in metres.
    trunc_voxels : float, TSDF truncation in voxels.
    min_weight : float, minimum number of observations per voxel (per fused frame set).
    refine : bool, refine the extrinsics by multiway ICP before fusing.
    device : ``"cpu"`` or ``"cuda[:N]"``.
    filter : DepthFilterConfig
    icp : ICPConfig
    cleanup : CleanupConfig or None (None: keep the raw TSDF mesh).
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
    frames: list[int] | None = None


@dataclass
class FusionResult:
    """A fused scan.

    Attributes
    ----------
    vertices : (n, 3) float64, faces : (m, 3) int64, colors : (n, 3) uint8.
    rig : Rig, the calibration used (refined when ICP ran).
    frames : list of RGBDFrame, the undistorted, filtered frames that were fused.
    timings : dict of step -> seconds.
    icp : ICPReport or None.
    """

    vertices: np.ndarray
    faces: np.ndarray
    colors: np.ndarray
    rig: Rig
    frames: list[RGBDFrame]
    timings: dict[str, float] = field(default_factory=dict)
    icp: ICPReport | None = None


def prepare_frames(frames: list[RGBDFrame], rig: Rig, config: DepthFilterConfig | None = None
                   ) -> list[RGBDFrame]:
    """Undistort and filter each frame (depth in metres, pinhole model afterwards).

    Parameters
    ----------
    frames : list of RGBDFrame straight from a session.
    rig : Rig
    config : DepthFilterConfig

    Returns
    -------
    list of RGBDFrame, each carrying its camera of ``rig``.
    """
    out = []
    for fr in frames:
        cam = rig.camera(fr.serial)  # the rig given here is the calibration used from now on
        und = undistort_frame(fr, cam)
        out.append(replace(und, depth=filter_depth(und.depth, config, cam), camera=cam))  # inputs stay untouched
    return out


def fuse_frames(frames: list[RGBDFrame], rig: Rig, config: FusionConfig | None = None) -> FusionResult:
    """Fuse raw session frames into one coloured mesh.

    Parameters
    ----------
    frames : list of RGBDFrame (any number per camera; the first frame of each camera is used
        for ICP refinement).
    rig : Rig
    config : FusionConfig

    Returns
    -------
    FusionResult
    """
    cfg = config or FusionConfig()
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    prepared = prepare_frames(frames, rig, cfg.filter)
    timings["filter"] = time.perf_counter() - t0
    used_rig, report = rig, None
    if cfg.refine:
        t0 = time.perf_counter()
        firsts: dict[str, RGBDFrame] = {}
        for fr in prepared:
            firsts.setdefault(fr.serial, fr)
        used_rig, report = refine_extrinsics(list(firsts.values()), rig, cfg.icp)
        prepared = [replace(f, camera=used_rig.camera(f.serial)) for f in prepared]
        timings["icp"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    n_sets = max(sum(1 for f in prepared if f.serial == s) for s in {f.serial for f in prepared})
    V, F, C = integrate_tsdf(prepared, used_rig, cfg.voxel_size, cfg.trunc_voxels,
                             depth_max=cfg.filter.max_depth, min_weight=cfg.min_weight * n_sets,
                             device=cfg.device)
    timings["tsdf"] = time.perf_counter() - t0
    if cfg.cleanup is not None:
        t0 = time.perf_counter()
        V, F, C = cleanup_mesh(V, F, C, cfg.cleanup)
        timings["cleanup"] = time.perf_counter() - t0
    return FusionResult(V, F, C, used_rig, prepared, timings, report)


def fuse_session(session: Session | str | os.PathLike, config: FusionConfig | None = None) -> FusionResult:
    """Fuse a capture session (all its frames, or ``config.frames``).

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
    return fuse_frames(frames, session.rig, cfg)


def save_scan(result: FusionResult, out_dir: str | os.PathLike, extra: dict[str, Any] | None = None) -> Path:
    """Write a fused scan folder: ``scan.ply`` (coloured), ``rig.json`` (used calibration),
    ``fusion.json`` (timings, ICP report, counts, ``extra``)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_ply(out / "scan.ply", result.vertices, result.faces, result.colors)
    save_rig(result.rig, out / "rig.json")
    info = {"vertices": int(len(result.vertices)), "faces": int(len(result.faces)),
            "timings_s": result.timings,
            "icp": None if result.icp is None else {
                "edges": [list(e) for e in result.icp.edges],
                "corrections_deg_m": {k: list(v) for k, v in result.icp.corrections.items()}},
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
    from dressmeup.io.jsonio import read_json

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
    prepared = [replace(f, camera=rig.camera(f.serial))
                for f in prepare_frames(frames, rig, cfg.filter)]
    if C is None:
        C = np.full((len(V), 3), 200, np.uint8)
    return FusionResult(V, F, C, rig, prepared, {"reused": 0.0}, None)


def load_scan(scan_dir: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read ``scan.ply`` of a scan folder: (V (n,3) float64, F (m,3) int64, colors (n,3) uint8 or None)."""
    import trimesh

    p = Path(scan_dir) / "scan.ply"
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no fused scan here (run 'dressmeup fuse' first)")
    m = trimesh.load(str(p), process=False, force="mesh")
    vc = getattr(m.visual, "vertex_colors", None)
    C = None if vc is None or len(vc) != len(m.vertices) else np.asarray(vc)[:, :3].astype(np.uint8)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64), C
