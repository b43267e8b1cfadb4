"""Depth-image filtering before fusion: undistortion, range, flying pixels, bilateral smoothing.

All functions take and return depth in metres as ``(h, w) float32`` arrays where 0 means
"no measurement".
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.frame import RGBDFrame

__all__ = ["DepthFilterConfig", "undistort_frame", "remove_flying_pixels", "view_cosines", "filter_depth"]


@dataclass
class DepthFilterConfig:
    """Depth filter settings.

    Attributes
    ----------
    min_depth, max_depth : float, metres; measurements outside are dropped.
    edge_threshold : float, metres at 1 m; 8-neighbours within ``edge_threshold * z`` (z in
        metres, at least 1 m) of a pixel support it.
    min_neighbors : int, pixels with fewer supporting 8-neighbours are dropped (flying pixels
        between surfaces, speckle).
    erode_boundary : int, pixels this close (8-connected) to a pixel without depth are dropped
        (the silhouette ring, where flying pixels live).
    occlusion_margin : int, background pixels within this many pixels of a foreground pixel
        nearer by more than the edge threshold are dropped. Without this, the background seen
        just beside a thin foreground part (an arm in front of the torso) tells the TSDF that
        the space where the arm's side surface lies is empty, and carves it away.
    min_view_cos : float, pixels whose surface (normal from the depth image) is seen at a
        cosine below this are dropped: at grazing angles the projective depth differences the
        TSDF uses are far from true distances (needs the camera; 0 disables).
    bilateral_diameter : int, pixel diameter of the bilateral filter (0 disables it).
    bilateral_sigma_depth : float, metres, range kernel of the bilateral filter.
    bilateral_sigma_space : float, pixels, spatial kernel of the bilateral filter.
    """

    min_depth: float = 0.25
    max_depth: float = 5.0
    edge_threshold: float = 0.015
    min_neighbors: int = 3
    erode_boundary: int = 0
    occlusion_margin: int = 0
    min_view_cos: float = 0.0
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
                         min_neighbors: int = 3) -> np.ndarray:
    """Drop flying pixels (mixed foreground/background depths) and speckles.

    A pixel is kept when at least ``min_neighbors`` of its 8-neighbours have a depth within
    ``edge_threshold * z`` of its own (z in metres, at least 1 m). A flying pixel differs from
    the surfaces on both sides of its edge and loses; a true edge pixel keeps the support of
    its own surface, so thin parts (arms seen edge-on) keep their outline, which the TSDF
    needs to avoid holes along occlusion edges.

    Parameters
    ----------
    depth : (h, w) float depth in metres (0 = none).
    edge_threshold : float, allowed depth difference to a supporting neighbour per metre.
    min_neighbors : int, minimum number of supporting 8-neighbours.

    Returns
    -------
    (h, w) float32 filtered depth.
    """
    d = np.asarray(depth, dtype=np.float32)
    valid = d > 0
    thr = edge_threshold * np.maximum(d, 1.0)
    support = np.zeros(d.shape, dtype=np.int32)
    for nb in _neighbors(d):
        support += (nb > 0) & (np.abs(nb - d) <= thr)
    out = d.copy()
    out[~valid | (support < min_neighbors)] = 0
    return out


def view_cosines(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """Cosine between the depth-image normal and the viewing ray at each pixel.

    Parameters
    ----------
    depth : (h, w) float depth in metres (pinhole image), camera : Camera.

    Returns
    -------
    (h, w) float64 in [0, 1]; 1 where the normal cannot be estimated (kept).
    """
    d = np.asarray(depth, dtype=np.float64)
    h, w = d.shape
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    P = np.stack([(u - camera.cx) / camera.fx * d, (v - camera.cy) / camera.fy * d, d], axis=-1)
    valid = d > 0
    dx = np.zeros_like(P)
    dy = np.zeros_like(P)
    dx[:, 1:-1] = P[:, 2:] - P[:, :-2]
    dy[1:-1] = P[2:] - P[:-2]
    okx = np.zeros_like(valid)
    oky = np.zeros_like(valid)
    okx[:, 1:-1] = valid[:, 2:] & valid[:, :-2]
    oky[1:-1] = valid[2:] & valid[:-2]
    n = np.cross(dx, dy)
    nn = np.linalg.norm(n, axis=-1)
    ray = P / np.maximum(np.linalg.norm(P, axis=-1, keepdims=True), 1e-12)
    cos = np.abs(np.einsum("hwc,hwc->hw", n, ray)) / np.maximum(nn, 1e-20)
    return np.where(okx & oky & (nn > 0), cos, 1.0)


def filter_depth(depth: np.ndarray, config: DepthFilterConfig | None = None,
                 camera: Camera | None = None) -> np.ndarray:
    """Range filter, flying-pixel removal, grazing-angle removal and bilateral smoothing.

    Parameters
    ----------
    depth : (h, w) float depth in metres (0 = none).
    config : DepthFilterConfig (defaults when None).
    camera : Camera of the (undistorted) image, for the grazing-angle test (skipped if None).

    Returns
    -------
    (h, w) float32 filtered depth in metres.

    Raises
    ------
    ValueError when ``depth`` is not a 2-D array.
    """
    cfg = config or DepthFilterConfig()
    d = np.asarray(depth, dtype=np.float32)
    if d.ndim != 2:
        raise ValueError(f"depth: expected shape (h, w), got {d.shape}")
    d = np.where((d >= cfg.min_depth) & (d <= cfg.max_depth), d, 0).astype(np.float32)
    d = remove_flying_pixels(d, cfg.edge_threshold, cfg.min_neighbors)
    if cfg.occlusion_margin > 0:
        k = np.ones((2 * cfg.occlusion_margin + 1,) * 2, np.uint8)
        nearest = cv2.erode(np.where(d > 0, d, np.float32(1e6)).astype(np.float32), k,
                            borderType=cv2.BORDER_CONSTANT, borderValue=1e6)
        d[(d > 0) & (d - nearest > cfg.edge_threshold * np.maximum(d, 1.0))] = 0
    if cfg.erode_boundary > 0:
        k = np.ones((2 * cfg.erode_boundary + 1,) * 2, np.uint8)
        d[cv2.erode((d > 0).astype(np.uint8), k, borderType=cv2.BORDER_CONSTANT, borderValue=0) == 0] = 0
    if camera is not None and cfg.min_view_cos > 0:
        sm = cv2.bilateralFilter(d, 5, 0.01, 2.0) if cfg.bilateral_diameter > 0 else d
        d[view_cosines(np.where(d > 0, sm, 0), camera) < cfg.min_view_cos] = 0
    if cfg.bilateral_diameter > 0:
        valid = d > 0
        sm = cv2.bilateralFilter(d, cfg.bilateral_diameter, cfg.bilateral_sigma_depth, cfg.bilateral_sigma_space)
        # zeros take part in OpenCV's range kernel only when within sigma of 0, i.e. never
        d = np.where(valid, sm, 0).astype(np.float32)
    return d
