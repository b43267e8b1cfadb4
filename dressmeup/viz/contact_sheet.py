"""Contact sheets: headless pictures of many meshes in a grid (matplotlib, painter's algorithm).

Each cell is an orthographic view of a few meshes (e.g. a body and its garment), flat shaded
by a headlight, triangles drawn back to front. No OpenGL or display is needed.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dressmeup.body import get_body_model
from dressmeup.data.dataset import Dataset
from dressmeup.data.synth.garments import BodyFrame
from dressmeup.errors import InputError
from dressmeup.io.images import read_image
from dressmeup.viz.figure import save_png


@dataclass
class MeshLayer:
    """One mesh of a cell: ``vertices (n, 3)``, ``faces (m, 3)``, RGB ``color`` in [0, 1]
    (or ``face_colors (m, 3)``)."""

    vertices: np.ndarray
    faces: np.ndarray
    color: tuple[float, float, float] = (0.7, 0.7, 0.7)
    face_colors: np.ndarray | None = None


def draw_cell(ax, layers: Sequence[MeshLayer], right: np.ndarray, up: np.ndarray,
              title: str = "", bounds: tuple | None = None) -> None:
    """Draw ``layers`` into a matplotlib axis, viewed along ``cross(right, up)``.

    Parameters
    ----------
    ax : matplotlib axis.
    layers : meshes to draw together (depth-sorted jointly).
    right, up : (3,) unit screen axes in world coordinates; the camera looks at the scene from
        ``cross(right, up)``.
    title : cell caption.
    bounds : optional ``(xmin, xmax, ymin, ymax)`` in screen units.
    """
    # heavy: matplotlib (~0.3 s to import)
    from matplotlib.collections import PolyCollection

    right = np.asarray(right, float)
    up = np.asarray(up, float)
    view = np.cross(right, up)  # towards the viewer
    polys, depth, cols = [], [], []
    for L in layers:
        V, F = np.asarray(L.vertices, float), np.asarray(L.faces, np.int64)
        tri = V[F]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        shade = 0.25 + 0.75 * np.abs(n @ view)
        base = np.asarray(L.face_colors, float) if L.face_colors is not None else \
            np.tile(np.asarray(L.color, float), (len(F), 1))
        cols.append(np.clip(base * shade[:, None], 0, 1))
        polys.append(np.stack([tri @ right, tri @ up], axis=2))
        depth.append(tri.mean(1) @ view)
    P = np.concatenate(polys)
    D = np.concatenate(depth)
    C = np.concatenate(cols)
    order = np.argsort(D)
    ax.add_collection(PolyCollection(P[order], facecolors=C[order], edgecolors="none",
                                     antialiased=False))
    if bounds is None:
        xy = P.reshape(-1, 2)
        lo, hi = xy.min(0), xy.max(0)
        c, r = (lo + hi) / 2, (hi - lo).max() / 2 * 1.05
        bounds = (c[0] - r, c[0] + r, c[1] - r, c[1] + r)
    ax.set_xlim(bounds[0], bounds[1])
    ax.set_ylim(bounds[2], bounds[3])
    ax.set_aspect("equal")
    ax.axis("off")
    if title:
        ax.set_title(title, fontsize=7)


def render_contact_sheet(cells: Sequence[Sequence[MeshLayer] | None], path: str | os.PathLike,
                         right: np.ndarray, up: np.ndarray, ncols: int,
                         titles: Sequence[str] | None = None, cell_size: float = 1.6,
                         dpi: int = 110, suptitle: str = "",
                         cell_height: float | None = None) -> None:
    """Render a grid of cells to a PNG (atomically).

    Parameters
    ----------
    cells : one list of :class:`MeshLayer` per cell, row-major; an empty list or None leaves
        the cell blank.
    path : output PNG.
    right, up : (3,) screen axes in world coordinates.
    ncols : cells per row.
    titles : optional caption per cell.
    cell_size, cell_height : cell width and height in inches (height default
        ``1.25 * cell_size``).
    dpi : pixels per inch; suptitle : optional title of the sheet.
    """
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib

    matplotlib.use("Agg", force=False)
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt

    nrows = max(1, int(np.ceil(len(cells) / ncols)))
    height = cell_size * 1.25 if cell_height is None else cell_height
    fig, axes = plt.subplots(nrows, ncols, figsize=(cell_size * ncols, height * nrows),
                             squeeze=False)
    for k, ax in enumerate(axes.ravel()):
        if k < len(cells) and cells[k]:
            draw_cell(ax, cells[k], right, up, titles[k] if titles else "")
        else:
            ax.axis("off")
    if suptitle:
        fig.suptitle(suptitle, fontsize=9)
    fig.tight_layout()
    save_png(fig, path, dpi=dpi)


def _face_colors_from_texture(g) -> np.ndarray | None:
    """Per-face RGB in [0, 1] sampled from the texture at each face's UV centroid."""
    if g.uv is None or g.texture_path is None:
        return None

    tex = read_image(g.texture_path, "texture").astype(np.float64) / 255.0
    uvf = g.uv_faces if g.uv_faces is not None else g.faces
    c = g.uv[uvf].mean(1)
    h, w = tex.shape[:2]
    x = np.clip((c[:, 0] % 1.0) * (w - 1), 0, w - 1).astype(int)
    y = np.clip((1.0 - c[:, 1] % 1.0) * (h - 1), 0, h - 1).astype(int)
    return tex[y, x]


