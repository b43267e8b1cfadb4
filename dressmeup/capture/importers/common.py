"""What every RGB-D dataset importer shares: frame selection, pose conventions, timestamp
association, and writing a moving sensor's frames as a session (one camera per frame)."""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from dressmeup.capture.camera import Camera, PoseRepair, rigid_pose
from dressmeup.capture.images import read_png, write_color_png, write_png
from dressmeup.capture.rig import Rig
from dressmeup.capture.session import SessionInfo, write_session
from dressmeup.errors import InputError
from dressmeup.progress import progress

__all__ = ["SourceFrame", "ImportReport", "select_frames", "associate", "nearest", "quaternion_pose",
           "opengl_to_opencv", "write_moving_session", "safe_id", "read_rows", "numbers"]

#: x right, y up, z backwards (OpenGL, ARKit) -> x right, y down, z forwards (OpenCV)
_GL_TO_CV = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass
class SourceFrame:
    """One frame of a dataset, before it is written into a session.

    Attributes
    ----------
    index : int, the frame's position in the dataset's own order (used in its serial).
    color : Path of the colour image (PNG or JPEG, 8-bit).
    depth : Path of the 16-bit depth PNG.
    camera : Camera (intrinsics, ``depth_scale`` of the dataset's depth units, camera-to-world).
    invalid : int or None, a depth value meaning "no measurement" besides 0 (7-Scenes: 65535).
    stamp : str, the dataset's name for the frame (timestamps, file names), kept in session.json.
    where : str, where the pose comes from (``groundtruth.txt:812``), named in errors.
    """

    index: int
    color: Path
    depth: Path
    camera: Camera
    invalid: int | None = None
    stamp: str = ""
    where: str = ""


@dataclass
class ImportReport:
    """What an import wrote and corrected.

    Attributes
    ----------
    session : Path. frames : int, frames written. skipped : list of str, frames left out and why.
    repairs : dict serial -> PoseRepair. resized_color : int, colour images resized to the
    depth image's size. notes : list of str.
    """

    session: Path
    frames: int = 0
    skipped: list[str] = field(default_factory=list)
    repairs: dict[str, PoseRepair] = field(default_factory=dict)
    resized_color: int = 0
    notes: list[str] = field(default_factory=list)


def select_frames(spec: str | None, n: int) -> list[int]:
    """Positions chosen by a ``--frames`` selector among ``n`` frames.

    Parameters
    ----------
    spec : None or ``"all"``: every frame; ``"start:stop:step"`` (Python slice, parts
        optional: ``"::10"`` every 10th frame, ``"100:400:30"``); ``"0,15,30"``: a list;
        ``"7"``: one frame.
    n : int, number of frames available.

    Returns
    -------
    list of int in ``0..n-1``, in the order given.

    Raises
    ------
    InputError for a malformed selector, an index out of range or an empty selection.
    """
    if spec is None or spec.strip() in ("", "all"):
        return list(range(n))
    text = spec.strip()
    try:
        if ":" in text:
            parts = [int(p) if p.strip() else None for p in text.split(":")]
            if len(parts) > 3 or (len(parts) == 3 and parts[2] == 0):
                raise ValueError
            out = list(range(n))[slice(*parts)]
        else:
            out = [int(p) for p in text.split(",") if p.strip()]
    except ValueError as exc:
        raise InputError(f"--frames {spec!r}: expected 'all', a slice 'start:stop:step' (e.g. '::10') "
                         "or a list '0,15,30'") from exc
    bad = [i for i in out if not 0 <= i < n]
    if bad:
        raise InputError(f"--frames {spec!r}: frame(s) {bad[:5]} out of range (the source has {n} frames, 0..{n - 1})")
    if not out:
        raise InputError(f"--frames {spec!r} selects no frame of {n}")
    return out


