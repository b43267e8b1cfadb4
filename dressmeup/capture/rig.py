"""Camera rigs: per-camera intrinsics (with distortion), extrinsics, depth scale, resolution.

A rig is stored as ``rig.json`` (see docs/capture-format.md)::

    {"format": "dressmeup-rig", "version": 1, "name": "default-7", "up": [0, 1, 0],
     "reference": "cam0",
     "cameras": [{"serial": "cam0", "width": 640, "height": 576,
                  "fx": 504.0, "fy": 504.0, "cx": 319.5, "cy": 287.5,
                  "distortion": [k1, k2, p1, p2, k3, k4, k5, k6],
                  "camera_to_world": [[...4 numbers...] x 4],
                  "depth_scale": 0.001}, ...]}

Conventions: the OpenCV camera frame (x right, y down, z forward); ``camera_to_world`` maps
camera coordinates to world coordinates in metres; depth images store ``depth / depth_scale``
as unsigned 16-bit integers (Azure Kinect: millimetres, ``depth_scale = 0.001``); distortion
follows OpenCV's rational model (Azure Kinect's ``k1..k6, p1, p2`` in OpenCV order); colour
images are registered to the depth camera (same size and intrinsics), as the Azure Kinect
SDK's ``transformed_color`` gives them.
"""

from __future__ import annotations

import json
import logging
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

# Camera and the pose rule live in capture.camera; re-exported here, where rigs are read
from dressmeup.capture.camera import Camera, PoseRepair, camera_pose_repair
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.jsonio import parse_json_file

__all__ = [
    "Rig", "RigReading", "read_rig", "parse_rig", "load_rig", "save_rig", "ring_rig",
    "perturb_rig", "look_at", "RIG_FORMAT"
]

RIG_FORMAT = "dressmeup-rig"

log = logging.getLogger(__name__)


