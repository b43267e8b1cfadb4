"""PNG images of capture sessions: colour (8-bit RGB), depth (16-bit units), label masks.

Readers check type and size and raise :class:`~dressmeup.errors.InputError` naming the file;
writers are atomic.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_path
from dressmeup.io.images import image_header

__all__ = ["frame_name", "read_png", "read_depth_png", "read_color_png", "read_label_png",
           "check_size", "write_png", "write_depth_png", "write_color_png"]


def frame_name(index: int) -> str:
    """File name of frame ``index`` in a session: ``000042.png``."""
    return f"{index:06d}.png"


def read_png(path: Path) -> np.ndarray:
    """Decode an image file as stored (any depth and channel count); InputError names the file."""
    if not path.is_file():
        raise InputError(f"{path}: file is missing")
    image_header(path)  # its size is bounded (dressmeup.limits) before anything is decoded
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
    img = read_png(path)
    if img.ndim != 2 or img.dtype != np.uint16:
        raise InputError(f"{path}: depth must be a single-channel 16-bit PNG, got "
                         f"{img.dtype} with shape {img.shape}")
    check_size(path, img, width, height)
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
    path = Path(path)
    img = read_png(path)
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (3, 4):
        raise InputError(f"{path}: colour must be an 8-bit RGB(A) PNG, got {img.dtype} with shape {img.shape}")
    check_size(path, img, width, height)
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
    img = read_png(path)
    if img.dtype != np.uint8 or img.ndim != 2:
        raise InputError(f"{path}: label mask must be a single-channel 8-bit PNG, got "
                         f"{img.dtype} with shape {img.shape}")
    check_size(path, img, width, height)
    return img


def check_size(path: Path, img: np.ndarray, width: int | None, height: int | None) -> None:
    """InputError naming ``path`` when ``img`` is not ``width`` x ``height`` (when given)."""
    if width is not None and height is not None and img.shape[:2] != (height, width):
        raise InputError(f"{path}: image is {img.shape[1]}x{img.shape[0]}, but rig.json says "
                         f"this camera is {width}x{height}")


def write_png(path: str | os.PathLike, img: np.ndarray) -> None:
    """Write an image array as PNG, atomically (OpenCV channel order: BGR)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), img):
            raise OSError(f"could not write {path}")


def write_depth_png(path: str | os.PathLike, depth: np.ndarray, depth_scale: float = 0.001) -> None:
    """Write depth in metres as a 16-bit PNG of ``depth / depth_scale`` units.

    Parameters
    ----------
    path : the PNG file.
    depth : (h, w) float depth in metres; 0, negative, non-finite values and values beyond
        65535 units are written as 0 (no measurement).
    depth_scale : metres per stored unit.
    """
    units = np.round(np.asarray(depth, dtype=np.float64) / depth_scale)
    units[(units < 0) | (units > 65535) | ~np.isfinite(units)] = 0
    write_png(path, units.astype(np.uint16))


def write_color_png(path: str | os.PathLike, color: np.ndarray) -> None:
    """Write an (h, w, 3) uint8 RGB image as PNG."""
    write_png(path, np.ascontiguousarray(np.asarray(color, dtype=np.uint8)[:, :, ::-1]))
