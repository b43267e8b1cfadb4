"""UV atlas helpers: cut a mesh into charts and flatten each chart (packing the charts and the
one call into xatlas: :mod:`dressmeup.geometry.uv_packing`).

A UV atlas here is stored per corner, as in OBJ files: ``uv (k, 2)`` and ``uv_faces (m, 3)``
indexing into it, plus ``chart_ids (m,)`` giving each face's chart. A vertex on a seam has
one UV per chart that touches it.

The flow every per-chart method follows::

    chart_ids = ...                                  # any face labelling
    chart_ids = make_disk_charts(V, F, chart_ids)    # split until every chart is a disk
    uv, uv_faces = parameterize_charts(V, F, chart_ids, flatten)   # flatten(Vc, Fc) -> (nc, 2)
    uv = pack_charts(V, F, uv, uv_faces, chart_ids)  # xatlas packing into [0, 1]^2

Extraction (garment texturing) and the UV-parameterisation baselines share these helpers.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from dressmeup.geometry.mesh import as_arrays, face_areas
from dressmeup.geometry.topology import face_adjacency

__all__ = [
    "Chart",
    "split_charts",
    "chart_is_disk",
    "relabel",
    "connected_charts",
    "merge_small_charts",
    "make_disk_charts",
    "parameterize_charts",
    "orient_chart_uv",
    "signed_uv_areas",
]

log = logging.getLogger(__name__)


@dataclass
class Chart:
    """One chart of a face labelling.

    Attributes
    ----------
    chart_id : int
    faces : (f,) int64
        Indices of the chart's faces in the full mesh.
    vertices : (v,) int64
        Global indices of the chart's vertices (the local vertex ``i`` is ``vertices[i]``).
    local_faces : (f, 3) int64
        The chart's faces in local vertex indices.
    """

    chart_id: int
    faces: np.ndarray
    vertices: np.ndarray
    local_faces: np.ndarray


def relabel(chart_ids: np.ndarray) -> np.ndarray:
    """Renumber labels to ``0..c-1`` in order of first appearance (deterministic).

    Parameters
    ----------
    chart_ids : (m,) int array

    Returns
    -------
    (m,) int64 ndarray
    """
    chart_ids = np.asarray(chart_ids)
    _, first, inv = np.unique(chart_ids, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    return rank[inv.reshape(-1)]


def connected_charts(F: np.ndarray, chart_ids: np.ndarray, adjacency: np.ndarray | None = None) -> np.ndarray:
    """Split every chart into its edge-connected components.

    Parameters
    ----------
    F : (m, 3) int array
    chart_ids : (m,) int array
    adjacency : (p, 2) int array, optional
        Output of :func:`face_adjacency` (computed when missing).

    Returns
    -------
    (m,) int64 ndarray, relabelled so that every chart is edge-connected.
    """

    m = len(F)
    adj = face_adjacency(F) if adjacency is None else adjacency
    keep = chart_ids[adj[:, 0]] == chart_ids[adj[:, 1]]
    a = adj[keep]
    g = sp.coo_matrix((np.ones(len(a)), (a[:, 0], a[:, 1])), shape=(m, m))
    _, comp = connected_components(g, directed=False)
    return relabel(comp)


def split_charts(F: np.ndarray, chart_ids: np.ndarray) -> list[Chart]:
    """Group faces by chart and re-index each chart's vertices locally.

    Parameters
    ----------
    F : (m, 3) int array
    chart_ids : (m,) int array

    Returns
    -------
    list of :class:`Chart`, ordered by chart id.
    """
    F = np.asarray(F, dtype=np.int64)
    chart_ids = np.asarray(chart_ids, dtype=np.int64)
    order = np.argsort(chart_ids, kind="stable")
    ids, starts = np.unique(chart_ids[order], return_index=True)
    bounds = np.r_[starts, len(order)]
    charts = []
    for c, s, e in zip(ids, bounds[:-1], bounds[1:], strict=True):
        faces = order[s:e]
        verts, local = np.unique(F[faces].reshape(-1), return_inverse=True)
        charts.append(Chart(int(c), faces, verts, local.reshape(-1, 3)))
    return charts


def chart_is_disk(local_faces: np.ndarray) -> bool:
    """Whether a connected chart is a topological disk (Euler characteristic 1, manifold edges).

    Parameters
    ----------
    local_faces : (f, 3) int array (local vertex indices, all vertices used)

    Returns
    -------
    bool
    """
    Fl = np.asarray(local_faces, dtype=np.int64)
    nv = int(Fl.max()) + 1
    e = np.sort(np.concatenate([Fl[:, [0, 1]], Fl[:, [1, 2]], Fl[:, [2, 0]]]), axis=1)
    key = e[:, 0] * nv + e[:, 1]
    _, counts = np.unique(key, return_counts=True)
    if np.any(counts > 2):
        return False
    chi = nv - len(counts) + len(Fl)
    if chi != 1:
        return False
    # one boundary loop: boundary edges form a single cycle with every vertex of degree 2
    b = e[np.isin(key, np.unique(key)[counts == 1])]
    if len(b) == 0:
        return False
    deg = np.bincount(b.reshape(-1), minlength=nv)
    return bool(np.all(deg[deg > 0] == 2))


def merge_small_charts(F: np.ndarray, chart_ids: np.ndarray, min_faces: int,
                       adjacency: np.ndarray | None = None) -> np.ndarray:
    """Merge charts with fewer than ``min_faces`` faces into the neighbour they share most edges with.

    Parameters
    ----------
    F : (m, 3) int array
    chart_ids : (m,) int array
    min_faces : int
    adjacency : (p, 2) int array, optional

    Returns
    -------
    (m,) int64 ndarray, relabelled.
    """
    ids = relabel(chart_ids)
    adj = face_adjacency(F) if adjacency is None else adjacency
    for _ in range(100):
        sizes = np.bincount(ids)
        small = np.flatnonzero(sizes < min_faces)
        if small.size == 0 or len(sizes) == 1:
            break
        a, b = ids[adj[:, 0]], ids[adj[:, 1]]
        cross = a != b
        a, b = a[cross], b[cross]
        a, b = np.r_[a, b], np.r_[b, a]
        merged = False
        target = np.arange(len(sizes))
        for c in small[np.argsort(sizes[small], kind="stable")]:
            nb = b[a == c]
            if nb.size == 0:
                continue  # an isolated component: nothing to merge into
            cnt = np.bincount(nb, minlength=len(sizes))
            t = int(np.argmax(cnt))
            if target[t] == c:
                continue
            target[c] = target[t]
            merged = True
        if not merged:
            break
        # resolve chains
        for _ in range(len(sizes)):
            nxt = target[target]
            if np.array_equal(nxt, target):
                break
            target = nxt
        ids = relabel(target[ids])
    return ids


def _split_in_two(V: np.ndarray, F: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Boolean mask splitting a chart's faces by the median along their principal axis."""
    c = V[F[faces]].mean(axis=1)
    c = c - c.mean(axis=0)
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    proj = c @ vt[0]
    return proj > np.median(proj)


