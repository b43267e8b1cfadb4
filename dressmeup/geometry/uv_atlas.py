"""UV atlas helpers: cut a mesh into charts, flatten each chart, pack the charts with xatlas.

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
from dressmeup.geometry.topology import face_adjacency  # re-exported (its home is topology)

__all__ = [
    "Chart",
    "face_adjacency",
    "split_charts",
    "chart_is_disk",
    "relabel",
    "connected_charts",
    "merge_small_charts",
    "make_disk_charts",
    "parameterize_charts",
    "orient_chart_uv",
    "pack_charts",
    "signed_uv_areas",
    "orient_charts",
    "uv_components",
    "shelf_pack",
    "xatlas_atlas",
    "XatlasAtlas",
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


def pack_charts(uv: np.ndarray, uv_faces: np.ndarray, padding: int = 2, resolution: int = 1024,
                rotate: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Pack UV charts into the unit square with xatlas (translation, rotation, uniform scale).

    Charts are the connected components of the UV mesh (corners sharing a UV index).

    Parameters
    ----------
    uv : (k, 2) float array
    uv_faces : (m, 3) int array
    padding : int
        Texels between charts.
    resolution : int
        Atlas resolution used for packing.
    rotate : bool
        Let xatlas rotate charts for a tighter packing. Off by default: xatlas' chart
        rotation can also transpose a chart (a mirror image), which would flip its triangles.

    Returns
    -------
    uv : (k, 2) float64, inside [0, 1]^2 (square texels)
    uv_faces : (m, 3) int64, the input's indexing (each chart moved by a global scale and
        its own translation)
    """
    # heavy: xatlas (~0.2 s to import)
    import xatlas

    uv = np.asarray(uv, dtype=np.float64)
    uv_faces = np.asarray(uv_faces, dtype=np.int64)
    lo = uv.min(axis=0)
    span = float(np.max(uv.max(axis=0) - lo)) or 1.0
    uvn = ((uv - lo) / span).astype(np.float32)
    atlas = xatlas.Atlas()
    atlas.add_uv_mesh(uvn, uv_faces.astype(np.uint32))
    po = xatlas.PackOptions()
    po.padding = int(padding)
    po.resolution = int(resolution)
    po.rotate_charts = bool(rotate)
    po.rotate_charts_to_axis = bool(rotate)
    po.bilinear = True
    atlas.generate(pack_options=po)
    vmapping, indices, uvs = atlas[0]
    packed = _square_texels(np.asarray(uvs, dtype=np.float64), atlas)
    # Use xatlas only to place the charts: it drops faces that are degenerate in float32
    # (their corners come back at the origin) and may split a chart there. Each chart keeps
    # its own UVs, moved by one global scale and its own translation, in the input indexing.
    pre = (uv - lo) / span
    vmap = np.asarray(vmapping, dtype=np.int64)
    comp = uv_components(uv_faces, len(uv))
    row_comp = np.zeros(len(uv), dtype=np.int64)
    row_comp[uv_faces.reshape(-1)] = np.repeat(comp, 3)
    c_of_new = row_comp[vmap]
    # the global scale: median ratio of packed to input distances between vertices of the
    # same chart (robust to the few misplaced corners)
    rng = np.random.default_rng(0)
    a = rng.integers(0, len(vmap), size=min(200000, 4 * len(vmap)))
    same = np.flatnonzero(c_of_new[a] == c_of_new[(a + 1) % len(vmap)])
    i, j = a[same], (a[same] + 1) % len(vmap)
    if len(i) < 10:  # charts of one vertex run: compare random pairs inside charts instead
        order0 = np.argsort(c_of_new, kind="stable")
        i, j = order0[:-1], order0[1:]
        keep = c_of_new[i] == c_of_new[j]
        i, j = i[keep], j[keep]
    dn = np.linalg.norm(packed[i] - packed[j], axis=1)
    do = np.linalg.norm(pre[vmap[i]] - pre[vmap[j]], axis=1)
    ok = do > 1e-9
    scale = float(np.median(dn[ok] / do[ok])) if np.any(ok) else 1.0
    off = packed - scale * pre[vmap]
    n_c = int(comp.max()) + 1
    t = np.zeros((n_c, 2))
    order = np.argsort(c_of_new, kind="stable")
    bounds = np.searchsorted(c_of_new[order], np.arange(n_c + 1))
    for c in range(n_c):
        sel = order[bounds[c]:bounds[c + 1]]
        if len(sel):
            t[c] = np.median(off[sel], axis=0)
    out = scale * pre + t[row_comp]
    # xatlas split some charts (at bow-tie vertices or float32-degenerate faces) or moved
    # them otherwise: fall back to shelf packing of the charts' bounding boxes, which cannot
    # overlap
    fit = np.abs(out[vmap] - packed).max(axis=1) < 1e-4
    if int(atlas.chart_count) != n_c or not np.all(np.bincount(c_of_new[~fit], minlength=n_c) == 0):
        log.info("xatlas changed the charts (%d -> %d); using shelf packing", n_c, int(atlas.chart_count))
        out = shelf_pack(pre, row_comp, comp, padding / float(resolution))
    return out, uv_faces.copy()


