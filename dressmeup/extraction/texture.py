"""UV atlas (xatlas) and texture baking from the capture views (best view + seam blending)."""

from __future__ import annotations

import logging
from collections.abc import Sequence

import cv2
import numpy as np

from dressmeup.capture.frame import RGBDFrame, frame_camera
from dressmeup.capture.rig import Rig
from dressmeup.capture.visibility import raycasting_scene, visible_from

__all__ = ["uv_atlas", "rasterize_uv", "bake_texture", "fill_gutters"]

log = logging.getLogger(__name__)


def uv_atlas(vertices: np.ndarray, faces: np.ndarray, resolution: int = 1024, padding: int = 4
             ) -> tuple[np.ndarray, np.ndarray]:
    """Per-corner UV atlas with xatlas (charts, packing with padding in texels).

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int.
    resolution : int, texture size the packing is done for.
    padding : int, texels between charts.

    Returns
    -------
    uv : (k, 2) float64 in [0, 1] (v up, OBJ convention), uv_faces : (m, 3) int64 into ``uv``,
    same face order as ``faces``.
    """
    # heavy: scipy.sparse
    from dressmeup.geometry.uv_packing import xatlas_atlas

    # Raw xatlas UVs (square_texels=False): they fill the square texture even when xatlas
    # packs a non-square atlas (texels then slightly anisotropic), as extraction always did.
    atlas = xatlas_atlas(vertices, faces, resolution=resolution, padding=padding, bilinear=True,
                         square_texels=False)
    return atlas.uv, atlas.uv_faces


