"""Capture sessions: a folder with rig.json, session.json and per-camera PNG frames.

Layout (docs/capture-format.md)::

    SESSION/
      rig.json                           the cameras (dressmeup.capture.rig)
      session.json                       subject, pose, garments worn, label ids, time, frames
      <serial>/color/000000.png          8-bit RGB, registered to the depth camera
      <serial>/depth/000000.png          16-bit depth in depth units (mm by default), 0 = none
      <serial>/labels/000000.png         optional 8-bit label mask (0 unknown, 1 skin,
                                         2.. garments as in session.json)
      ground_truth/                      optional, written by synth-capture (exact surface)

Readers validate everything and report every problem with the file it comes from.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

# frames and their PNG files have their own homes; re-exported here, where sessions are read
from dressmeup.capture.frame import RGBDFrame
from dressmeup.capture.images import (
    frame_name,
    read_color_png,
    read_depth_png,
    read_label_png,
    write_color_png,
    write_depth_png,
    write_png,
)
from dressmeup.capture.rig import Rig, read_rig, save_rig
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.jsonio import parse_json_file, validate_json

__all__ = [
    "GarmentInfo", "SessionInfo", "Session", "SessionCheck", "open_session", "check_session",
    "validate_session", "write_session", "write_frame", "SESSION_FORMAT", "LABEL_UNKNOWN",
    "LABEL_SKIN"
]

SESSION_FORMAT = "dressmeup-session"
LABEL_UNKNOWN = 0
LABEL_SKIN = 1
_ID_CHARS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_")


@dataclass
class GarmentInfo:
    """A garment worn in the session.

    Attributes
    ----------
    id : str, garment id (letters, digits, ``-``, ``_``).
    category : str, e.g. ``topwear``, ``bottomwear``, ``dress``.
    label : int, its value in the label masks (>= 2).
    garment_type : str, e.g. ``tshirt`` (free text, optional).
    """

    id: str
    category: str
    label: int
    garment_type: str = ""


@dataclass
class SessionInfo:
    """The content of session.json."""

    subject_id: str
    pose_id: str
    garments: list[GarmentInfo] = field(default_factory=list)
    capture_time: str = ""
    n_frames: int = 1
    extra: dict[str, Any] = field(default_factory=dict)

    def label_names(self) -> dict[int, str]:
        """Label value -> name (``unknown``, ``skin`` and the garment ids)."""
        out = {LABEL_UNKNOWN: "unknown", LABEL_SKIN: "skin"}
        out.update({g.label: g.id for g in self.garments})
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {"format": SESSION_FORMAT, "version": 1, "subject_id": self.subject_id,
                "pose_id": self.pose_id, "capture_time": self.capture_time,
                "frames": int(self.n_frames),
                "garments": [{"id": g.id, "category": g.category, "label": int(g.label),
                              "garment_type": g.garment_type} for g in self.garments],
                **({"extra": self.extra} if self.extra else {})}

    @classmethod
    def from_dict(cls, d: dict[str, Any], source: str = "session.json") -> SessionInfo:
        """Build and validate from a session.json dictionary; errors name ``source``."""
        validate_json(d, "session", source)
        if d.get("format", SESSION_FORMAT) != SESSION_FORMAT:
            raise InputError(f"{source}: format {d.get('format')!r} is not {SESSION_FORMAT!r}")
        for key in ("subject_id", "pose_id"):
            val = d.get(key)
            if not isinstance(val, str) or not val or not set(val) <= _ID_CHARS:
                raise InputError(f"{source}: '{key}' must be an id of letters, digits, '-' or '_', got {val!r}")
        garments = []
        labels_seen: set[int] = set()
        for i, g in enumerate(d.get("garments", [])):
            where = f"{source}: garments[{i}]"
            if not isinstance(g, dict) or "id" not in g or "category" not in g:
                raise InputError(f"{where}: expected an object with 'id', 'category' and 'label'")
            gid = str(g["id"])
            if not gid or not set(gid) <= _ID_CHARS:
                raise InputError(f"{where}: id {gid!r} must use letters, digits, '-' or '_'")
            try:
                label = int(g.get("label", i + 2))
            except (TypeError, ValueError) as exc:
                raise InputError(f"{where}: label must be an integer") from exc
            if not 2 <= label <= 255 or label in labels_seen:
                raise InputError(f"{where}: label {label} must be unique and in 2..255 (0 = unknown, 1 = skin)")
            labels_seen.add(label)
            garments.append(GarmentInfo(gid, str(g["category"]), label, str(g.get("garment_type", ""))))
        try:
            n_frames = int(d.get("frames", 1))
        except (TypeError, ValueError) as exc:
            raise InputError(f"{source}: 'frames' must be an integer") from exc
        if n_frames < 1:
            raise InputError(f"{source}: 'frames' must be >= 1, got {n_frames}")
        return cls(subject_id=d["subject_id"], pose_id=d["pose_id"], garments=garments,
                   capture_time=str(d.get("capture_time", "")), n_frames=n_frames,
                   extra=dict(d.get("extra", {})))


@dataclass
class Session:
    """An opened, validated capture session (see :func:`open_session`).

    ``notes``: what validation corrected (rotations re-orthonormalised by the pose rule of
    :mod:`dressmeup.capture.camera`), one line each, naming the file and camera.
    """

    root: Path
    rig: Rig
    info: SessionInfo
    notes: list[str] = field(default_factory=list)

    def path(self, serial: str, kind: str, index: int = 0) -> Path:
        """Path of one image: ``kind`` is ``color``, ``depth`` or ``labels``."""
        return self.root / serial / kind / frame_name(index)

    def has_labels(self, index: int = 0) -> bool:
        """True when every camera has a label mask for this frame."""
        return all(self.path(s, "labels", index).is_file() for s in self.rig.serials)

    def load_frame(self, serial: str, index: int = 0, labels: bool = True) -> RGBDFrame:
        """Read one camera's frame (validated; errors name the file)."""
        cam = self.rig.camera(serial)
        color = read_color_png(self.path(serial, "color", index), cam.width, cam.height)
        depth = read_depth_png(self.path(serial, "depth", index), cam.width, cam.height, cam.depth_scale)
        lab = None
        lp = self.path(serial, "labels", index)
        if labels and lp.is_file():
            lab = read_label_png(lp, cam.width, cam.height)
        return RGBDFrame(serial, index, color, depth, lab, cam)

    def load_frames(self, index: int = 0, labels: bool = True) -> list[RGBDFrame]:
        """Every camera's frame at ``index``, in rig order."""
        if not 0 <= index < self.info.n_frames:
            raise InputError(f"{self.root}: frame {index} requested, session has {self.info.n_frames}")
        return [self.load_frame(s, index, labels) for s in self.rig.serials]

    def ground_truth_dir(self) -> Path | None:
        """The ``ground_truth`` folder of a synthetic session, or None."""
        p = self.root / "ground_truth"
        return p if p.is_dir() else None


