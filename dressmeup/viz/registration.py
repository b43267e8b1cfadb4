"""Picture of a registration: the fitted body and the scan overlaid, front and side.

The body is drawn shaded grey with the parts lying more than 15 mm *outside* the scan in
red (a clothed scan should contain the body), the scan points on top in translucent blue.
Views follow the fitted body's own facing direction, so a body fitted backwards or with
its arms down in a T-pose scan is plain to see.
"""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import numpy as np

from dressmeup.viz.contact_sheet import MeshLayer, draw_cell
from dressmeup.viz.figure import save_png

BODY_RGB = (0.72, 0.72, 0.72)
OUTSIDE_RGB = (0.9, 0.15, 0.1)
SCAN_RGB = (0.2, 0.4, 0.9)


def render_registration(body_vertices: np.ndarray, body_faces: np.ndarray,
                        scan_points: np.ndarray, path: str | os.PathLike,
                        forward: np.ndarray = (0.0, 0.0, 1.0), up: np.ndarray = (0.0, 1.0, 0.0),
                        outside_mm: np.ndarray | None = None, threshold_mm: float = 15.0,
                        title: str = "", max_points: int = 15000, seed: int = 0) -> Path:
    """Write a PNG with the body over the scan, seen from the body's front and left side.

    Parameters
    ----------
    body_vertices : (n, 3) float64 fitted body (m); body_faces : (m, 3) int64.
    scan_points : (p, 3) float64 scan points or mesh vertices (m).
    path : output PNG (written atomically).
    forward, up : (3,) the body's facing direction and up axis (world).
    outside_mm : optional (n,) per-vertex distance outside the scan (mm); faces whose
        vertices all exceed ``threshold_mm`` are drawn red.
    title : caption (e.g. the fit's figures); max_points, seed : scan subsample.

    Returns
    -------
    The written path.
    """

    # heavy: matplotlib (~0.3 s to import)
    import matplotlib

    matplotlib.use("Agg", force=False)
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt

    P = np.asarray(scan_points, dtype=np.float64)
    if len(P) > max_points:
        P = P[np.random.default_rng(seed).choice(len(P), max_points, replace=False)]
    fig, axes = plt.subplots(1, 2, figsize=(6.4, 4.6))
    draw_registration_views(axes, body_vertices, body_faces, P, forward=forward, up=up,
                            outside_mm=outside_mm, threshold_mm=threshold_mm,
                            titles=("front", "left side"))
    fig.suptitle("\n".join(textwrap.wrap(title, 90)) if title else
                 "body (grey; red: > 15 mm outside the scan) over the scan (blue)", fontsize=7)
    fig.tight_layout()
    return save_png(fig, path, dpi=110)


def draw_registration_views(axes, body_vertices: np.ndarray, body_faces: np.ndarray,
                            scan_points: np.ndarray, forward: np.ndarray = (0.0, 0.0, 1.0),
                            up: np.ndarray = (0.0, 1.0, 0.0),
                            outside_mm: np.ndarray | None = None, threshold_mm: float = 15.0,
                            titles: tuple[str, str] = ("", "")) -> None:
    """Draw the body over the scan into two matplotlib axes: from the front along
    ``forward`` and from the left side (the views of :func:`render_registration`).

    Parameters
    ----------
    axes : two matplotlib axes (front, left side).
    body_vertices : (n, 3) float64 (m); body_faces : (m, 3) int64.
    scan_points : (p, 3) float64 (m), all drawn.
    forward, up : (3,) the facing direction and up axis (world).
    outside_mm : optional (n,) per-vertex distance outside the scan (mm); faces whose
        vertices all exceed ``threshold_mm`` are drawn red.
    titles : the two axes' captions.
    """
    V = np.asarray(body_vertices, dtype=np.float64)
    F = np.asarray(body_faces, dtype=np.int64)
    P = np.asarray(scan_points, dtype=np.float64)
    up = np.asarray(up, float) / np.linalg.norm(up)
    fwd = np.asarray(forward, float)
    fwd = fwd - (fwd @ up) * up
    fwd = fwd / max(np.linalg.norm(fwd), 1e-12)
    left = np.cross(up, fwd)
    colors = np.tile(np.asarray(BODY_RGB), (len(F), 1))
    if outside_mm is not None:
        bad = (np.asarray(outside_mm)[F] > threshold_mm).all(1)
        colors[bad] = OUTSIDE_RGB
    layer = MeshLayer(V, F, face_colors=colors)
    allpts = np.vstack([V, P])
    for ax, right, name in zip(axes, (left, np.cross(up, left)), titles, strict=True):
        xy = np.stack([allpts @ right, allpts @ up], 1)
        lo, hi = xy.min(0), xy.max(0)
        c, r = (lo + hi) / 2, (hi - lo).max() / 2 * 1.05
        draw_cell(ax, [layer], right, up, name, bounds=(c[0] - r, c[0] + r, c[1] - r, c[1] + r))
        ax.scatter(P @ right, P @ up, s=0.3, c=[SCAN_RGB], alpha=0.25, linewidths=0)
