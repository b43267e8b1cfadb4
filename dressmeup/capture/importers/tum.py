"""TUM RGB-D benchmark sequences (``rgbd_dataset_freiburg<k>_<name>/``).

Layout and conventions, as the benchmark's "File Formats" page and its ``associate.py``
describe them:

- ``rgb.txt`` / ``depth.txt``: ``timestamp filename`` per line (``#`` comments), images in
  ``rgb/`` (8-bit colour PNG, 640x480) and ``depth/`` (16-bit PNG, 5000 units per metre, 0 =
  no measurement), the depth already registered to the colour camera.
- ``groundtruth.txt``: ``timestamp tx ty tz qx qy qz qw``: the colour camera's optical centre
  and orientation (unit quaternion, scalar last) in the motion-capture world, i.e.
  camera-to-world, at the motion-capture rate.
- Colour and depth are associated one to one by nearest timestamp within 0.02 s, closest
  pairs first (``associate.py``); each pair takes the nearest ground-truth pose within
  ``max_time_difference`` (pairs without one are skipped and reported).
- Intrinsics: the published calibration of the sequence's camera (``freiburg1/2/3`` in the
  folder name): fr1 517.3 516.5 318.6 255.3 with distortion 0.2624 -0.9531 -0.0054 0.0026
  1.1633, fr2 520.9 521.0 325.1 249.7 with 0.2312 -0.7849 -0.0033 -0.0001 0.9172, fr3 535.4
  539.2 320.1 247.6 undistorted; other names take the ROS default 525 525 319.5 239.5 that
  the benchmark's own point-cloud tools use.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.images import read_png
from dressmeup.capture.importers.common import (
    SourceFrame,
    associate,
    nearest,
    numbers,
    quaternion_pose,
    read_rows,
)

__all__ = ["read_tum", "TUM_CAMERAS"]

#: fx, fy, cx, cy, k1, k2, p1, p2, k3 of the benchmark's published calibrations
TUM_CAMERAS = {
    "freiburg1": (517.3, 516.5, 318.6, 255.3, 0.2624, -0.9531, -0.0054, 0.0026, 1.1633),
    "freiburg2": (520.9, 521.0, 325.1, 249.7, 0.2312, -0.7849, -0.0033, -0.0001, 0.9172),
    "freiburg3": (535.4, 539.2, 320.1, 247.6, 0.0, 0.0, 0.0, 0.0, 0.0),
    "ros-default": (525.0, 525.0, 319.5, 239.5, 0.0, 0.0, 0.0, 0.0, 0.0),
}


def _camera_name(src: Path) -> str:
    for name in ("freiburg1", "freiburg2", "freiburg3"):
        if name in src.resolve().name:
            return name
    return "ros-default"


def _stamped(src: Path, name: str, what: str) -> tuple[list[float], list[str]]:
    rows = read_rows(src / name, 2, what)
    return [numbers(r[:1], f"{src / name}")[0] for r in rows], [r[1] for r in rows]


def read_tum(src: Path, intrinsics: tuple[float, float, float, float] | None = None,
             max_time_difference: float = 0.02) -> tuple[list[SourceFrame], dict]:
    """Every associated frame of a TUM RGB-D sequence that has a ground-truth pose.

    Parameters
    ----------
    src : the sequence folder. intrinsics : (fx, fy, cx, cy) to use instead of the published
    calibration (no distortion then). max_time_difference : float, seconds.

    Returns
    -------
    (frames, source description for session.json)
    """
    rgb_t, rgb_f = _stamped(src, "rgb.txt", "timestamp filename")
    dep_t, dep_f = _stamped(src, "depth.txt", "timestamp filename")
    gt_rows = read_rows(src / "groundtruth.txt", 8, "timestamp tx ty tz qx qy qz qw")
    gt = np.array([numbers(r[:8], f"{src / 'groundtruth.txt'}") for r in gt_rows])
    name = _camera_name(src) if intrinsics is None else "given"
    fx, fy, cx, cy, *dist = TUM_CAMERAS[name] if intrinsics is None else (*intrinsics, 0, 0, 0, 0, 0)
    pairs = associate(rgb_t, dep_t, 0.02)
    h, w = read_png(src / dep_f[pairs[0][1]]).shape[:2] if pairs else (480, 640)
    poses = nearest([rgb_t[i] for i, _ in pairs], gt[:, 0], max_time_difference)
    frames = []
    for (i, j), k in zip(pairs, poses, strict=True):
        if k is None:
            continue
        c2w = quaternion_pose(gt[k, 1:4], gt[k, 4:8])
        cam = Camera(serial="tum", width=w, height=h, fx=fx, fy=fy, cx=cx, cy=cy,
                     camera_to_world=c2w, distortion=np.array(dist + [0.0] * (8 - len(dist))),
                     depth_scale=1.0 / 5000.0)
        frames.append(SourceFrame(len(frames), src / rgb_f[i], src / dep_f[j], cam,
                                  stamp=f"rgb {rgb_t[i]:.6f} depth {dep_t[j]:.6f} pose {gt[k, 0]:.6f}",
                                  where=f"{src / 'groundtruth.txt'} at {gt[k, 0]:.6f}"))
    source = {"format": "tum", "path": str(src), "camera": name, "depth_units_per_metre": 5000,
              "pose": "groundtruth.txt, camera-to-world, quaternion qx qy qz qw",
              "associated": len(pairs), "with_pose": len(frames)}
    return frames, source
