"""Depth-image filtering before fusion: undistortion, range, flying pixels, bilateral smoothing.

All functions take and return depth in metres as ``(h, w) float32`` arrays where 0 means
"no measurement".
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dressmeup.capture.rig import Camera
from dressmeup.capture.session import RGBDFrame

__all__ = ["DepthFilterConfig", "undistort_frame", "remove_flying_pixels", "filter_depth"]


@dataclass
class DepthFilterConfig:
    """Depth filter settings.

    Attributes
    ----------
    min_depth, max_depth : float, metres; measurements outside are dropped.
    edge_threshold : float, metres at 1 m; a pixel whose depth differs from a valid
        8-neighbour by more than ``edge_threshold * z`` (z in metres, at least 1 m) is an edge
        or flying pixel and is dropped.
    min_neighbors : int, pixels with fewer valid 8-neighbours are dropped (speckle).
    erode_boundary : int, pixels this close (8-connected) to a pixel without depth are dropped
        (the silhouette ring, where flying pixels live).
    bilateral_diameter : int, pixel diameter of the bilateral filter (0 disables it).
    bilateral_sigma_depth : float, metres, range kernel of the bilateral filter.
    bilateral_sigma_space : float, pixels, spatial kernel of the bilateral filter.
    """

    min_depth: float = 0.25
    max_depth: float = 5.0
    edge_threshold: float = 0.015
    min_neighbors: int = 5
    erode_boundary: int = 0
    bilateral_diameter: int = 5
    bilateral_sigma_depth: float = 0.008
    bilateral_sigma_space: float = 1.5


def undistort_frame(frame: RGBDFrame, camera: Camera) -> RGBDFrame:
    """Remove lens distortion: resample colour (bilinear), depth and labels (nearest).

    The output images follow the pinhole model of ``camera.K`` with no distortion. Frames of
    cameras without distortion are returned unchanged.

    Parameters
    ----------
    frame : RGBDFrame of size ``camera.height x camera.width``.
    camera : Camera

    Returns
    -------
    RGBDFrame
    """
    import cv2

    if not camera.has_distortion:
        return frame
    size = (camera.width, camera.height)
    mx, my = cv2.initUndistortRectifyMap(camera.K, camera.distortion, None, camera.K, size, cv2.CV_32FC1)
    depth = cv2.remap(frame.depth, mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    color = cv2.remap(frame.color, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    labels = None
    if frame.labels is not None:
        labels = cv2.remap(frame.labels, mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return replace(frame, depth=depth, color=color, labels=labels)


def _neighbors(d: np.ndarray) -> list[np.ndarray]:
    p = np.pad(d, 1, mode="constant", constant_values=0)
    h, w = d.shape
    return [p[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] for dy in (-1, 0, 1) for dx in (-1, 0, 1)
            if (dy, dx) != (0, 0)]


def remove_flying_pixels(depth: np.ndarray, edge_threshold: float = 0.015,
                         min_neighbors: int = 5) -> np.ndarray:
    """Drop edge and flying pixels (mixed foreground/background depths) and speckles.

    Parameters
    ----------
    depth : (h, w) float depth in metres (0 = none).
    edge_threshold : float, allowed jump to a valid 8-neighbour per metre of depth.
    min_neighbors : int, minimum number of valid 8-neighbours.

    Returns
    -------
    (h, w) float32 filtered depth.
    """
    d = np.asarray(depth, dtype=np.float32)
    valid = d > 0
    thr = edge_threshold * np.maximum(d, 1.0)
    bad = np.zeros(d.shape, dtype=bool)
    count = np.zeros(d.shape, dtype=np.int32)
    for nb in _neighbors(d):
        nv = nb > 0
        count += nv
        bad |= nv & (np.abs(nb - d) > thr)
    out = d.copy()
    out[~valid | bad | (count < min_neighbors)] = 0
    return out


def filter_depth(depth: np.ndarray, config: DepthFilterConfig | None = None) -> np.ndarray:
    """Range filter, flying-pixel removal and edge-preserving bilateral smoothing.

    Parameters
    ----------
    depth : (h, w) float depth in metres (0 = none).
    config : DepthFilterConfig (defaults when None).

    Returns
    -------
    (h, w) float32 filtered depth in metres.

    Raises
    ------
    ValueError when ``depth`` is not a 2-D array.
    """
    import cv2

    cfg = config or DepthFilterConfig()
    d = np.asarray(depth, dtype=np.float32)
    if d.ndim != 2:
        raise ValueError(f"depth: expected shape (h, w), got {d.shape}")
    d = np.where((d >= cfg.min_depth) & (d <= cfg.max_depth), d, 0).astype(np.float32)
    d = remove_flying_pixels(d, cfg.edge_threshold, cfg.min_neighbors)
    if cfg.erode_boundary > 0:
        k = np.ones((2 * cfg.erode_boundary + 1,) * 2, np.uint8)
        d[cv2.erode((d > 0).astype(np.uint8), k, borderType=cv2.BORDER_CONSTANT, borderValue=0) == 0] = 0
    if cfg.bilateral_diameter > 0:
        valid = d > 0
        sm = cv2.bilateralFilter(d, cfg.bilateral_diameter, cfg.bilateral_sigma_depth, cfg.bilateral_sigma_space)
        # zeros take part in OpenCV's range kernel only when within sigma of 0, i.e. never
        d = np.where(valid, sm, 0).astype(np.float32)
    return d
