"""Redwood / Open3D-style RGB-D folders with a ``.log`` trajectory.

Layout and conventions, as Open3D's RGB-D datasets and reconstruction system use them:

- colour images in ``color/`` (or ``rgb/``, ``image/``), depth in ``depth/`` (16-bit PNG,
  millimetres, 0 = no measurement), matched by sorted file name;
- the trajectory in Open3D's ``.log`` format (Redwood's): per frame one line of three integers
  (metadata, ignored) and four lines of a 4x4 matrix, the camera-to-world pose (Open3D's
  ``read_pinhole_camera_trajectory`` inverts it into an extrinsic); frame k of the log is
  the k-th image;
- intrinsics from ``camera_intrinsic.json`` or ``intrinsic.json`` when present (Open3D's
  ``PinholeCameraIntrinsic`` JSON: ``width``, ``height`` and ``intrinsic_matrix``, 9 numbers
  in column-major order), else Open3D's ``PrimeSenseDefault`` (525, 525, 319.5, 239.5).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.images import read_png
from dressmeup.capture.importers.common import SourceFrame, numbers
from dressmeup.errors import InputError

__all__ = ["read_log_trajectory", "read_redwood"]

_IMAGES = (".png", ".jpg", ".jpeg")


def read_log_trajectory(path: Path) -> list[tuple[np.ndarray, str]]:
    """The poses of an Open3D / Redwood ``.log`` trajectory.

    Returns
    -------
    list of ((4, 4) float64 camera-to-world as written, ``"file:line"`` of its block).

    Raises
    ------
    InputError naming the file and line of a malformed block.
    """
    lines = [(k, ln.split()) for k, ln in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if ln.strip()]
    if len(lines) % 5:
        raise InputError(f"{path}: a .log trajectory has 5 lines per frame (3 integers, then a 4x4 "
                         f"matrix), got {len(lines)} non-empty lines")
    out = []
    for b in range(0, len(lines), 5):
        k, meta = lines[b]
        if len(meta) != 3:
            raise InputError(f"{path}:{k}: expected 3 integers before each matrix, got {' '.join(meta)!r}")
        rows = [numbers(r, f"{path}:{kk}") for kk, r in lines[b + 1: b + 5]]
        if any(len(r) != 4 for r in rows):
            raise InputError(f"{path}:{lines[b + 1][0]}: expected 4 rows of 4 numbers")
        out.append((np.array(rows), f"{path}:{k}"))
    return out


def _folder(src: Path, names: tuple[str, ...], what: str) -> Path:
    for n in names:
        if (src / n).is_dir():
            return src / n
    raise InputError(f"{src}: no {what} folder (looked for {', '.join(names)})")


def _intrinsics(src: Path, first_depth: Path) -> tuple[int, int, float, float, float, float, str]:
    for name in ("camera_intrinsic.json", "intrinsic.json"):
        p = src / name
        if p.is_file():
            try:
                d = json.loads(p.read_text(encoding="utf-8"))
                m = np.asarray(d["intrinsic_matrix"], dtype=np.float64).reshape(3, 3).T  # column-major
                return int(d["width"]), int(d["height"]), m[0, 0], m[1, 1], m[0, 2], m[1, 2], name
            except (KeyError, TypeError, ValueError, json.JSONDecodeError) as exc:
                raise InputError(f"{p}: expected Open3D's PinholeCameraIntrinsic JSON (width, height, "
                                 f"intrinsic_matrix of 9 numbers): {exc}") from exc
    h, w = read_png(first_depth).shape[:2]
    return w, h, 525.0, 525.0, 319.5, 239.5, "PrimeSenseDefault"


def read_redwood(src: Path, intrinsics: tuple[float, float, float, float] | None = None,
                 trajectory: Path | None = None) -> tuple[list[SourceFrame], dict]:
    """Every frame of a Redwood / Open3D-style folder that the trajectory covers.

    Parameters
    ----------
    src : the folder. intrinsics : (fx, fy, cx, cy) to use instead.
    trajectory : the ``.log`` file (default: the only ``*.log`` in ``src`` or ``src/scene``).

    Returns
    -------
    (frames, source description for session.json)
    """
    if trajectory is None:
        logs = sorted(src.glob("*.log")) or sorted((src / "scene").glob("*.log"))
        if len(logs) != 1:
            raise InputError(f"{src}: expected one .log trajectory, found {[p.name for p in logs] or 'none'}; "
                             "name it with --trajectory")
        trajectory = logs[0]
    poses = read_log_trajectory(Path(trajectory))
    colors = sorted(p for p in _folder(src, ("color", "rgb", "image"), "colour").iterdir() if p.suffix.lower() in _IMAGES)
    depths = sorted(p for p in _folder(src, ("depth",), "depth").iterdir() if p.suffix.lower() == ".png")
    n = min(len(colors), len(depths), len(poses))
    if n == 0:
        raise InputError(f"{src}: no frames ({len(colors)} colour, {len(depths)} depth images, {len(poses)} poses)")
    w, h, fx, fy, cx, cy, origin = _intrinsics(src, depths[0])
    if intrinsics is not None:
        (fx, fy, cx, cy), origin = intrinsics, "given"
    frames = [SourceFrame(k, colors[k], depths[k],
                          Camera(serial="redwood", width=w, height=h, fx=fx, fy=fy, cx=cx, cy=cy,
                                 camera_to_world=poses[k][0], depth_scale=0.001),
                          stamp=colors[k].name, where=poses[k][1]) for k in range(n)]
    source = {"format": "redwood", "path": str(src), "trajectory": str(trajectory), "intrinsics": origin,
              "depth_units_per_metre": 1000, "pose": ".log blocks, camera-to-world",
              "counts": {"color": len(colors), "depth": len(depths), "poses": len(poses)}}
    return frames, source
