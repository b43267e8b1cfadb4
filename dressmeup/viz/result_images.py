"""Pictures of benchmark results: a prediction beside its ground truth with an error heat map,
and per-category bar charts with intervals (headless matplotlib, no display, no OpenGL).

Why matplotlib and not open3d's offscreen renderer: open3d's ``OffscreenRenderer`` needs a
Vulkan or EGL driver, which a fresh headless CPU machine does not have ("Failed to load
vulkan library"); the painter's-algorithm renderer of :mod:`dressmeup.viz.contact_sheet`
draws a 5k-face garment in well under a second with nothing but matplotlib.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from dressmeup.geometry.proximity import closest_points
from dressmeup.geometry.winding import winding_number
from dressmeup.viz.contact_sheet import MeshLayer, draw_cell
from dressmeup.viz.figure import save_png
from dressmeup.viz.overlay import up_axis

#: Colour of penetrating faces (inside the target body).
PENETRATION_RGB = (0.86, 0.08, 0.08)
#: Colour of the ground truth.
TRUTH_RGB = (0.72, 0.74, 0.78)
#: Colour map of error heat maps (red is kept for penetrations).
ERROR_CMAP = "viridis"


def vertex_distances_mm(V: np.ndarray, ref_V: np.ndarray, ref_F: np.ndarray) -> np.ndarray:
    """Distance of every vertex of a mesh to a reference surface, in millimetres.

    Parameters
    ----------
    V : (n, 3) float64 vertices of the mesh (e.g. a prediction), metres.
    ref_V, ref_F : (k, 3) float64 / (l, 3) int64, the reference surface (e.g. the ground
        truth).

    Returns
    -------
    (n,) float64: the point-to-surface distance of each vertex (the per-vertex form of
    P2S), mm.
    """

    dist, _, _ = closest_points(np.asarray(ref_V, np.float64), np.asarray(ref_F, np.int64),
                                np.asarray(V, np.float64))
    return 1000.0 * np.asarray(dist, np.float64)


def face_distances_mm(V: np.ndarray, F: np.ndarray, ref_V: np.ndarray,
                      ref_F: np.ndarray) -> np.ndarray:
    """Per-face distance of a mesh to a reference surface, in millimetres.

    Parameters
    ----------
    V, F : (n, 3) float64 vertices, (m, 3) int64 faces of the mesh (e.g. a prediction).
    ref_V, ref_F : the reference surface (e.g. the ground truth).

    Returns
    -------
    (m,) float64: mean over the face's three corners of :func:`vertex_distances_mm`, mm.
    """

    return vertex_distances_mm(V, ref_V, ref_F)[np.asarray(F, np.int64)].mean(axis=1)


def penetrating_faces(V: np.ndarray, F: np.ndarray, body_V: np.ndarray,
                      body_F: np.ndarray) -> np.ndarray:
    """(m,) bool: faces whose centroid lies inside the body (winding number > 0.5)."""

    cent = np.asarray(V, np.float64)[np.asarray(F, np.int64)].mean(axis=1)
    return np.asarray(winding_number(np.asarray(body_V, np.float64),
                                     np.asarray(body_F, np.int64), cent)) > 0.5


def _screen_axes(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(right, up) for a front view: up along the largest extent, right along the wider
    horizontal axis (the camera looks along the thinnest one)."""

    up = up_axis(points)
    ext = np.ptp(np.asarray(points, float), axis=0)
    horiz = [i for i in range(3) if up[i] == 0]
    return np.eye(3)[max(horiz, key=lambda i: ext[i])], up


def _bounds(points: np.ndarray, right: np.ndarray, up: np.ndarray) -> tuple:
    xy = np.stack([points @ right, points @ up], axis=1)
    lo, hi = xy.min(0), xy.max(0)
    c, r = (lo + hi) / 2, float((hi - lo).max()) / 2 * 1.06 + 1e-9
    return (c[0] - r, c[0] + r, c[1] - r, c[1] + r)