def rasterize_uv(uv: np.ndarray, uv_faces: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Which face covers each texel centre, and where in it.

    Parameters
    ----------
    uv : (k, 2) float in [0, 1], uv_faces : (m, 3) int, size : int texture side.

    Returns
    -------
    face_id : (size, size) int64, -1 where no face; bary : (size, size, 3) float64.
    Row 0 of the image is v = 1 (images are stored top-down).
    """
    P = np.asarray(uv, dtype=np.float64)[np.asarray(uv_faces, dtype=np.int64)]  # (m, 3, 2)
    px = np.stack([P[..., 0] * size - 0.5, (1.0 - P[..., 1]) * size - 0.5], axis=-1)
    fid = np.full((size, size), -1, dtype=np.int32)
    shift = 4
    pts = np.round(px * (1 << shift)).astype(np.int32)
    for f in range(len(pts)):
        cv2.fillConvexPoly(fid, pts[f], int(f), lineType=cv2.LINE_8, shift=shift)
    # also claim texels whose centres the fill missed along thin triangles: dilate by one
    ys, xs = np.nonzero(fid >= 0)
    f = fid[ys, xs].astype(np.int64)
    a, b, c = px[f, 0], px[f, 1], px[f, 2]
    q = np.stack([xs, ys], axis=1).astype(np.float64)
    v0, v1, v2 = b - a, c - a, q - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    den = np.where(np.abs(den) < 1e-12, 1e-12, den)
    w1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
    w2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
    bary = np.zeros((size, size, 3))
    bb = np.clip(np.stack([1 - w1 - w2, w1, w2], axis=1), 0, 1)
    bb /= np.maximum(bb.sum(axis=1, keepdims=True), 1e-12)
    bary[ys, xs] = bb
    return fid.astype(np.int64), bary


def fill_gutters(image: np.ndarray, mask: np.ndarray, iterations: int = 8) -> np.ndarray:
    """Grow texel colours into empty texels (so bilinear lookups at chart edges stay clean).

    Parameters
    ----------
    image : (h, w, 3) uint8, mask : (h, w) bool filled texels, iterations : int (texels grown).

    Returns
    -------
    (h, w, 3) uint8
    """
    img = image.astype(np.float32)
    m = mask.astype(np.float32)
    k = np.ones((3, 3), np.float32)
    for _ in range(int(iterations)):
        s = cv2.filter2D(img * m[..., None], -1, k, borderType=cv2.BORDER_CONSTANT)
        c = cv2.filter2D(m, -1, k, borderType=cv2.BORDER_CONSTANT)
        grow = (m == 0) & (c > 0)
        img[grow] = s[grow] / c[grow, None]
        m = np.maximum(m, grow.astype(np.float32))
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def _bilinear(image: np.ndarray, xy: np.ndarray) -> np.ndarray:
    h, w = image.shape[:2]
    x = np.clip(xy[:, 0], 0, w - 1)
    y = np.clip(xy[:, 1], 0, h - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), w - 2)
    y0 = np.minimum(np.floor(y).astype(np.int64), h - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    im = image.astype(np.float64)
    return ((1 - fx) * (1 - fy) * im[y0, x0] + fx * (1 - fy) * im[y0, x0 + 1]
            + (1 - fx) * fy * im[y0 + 1, x0] + fx * fy * im[y0 + 1, x0 + 1])


def bake_texture(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, uv_faces: np.ndarray,
                 frames: Sequence[RGBDFrame], rig: Rig, size: int = 1024,
                 occluders: tuple[np.ndarray, np.ndarray] | None = None, sharpness: float = 8.0,
                 visibility_tolerance: float = 0.01, default_color: Sequence[int] = (128, 128, 128)
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Bake a texture from the capture views.

    Each texel's surface point is projected into every view that sees it (front-facing,
    not occluded by ``occluders``); view weights are ``cos(view angle)`` raised to
    ``sharpness`` and normalised, so the texel takes the colour of its best view and blends
    views only where they are nearly equally good (the seams between views' regions).

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int, the garment.
    uv : (k, 2) float, uv_faces : (m, 3) int, its atlas.
    frames : undistorted frames (colour registered to depth), rig : Rig (cameras of frames that
        carry none).
    size : int, texture side in texels.
    occluders : (V, F) whole scan used for the visibility test (default: the garment).
    sharpness : float, exponent of the view weights (large: pure best view).
    visibility_tolerance : float, metres.
    default_color : RGB for texels no camera sees.

    Returns
    -------
    texture : (size, size, 3) uint8 RGB, coverage : (size, size) bool (texels seen by a view).
    """

    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    fid, bary = rasterize_uv(uv, uv_faces, size)
    ys, xs = np.nonzero(fid >= 0)
    f = fid[ys, xs]
    pts = np.einsum("kj,kjc->kc", bary[ys, xs], V[F[f]])
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-20)
    nrm = fn[f]
    ov, of = occluders if occluders is not None else (V, F)
    scene = raycasting_scene(ov, of)
    acc = np.zeros((len(pts), 3))
    wsum = np.zeros(len(pts))
    for fr in frames:
        cam = frame_camera(fr, rig)
        to_cam = cam.center - pts
        to_cam /= np.maximum(np.linalg.norm(to_cam, axis=1, keepdims=True), 1e-20)
        cos = np.einsum("ij,ij->i", nrm, to_cam)
        uvp, z = cam.project(pts)
        ok = (cos > 0.05) & (z > 0) & (uvp[:, 0] >= 0) & (uvp[:, 1] >= 0) & \
             (uvp[:, 0] <= cam.width - 1) & (uvp[:, 1] <= cam.height - 1)
        idx = np.nonzero(ok)[0]
        if len(idx) == 0:
            continue
        idx = idx[visible_from(pts[idx], cam.center, scene, visibility_tolerance)]
        # the measured depth must agree too (no colour from where the camera saw nothing)
        pu = np.round(uvp[idx]).astype(np.int64)
        dz = fr.depth[pu[:, 1], pu[:, 0]]
        idx = idx[(dz > 0) & (np.abs(dz - z[idx]) < 0.03)]
        if len(idx) == 0:
            continue
        col = _bilinear(fr.color, uvp[idx])
        w = cos[idx] ** sharpness
        acc[idx] += w[:, None] * col
        wsum[idx] += w
    tex = np.zeros((size, size, 3), dtype=np.uint8)
    tex[:] = np.asarray(default_color, dtype=np.uint8)
    seen = wsum > 0
    tex[ys[seen], xs[seen]] = np.clip(np.round(acc[seen] / wsum[seen, None]), 0, 255).astype(np.uint8)
    coverage = np.zeros((size, size), dtype=bool)
    coverage[ys[seen], xs[seen]] = True
    tex = fill_gutters(tex, coverage, iterations=8)
    return tex, coverage
