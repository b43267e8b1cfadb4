"""Apple ARKitScenes "raw" scans (``<video_id>/``), ARKit's tracked poses.

Layout and conventions, as the dataset's ``DATA.md`` and its loaders describe them:

- ``lowres_wide/<video_id>_<timestamp>.png`` (8-bit RGB, 256x192), ``lowres_depth/`` with
  the same names (16-bit PNG, millimetres, 0 = no measurement), and per frame
  ``lowres_wide_intrinsics/<video_id>_<timestamp>.pincam``: ``width height fx fy cx cy``;
- ``lowres_wide.traj``: ``timestamp rx ry rz tx ty tz`` per line, an axis-angle rotation
  (radians) and a translation (metres) of the **world-to-camera** transform; the
  camera-to-world pose is its inverse, in OpenCV axes (the dataset's loaders back-project
  ``x = (u - cx) z / fx`` with it);
- each image takes the nearest trajectory entry within ``max_time_difference`` seconds
  (frames without one are skipped and reported).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.importers.common import SourceFrame, nearest, numbers, read_rows
from dressmeup.errors import InputError

__all__ = ["read_arkitscenes", "axis_angle_matrix"]


def axis_angle_matrix(r: np.ndarray) -> np.ndarray:
    """(3, 3) rotation of an axis-angle vector (Rodrigues' formula; radians)."""
    r = np.asarray(r, dtype=np.float64)
    a = float(np.linalg.norm(r))
    if a < 1e-12:
        return np.eye(3)
    k = r / a
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * kx + (1 - np.cos(a)) * (kx @ kx)


def _stamp(p: Path) -> float:
    try:
        return float(p.stem.rsplit("_", 1)[1])
    except (IndexError, ValueError) as exc:
        raise InputError(f"{p}: expected a name <video_id>_<timestamp>.png") from exc


def read_arkitscenes(src: Path, intrinsics: tuple[float, float, float, float] | None = None,
                     max_time_difference: float = 0.05) -> tuple[list[SourceFrame], dict]:
    """Every frame of an ARKitScenes scan folder that has a pose, in time order.

    Parameters
    ----------
    src : the ``<video_id>`` folder. intrinsics : (fx, fy, cx, cy) instead of each frame's
    ``.pincam``. max_time_difference : float, seconds.

    Returns
    -------
    (frames, source description for session.json)
    """
    if not (src / "lowres_wide").is_dir():
        raise InputError(f"{src}: no lowres_wide/ folder (an ARKitScenes raw scan folder has lowres_wide/, "
                         "lowres_depth/, lowres_wide_intrinsics/ and lowres_wide.traj)")
    traj_path = src / "lowres_wide.traj"
    traj = np.array([numbers(r[:7], str(traj_path)) for r in read_rows(traj_path, 7, "timestamp rx ry rz tx ty tz")])
    images = sorted((src / "lowres_wide").glob("*.png"), key=_stamp)
    times = [_stamp(p) for p in images]
    match = nearest(times, traj[:, 0], max_time_difference)
    frames = []
    for p, k in zip(images, match, strict=True):
        if k is None:
            continue
        w2c = np.eye(4)
        w2c[:3, :3] = axis_angle_matrix(traj[k, 1:4])
        w2c[:3, 3] = traj[k, 4:7]
        pincam = src / "lowres_wide_intrinsics" / f"{p.stem}.pincam"
        w, h, fx, fy, cx, cy = numbers(read_rows(pincam, 6, "width height fx fy cx cy")[0][:6], str(pincam))
        if intrinsics is not None:
            fx, fy, cx, cy = intrinsics
        cam = Camera(serial="arkit", width=int(w), height=int(h), fx=fx, fy=fy, cx=cx, cy=cy,
                     camera_to_world=np.linalg.inv(w2c), depth_scale=0.001)
        frames.append(SourceFrame(len(frames), p, src / "lowres_depth" / p.name, cam,
                                  stamp=f"{p.name} pose {traj[k, 0]:.3f}", where=f"{traj_path} at {traj[k, 0]:.3f}"))
    source = {"format": "arkitscenes", "path": str(src), "depth_units_per_metre": 1000,
              "pose": "lowres_wide.traj, world-to-camera axis-angle + translation, inverted",
              "images": len(images), "with_pose": len(frames)}
    return frames, source
