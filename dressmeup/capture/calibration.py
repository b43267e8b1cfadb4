"""Extrinsic calibration of a multi-camera rig from ChArUco-board images (OpenCV ``aruco``).

The cameras' intrinsics come from the devices (the Azure Kinect stores a factory calibration)
in a template rig.json; this module estimates where each camera is. The board is shown in
several *shots*; in each shot every camera that sees it gets the board's pose by PnP on the
detected ChArUco corners. Cameras that see the board in the same shot are linked, and the
links are chained outwards from the reference camera (which keeps the pose of the template),
averaging when a camera is reached by several shots.

Image layout: ``IMAGES/<shot>/<serial>.png`` (one folder per board placement).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.rig import Rig
from dressmeup.errors import InputError

__all__ = ["BoardSpec", "make_board", "render_board_view", "detect_board_pose", "solve_extrinsics",
           "calibrate_rig", "board_pose_facing"]

log = logging.getLogger(__name__)


@dataclass
class BoardSpec:
    """A ChArUco board: squares along x and y, square and marker sizes in metres, dictionary."""

    squares_x: int = 7
    squares_y: int = 5
    square: float = 0.12
    marker: float = 0.09
    dictionary: str = "DICT_5X5_100"

    @property
    def size(self) -> tuple[float, float]:
        """(width, height) of the board in metres."""
        return self.squares_x * self.square, self.squares_y * self.square


def make_board(spec: BoardSpec) -> Any:
    """The OpenCV ``CharucoBoard`` of a spec (InputError on an unknown dictionary name)."""
    name = spec.dictionary
    if not hasattr(cv2.aruco, name):
        raise InputError(f"board dictionary {name!r} is not an OpenCV aruco dictionary (e.g. DICT_5X5_100)")
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))
    return cv2.aruco.CharucoBoard((spec.squares_x, spec.squares_y), spec.square, spec.marker, d)


def board_pose_facing(center: Any, normal: Any, up: Any) -> np.ndarray:
    """Board-to-world transform of a board centred at ``center`` whose printed side faces
    ``normal`` and whose top edge points along ``up`` (board frame: x right, y down the
    printed image, z into the board; origin at the printed image's top-left corner is applied
    by :func:`render_board_view`).

    Returns
    -------
    (4, 4) float64
    """
    n = np.asarray(normal, dtype=np.float64)
    n /= np.linalg.norm(n)
    u = np.asarray(up, dtype=np.float64)
    y = -(u - n * (u @ n))
    y /= np.linalg.norm(y)
    z = -n
    x = np.cross(y, z)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, y, z, np.asarray(center, dtype=np.float64)
    return T


def render_board_view(spec: BoardSpec, camera: Camera, board_center_to_world: np.ndarray,
                      pixels_per_metre: float = 2000.0, background: int = 128) -> np.ndarray:
    """Synthetic grey image of the board seen by a pinhole camera (no distortion), for tests.

    Parameters
    ----------
    spec : BoardSpec
    camera : Camera
    board_center_to_world : (4, 4) float, pose of the board centre (:func:`board_pose_facing`).
    pixels_per_metre : float, resolution of the printed board image.
    background : int, grey level around the board.

    Returns
    -------
    (h, w) uint8
    """
    board = make_board(spec)
    W, H = spec.size
    pw, ph = round(W * pixels_per_metre), round(H * pixels_per_metre)
    img = board.generateImage((pw, ph), marginSize=0, borderBits=1)
    origin = np.eye(4)
    origin[:3, 3] = [-W / 2, -H / 2, 0.0]
    b2c = camera.world_to_camera @ board_center_to_world @ origin
    M = np.stack([b2c[:3, 0], b2c[:3, 1], b2c[:3, 3]], axis=1)
    S = np.diag([1.0 / pixels_per_metre, 1.0 / pixels_per_metre, 1.0])
    S[:2, 2] = 0.5 / pixels_per_metre
    Hm = camera.K @ M @ S
    out = cv2.warpPerspective(img, Hm, (camera.width, camera.height), flags=cv2.INTER_AREA,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=background)
    # pixels behind the camera would wrap: blank them
    return out


def detect_board_pose(image: np.ndarray, camera: Camera, spec: BoardSpec, min_corners: int = 6
                      ) -> np.ndarray | None:
    """Board-to-camera transform from one image, or None when the board is not found.

    Parameters
    ----------
    image : (h, w) or (h, w, 3) uint8
    camera : Camera (intrinsics and distortion used for PnP).
    spec : BoardSpec
    min_corners : int, fewer detected ChArUco corners count as "not seen".

    Returns
    -------
    (4, 4) float64 mapping board coordinates (origin at the board's first corner) to camera
    coordinates, or None.
    """
    board = make_board(spec)
    gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    detector = cv2.aruco.CharucoDetector(board)
    corners, ids, _, _ = detector.detectBoard(gray)
    if ids is None or len(ids) < min_corners:
        return None
    obj, img = board.matchImagePoints(corners, ids)
    if obj is None or len(obj) < min_corners:
        return None
    ok, rvec, tvec = cv2.solvePnP(obj.reshape(-1, 3), img.reshape(-1, 2), camera.K, camera.distortion,
                                  flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        return None
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(rvec)[0]
    T[:3, 3] = tvec.ravel()
    return T


def _average(transforms: list[np.ndarray]) -> np.ndarray:
    R = sum(t[:3, :3] for t in transforms)
    u, _, vt = np.linalg.svd(R)
    d = np.sign(np.linalg.det(u @ vt))
    out = np.eye(4)
    out[:3, :3] = u @ np.diag([1, 1, d]) @ vt
    out[:3, 3] = np.mean([t[:3, 3] for t in transforms], axis=0)
    return out


def solve_extrinsics(observations: Mapping[str, Mapping[str, np.ndarray]], rig: Rig) -> Rig:
    """Camera-to-world transforms from board observations.

    Parameters
    ----------
    observations : shot -> serial -> (4, 4) board-to-camera transform.
    rig : template Rig (intrinsics; the reference camera's pose defines the world).

    Returns
    -------
    Rig copy with every camera's ``camera_to_world`` estimated.

    Raises
    ------
    InputError naming the cameras that no chain of shots connects to the reference.
    """
    out = rig.copy()
    known = {rig.reference: out.camera(rig.reference).camera_to_world.copy()}
    for _ in range(len(rig.cameras)):
        estimates: dict[str, list[np.ndarray]] = {}
        for obs in observations.values():
            anchors = [s for s in obs if s in known]
            if not anchors:
                continue
            boards = [known[s] @ obs[s] for s in anchors]  # board-to-world
            board = _average(boards)
            for s, T in obs.items():
                if s not in known:
                    estimates.setdefault(s, []).append(board @ np.linalg.inv(T))
        if not estimates:
            break
        for s, ts in estimates.items():
            known[s] = _average(ts)
    missing = [s for s in rig.serials if s not in known]
    if missing:
        raise InputError(f"no shot links camera(s) {missing} to the reference camera {rig.reference!r}: "
                         "show the board so that each camera shares a view with an already linked one")
    for c in out.cameras:
        c.camera_to_world = known[c.serial]
    return out


def calibrate_rig(images_dir: str | os.PathLike, rig: Rig, spec: BoardSpec) -> tuple[Rig, dict[str, list[str]]]:
    """Estimate extrinsics from ``IMAGES/<shot>/<serial>.png`` images.

    Parameters
    ----------
    images_dir : folder of shot folders.
    rig : template Rig with intrinsics (and the reference camera's pose).
    spec : BoardSpec

    Returns
    -------
    (calibrated Rig, shot -> serials that saw the board)

    Raises
    ------
    InputError for unreadable images (naming the file) or unconnected cameras.
    """
    root = Path(images_dir)
    if not root.is_dir():
        raise FileNotFoundError(f"calibration image folder not found: {root}")
    observations: dict[str, dict[str, np.ndarray]] = {}
    seen: dict[str, list[str]] = {}
    for shot in sorted(p for p in root.iterdir() if p.is_dir()):
        for cam in rig.cameras:
            p = shot / f"{cam.serial}.png"
            if not p.is_file():
                continue
            img = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
            if img is None:
                raise InputError(f"{p}: not a readable image")
            T = detect_board_pose(img, cam, spec)
            if T is not None:
                observations.setdefault(shot.name, {})[cam.serial] = T
                seen.setdefault(shot.name, []).append(cam.serial)
    if not observations:
        raise InputError(f"{root}: the board was not detected in any image (check --board sizes and dictionary)")
    return solve_extrinsics(observations, rig), seen