def associate(first: Sequence[float], second: Sequence[float], max_difference: float = 0.02,
              offset: float = 0.0) -> list[tuple[int, int]]:
    """Match two timestamp lists one to one, closest pairs first (TUM RGB-D's ``associate.py``).

    Every pair closer than ``max_difference`` seconds is a candidate; candidates are taken in
    order of increasing difference, each timestamp used at most once.

    Parameters
    ----------
    first, second : timestamps in seconds. max_difference : float, seconds.
    offset : float, seconds added to ``second``.

    Returns
    -------
    list of (index in first, index in second), sorted by the first index.
    """
    a = np.asarray(first, dtype=np.float64)
    b = np.asarray(second, dtype=np.float64) + offset
    order = np.argsort(b)
    bs = b[order]
    cands = []
    for i, t in enumerate(a):
        lo, hi = np.searchsorted(bs, [t - max_difference, t + max_difference])
        cands.extend((abs(t - bs[k]), i, int(order[k])) for k in range(lo, hi) if abs(t - bs[k]) < max_difference)
    cands.sort()
    used_a, used_b, out = set(), set(), []
    for _, i, j in cands:
        if i not in used_a and j not in used_b:
            used_a.add(i)
            used_b.add(j)
            out.append((i, j))
    return sorted(out)


def nearest(times: Sequence[float], reference: Sequence[float], max_difference: float) -> list[int | None]:
    """Index of the nearest ``reference`` timestamp for each of ``times`` (None beyond
    ``max_difference`` seconds); a reference may serve several times (poses sampled faster
    or slower than images).

    Returns
    -------
    list of int or None, one per entry of ``times``.
    """
    ref = np.asarray(reference, dtype=np.float64)
    if not len(ref):
        return [None] * len(times)
    order = np.argsort(ref)
    rs = ref[order]
    out: list[int | None] = []
    for t in np.asarray(times, dtype=np.float64):
        k = int(np.searchsorted(rs, t))
        best = min((c for c in (k - 1, k) if 0 <= c < len(rs)), key=lambda c: abs(rs[c] - t))
        out.append(int(order[best]) if abs(rs[best] - t) <= max_difference else None)
    return out


def quaternion_pose(t: Sequence[float], q_xyzw: Sequence[float]) -> np.ndarray:
    """(4, 4) float64 transform from a translation and a unit quaternion ``qx qy qz qw``
    (Hamilton convention, scalar last, as TUM RGB-D and scipy write it); the quaternion is
    normalised first."""
    x, y, z, w = (float(v) for v in q_xyzw)
    n = np.sqrt(x * x + y * y + z * z + w * w)
    if not n > 0:
        raise InputError(f"quaternion {list(q_xyzw)} has zero length")
    x, y, z, w = x / n, y / n, z / n, w / n
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = np.asarray(t, dtype=np.float64)
    return m


def opengl_to_opencv(camera_to_world: np.ndarray) -> np.ndarray:
    """A camera-to-world pose of an OpenGL/ARKit camera (x right, y up, looking along -z)
    as the pose of the same camera in OpenCV axes (x right, y down, looking along +z)."""
    return np.asarray(camera_to_world, dtype=np.float64) @ _GL_TO_CV


def safe_id(text: str, default: str = "scene") -> str:
    """An id of letters, digits, ``-`` and ``_`` made from ``text`` (for session.json)."""
    out = re.sub(r"[^A-Za-z0-9_-]+", "-", text).strip("-")
    return out or default


def _write_frame_files(out: Path, serial: str, fr: SourceFrame, report: ImportReport) -> None:
    depth = read_png(fr.depth)
    if depth.dtype != np.uint16 or depth.ndim != 2:
        raise InputError(f"{fr.depth}: depth must be a single-channel 16-bit PNG, got {depth.dtype} "
                         f"with shape {depth.shape}")
    if depth.shape != (fr.camera.height, fr.camera.width):
        raise InputError(f"{fr.depth}: depth is {depth.shape[1]}x{depth.shape[0]}, the dataset's camera "
                         f"is {fr.camera.width}x{fr.camera.height}")
    if fr.invalid is not None:
        depth = np.where(depth == fr.invalid, 0, depth).astype(np.uint16)
    color = read_png(fr.color)
    if color.dtype != np.uint8 or color.ndim != 3:
        raise InputError(f"{fr.color}: colour must be an 8-bit RGB image, got {color.dtype} with shape {color.shape}")
    color = cv2.cvtColor(color[:, :, :3], cv2.COLOR_BGR2RGB)
    if color.shape[:2] != depth.shape:
        color = cv2.resize(color, (depth.shape[1], depth.shape[0]), interpolation=cv2.INTER_AREA)
        report.resized_color += 1
    write_png(out / serial / "depth" / "000000.png", depth)
    write_color_png(out / serial / "color" / "000000.png", color)