def render_error_pair(pred_V: np.ndarray, pred_F: np.ndarray, gt_V: np.ndarray,
                      gt_F: np.ndarray, path: str | os.PathLike, *, face_error_mm: np.ndarray,
                      vmax_mm: float, penetrating: np.ndarray | None = None,
                      title: str = "", error_label: str = "P2S", dpi: int = 90) -> Path:
    """Write a PNG: the prediction (front and back) coloured by its per-face error, beside
    the ground truth, with a colour bar in mm; penetrating faces in red.

    Parameters
    ----------
    pred_V, pred_F : prediction mesh, (n, 3) float64 / (m, 3) int64, metres.
    gt_V, gt_F : ground-truth mesh.
    path : output PNG (written atomically).
    face_error_mm : (m,) per-face error of the prediction, mm (see :func:`face_distances_mm`).
    vmax_mm : top of the colour scale, mm (shared by the pictures of one page).
    penetrating : (m,) bool faces drawn red, or None.
    title : caption above the panels.
    error_label : what the colour bar measures.

    Returns
    -------
    Path of the PNG.
    """
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib

    matplotlib.use("Agg", force=False)
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt
    from matplotlib import cm, colors

    pred_V = np.asarray(pred_V, np.float64)
    gt_V = np.asarray(gt_V, np.float64)
    err = np.nan_to_num(np.asarray(face_error_mm, np.float64), nan=0.0)
    norm = colors.Normalize(vmin=0.0, vmax=max(float(vmax_mm), 1e-6))
    cmap = plt.get_cmap(ERROR_CMAP)
    fc = cmap(norm(err))[:, :3]
    if penetrating is not None and np.any(penetrating):
        fc[np.asarray(penetrating, bool)] = PENETRATION_RGB
    right, up = _screen_axes(np.vstack([pred_V, gt_V]))
    bounds = _bounds(np.vstack([pred_V, gt_V]), right, up)
    back_bounds = (-bounds[1], -bounds[0], bounds[2], bounds[3])
    fig = plt.figure(figsize=(6.4, 2.9))
    grid = fig.add_gridspec(1, 4, width_ratios=[1, 1, 1, 0.06], wspace=0.05)
    pred = [MeshLayer(pred_V, pred_F, face_colors=fc)]
    n_pen = int(np.sum(penetrating)) if penetrating is not None else 0
    draw_cell(fig.add_subplot(grid[0]), pred, right, up, "prediction (front)", bounds)
    draw_cell(fig.add_subplot(grid[1]), pred, -right, up, "prediction (back)", back_bounds)
    draw_cell(fig.add_subplot(grid[2]), [MeshLayer(gt_V, gt_F, TRUTH_RGB)], right, up,
              "ground truth", bounds)
    cax = fig.add_subplot(grid[3])
    bar = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), cax=cax, extend="max")
    bar.set_label(f"{error_label} [mm]", fontsize=7)
    bar.ax.tick_params(labelsize=6)
    sub = f"; {n_pen} penetrating faces in red" if penetrating is not None else ""
    if title or sub:
        fig.suptitle(title + sub, fontsize=7.5)
    return save_png(fig, path, dpi=dpi, tight=True)


def _style_bar_axes(ax, x: np.ndarray, labels: Sequence[str], ylabel: str) -> None:
    """The bar charts' common look: labels under the bars, small type, no top/right frame."""
    ax.set_xticks(x, [str(c) for c in labels], fontsize=8)
    ax.set_ylabel(ylabel, fontsize=8)
    ax.tick_params(axis="y", labelsize=7)
    ax.spines[["top", "right"]].set_visible(False)