@dataclass
class Rig:
    """A set of calibrated cameras sharing one world frame.

    Attributes
    ----------
    cameras : list of Camera
    name : str
    up : (3,) float64 world up direction (used by the synthetic renderer to stand a subject).
    target : (3,) float64 point the cameras look at (the subject's centre).
    reference : str
        Serial of the reference camera (kept fixed by extrinsic refinement).
    """

    cameras: list[Camera]
    name: str = "rig"
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reference: str | None = None

    def __post_init__(self) -> None:
        if not self.cameras:
            raise InputError("rig: needs at least one camera")
        serials = [c.serial for c in self.cameras]
        dup = sorted({s for s in serials if serials.count(s) > 1})
        if dup:
            raise InputError(f"rig: duplicate camera serial(s) {dup}")
        if self.reference is None:
            self.reference = serials[0]
        elif self.reference not in serials:
            raise InputError(f"rig: reference camera {self.reference!r} is not one of {serials}")

    @property
    def serials(self) -> list[str]:
        """Camera serials in rig order."""
        return [c.serial for c in self.cameras]

    def camera(self, serial: str) -> Camera:
        """The camera with this serial (KeyError naming the known serials otherwise)."""
        for c in self.cameras:
            if c.serial == serial:
                return c
        raise KeyError(f"no camera {serial!r} in rig {self.name!r} (cameras: {self.serials})")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (the rig.json content)."""
        return {"format": RIG_FORMAT, "version": 1, "name": self.name,
                "up": [float(x) for x in self.up], "target": [float(x) for x in self.target],
                "reference": self.reference, "cameras": [c.to_dict() for c in self.cameras]}

    @classmethod
    def from_dict(cls, d: dict[str, Any], source: str = "rig.json") -> Rig:
        """Build and validate a rig from a rig.json dictionary.

        Raises
        ------
        InputError
            Listing every problem (each camera named by its index in ``source``).
        """
        return parse_rig(d, source).unwrap(source)

    def with_cameras(self, cameras: list[Camera]) -> Rig:
        """The same rig (name, up, target, reference) with other cameras.

        The reference is kept when one of ``cameras`` has its serial, else it becomes the
        first camera's.
        """
        serials = [c.serial for c in cameras]
        return Rig(cameras=list(cameras), name=self.name, up=self.up.copy(), target=self.target.copy(),
                   reference=self.reference if self.reference in serials else None)

    def copy(self) -> Rig:
        """Deep copy."""
        return Rig(cameras=[replace(c, camera_to_world=c.camera_to_world.copy(),
                                    distortion=c.distortion.copy()) for c in self.cameras],
                   name=self.name, up=self.up.copy(), target=self.target.copy(),
                   reference=self.reference)

    def scaled(self, factor: float) -> Rig:
        """The same rig with every image resized by ``factor`` (intrinsics scaled to match)."""
        out = self.copy()
        for c in out.cameras:
            w, h = max(1, round(c.width * factor)), max(1, round(c.height * factor))
            sx, sy = w / c.width, h / c.height
            c.fx, c.fy = c.fx * sx, c.fy * sy
            c.cx, c.cy = (c.cx + 0.5) * sx - 0.5, (c.cy + 0.5) * sy - 0.5
            c.width, c.height = w, h
        return out


@dataclass
class RigReading:
    """What reading a rig.json found.

    Attributes
    ----------
    rig : Rig, or None when there were problems.
    problems : list of str, every problem, each naming the file and the camera.
    repairs : dict serial -> PoseRepair, the cameras whose rotation was re-orthonormalised.
    """

    rig: Rig | None
    problems: list[str] = field(default_factory=list)
    repairs: dict[str, PoseRepair] = field(default_factory=dict)

    def unwrap(self, source: str) -> Rig:
        """The rig, or an InputError listing every problem."""
        if self.rig is not None:
            return self.rig
        if len(self.problems) == 1:
            raise InputError(self.problems[0])
        raise InputError(f"{source}: {len(self.problems)} problems:\n  " + "\n  ".join(self.problems))


def parse_rig(d: Any, source: str = "rig.json") -> RigReading:
    """Validate a rig.json dictionary, collecting every problem rather than the first.

    Parameters
    ----------
    d : the parsed JSON.
    source : str, named in messages.

    Returns
    -------
    RigReading
    """
    if not isinstance(d, dict) or not isinstance(d.get("cameras"), list):
        return RigReading(None, [f"{source}: expected an object with a 'cameras' list"])
    if d.get("format", RIG_FORMAT) != RIG_FORMAT:
        return RigReading(None, [f"{source}: format {d.get('format')!r} is not {RIG_FORMAT!r}"])
    problems: list[str] = []
    cams, repairs = [], {}
    for i, c in enumerate(d["cameras"]):
        where = f"{source}: cameras[{i}]" + (f" ({c['serial']})" if isinstance(c, dict) and "serial" in c else "")
        try:
            cam = Camera.from_dict(c, where)
        except InputError as exc:
            problems.append(str(exc))
            continue
        cams.append(cam)
        repair = camera_pose_repair(c)
        if repair is not None:
            repairs[cam.serial] = repair
    up = np.asarray(d.get("up", [0, 1, 0]), dtype=np.float64)
    if up.shape != (3,) or not np.isfinite(up).all() or np.linalg.norm(up) == 0:
        problems.append(f"{source}: 'up' must be a non-zero 3-vector, got {d.get('up')!r}")
    target = np.asarray(d.get("target", [0, 0, 0]), dtype=np.float64)
    if target.shape != (3,):
        problems.append(f"{source}: 'target' must be a 3-vector, got {d.get('target')!r}")
    if problems:
        return RigReading(None, problems, repairs)
    try:
        rig = Rig(cameras=cams, name=str(d.get("name", "rig")), up=up / np.linalg.norm(up),
                  target=target, reference=d.get("reference"))
    except InputError as exc:
        return RigReading(None, [f"{source}: {exc}"], repairs)
    return RigReading(rig, [], repairs)


def read_rig(path: str | os.PathLike) -> RigReading:
    """Read a rig.json (or the rig.json in a folder), collecting every problem.

    Returns
    -------
    RigReading (a missing or unparsable file is one problem).
    """
    path = Path(path)
    if path.is_dir():
        path = path / "rig.json"
    if not path.is_file():
        return RigReading(None, [f"{path}: file is missing"])
    try:
        d = parse_json_file(path)
    except InputError as exc:
        return RigReading(None, [str(exc)])
    return parse_rig(d, str(path))


def load_rig(path: str | os.PathLike) -> Rig:
    """Read and validate a rig.json file (rotations repaired by the pose rule are logged).

    Raises
    ------
    FileNotFoundError, InputError
        Naming the file and every camera at fault.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "rig.json"
    if not path.is_file():
        raise FileNotFoundError(f"rig file not found: {path}")
    reading = read_rig(path)
    rig = reading.unwrap(str(path))
    for serial, repair in reading.repairs.items():
        log.warning("%s: camera %s: %s", path, serial, repair.describe())
    return rig