def render_dataset_contact_sheet(root: str | os.PathLike, path: str | os.PathLike,
                                 max_garments: int = 8, max_poses: int = 5,
                                 view: str = "front", one_per_type: bool = True) -> None:
    """Contact sheet of a dataset: one row per garment, one column per pose.

    Each cell shows the posed body (grey, from ``body()`` through its body model) and the
    textured garment. Needs the body model named in each body file.

    Parameters
    ----------
    root : dataset folder.
    path : output PNG.
    max_garments, max_poses : grid size limits.
    view : ``front`` or ``side``.
    one_per_type : show garments of distinct types first.
    """
    ds = Dataset(root)
    m = ds.manifest.sort_values(["garment_id", "pose_id"])
    garments = list(dict.fromkeys(m["garment_id"]))
    if one_per_type:
        first = m.drop_duplicates("garment_type")["garment_id"].tolist()
        garments = first + [g for g in garments if g not in first]
    garments = garments[:max_garments]
    cells, titles = [], []
    frame = None
    for g in garments:
        rows = m[m["garment_id"] == g].head(max_poses)
        for _, r in rows.iterrows():
            s = ds[r["sample_id"]]
            gm = s.garment()
            layers = []
            b = s.body()
            if b is not None:
                model = get_body_model(b.model)
                out = model.posed(b)
                layers.append(MeshLayer(out.vertices, model.faces, (0.75, 0.75, 0.75)))
                if frame is None:
                    frame = BodyFrame.from_joints(out.rest_joints, tuple(model.joint_names))
            layers.append(MeshLayer(gm.vertices, gm.faces, (0.8, 0.35, 0.3),
                                    _face_colors_from_texture(gm)))
            cells.append(layers)
            pose = ds.info.get("subjects", {}).get(s.subject_id, {}).get("poses", {}).get(
                s.pose_id, s.pose_id)
            titles.append(f"{s.sample_id}\n{s.garment_type}, {pose}")
        for _ in range(max_poses - len(rows)):
            cells.append([])
            titles.append("")
    up = frame.up if frame is not None else np.array([0.0, 1.0, 0.0])
    right = (frame.left if view == "front" else frame.forward) if frame is not None else \
        np.array([1.0, 0.0, 0.0])
    render_contact_sheet(cells, path, right, up, max_poses, titles, cell_size=1.9, cell_height=2.4,
                         dpi=100)


def render_garment_on_bodies(root: str | os.PathLike, garment_id: str, path: str | os.PathLike,
                             view: str = "front", max_poses: int = 6) -> None:
    """Contact sheet of one garment worn by every subject: one row per subject, one column
    per pose (generator 2.x data, where a garment is fitted to several bodies).

    Parameters
    ----------
    root : dataset folder.
    garment_id : the garment to show.
    path : output PNG.
    view : ``front`` or ``side``.
    max_poses : columns at most.
    """
    ds = Dataset(root)
    m = ds.manifest[ds.manifest["garment_id"] == garment_id]
    if m.empty:
        raise InputError(f"garment {garment_id!r} not found in {root}")
    pids = sorted(m["pose_id"].unique())[:max_poses]
    cells, titles, frame = [], [], None
    subjects = ds.info.get("subjects", {})
    for sid in sorted(m["subject_id"].unique()):
        for pid in pids:
            rows = m[(m["subject_id"] == sid) & (m["pose_id"] == pid)]
            if rows.empty:
                cells.append(None)
                titles.append("")
                continue
            s = ds[rows["sample_id"].iloc[0]]
            b = s.body()
            model = get_body_model(b.model)
            out = model.posed(b)
            if frame is None:
                frame = BodyFrame.from_joints(out.rest_joints, tuple(model.joint_names))
            gm = s.garment()
            cells.append([MeshLayer(out.vertices, model.faces, (0.75, 0.75, 0.75)),
                          MeshLayer(gm.vertices, gm.faces, (0.8, 0.35, 0.3),
                                    _face_colors_from_texture(gm))])
            name = subjects.get(sid, {}).get("name", sid)
            pose = ds.info.get("poses", {}).get(pid, pid)
            titles.append(f"{sid} {name}\n{pid} {pose}")
    up = frame.up if frame is not None else np.array([0.0, 1.0, 0.0])
    right = (frame.left if view == "front" else frame.forward) if frame is not None else \
        np.array([1.0, 0.0, 0.0])
    render_contact_sheet(cells, path, right, up, len(pids), titles, cell_size=1.9, cell_height=2.4,
                         dpi=100)