def write_moving_session(out: str | os.PathLike, frames: Sequence[SourceFrame], info: SessionInfo,
                         rig_name: str, source: dict[str, Any], report: ImportReport | None = None,
                         up: np.ndarray | None = None) -> ImportReport:
    """Write a moving sensor's frames as a session: one camera per frame, one frame each.

    Each frame becomes camera ``frame-<index:06d>`` (its index in the dataset's own order)
    with the dataset's intrinsics and depth unit, and its pose as camera-to-world; its depth
    PNG is copied value for value (``invalid`` values set to 0) and its colour resized to the
    depth image when the sizes differ. ``session.json`` keeps the source under ``extra``.

    Parameters
    ----------
    out : session folder to write. frames : the selected frames, in order.
    info : SessionInfo (``n_frames`` is set to 1).
    rig_name : str. source : dict, what was imported (format, path, conventions).
    report : ImportReport to complete (made when None).
    up : (3,) world up, or None for the first camera's image up (``-y`` of its axes).

    Returns
    -------
    ImportReport
    """
    out = Path(out)
    report = report or ImportReport(out)
    if not frames:
        raise InputError("no frame to import (check --frames and the pose file)")
    cams, problems = [], []
    for fr in frames:
        serial = f"frame-{fr.index:06d}"
        try:
            pose, repair = rigid_pose(fr.camera.camera_to_world, f"{fr.where or fr.stamp} (frame {fr.index})")
        except InputError as exc:
            problems.append(str(exc))
            continue
        if repair is not None:
            report.repairs[serial] = repair
        cams.append(replace(fr.camera, serial=serial, camera_to_world=pose))
    if problems:
        raise InputError(f"{len(problems)} of {len(frames)} pose(s) refused by the pose rule "
                         "(docs/capture-format.md):\n  " + "\n  ".join(problems))
    first = cams[0].camera_to_world
    up = -first[:3, 1] if up is None else np.asarray(up, dtype=np.float64)
    rig = Rig(cameras=cams, name=rig_name, up=up / np.linalg.norm(up),
              target=first[:3, 3] + 1.5 * first[:3, 2], reference=cams[0].serial)
    info = replace(info, n_frames=1, extra={**info.extra, "source": {
        **source, "frames": {c.serial: fr.stamp for c, fr in zip(cams, frames, strict=True)}}})
    write_session(out, rig, info)
    for cam, fr in progress(list(zip(cams, frames, strict=True)), desc="importing frames"):
        _write_frame_files(out, cam.serial, fr, report)
    report.frames = len(frames)
    if report.resized_color:
        report.notes.append(f"{report.resized_color} colour image(s) resized to their depth image's size")
    return report


def read_rows(path: Path, n_fields: int, what: str) -> list[list[str]]:
    """Rows of a whitespace-separated text file (``#`` comments and blank lines skipped).

    Returns
    -------
    list of rows, each a list of at least ``n_fields`` strings.

    Raises
    ------
    InputError naming the file and line when a row has fewer than ``n_fields`` fields.
    """
    if not path.is_file():
        raise InputError(f"{path}: {what} is missing")
    rows = []
    for k, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.replace(",", " ").split()
        if len(parts) < n_fields:
            raise InputError(f"{path}:{k}: expected {n_fields} fields ({what}), got {len(parts)}: {s[:80]!r}")
        rows.append(parts)
    return rows


def numbers(row: Sequence[str], where: str) -> list[float]:
    """The fields of a row as floats (InputError naming ``where`` otherwise)."""
    try:
        return [float(v) for v in row]
    except ValueError as exc:
        raise InputError(f"{where}: expected numbers, got {' '.join(row)[:80]!r}") from exc
