"""Packing UV charts into the unit square, and the one call into xatlas for whole meshes
(charts of :mod:`dressmeup.geometry.uv_atlas`)."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import xatlas
from scipy.sparse.csgraph import connected_components

from dressmeup.geometry.uv_atlas import relabel, signed_uv_areas

__all__ = ["pack_charts", "orient_charts", "uv_components", "shelf_pack", "xatlas_atlas",
           "XatlasAtlas"]

log = logging.getLogger(__name__)


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
    scale = _packed_scale(packed, pre[vmap], c_of_new)
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


def _packed_scale(packed: np.ndarray, before: np.ndarray, chart: np.ndarray) -> float:
    """The one scale xatlas applied: the median ratio of packed to input distances between
    vertices of the same chart (robust to the few misplaced corners).

    ``packed``, ``before`` : (r, 2) float64, each packed vertex after and before packing;
    ``chart`` : (r,) int64, its chart. Pairs are drawn seeded (consecutive rows, or
    neighbours in chart order when charts are runs of one vertex).
    """
    rng = np.random.default_rng(0)
    a = rng.integers(0, len(chart), size=min(200000, 4 * len(chart)))
    same = np.flatnonzero(chart[a] == chart[(a + 1) % len(chart)])
    i, j = a[same], (a[same] + 1) % len(chart)
    if len(i) < 10:  # charts of one vertex run: compare random pairs inside charts instead
        order0 = np.argsort(chart, kind="stable")
        i, j = order0[:-1], order0[1:]
        keep = chart[i] == chart[j]
        i, j = i[keep], j[keep]
    dn = np.linalg.norm(packed[i] - packed[j], axis=1)
    do = np.linalg.norm(before[i] - before[j], axis=1)
    ok = do > 1e-9
    return float(np.median(dn[ok] / do[ok])) if np.any(ok) else 1.0


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
