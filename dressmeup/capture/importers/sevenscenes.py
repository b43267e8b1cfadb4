"""Microsoft 7-Scenes sequences (``<scene>/seq-XX/``).

Layout and conventions, as the dataset's page describes them: per frame
``frame-XXXXXX.color.png`` (8-bit RGB, 640x480), ``frame-XXXXXX.depth.png`` (16-bit, millimetres,
65535 = no measurement) and ``frame-XXXXXX.pose.txt`` (a 4x4 camera-to-world matrix, the
KinectFusion track, in metres). Intrinsics: principal point (320, 240), focal length 585
(the depth camera's). The colour and depth cameras are not registered to each other in this
dataset: colour is taken as it is, so a textured scan is a few pixels off; geometry is not
affected.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.importers.common import SourceFrame, numbers, read_rows
from dressmeup.errors import InputError

__all__ = ["read_7scenes"]

_FRAME = re.compile(r"frame-(\d+)\.pose\.txt$")


def read_7scenes(src: Path, intrinsics: tuple[float, float, float, float] | None = None
                 ) -> tuple[list[SourceFrame], dict]:
    """Every frame of a 7-Scenes sequence folder (``seq-XX``), in frame order.

    Parameters
    ----------
    src : a ``seq-XX`` folder. intrinsics : (fx, fy, cx, cy) instead of (585, 585, 320, 240).

    Returns
    -------
    (frames, source description for session.json)

    Raises
    ------
    InputError when ``src`` holds no frames (naming its ``seq-*`` subfolders if it has some).
    """
    poses = sorted((int(m.group(1)), p) for p in src.glob("frame-*.pose.txt") if (m := _FRAME.search(p.name)))
    if not poses:
        seqs = sorted(p.name for p in src.glob("seq-*") if p.is_dir())
        hint = f"; it holds sequences {seqs}: import one of them (SRC/{seqs[0]})" if seqs else ""
        raise InputError(f"{src}: no frame-XXXXXX.pose.txt here{hint}")
    fx, fy, cx, cy = intrinsics or (585.0, 585.0, 320.0, 240.0)
    frames = []
    for number, pose_path in poses:
        rows = read_rows(pose_path, 4, "a row of the 4x4 camera-to-world matrix")
        if len(rows) != 4:
            raise InputError(f"{pose_path}: expected 4 rows of 4 numbers, got {len(rows)} rows")
        m = np.array([numbers(r[:4], str(pose_path)) for r in rows])
        stem = pose_path.name[: -len(".pose.txt")]
        cam = Camera(serial="7scenes", width=640, height=480, fx=fx, fy=fy, cx=cx, cy=cy,
                     camera_to_world=m, depth_scale=0.001)
        frames.append(SourceFrame(number, src / f"{stem}.color.png", src / f"{stem}.depth.png", cam,
                                  invalid=65535, stamp=stem, where=str(pose_path)))
    source = {"format": "7scenes", "path": str(src), "depth_units_per_metre": 1000,
              "invalid_depth": 65535, "pose": "frame-XXXXXX.pose.txt, 4x4 camera-to-world",
              "note": "colour not registered to depth in this dataset"}
    return frames, source