@dataclass
class SessionCheck:
    """What checking a session folder found.

    Attributes
    ----------
    problems : list of str, every problem, each naming the file (and camera and frame).
    notes : list of str, what reading corrects (re-orthonormalised rotations), each naming
        the file and camera.
    rig, info : the parsed rig.json and session.json (None when they have problems).
    """

    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    rig: Rig | None = None
    info: SessionInfo | None = None


def check_session(root: str | os.PathLike, check_images: bool = True) -> SessionCheck:
    """Check a session folder, collecting every problem at once (see :func:`validate_session`).

    Parameters
    ----------
    root : session folder.
    check_images : decode every image (slower) rather than only checking files exist.

    Returns
    -------
    SessionCheck
    """
    root = Path(root)
    if not root.is_dir():
        return SessionCheck([f"{root}: session folder not found"])
    reading = read_rig(root / "rig.json")
    out = SessionCheck(list(reading.problems), rig=reading.rig)
    out.notes = [f"{root / 'rig.json'}: camera {serial}: {r.describe()}" for serial, r in reading.repairs.items()]
    sj = root / "session.json"
    if not sj.is_file():
        out.problems.append(f"{sj}: file is missing")
    else:
        try:  # bounded (json_bytes), UTF-8 and JSON checked
            out.info = SessionInfo.from_dict(parse_json_file(sj), str(sj))
        except InputError as exc:
            out.problems.append(str(exc))
    if out.rig is not None and out.info is not None:
        for cam in out.rig.cameras:
            out.problems.extend(_camera_problems(root, cam, out.info, check_images))
    return out


