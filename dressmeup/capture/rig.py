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
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text

__all__ = [
    "Camera",
    "Rig",
    "load_rig",
    "save_rig",
    "ring_rig",
    "check_rigid",
    "perturb_rig",
    "look_at",
    "RIG_FORMAT",
]

RIG_FORMAT = "dressmeup-rig"
_RIGID_TOL = 1e-4


def check_rigid(matrix: Any, name: str = "camera_to_world", tol: float = _RIGID_TOL) -> np.ndarray:
    """Check that ``matrix`` is a 4x4 rigid transform and return it as float64.

    Parameters
    ----------
    matrix : (4, 4) array_like of float
    name : str
        Used in error messages (for example ``"rig.json: cameras[2].camera_to_world"``).
    tol : float
        Tolerance on ``R^T R = I``, ``det R = 1`` and the last row ``[0, 0, 0, 1]``.

    Returns
    -------
    (4, 4) float64 ndarray

    Raises
    ------
    InputError
        Wrong shape, non-finite values, a rotation that is not orthonormal (scale, shear) or
        a reflection.
    """
    try:
        m = np.asarray(matrix, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected a 4x4 matrix of numbers, got {matrix!r:.80}") from exc
    if m.shape != (4, 4):
        raise InputError(f"{name}: expected shape (4, 4), got {m.shape}")
    if not np.all(np.isfinite(m)):
        raise InputError(f"{name}: contains NaN or inf")
    if np.abs(m[3] - [0, 0, 0, 1]).max() > tol:
        raise InputError(f"{name}: last row must be [0, 0, 0, 1], got {m[3].tolist()}")
    r = m[:3, :3]
    err = np.abs(r.T @ r - np.eye(3)).max()
    if err > tol:
        raise InputError(
            f"{name}: not a rigid transform (rotation part is not orthonormal, "
            f"max |R^T R - I| = {err:.2e}); extrinsics must be rotation + translation in metres")
    if np.linalg.det(r) < 0:
        raise InputError(f"{name}: rotation part has determinant < 0 (a reflection)")
    return m


@dataclass
class Camera:
    """One RGBD camera of a rig.

    Attributes
    ----------
    serial : str
        Device serial number or any unique name (used as the frame folder name).
    width, height : int
        Depth (and registered colour) image size in pixels.
    fx, fy, cx, cy : float
        Pinhole intrinsics in pixels (OpenCV convention, pixel centres at integers).
    distortion : (8,) float64
        OpenCV rational model ``k1, k2, p1, p2, k3, k4, k5, k6`` (zeros: no distortion).
    camera_to_world : (4, 4) float64
        Rigid transform from the camera frame (x right, y down, z forward) to the world, metres.
    depth_scale : float
        Metres per depth unit (0.001: 16-bit PNG depth in millimetres).
    """

    serial: str
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    camera_to_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    distortion: np.ndarray = field(default_factory=lambda: np.zeros(8))
    depth_scale: float = 0.001

    @property
    def K(self) -> np.ndarray:  # noqa: N802 - the usual name of the matrix
        """(3, 3) float64 intrinsic matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def world_to_camera(self) -> np.ndarray:
        """(4, 4) float64 inverse of ``camera_to_world``."""
        r = self.camera_to_world[:3, :3]
        t = self.camera_to_world[:3, 3]
        out = np.eye(4)
        out[:3, :3] = r.T
        out[:3, 3] = -r.T @ t
        return out

    @property
    def center(self) -> np.ndarray:
        """(3,) float64 camera centre in world coordinates."""
        return self.camera_to_world[:3, 3].copy()

    @property
    def has_distortion(self) -> bool:
        """True when any distortion coefficient is non-zero."""
        return bool(np.any(np.abs(self.distortion) > 0))

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project world points with the pinhole model (no distortion: use undistorted images).

        Parameters
        ----------
        points : (n, 3) float world points.

        Returns
        -------
        uv : (n, 2) float64 pixel coordinates (x, y).
        z : (n,) float64 depth along the optical axis (metres; <= 0 behind the camera).
        """
        p = np.asarray(points, dtype=np.float64)
        pc = p @ self.world_to_camera[:3, :3].T + self.world_to_camera[:3, 3]
        z = pc[:, 2]
        zs = np.where(np.abs(z) < 1e-12, 1e-12, z)
        uv = np.stack([self.fx * pc[:, 0] / zs + self.cx, self.fy * pc[:, 1] / zs + self.cy], axis=1)
        return uv, z

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (the rig.json camera entry)."""
        return {
            "serial": self.serial, "width": int(self.width), "height": int(self.height),
            "fx": float(self.fx), "fy": float(self.fy), "cx": float(self.cx), "cy": float(self.cy),
            "distortion": [float(x) for x in self.distortion],
            "camera_to_world": [[float(x) for x in row] for row in self.camera_to_world],
            "depth_scale": float(self.depth_scale),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "camera") -> Camera:
        """Build and validate a camera from its rig.json entry; errors name ``where``."""
        if not isinstance(d, dict):
            raise InputError(f"{where}: expected an object, got {type(d).__name__}")
        missing = [k for k in ("serial", "width", "height", "fx", "fy", "cx", "cy", "camera_to_world")
                   if k not in d]
        if missing:
            raise InputError(f"{where}: missing field(s) {', '.join(missing)}")
        try:
            width, height = int(d["width"]), int(d["height"])
            fx, fy, cx, cy = (float(d[k]) for k in ("fx", "fy", "cx", "cy"))
            scale = float(d.get("depth_scale", 0.001))
        except (TypeError, ValueError) as exc:
            raise InputError(f"{where}: intrinsics must be numbers ({exc})") from exc
        if width <= 0 or height <= 0:
            raise InputError(f"{where}: resolution must be positive, got {width}x{height}")
        if not (fx > 0 and fy > 0 and math.isfinite(fx) and math.isfinite(fy)):
            raise InputError(f"{where}: focal lengths must be positive, got fx={fx}, fy={fy}")
        if not (0 <= cx <= width and 0 <= cy <= height):
            raise InputError(f"{where}: principal point ({cx}, {cy}) outside the {width}x{height} image")
        if not (scale > 0 and math.isfinite(scale)):
            raise InputError(f"{where}: depth_scale must be a positive number of metres per unit, got {scale}")
        dist = np.zeros(8)
        raw = d.get("distortion", [])
        try:
            raw = np.asarray(raw, dtype=np.float64).ravel()
        except (TypeError, ValueError) as exc:
            raise InputError(f"{where}: distortion must be a list of numbers") from exc
        if raw.size not in (0, 4, 5, 8) or not np.all(np.isfinite(raw)):
            raise InputError(
                f"{where}: distortion must have 4, 5 or 8 finite OpenCV coefficients "
                f"(k1 k2 p1 p2 [k3 [k4 k5 k6]]), got {raw.size}")
        dist[: raw.size] = raw
        c2w = check_rigid(d["camera_to_world"], f"{where}.camera_to_world")
        serial = str(d["serial"])
        if not serial or any(ch in serial for ch in "/\\") or serial in (".", ".."):
            raise InputError(f"{where}: serial {serial!r} cannot be used as a folder name")
        return cls(serial=serial, width=width, height=height, fx=fx, fy=fy, cx=cx, cy=cy,
                   camera_to_world=c2w, distortion=dist, depth_scale=scale)


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
        """Build and validate a rig from a rig.json dictionary; errors name ``source``."""
        if not isinstance(d, dict) or not isinstance(d.get("cameras"), list):
            raise InputError(f"{source}: expected an object with a 'cameras' list")
        if d.get("format", RIG_FORMAT) != RIG_FORMAT:
            raise InputError(f"{source}: format {d.get('format')!r} is not {RIG_FORMAT!r}")
        cams = [Camera.from_dict(c, f"{source}: cameras[{i}]") for i, c in enumerate(d["cameras"])]
        up = np.asarray(d.get("up", [0, 1, 0]), dtype=np.float64)
        if up.shape != (3,) or not np.isfinite(up).all() or np.linalg.norm(up) == 0:
            raise InputError(f"{source}: 'up' must be a non-zero 3-vector, got {d.get('up')!r}")
        target = np.asarray(d.get("target", [0, 0, 0]), dtype=np.float64)
        if target.shape != (3,):
            raise InputError(f"{source}: 'target' must be a 3-vector, got {d.get('target')!r}")
        try:
            return cls(cameras=cams, name=str(d.get("name", "rig")), up=up / np.linalg.norm(up),
                       target=target, reference=d.get("reference"))
        except InputError as exc:
            raise InputError(f"{source}: {exc}") from exc

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


def load_rig(path: str | os.PathLike) -> Rig:
    """Read and validate a rig.json file.

    Raises
    ------
    FileNotFoundError, InputError
        Naming the file and the field at fault.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "rig.json"
    if not path.is_file():
        raise FileNotFoundError(f"rig file not found: {path}")
    from dressmeup.io.jsonio import parse_json_file

    return Rig.from_dict(parse_json_file(path), source=str(path))


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