def render_category_bars(categories: Sequence[str], means: Sequence[float],
                         intervals: Sequence[tuple[float, float] | None],
                         path: str | os.PathLike, *, ylabel: str, title: str = "",
                         dpi: int = 90) -> Path:
    """Write a PNG bar chart: one bar per category with its 95 % interval as an error bar.

    Parameters
    ----------
    categories : bar labels.
    means : (k,) bar heights in display units (NaN: no bar).
    intervals : per bar ``(lo, hi)`` in display units, or None (no error bar: old result or
        a single unit).
    path : output PNG (atomic).
    ylabel : axis label with its unit, e.g. ``P2S [mm]``.
    """
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib

    matplotlib.use("Agg", force=False)
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt

    m = np.asarray(means, np.float64)
    lo = np.array([m[i] - iv[0] if iv else 0.0 for i, iv in enumerate(intervals)])
    hi = np.array([iv[1] - m[i] if iv else 0.0 for i, iv in enumerate(intervals)])
    fig, ax = plt.subplots(figsize=(max(2.8, 1.2 + 0.9 * len(categories)), 2.6))
    x = np.arange(len(categories))
    ax.bar(x, np.nan_to_num(m), color="#4c78a8", width=0.6)
    has = np.array([iv is not None for iv in intervals])
    if has.any():
        ax.errorbar(x[has], m[has], yerr=[np.maximum(lo[has], 0), np.maximum(hi[has], 0)],
                    fmt="none", ecolor="#1d2330", capsize=4, linewidth=1)
    _style_bar_axes(ax, x, categories, ylabel)
    if title:
        ax.set_title(title, fontsize=8)
    fig.tight_layout()
    return save_png(fig, path, dpi=dpi)


def render_grouped_bars(groups: Sequence[str], series: dict[str, Sequence[float]],
                        intervals: dict[str, Sequence[tuple[float, float] | None]],
                        path: str | os.PathLike, *, ylabel: str, title: str = "",
                        dpi: int = 90) -> Path:
    """Write a PNG: for each group (category or track) one bar per series (method) with its
    95 % interval as an error bar.

    Parameters
    ----------
    groups : group labels on the x axis, k of them.
    series : ``{name: (k,) means}`` in display units (NaN: no bar), in legend order.
    intervals : ``{name: k x ((lo, hi) or None)}`` in display units.
    path : output PNG (atomic).
    ylabel : axis label with its unit.
    """
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib

    matplotlib.use("Agg", force=False)
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt

    names = list(series)
    k, n = len(groups), max(len(names), 1)
    width = 0.8 / n
    fig, ax = plt.subplots(figsize=(max(4.0, 1.0 + 0.35 * n * k + 0.6 * k), 3.0))
    cmap = plt.get_cmap("tab10")
    x = np.arange(k)
    for j, name in enumerate(names):
        m = np.asarray(series[name], np.float64)
        xs = x - 0.4 + width * (j + 0.5)
        ax.bar(xs, np.nan_to_num(m), width=width * 0.92, color=cmap(j % 10), label=name)
        ivs = intervals.get(name, [None] * k)
        has = np.array([iv is not None and np.isfinite(m[i]) for i, iv in enumerate(ivs)])
        if has.any():
            lo = np.array([m[i] - ivs[i][0] if has[i] else 0.0 for i in range(k)])
            hi = np.array([ivs[i][1] - m[i] if has[i] else 0.0 for i in range(k)])
            ax.errorbar(xs[has], m[has], yerr=[np.maximum(lo[has], 0), np.maximum(hi[has], 0)],
                        fmt="none", ecolor="#1d2330", capsize=2, linewidth=0.8)
    _style_bar_axes(ax, x, groups, ylabel)
    if names:  # no series (e.g. every result not comparable): no legend, no warning
        ax.legend(fontsize=6.5, frameon=False, ncol=min(n, 4), loc="upper left",
                  bbox_to_anchor=(0, -0.12))
    if title:
        ax.set_title(title, fontsize=8)
    fig.tight_layout()
    return save_png(fig, path, dpi=dpi, tight=True)
