"""Pictures of one sample's garment on its body (front and side), to see at a glance whether
an imported dataset's garments and bodies line up."""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import numpy as np

from dressmeup.body import get_body_model
from dressmeup.errors import MissingModelError
from dressmeup.viz.contact_sheet import MeshLayer, draw_cell
from dressmeup.viz.figure import save_png

GARMENT_RGB = (0.85, 0.35, 0.25)
BODY_RGB = (0.72, 0.72, 0.72)
SCAN_RGB = (0.55, 0.65, 0.8)


def up_axis(points: np.ndarray) -> np.ndarray:
    """(3,) unit vector along the coordinate axis of largest extent (a standing person's
    height), pointing to its positive end; works for y-up and z-up data alike."""
    ext = np.ptp(np.asarray(points, float), axis=0)
    up = np.zeros(3)
    up[int(np.argmax(ext))] = 1.0
    return up


def render_sample_overlay(sample, path: str | os.PathLike,
                          model_path: str | os.PathLike | None = None) -> str:
    """Draw ``sample``'s garment over its posed body, front and side, to a PNG.

    Parameters
    ----------
    sample : a :class:`~dressmeup.data.Sample` (dataset or adapter).
    path : output PNG (written atomically).
    model_path : SMPL-family model file or folder for bodies of those models.

    Returns
    -------
    A one-line note: what was drawn, or why the body is missing (then the scan, if any, is
    drawn instead).
    """

    g = sample.garment()
    layers = [MeshLayer(g.vertices, g.faces, GARMENT_RGB)]
    note = "garment (red) on body (grey)"
    params = sample.body()
    body_vertices = None
    if params is None:
        note = "no body in this sample"
    else:
        kw = {}
        if params.model.startswith("smpl"):
            kw["gender"] = params.gender or "neutral"
            if model_path is not None:
                kw["model_path"] = str(model_path)
        try:
            model = get_body_model(params.model, **kw)
            out = model.posed(params)
            body_vertices = out.vertices
            layers.insert(0, MeshLayer(out.vertices, model.faces, BODY_RGB))
        except MissingModelError as exc:
            note = f"body not drawn: {str(exc).split('. ')[0]}"
    if body_vertices is None:
        scan = sample.scan()
        if scan is not None:
            layers.insert(0, MeshLayer(scan[0], scan[1], SCAN_RGB))
            note += "; scan (blue) drawn instead"
    pts = np.concatenate([np.asarray(L.vertices, float) for L in layers])
    up = up_axis(pts)
    # front: look along the horizontal axis of least extent; side: the other one
    horiz = [i for i in range(3) if up[i] == 0]
    ext = np.ptp(pts, axis=0)
    depth_axis = min(horiz, key=lambda i: ext[i])
    side_axis = max(horiz, key=lambda i: ext[i])
    _render_two_views(layers, Path(path), np.eye(3)[side_axis], np.eye(3)[depth_axis], up,
                      f"{sample.sample_id} - {note}")
    return note


def _render_two_views(layers, path: Path, right_front, right_side, up, title: str) -> None:
    """Front and side views of the same layers side by side, to ``path`` (atomic PNG)."""
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib

    matplotlib.use("Agg", force=False)
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(4.8, 3.2))
    draw_cell(axes[0], layers, right_front, up, "front")
    draw_cell(axes[1], layers, right_side, up, "side")

    fig.suptitle("\n".join(textwrap.wrap(title, 60)), fontsize=7)
    fig.tight_layout()
    save_png(fig, path, dpi=110)
