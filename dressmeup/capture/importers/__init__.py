"""RGB-D datasets -> capture sessions (``dressmeup import-capture``).

One module per dataset layout reads its files into :class:`~.common.SourceFrame` s (images,
intrinsics, depth unit, camera-to-world pose in OpenCV axes); :func:`import_capture` selects
frames, applies the pose rule and writes a session with one camera per frame, as a moving
sensor's session is (docs/capture-format.md).

=============== ===================================================== ===========================
format          layout                                                poses
=============== ===================================================== ===========================
``tum``         TUM RGB-D: rgb.txt, depth.txt, groundtruth.txt        camera-to-world, qx qy qz qw
``7scenes``     7-Scenes: seq-XX/frame-XXXXXX.{color,depth,pose}      4x4 camera-to-world
``redwood``     Redwood / Open3D: color/, depth/, a .log trajectory   4x4 camera-to-world
``open3d-log``  the same reader under Open3D's name for the layout
``arkitscenes`` ARKitScenes: lowres_wide/, lowres_depth/, .traj       world-to-camera, axis-angle
=============== ===================================================== ===========================
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from dressmeup.capture.importers.arkitscenes import read_arkitscenes
from dressmeup.capture.importers.common import (
    ImportReport,
    SourceFrame,
    safe_id,
    select_frames,
    write_moving_session,
)
from dressmeup.capture.importers.redwood import read_redwood
from dressmeup.capture.importers.sevenscenes import read_7scenes
from dressmeup.capture.importers.tum import read_tum
from dressmeup.capture.session import SessionInfo
from dressmeup.errors import InputError

__all__ = ["ImportOptions", "ImportReport", "FORMATS", "import_capture", "read_source"]


@dataclass(frozen=True)
class ImportOptions:
    """How to import.

    Attributes
    ----------
    frames : ``--frames`` selector (:func:`~.common.select_frames`), None: all frames.
    intrinsics : (fx, fy, cx, cy) in pixels instead of the dataset's own, or None.
    max_time_difference : seconds between an image and its pose (timestamped formats), or
        None for the format's default (TUM 0.02, ARKitScenes 0.05).
    trajectory : the ``.log`` file of a Redwood folder, or None to find it.
    subject_id, pose_id : ids written to session.json (default: the source folder's name, ``P0``).
    """

    frames: str | None = None
    intrinsics: tuple[float, float, float, float] | None = None
    max_time_difference: float | None = None
    trajectory: str | None = None
    subject_id: str | None = None
    pose_id: str = "P0"


def _tum(src: Path, o: ImportOptions) -> tuple[list[SourceFrame], dict]:
    return read_tum(src, o.intrinsics, o.max_time_difference or 0.02)


def _arkit(src: Path, o: ImportOptions) -> tuple[list[SourceFrame], dict]:
    return read_arkitscenes(src, o.intrinsics, o.max_time_difference or 0.05)


def _redwood(src: Path, o: ImportOptions) -> tuple[list[SourceFrame], dict]:
    return read_redwood(src, o.intrinsics, Path(o.trajectory) if o.trajectory else None)


def _seven(src: Path, o: ImportOptions) -> tuple[list[SourceFrame], dict]:
    return read_7scenes(src, o.intrinsics)


#: format name -> reader(src, options) -> (frames, source description)
FORMATS: dict[str, Callable[[Path, ImportOptions], tuple[list[SourceFrame], dict]]] = {
    "tum": _tum, "7scenes": _seven, "redwood": _redwood, "open3d-log": _redwood, "arkitscenes": _arkit,
}


def read_source(fmt: str, src: str | os.PathLike, options: ImportOptions | None = None
                ) -> tuple[list[SourceFrame], dict]:
    """The selected frames of a dataset folder, before writing (see :func:`import_capture`)."""
    if fmt not in FORMATS:
        raise InputError(f"format {fmt!r}: expected one of {sorted(FORMATS)}")
    src = Path(src)
    if not src.is_dir():
        raise InputError(f"{src}: source folder not found")
    o = options or ImportOptions()
    frames, source = FORMATS[fmt](src, o)
    if not frames:
        raise InputError(f"{src}: no frame with a pose found ({fmt})")
    chosen = select_frames(o.frames, len(frames))
    return [frames[i] for i in chosen], {**source, "selector": o.frames or "all"}


def import_capture(fmt: str, src: str | os.PathLike, out: str | os.PathLike,
                   options: ImportOptions | None = None) -> ImportReport:
    """Import an RGB-D dataset folder as a capture session (one camera per frame).

    Parameters
    ----------
    fmt : one of :data:`FORMATS`. src : the dataset folder (see each module for its layout).
    out : session folder to write. options : ImportOptions.

    Returns
    -------
    ImportReport (frames written, frames skipped, poses re-orthonormalised).

    Raises
    ------
    InputError naming the file at fault: a missing or malformed file, a frame selector out
    of range, poses beyond the pose rule (every one listed).
    """
    o = options or ImportOptions()
    frames, source = read_source(fmt, src, o)
    info = SessionInfo(subject_id=o.subject_id or safe_id(Path(src).resolve().name), pose_id=safe_id(o.pose_id, "P0"))
    report = ImportReport(Path(out))
    if "with_pose" in source and source.get("with_pose", 0) < source.get("associated", source.get("images", 0)):
        n_all = source.get("associated", source.get("images"))
        report.skipped.append(f"{n_all - source['with_pose']} of {n_all} frame(s) have no pose within the time limit")
    return write_moving_session(out, frames, info, rig_name=f"{fmt}-{info.subject_id}", source=source, report=report)
