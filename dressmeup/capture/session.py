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

from dressmeup.capture.rig import Camera, Rig, load_rig, save_rig
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_path, atomic_write_text

__all__ = [
    "GarmentInfo",
    "SessionInfo",
    "RGBDFrame",
    "frame_camera",
    "Session",
    "open_session",
    "validate_session",
    "write_session",
    "write_frame",
    "read_depth_png",
    "read_color_png",
    "read_label_png",
    "SESSION_FORMAT",
    "LABEL_UNKNOWN",
    "LABEL_SKIN",
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
        from dressmeup.io.jsonio import validate_json

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
class RGBDFrame:
    """One camera's images at one time.

    Attributes
    ----------
    serial : str
    index : int, frame number.
    color : (h, w, 3) uint8 RGB.
    depth : (h, w) float32 metres, 0 where there is no measurement.
    labels : (h, w) uint8 label mask, or None.
    camera : the calibrated camera that took it, or None (then :func:`frame_camera` looks it
        up in a rig by serial). Set by ``Session.load_frame`` (the session's rig),
        ``render_frames`` (the rendering rig) and ``fusion.prepare_frames`` (the rig it is
        given; after ICP, ``fuse_frames`` attaches the refined cameras).
    """

    serial: str
    index: int
    color: np.ndarray
    depth: np.ndarray
    labels: np.ndarray | None = None
    camera: Camera | None = None


def frame_camera(frame: RGBDFrame, rig: Rig | None = None) -> Camera:
    """The camera of a frame: the one it carries, else ``rig``'s camera of its serial.

    Raises
    ------
    InputError
        When the frame carries no camera and no rig is given.
    """
    if frame.camera is not None:
        return frame.camera
    if rig is None:
        raise InputError(f"frame {frame.serial}/{frame.index} carries no camera and no rig was given")
    return rig.camera(frame.serial)


def _frame_name(index: int) -> str:
    return f"{index:06d}.png"


def _imread(path: Path) -> np.ndarray:
    import cv2

    if not path.is_file():
        raise InputError(f"{path}: file is missing")
    data = np.fromfile(str(path), dtype=np.uint8)
    img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
    if img is None:
        raise InputError(f"{path}: not a readable PNG image (corrupt or truncated file)")
    return img


def read_depth_png(path: str | os.PathLike, width: int | None = None, height: int | None = None,
                   depth_scale: float = 0.001) -> np.ndarray:
    """Read a 16-bit depth PNG into metres.

    Parameters
    ----------
    path : the PNG file.
    width, height : expected size (checked when given).
    depth_scale : metres per stored unit.

    Returns
    -------
    (h, w) float32 depth in metres (0 = no measurement).

    Raises
    ------
    InputError naming the file (missing, corrupt, not 16-bit single channel, wrong size).
    """
    path = Path(path)
    img = _imread(path)
    if img.ndim != 2 or img.dtype != np.uint16:
        raise InputError(f"{path}: depth must be a single-channel 16-bit PNG, got "
                         f"{img.dtype} with shape {img.shape}")
    _check_size(path, img, width, height)
    return img.astype(np.float32) * np.float32(depth_scale)


def read_color_png(path: str | os.PathLike, width: int | None = None,
                   height: int | None = None) -> np.ndarray:
    """Read an 8-bit colour PNG as RGB.

    Returns
    -------
    (h, w, 3) uint8 RGB.

    Raises
    ------
    InputError naming the file.
    """
    import cv2

    path = Path(path)
    img = _imread(path)
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (3, 4):
        raise InputError(f"{path}: colour must be an 8-bit RGB(A) PNG, got {img.dtype} with shape {img.shape}")
    _check_size(path, img, width, height)
    return cv2.cvtColor(img[:, :, :3], cv2.COLOR_BGR2RGB)


def read_label_png(path: str | os.PathLike, width: int | None = None,
                   height: int | None = None) -> np.ndarray:
    """Read an 8-bit single-channel label mask.

    Returns
    -------
    (h, w) uint8 labels.

    Raises
    ------
    InputError naming the file.
    """
    path = Path(path)
    img = _imread(path)
    if img.dtype != np.uint8 or img.ndim != 2:
        raise InputError(f"{path}: label mask must be a single-channel 8-bit PNG, got "
                         f"{img.dtype} with shape {img.shape}")
    _check_size(path, img, width, height)
    return img


def _check_size(path: Path, img: np.ndarray, width: int | None, height: int | None) -> None:
    if width is not None and height is not None and img.shape[:2] != (height, width):
        raise InputError(f"{path}: image is {img.shape[1]}x{img.shape[0]}, but rig.json says "
                         f"this camera is {width}x{height}")


@dataclass
class Session:
    """An opened, validated capture session (see :func:`open_session`)."""

    root: Path
    rig: Rig
    info: SessionInfo

    def path(self, serial: str, kind: str, index: int = 0) -> Path:
        """Path of one image: ``kind`` is ``color``, ``depth`` or ``labels``."""
        return self.root / serial / kind / _frame_name(index)

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


def validate_session(root: str | os.PathLike, check_images: bool = True) -> list[str]:
    """List every problem of a session folder (empty list: valid).

    Checks rig.json and session.json fields, that every camera has every frame's colour and
    depth image, and (``check_images``) that each image decodes with the right type and size
    and that label values are declared in session.json.

    Parameters
    ----------
    root : session folder.
    check_images : decode every image (slower) rather than only checking files exist.

    Returns
    -------
    list of str, one message per problem, each naming the file.
    """
    root = Path(root)
    problems: list[str] = []
    if not root.is_dir():
        return [f"{root}: session folder not found"]
    try:
        rig = load_rig(root / "rig.json")
    except (InputError, FileNotFoundError) as exc:
        problems.append(str(exc))
        rig = None
    sj = root / "session.json"
    info = None
    if not sj.is_file():
        problems.append(f"{sj}: file is missing")
    else:
        try:
            info = SessionInfo.from_dict(json.loads(sj.read_text(encoding="utf-8")), str(sj))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            problems.append(f"{sj}: not valid JSON ({exc})")
        except InputError as exc:
            problems.append(str(exc))
    if rig is None or info is None:
        return problems
    known = set(info.label_names())
    for cam in rig.cameras:
        if not (root / cam.serial).is_dir():
            problems.append(f"{root / cam.serial}: folder of camera {cam.serial!r} (listed in rig.json) is missing")
            continue
        for i in range(info.n_frames):
            for kind in ("color", "depth", "labels"):
                p = root / cam.serial / kind / _frame_name(i)
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
                        lab = read_label_png(p, cam.width, cam.height)
                        extra = sorted(set(np.unique(lab).tolist()) - known)
                        if extra:
                            problems.append(f"{p}: label value(s) {extra} are not declared in session.json "
                                            f"(known: {sorted(known)})")
                except InputError as exc:
                    problems.append(str(exc))
    return problems


def open_session(root: str | os.PathLike, check_images: bool = True) -> Session:
    """Open and validate a session folder.

    Parameters
    ----------
    root : session folder.
    check_images : decode every image while validating.

    Returns
    -------
    Session

    Raises
    ------
    InputError listing every problem (each naming its file).
    """
    root = Path(root)
    problems = validate_session(root, check_images=check_images)
    if problems:
        raise InputError(f"invalid capture session {root} ({len(problems)} problem(s)):\n  "
                         + "\n  ".join(problems))
    rig = load_rig(root / "rig.json")
    info = SessionInfo.from_dict(json.loads((root / "session.json").read_text(encoding="utf-8")))
    return Session(root=root, rig=rig, info=info)


def write_session(root: str | os.PathLike, rig: Rig, info: SessionInfo) -> Path:
    """Create a session folder with rig.json and session.json (frames via :func:`write_frame`)."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    if not info.capture_time:
        info.capture_time = datetime.now(timezone.utc).isoformat(timespec="seconds")
    save_rig(rig, root / "rig.json")
    atomic_write_text(root / "session.json", json.dumps(info.to_dict(), indent=2) + "\n")
    return root


def _imwrite(path: Path, img: np.ndarray) -> None:
    import cv2

    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), img):
            raise OSError(f"could not write {path}")


def write_frame(root: str | os.PathLike, frame: RGBDFrame, depth_scale: float = 0.001) -> None:
    """Write one camera frame as PNGs (colour RGB, 16-bit depth, optional labels), atomically.

    Parameters
    ----------
    root : session folder.
    frame : RGBDFrame with ``depth`` in metres (values beyond 65535 units are set to 0).
    depth_scale : metres per stored unit.
    """
    import cv2

    root = Path(root)
    name = _frame_name(frame.index)
    units = np.round(np.asarray(frame.depth, dtype=np.float64) / depth_scale)
    units[(units < 0) | (units > 65535) | ~np.isfinite(units)] = 0
    _imwrite(root / frame.serial / "depth" / name, units.astype(np.uint16))
    _imwrite(root / frame.serial / "color" / name, cv2.cvtColor(np.ascontiguousarray(frame.color), cv2.COLOR_RGB2BGR))
    if frame.labels is not None:
        _imwrite(root / frame.serial / "labels" / name, np.ascontiguousarray(frame.labels, dtype=np.uint8))
