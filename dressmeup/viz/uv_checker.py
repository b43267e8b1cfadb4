"""Checkerboard pictures of a UV map: the textured 3D mesh beside its UV layout.

A checkerboard texture shows a parameterisation's quality at a glance: squares that stay
square mean low angle distortion (QCE near 1), squares of equal size mean low area
distortion (ASE near 0), and seams show where charts meet. Rendering is headless
(matplotlib, Agg): each triangle is split into 16 and flat-shaded with the checker colour at
its UV centroid, times a simple Lambert term.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.viz.figure import save_png

__all__ = ["checker_colors", "render_uv_checker"]


def checker_colors(uv: np.ndarray, squares: float = 16.0) -> np.ndarray:
    """Checker colour (two tones) of UV points.

    Parameters
    ----------
    uv : (p, 2) float array, atlas coordinates (usually in [0, 1])
    squares : float
        Squares across the unit UV square.

    Returns
    -------
    (p, 3) float64 RGB in [0, 1]
    """
    ij = np.floor(np.asarray(uv) * squares).astype(np.int64)
    odd = (ij[:, 0] + ij[:, 1]) % 2 == 1
    light = np.array([0.95, 0.93, 0.88])
    dark = np.array([0.20, 0.35, 0.60])
    return np.where(odd[:, None], dark, light)


def _subdivide(P: np.ndarray, T: np.ndarray, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Split each triangle (corner arrays (f, 3, d)) into 4**levels triangles."""
    for _ in range(levels):
        a, b, c = P[:, 0], P[:, 1], P[:, 2]
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        P = np.concatenate([np.stack(t, 1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
        ta, tb, tc = T[:, 0], T[:, 1], T[:, 2]
        tab, tbc, tca = (ta + tb) / 2, (tb + tc) / 2, (tc + ta) / 2
        T = np.concatenate([np.stack(t, 1) for t in ((ta, tab, tca), (tab, tb, tbc), (tca, tbc, tc), (tab, tbc, tca))])
    return P, T


def render_uv_checker(V: np.ndarray, F: np.ndarray, uv: np.ndarray, uv_faces: np.ndarray,
                      path: str | Path, title: str = "", squares: float = 24.0,
                      chart_ids: np.ndarray | None = None, views: tuple = ((20, 30), (20, 210)),
                      max_faces: int = 40000, dpi: int = 110) -> Path:
    """Write a PNG: the mesh with a checker texture from ``views`` and the UV layout.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    uv : (k, 2) float array
    uv_faces : (m, 3) int array
    path : str or Path
        Output PNG (written atomically).
    title : str
    squares : float
        Checker squares across the UV unit square.
    chart_ids : (m,) int array, optional
        Colours the UV layout by chart.
    views : tuple of (elevation, azimuth) in degrees
    max_faces : int
        Larger meshes are drawn from a random subset of faces (seeded).
    dpi : int

    Returns
    -------
    Path of the written file.
    """
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib

    matplotlib.use("Agg")
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    uv = np.asarray(uv, dtype=np.float64)
    uv_faces = np.asarray(uv_faces, dtype=np.int64)
    sel = np.arange(len(F))
    if len(F) > max_faces:
        sel = np.sort(np.random.default_rng(0).choice(len(F), max_faces, replace=False))
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    span = float(np.max(hi - lo)) or 1.0
    uvn = (uv - lo) / span
    levels = 2 if len(sel) <= 6000 else (1 if len(sel) <= 20000 else 0)
    P, T = _subdivide(V[F[sel]], uvn[uv_faces[sel]], levels)
    col = checker_colors(T.mean(axis=1), squares)

    fig = plt.figure(figsize=(4.2 * (len(views) + 1), 4.4))
    _draw_views(fig, V, P, col, views)
    ax = fig.add_subplot(1, len(views) + 1, len(views) + 1)
    _draw_layout(ax, uvn[uv_faces[sel]],
                 None if chart_ids is None else np.asarray(chart_ids)[sel])
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save_png(fig, path, dpi=dpi)


def _draw_views(fig: Any, V: np.ndarray, P: np.ndarray, col: np.ndarray,
                views: tuple) -> None:
    """One 3-D axis per ``(elevation, azimuth)`` of ``views`` (the first of ``fig``'s
    ``len(views) + 1`` columns): triangles ``P (f, 3, 3)`` in checker colours ``col (f, 3)``
    shaded by how squarely they face the eye, framed on the bounds of ``V (n, 3)``."""
    # heavy: mpl_toolkits.mplot3d
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    nrm = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True) + 1e-20
    lo3, hi3 = V.min(axis=0), V.max(axis=0)
    c = 0.5 * (lo3 + hi3)
    half = np.maximum(0.5 * (hi3 - lo3), 1e-3 * float(np.max(hi3 - lo3) or 1.0))
    for i, (elev, azim) in enumerate(views):
        ax = fig.add_subplot(1, len(views) + 1, i + 1, projection="3d")
        e, a = np.deg2rad(elev), np.deg2rad(azim)
        eye = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        shade = 0.35 + 0.65 * np.abs(nrm @ eye)
        pc = Poly3DCollection(P, facecolors=np.clip(col * shade[:, None], 0, 1), edgecolors="none")
        ax.add_collection3d(pc)
        ax.set_xlim(c[0] - half[0], c[0] + half[0])
        ax.set_ylim(c[1] - half[1], c[1] + half[1])
        ax.set_zlim(c[2] - half[2], c[2] + half[2])
        ax.view_init(elev=elev, azim=azim)
        ax.set_box_aspect(tuple(half / half.max()), zoom=1.35)
        ax.set_axis_off()


def _draw_layout(ax: Any, tri: np.ndarray, chart_ids: np.ndarray | None) -> None:
    """The UV layout on ``ax``: triangles ``tri (f, 3, 2)`` in the unit square, grey or
    coloured by ``chart_ids (f,)``."""
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    fc = "0.7" if chart_ids is None else plt.get_cmap("tab20")(chart_ids % 20)
    ax.add_collection(PolyCollection(tri, facecolors=fc, edgecolors="k", linewidths=0.05))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_aspect("equal")
    ax.set_title("UV layout", fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