def _square_texels(uv: np.ndarray, atlas) -> np.ndarray:
    """Undo xatlas' anisotropy: it normalises u by the atlas width and v by its height, so a
    non-square atlas stretches its charts; rescale to square texels inside [0, 1]^2."""
    w, h = float(atlas.width), float(atlas.height)
    if w > 0 and h > 0:
        uv = uv * (np.array([w, h]) / max(w, h))
    return uv


@dataclass
class XatlasAtlas:
    """What :func:`xatlas_atlas` returns.

    Attributes
    ----------
    uv : (k, 2) float64, per-corner UVs in [0, 1]^2.
    uv_faces : (m, 3) int64 into ``uv``, same face order as the input.
    vertex_map : (k,) int64, input vertex of each UV row.
    n_charts : int, xatlas' chart count.
    width, height : int, atlas size in texels.
    """

    uv: np.ndarray
    uv_faces: np.ndarray
    vertex_map: np.ndarray
    n_charts: int
    width: int
    height: int


def xatlas_atlas(V: np.ndarray, F: np.ndarray, *, resolution: int | None = None,
                 padding: int | None = None, bilinear: bool | None = None,
                 rotate_charts: bool | None = None, max_iterations: int | None = None,
                 square_texels: bool = True) -> XatlasAtlas:
    """Segment, flatten and pack a mesh with xatlas: the one entry point to the library for
    whole meshes (:func:`pack_charts` packs given charts).

    Parameters
    ----------
    V : (n, 3) float array (passed to xatlas as float32), F : (m, 3) int array.
    resolution, padding, bilinear, rotate_charts, max_iterations : xatlas options (texels;
        ``None`` keeps xatlas' default: resolution 0 = xatlas picks, padding 0, bilinear on,
        chart rotation on, 1 chart-growing iteration).
    square_texels : undo xatlas' normalisation of u by the atlas width and v by its height
        (on a non-square atlas the raw UVs are stretched). ``False`` returns xatlas' raw UVs:
        only the synthetic garment generator uses it, because its released datasets were made
        that way (changing it would change every garment's UVs and the dataset hashes).

    Returns
    -------
    XatlasAtlas
    """
    # heavy: xatlas (~0.2 s to import)
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(np.ascontiguousarray(V, dtype=np.float32), np.ascontiguousarray(F, dtype=np.uint32))
    co = xatlas.ChartOptions()
    if max_iterations is not None:
        co.max_iterations = int(max_iterations)
    po = xatlas.PackOptions()
    if resolution is not None:
        po.resolution = int(resolution)
    if padding is not None:
        po.padding = int(padding)
    if bilinear is not None:
        po.bilinear = bool(bilinear)
    if rotate_charts is not None:
        po.rotate_charts = bool(rotate_charts)
    atlas.generate(chart_options=co, pack_options=po)
    vmapping, indices, uvs = atlas[0]
    uv = np.asarray(uvs, dtype=np.float64)
    if square_texels:
        uv = _square_texels(uv, atlas)
    return XatlasAtlas(uv, np.asarray(indices, dtype=np.int64), np.asarray(vmapping, dtype=np.int64),
                       int(atlas.chart_count), int(atlas.width), int(atlas.height))