def make_disk_charts(V: np.ndarray, F: np.ndarray, chart_ids: np.ndarray,
                     max_rounds: int = 12) -> np.ndarray:
    """Refine a face labelling until every chart is an edge-connected topological disk.

    Disconnected charts are split into components; charts that are closed, have handles,
    several boundary loops or non-manifold edges are cut in two at the median of their
    principal axis, repeatedly.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    chart_ids : (m,) int array
    max_rounds : int
        Maximum number of splitting rounds.

    Returns
    -------
    (m,) int64 ndarray of chart ids ``0..c-1``.
    """
    V, F = as_arrays(V, F)
    chart_ids = np.asarray(chart_ids, dtype=np.int64)
    if chart_ids.shape != (len(F),):
        raise ValueError(f"chart_ids: expected shape ({len(F)},), got {chart_ids.shape}")
    adj = face_adjacency(F)
    ids = connected_charts(F, chart_ids, adj)
    for _ in range(max_rounds):
        changed = False
        next_id = int(ids.max()) + 1
        for ch in split_charts(F, ids):
            if len(ch.faces) >= 2 and not chart_is_disk(ch.local_faces):
                mask = _split_in_two(V, F, ch.faces)
                ids[ch.faces[mask]] = next_id
                next_id += 1
                changed = True
        if not changed:
            break
        ids = connected_charts(F, ids, adj)
    return relabel(ids)


def signed_uv_areas(uv: np.ndarray, uv_faces: np.ndarray) -> np.ndarray:
    """Signed UV triangle areas (positive = counter-clockwise).

    Parameters
    ----------
    uv : (k, 2) float array
    uv_faces : (m, 3) int array

    Returns
    -------
    (m,) float64 ndarray
    """
    a, b, c = uv[uv_faces[:, 0]], uv[uv_faces[:, 1]], uv[uv_faces[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def orient_chart_uv(uv: np.ndarray, local_faces: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Mirror a chart's UVs when most of its (weighted) area is clockwise.

    Parameters
    ----------
    uv : (v, 2) float array
    local_faces : (f, 3) int array
    weights : (f,) float array, optional (default: UV area magnitudes)

    Returns
    -------
    (v, 2) float64 ndarray, counter-clockwise for the majority of the area.
    """
    uv = np.asarray(uv, dtype=np.float64)
    s = signed_uv_areas(uv, local_faces)
    w = np.abs(s) if weights is None else np.asarray(weights, dtype=np.float64)
    if np.sum(w * np.sign(s)) < 0:
        uv = uv * np.array([-1.0, 1.0])
    return uv


def parameterize_charts(V: np.ndarray, F: np.ndarray, chart_ids: np.ndarray,
                        flatten: Callable[[np.ndarray, np.ndarray], np.ndarray],
                        rescale: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Flatten every chart separately and gather per-corner UVs.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    chart_ids : (m,) int array
    flatten : callable ``(Vc (v, 3), Fc (f, 3)) -> (v, 2)``
        Flattens one chart (local indices).
    rescale : bool
        Scale each chart's UV so that its UV area equals its 3D area, then orient it
        counter-clockwise (so charts are comparable before packing).

    Returns
    -------
    uv : (k, 2) float64
        One row per (chart, vertex) pair.
    uv_faces : (m, 3) int64
    """
    V, F = as_arrays(V, F)
    uv_parts, uv_faces = [], np.zeros_like(F)
    offset = 0
    for ch in split_charts(F, chart_ids):
        Vc = V[ch.vertices]
        uvc = np.asarray(flatten(Vc, ch.local_faces), dtype=np.float64)
        if uvc.shape != (len(ch.vertices), 2):
            raise ValueError(f"flatten: expected shape ({len(ch.vertices)}, 2), got {uvc.shape}")
        uvc = np.where(np.isfinite(uvc), uvc, 0.0)
        if rescale:
            uvc = orient_chart_uv(uvc, ch.local_faces)
            a3 = face_areas(Vc, ch.local_faces).sum()
            a2 = np.abs(signed_uv_areas(uvc, ch.local_faces)).sum()
            if a2 > 0 and a3 > 0:
                uvc = (uvc - uvc.mean(axis=0)) * np.sqrt(a3 / a2)
        uv_parts.append(uvc)
        uv_faces[ch.faces] = ch.local_faces + offset
        offset += len(uvc)
    return np.concatenate(uv_parts), uv_faces
