"""One calibrated RGBD camera, and the rule for its pose (``camera_to_world``).

The pose rule: the rotation part ``R`` of a ``camera_to_world`` matrix may deviate from
orthonormal by ``max |R^T R - I| <=`` :data:`REPAIR_TOL` (2e-3). Within
:data:`EXACT_TOL` (1e-6, the round-off of matrices printed with 6-7 digits) the matrix is
kept bit for bit; between the two it is replaced by the nearest rotation (SVD: ``R' = U V^T``
for ``R = U S V^T``) and the correction is reported (:class:`PoseRepair`): poses from a
camera tracker or a calibration tool are orthonormal to about 1e-4 - 4e-4. Beyond
:data:`REPAIR_TOL` the matrix is scaled, sheared or wrong and is refused; so are
reflections, non-finite values and a last row other than ``[0, 0, 0, 1]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dressmeup.errors import InputError

__all__ = ["Camera", "PoseRepair", "rigid_pose", "check_rigid", "camera_pose_repair",
           "EXACT_TOL", "REPAIR_TOL"]

EXACT_TOL = 1e-6
REPAIR_TOL = 2e-3


@dataclass(frozen=True)
class PoseRepair:
    """How a nearly orthonormal rotation was corrected.

    Attributes
    ----------
    orthonormality : float, ``max |R^T R - I|`` of the rotation as given.
    correction_mm : float, the largest displacement the correction causes to a point 1 m
        from the camera, in millimetres (the spectral norm of ``R' - R``, times 1000).
    """

    orthonormality: float
    correction_mm: float

    def describe(self) -> str:
        """One line: ``'|R^T R - I| = 3.8e-04, re-orthonormalised (moves points 1 m away by 0.19 mm)'``."""
        return (f"|R^T R - I| = {self.orthonormality:.1e}, re-orthonormalised (moves points 1 m "
                f"away by {self.correction_mm:.2f} mm)")


def rigid_pose(matrix: Any, name: str = "camera_to_world", repair_tol: float = REPAIR_TOL
               ) -> tuple[np.ndarray, PoseRepair | None]:
    """Check a 4x4 camera pose and repair a nearly orthonormal rotation (the module's rule).

    Parameters
    ----------
    matrix : (4, 4) array_like of float
    name : str, used in error messages (``"rig.json: cameras[2].camera_to_world"``).
    repair_tol : float, largest ``max |R^T R - I|`` that is re-orthonormalised.

    Returns
    -------
    pose : (4, 4) float64, rigid (the rotation replaced by the nearest rotation when repaired).
    repair : PoseRepair or None (None: kept as given, within :data:`EXACT_TOL`).

    Raises
    ------
    InputError
        Wrong shape, non-finite values, a last row other than ``[0, 0, 0, 1]``, a rotation
        further than ``repair_tol`` from orthonormal (scale, shear) or a reflection.
    """
    try:
        m = np.array(matrix, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected a 4x4 matrix of numbers, got {matrix!r:.80}") from exc
    if m.shape != (4, 4):
        raise InputError(f"{name}: expected shape (4, 4), got {m.shape}")
    if not np.all(np.isfinite(m)):
        raise InputError(f"{name}: contains NaN or inf")
    if np.abs(m[3] - [0, 0, 0, 1]).max() > repair_tol:
        raise InputError(f"{name}: last row must be [0, 0, 0, 1], got {m[3].tolist()}")
    r = m[:3, :3]
    if np.linalg.det(r) < 0:
        raise InputError(f"{name}: rotation part has determinant < 0 (a reflection)")
    err = float(np.abs(r.T @ r - np.eye(3)).max())
    if err > repair_tol:
        raise InputError(
            f"{name}: not a rigid transform (rotation part is not orthonormal, max |R^T R - I| = "
            f"{err:.2e}, more than the {repair_tol:g} a camera tracker's poses meet); extrinsics "
            "must be rotation + translation in metres")
    if err <= EXACT_TOL and np.abs(m[3] - [0, 0, 0, 1]).max() <= EXACT_TOL:
        return m, None
    u, _, vt = np.linalg.svd(r)
    fixed = u @ vt
    repair = PoseRepair(err, 1000.0 * float(np.linalg.norm(fixed - r, ord=2)))
    m[:3, :3] = fixed
    m[3] = [0.0, 0.0, 0.0, 1.0]
    return m, repair


def check_rigid(matrix: Any, name: str = "camera_to_world", tol: float = REPAIR_TOL) -> np.ndarray:
    """The pose of :func:`rigid_pose` without its report.

    Returns
    -------
    (4, 4) float64 rigid transform.

    Raises
    ------
    InputError as :func:`rigid_pose`.
    """
    return rigid_pose(matrix, name, tol)[0]


def camera_pose_repair(d: dict[str, Any]) -> PoseRepair | None:
    """The repair :meth:`Camera.from_dict` makes to a rig.json camera entry's pose.

    Parameters
    ----------
    d : a rig.json camera entry whose ``camera_to_world`` passed :func:`rigid_pose`.

    Returns
    -------
    PoseRepair or None
    """
    return rigid_pose(d["camera_to_world"])[1]


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
        """Build and validate a camera from its rig.json entry; errors name ``where``.

        A rotation within :data:`REPAIR_TOL` of orthonormal is replaced by the nearest
        rotation (:func:`rigid_pose`); :func:`camera_pose_repair` says by how much.
        """
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
        c2w, _ = rigid_pose(d["camera_to_world"], f"{where}.camera_to_world")
        serial = str(d["serial"])
        if not serial or any(ch in serial for ch in "/\\") or serial in (".", ".."):
            raise InputError(f"{where}: serial {serial!r} cannot be used as a folder name")
        return cls(serial=serial, width=width, height=height, fx=fx, fy=fy, cx=cx, cy=cy,
                   camera_to_world=c2w, distortion=dist, depth_scale=scale)