def save_rig(rig: Rig, path: str | os.PathLike) -> Path:
    """Write ``rig`` as JSON (atomically) and return the path."""
    path = Path(path)
    atomic_write_text(path, json.dumps(rig.to_dict(), indent=2) + "\n")
    return path


def look_at(eye: Any, target: Any, up: Any) -> np.ndarray:
    """Camera-to-world matrix of an OpenCV camera at ``eye`` looking at ``target``.

    Parameters
    ----------
    eye, target, up : (3,) float

    Returns
    -------
    (4, 4) float64 rigid transform (the camera's y axis, image down, points along ``-up``).
    """
    eye, target, up = (np.asarray(a, dtype=np.float64) for a in (eye, target, up))
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:
        raise InputError("look_at: viewing direction is parallel to up")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, eye
    return m


def ring_rig(n_cameras: int = 7, radius: float = 2.2, height: float = 1.0,
             target_height: float = 0.9, width: int = 640, height_px: int = 576,
             fov_x_deg: float = 75.0, distortion: Any = None, up: Any = (0.0, 1.0, 0.0),
             name: str = "ring") -> Rig:
    """A ring of identical cameras around the vertical axis looking at the centre.

    The default mimics seven Azure Kinects in NFOV unbinned mode (640x576 depth, about
    75 x 65 degrees) on a 2.2 m ring, lenses 1 m above the floor, aimed at 0.9 m.

    Parameters
    ----------
    n_cameras : int >= 1
    radius : float, metres from the vertical axis.
    height : float, camera height above the floor (world ``up`` coordinate), metres.
    target_height : float, height of the point the cameras look at.
    width, height_px : int, image size.
    fov_x_deg : float, horizontal field of view.
    distortion : (8,) float or None, OpenCV coefficients shared by every camera.
    up : (3,) float, world up axis (``(0, 1, 0)``: y-up as SMPL; ``(0, 0, 1)``: z-up).
    name : str

    Returns
    -------
    Rig with serials ``cam0 .. cam{n-1}``; ``cam0`` is the reference.
    """
    if n_cameras < 1:
        raise InputError(f"n_cameras: expected >= 1, got {n_cameras}")
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    a = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    e1 = a - up * (a @ up)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    fx = (width / 2.0) / math.tan(math.radians(fov_x_deg) / 2.0)
    dist = np.zeros(8) if distortion is None else np.asarray(distortion, dtype=np.float64)
    target = up * target_height
    cams = []
    for i in range(n_cameras):
        ang = 2 * math.pi * i / n_cameras
        eye = up * height + radius * (math.cos(ang) * e2 + math.sin(ang) * e1)
        cams.append(Camera(serial=f"cam{i}", width=width, height=height_px, fx=fx, fy=fx,
                           cx=(width - 1) / 2.0, cy=(height_px - 1) / 2.0,
                           camera_to_world=look_at(eye, target, up), distortion=dist.copy()))
    return Rig(cameras=cams, name=name, up=up, target=target, reference="cam0")


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def perturb_rig(rig: Rig, rotation_deg: float = 1.0, translation_m: float = 0.01,
                seed: int = 0, keep_reference: bool = True) -> Rig:
    """A drifted calibration: each camera moved by a random rigid motion of fixed size.

    Every camera (except the reference one when ``keep_reference``) is rotated by exactly
    ``rotation_deg`` about a random axis through its centre and shifted by exactly
    ``translation_m`` in a random direction.

    Parameters
    ----------
    rig : Rig
    rotation_deg : float, rotation angle in degrees.
    translation_m : float, translation length in metres.
    seed : int, random seed.
    keep_reference : bool

    Returns
    -------
    Rig, a perturbed copy.
    """
    rng = np.random.default_rng(seed)
    out = rig.copy()
    for c in out.cameras:
        if keep_reference and c.serial == rig.reference:
            continue
        axis = rng.normal(size=3)
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        m = c.camera_to_world.copy()
        m[:3, :3] = _rotation(axis, math.radians(rotation_deg)) @ m[:3, :3]
        m[:3, 3] = m[:3, 3] + translation_m * direction
        c.camera_to_world = m
    return out
