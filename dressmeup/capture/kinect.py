"""Azure Kinect recordings (MKV) -> capture sessions, through the optional ``pyk4a`` package.

Written against pyk4a's documented API (``PyK4APlayback``, ``Calibration``,
``color_image_to_depth_camera``) and **untested on hardware**: the Azure Kinect SDK cannot be
installed where this toolkit is developed. Everything downstream (sessions, fusion) is tested
on PNG sessions. Install with ``pip install dressmeup[kinect]`` (needs the Azure Kinect SDK).

One MKV per camera, named ``<serial>.mkv`` (``capture/record_kinect.py`` writes them so).
Colour is re-projected into the depth camera (``transformed_color``), so a session's colour and
depth share the depth camera's intrinsics, which are read from each recording's factory
calibration; the extrinsics come from a calibrated rig.json (``capture/calibrate.py``).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.frame import RGBDFrame
from dressmeup.capture.rig import Rig
from dressmeup.capture.session import SessionInfo, write_frame, write_session
from dressmeup.errors import DressmeupError, InputError

__all__ = ["require_pyk4a", "read_intrinsics", "mkv_frames", "mkv_to_session"]

log = logging.getLogger(__name__)


def require_pyk4a() -> Any:
    """Import ``pyk4a`` or raise a clear error saying how to get it."""
    try:
        # optional: pyk4a (ImportError handled)
        import pyk4a
    except ImportError as exc:
        raise DressmeupError(
            "reading Azure Kinect recordings needs the optional 'pyk4a' package and the Azure Kinect "
            "SDK: install the SDK (https://github.com/microsoft/Azure-Kinect-Sensor-SDK), then "
            "'pip install dressmeup[kinect]'. PNG sessions need neither.") from exc
    return pyk4a


def _open(path: Path) -> Any:
    pyk4a = require_pyk4a()
    if not path.is_file():
        raise FileNotFoundError(f"recording not found: {path}")
    pb = pyk4a.PyK4APlayback(str(path))
    pb.open()
    return pb


def read_intrinsics(mkv: str | os.PathLike) -> Camera:
    """The depth camera's factory intrinsics of a recording (extrinsics left at identity).

    Returns
    -------
    Camera with serial = the file stem, depth resolution, K and OpenCV-ordered distortion.
    """
    pyk4a = require_pyk4a()
    path = Path(mkv)
    pb = _open(path)
    try:
        calib = pb.calibration
        K = np.asarray(calib.get_camera_matrix(pyk4a.CalibrationType.DEPTH), dtype=np.float64)
        dist = np.asarray(calib.get_distortion_coefficients(pyk4a.CalibrationType.DEPTH), dtype=np.float64).ravel()
        capture = pb.get_next_capture()
        h, w = capture.depth.shape[:2]
    finally:
        pb.close()
    d8 = np.zeros(8)
    d8[: min(8, dist.size)] = dist[:8]
    return Camera(serial=path.stem, width=int(w), height=int(h), fx=K[0, 0], fy=K[1, 1], cx=K[0, 2], cy=K[1, 2],
                  distortion=d8, depth_scale=0.001)


def mkv_frames(mkv: str | os.PathLike, n_frames: int = 1, skip_frames: int = 30) -> list[RGBDFrame]:
    """Read ``n_frames`` frames (after ``skip_frames``) of one recording.

    Returns
    -------
    list of RGBDFrame with colour in the depth camera's geometry and depth in metres.
    """
    pyk4a = require_pyk4a()
    path = Path(mkv)
    pb = _open(path)
    frames: list[RGBDFrame] = []
    try:
        mjpg = pb.configuration["color_format"] == pyk4a.ImageFormat.COLOR_MJPG
        i = 0
        while len(frames) < n_frames:
            try:
                cap = pb.get_next_capture()
            except EOFError:
                break
            if cap.depth is None or cap.color is None:
                continue
            i += 1
            if i <= skip_frames:
                continue
            if mjpg:
                bgr = cv2.imdecode(np.frombuffer(cap.color, np.uint8), cv2.IMREAD_COLOR)
                bgra = cv2.cvtColor(bgr, cv2.COLOR_BGR2BGRA)
                color = pyk4a.color_image_to_depth_camera(bgra, cap.depth, pb.calibration, pb.thread_safe)
            else:
                color = cap.transformed_color
            rgb = cv2.cvtColor(np.ascontiguousarray(color[:, :, :3]), cv2.COLOR_BGR2RGB)
            frames.append(RGBDFrame(path.stem, len(frames), rgb, cap.depth.astype(np.float32) * 0.001))
    finally:
        pb.close()
    if len(frames) < n_frames:
        raise InputError(f"{path}: only {len(frames)} usable frame(s) after skipping {skip_frames}, "
                         f"{n_frames} asked for")
    return frames


def mkv_to_session(mkvs: Sequence[str | os.PathLike], rig: Rig, out: str | os.PathLike, info: SessionInfo,
                   n_frames: int = 1, skip_frames: int = 30) -> Path:
    """Convert synchronised recordings (one ``<serial>.mkv`` per camera) into a PNG session.

    Parameters
    ----------
    mkvs : recordings; their stems must be serials of ``rig``.
    rig : calibrated Rig (extrinsics); intrinsics are replaced by each recording's factory ones.
    out : session folder, info : SessionInfo (subject, pose, garments).
    n_frames, skip_frames : frames to convert and frames to skip at the start (auto-exposure).

    Returns
    -------
    Path of the session.
    """
    out_rig = rig.copy()
    paths = [Path(p) for p in mkvs]
    unknown = [p.name for p in paths if p.stem not in rig.serials]
    if unknown:
        raise InputError(f"recordings {unknown} are not named after a camera serial of the rig {rig.serials}")
    missing = sorted(set(rig.serials) - {p.stem for p in paths})
    if missing:
        raise InputError(f"no recording for camera(s) {missing} of the rig")
    for p in paths:
        cam = read_intrinsics(p)
        target = out_rig.camera(p.stem)
        for attr in ("width", "height", "fx", "fy", "cx", "cy", "distortion"):
            setattr(target, attr, getattr(cam, attr))
    info.n_frames = n_frames
    write_session(out, out_rig, info)
    for p in paths:
        for fr in mkv_frames(p, n_frames, skip_frames):
            write_frame(out, fr)
    return Path(out)