def _camera_problems(root: Path, cam: Any, info: SessionInfo, check_images: bool) -> list[str]:
    """Every problem of one camera's folder: missing files, images of the wrong kind or size."""
    if not (root / cam.serial).is_dir():
        return [f"{root / cam.serial}: folder of camera {cam.serial!r} (listed in rig.json) is missing"]
    problems = []
    known = set(info.label_names())
    for i in range(info.n_frames):
        for kind in ("color", "depth", "labels"):
            p = root / cam.serial / kind / frame_name(i)
            if kind == "labels" and not p.exists():
                continue
            if not p.is_file():
                problems.append(f"{p}: file is missing (camera {cam.serial}, frame {i})")
                continue
            if not check_images:
                continue
            try:
                if kind == "color":
                    read_color_png(p, cam.width, cam.height)
                elif kind == "depth":
                    read_depth_png(p, cam.width, cam.height, cam.depth_scale)
                else:
                    extra = sorted(set(np.unique(read_label_png(p, cam.width, cam.height)).tolist()) - known)
                    if extra:
                        problems.append(f"{p}: label value(s) {extra} are not declared in session.json "
                                        f"(known: {sorted(known)})")
            except InputError as exc:
                problems.append(f"{exc} (camera {cam.serial}, frame {i})")
    return problems


def validate_session(root: str | os.PathLike, check_images: bool = True) -> list[str]:
    """List every problem of a session folder (empty list: valid).

    Checks rig.json (every camera: intrinsics, distortion, the pose rule of
    :mod:`dressmeup.capture.camera`) and session.json fields, that every camera has every
    frame's colour and depth image, and (``check_images``) that each image decodes with the
    right type and size and that label values are declared in session.json.

    Parameters
    ----------
    root : session folder.
    check_images : decode every image (slower) rather than only checking files exist.

    Returns
    -------
    list of str, one message per problem, each naming the file (and the camera).
    """
    return check_session(root, check_images).problems


def open_session(root: str | os.PathLike, check_images: bool = True) -> Session:
    """Open and validate a session folder.

    Parameters
    ----------
    root : session folder.
    check_images : decode every image while validating.

    Returns
    -------
    Session (its ``notes`` say what reading corrected).

    Raises
    ------
    InputError listing every problem (each naming its file).
    """
    root = Path(root)
    check = check_session(root, check_images=check_images)
    if check.problems or check.rig is None or check.info is None:
        raise InputError(f"invalid capture session {root} ({len(check.problems)} problem(s)):\n  "
                         + "\n  ".join(check.problems))
    return Session(root=root, rig=check.rig, info=check.info, notes=check.notes)


def write_session(root: str | os.PathLike, rig: Rig, info: SessionInfo) -> Path:
    """Create a session folder with rig.json and session.json (frames via :func:`write_frame`).

    Parameters
    ----------
    root : session folder (created; files already there are replaced).
    rig : Rig, written as ``rig.json``.
    info : SessionInfo, written as ``session.json`` (``capture_time`` set to now when empty).

    Returns
    -------
    Path of the session folder.
    """
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    if not info.capture_time:
        info.capture_time = datetime.now(timezone.utc).isoformat(timespec="seconds")
    save_rig(rig, root / "rig.json")
    atomic_write_text(root / "session.json", json.dumps(info.to_dict(), indent=2) + "\n")
    return root


def write_frame(root: str | os.PathLike, frame: RGBDFrame, depth_scale: float = 0.001) -> None:
    """Write one camera frame as PNGs (colour RGB, 16-bit depth, optional labels), atomically.

    Files: ``root/<serial>/{color,depth,labels}/<index:06d>.png``.

    Parameters
    ----------
    root : session folder.
    frame : RGBDFrame with ``depth`` in metres (values beyond 65535 units are set to 0).
    depth_scale : metres per stored unit (the camera's ``depth_scale`` in rig.json).
    """
    root = Path(root)
    name = frame_name(frame.index)
    write_depth_png(root / frame.serial / "depth" / name, frame.depth, depth_scale)
    write_color_png(root / frame.serial / "color" / name, frame.color)
    if frame.labels is not None:
        write_png(root / frame.serial / "labels" / name, np.ascontiguousarray(frame.labels, dtype=np.uint8))