def shelf_pack(uv: np.ndarray, row_comp: np.ndarray, comp: np.ndarray, padding: float = 0.002) -> np.ndarray:
    """Pack charts by their bounding boxes on shelves (tallest first); no overlaps by construction.

    Parameters
    ----------
    uv : (k, 2) float array
    row_comp : (k,) int array, chart of each UV row
    comp : (m,) int array, chart of each face (defines the number of charts)
    padding : float
        Gap between boxes, relative to the final unit square.

    Returns
    -------
    (k, 2) float64 ndarray inside [0, 1]^2
    """
    n_c = int(comp.max()) + 1
    lo = np.full((n_c, 2), np.inf)
    hi = np.full((n_c, 2), -np.inf)
    np.minimum.at(lo, row_comp, uv)
    np.maximum.at(hi, row_comp, uv)
    size = hi - lo
    pad = padding * float(np.sqrt(np.sum(np.prod(size, axis=1))) or 1.0)
    size = size + pad
    width = max(float(np.sqrt(np.sum(np.prod(size, axis=1))) * 1.15), float(size[:, 0].max()))
    order = np.argsort(-size[:, 1], kind="stable")
    pos = np.zeros((n_c, 2))
    x = y = shelf_h = 0.0
    for c in order:
        if x + size[c, 0] > width and x > 0:
            x, y = 0.0, y + shelf_h
            shelf_h = 0.0
        pos[c] = (x, y)
        x += size[c, 0]
        shelf_h = max(shelf_h, size[c, 1])
    out = uv - lo[row_comp] + pos[row_comp] + 0.5 * pad
    extent = float(max(width, y + shelf_h)) or 1.0
    return out / extent


def uv_components(uv_faces: np.ndarray, k: int) -> np.ndarray:
    """Connected components of a UV mesh (faces sharing a UV index), one id per face.

    Parameters
    ----------
    uv_faces : (m, 3) int array
    k : int
        Number of UV rows.

    Returns
    -------
    (m,) int64 ndarray of ids ``0..c-1``.
    """

    m = len(uv_faces)
    rows = np.repeat(np.arange(m), 3)
    g = sp.coo_matrix((np.ones(3 * m), (rows, np.asarray(uv_faces).reshape(-1))), shape=(m, k)).tocsr()
    big = sp.bmat([[None, g], [g.T, None]])
    _, comp = connected_components(big, directed=False)
    return relabel(comp[:m])


def orient_charts(uv: np.ndarray, uv_faces: np.ndarray) -> np.ndarray:
    """Mirror every UV chart whose area is mostly clockwise, about its own bounding box.

    Mirroring inside the chart's bounding box keeps a packed atlas free of new overlaps and
    gives every chart the same (counter-clockwise) orientation.

    Parameters
    ----------
    uv : (k, 2) float array
    uv_faces : (m, 3) int array

    Returns
    -------
    (k, 2) float64 ndarray
    """
    uv = np.array(uv, dtype=np.float64)
    comp = uv_components(uv_faces, len(uv))
    s = signed_uv_areas(uv, uv_faces)
    tot = np.bincount(comp, weights=s)
    bad = np.flatnonzero(tot < 0)
    if bad.size:
        face_bad = np.isin(comp, bad)
        rows = np.unique(uv_faces[face_bad].reshape(-1))
        row_comp = np.empty(len(uv), dtype=np.int64)
        row_comp[uv_faces.reshape(-1)] = np.repeat(comp, 3)
        rc = row_comp[rows]
        lo = np.full(len(tot), np.inf)
        hi = np.full(len(tot), -np.inf)
        np.minimum.at(lo, rc, uv[rows, 0])
        np.maximum.at(hi, rc, uv[rows, 0])
        uv[rows, 0] = lo[rc] + hi[rc] - uv[rows, 0]
    return uv
