"""Validity of a UV layout (flipped and overlapping UV area) and its seams, charts and
packing efficiency (:func:`uv_seams`).

UVs come per vertex (``uv (n, 2)``, ``uv_faces=None``) or per corner as in OBJ files
(``uv (k, 2)`` with ``uv_faces (m, 3)`` indexing into it; seams are then free).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dressmeup.geometry.mesh import as_arrays, as_faces, as_points
from dressmeup.metrics.uv import _corners, _geometry

__all__ = ["UVValidity", "uv_validity", "uv_coverage", "UVSeams", "uv_seams", "seam_edges"]


@dataclass
class UVValidity:
    """Flipped and overlapping UV triangles.

    Attributes
    ----------
    flipped_fraction : float
        Share of faces whose UV orientation is opposite to the majority's (by count; zero-area
        UV triangles are neither).
    overlap_fraction : float
        Share of the covered UV area that is covered more than once, estimated on a grid of
        ``resolution`` samples along the longer side of the UV bounding box.
    n_flipped : int
    n_zero_uv_area : int
    resolution : int
    """

    flipped_fraction: float
    overlap_fraction: float
    n_flipped: int
    n_zero_uv_area: int
    resolution: int

    def as_dict(self) -> dict[str, float]:
        """``{"uv_flipped": ..., "uv_overlap": ...}``."""
        return {"uv_flipped": self.flipped_fraction, "uv_overlap": self.overlap_fraction}


# Sample offsets inside each grid cell: irrational-looking so that samples practically never
# fall on an edge of a UV layout built on a regular grid.
_OFFSET = (0.5 + 0.0917431, 0.5 - 0.1271828)


def uv_coverage(T: np.ndarray, resolution: int = 1024, max_pairs: int = 4_000_000) -> np.ndarray:
    """Coverage counts of UV triangles on a regular grid of sample points.

    Parameters
    ----------
    T : (m, 3, 2) float array
        UV triangles.
    resolution : int
        Samples along the longer side of the UV bounding box.
    max_pairs : int
        Bound on (triangle, sample) candidate pairs processed at once (memory).

    Returns
    -------
    (ny, nx) int64 ndarray
        Number of triangles covering each sample.
    """
    lo = T.reshape(-1, 2).min(axis=0)
    hi = T.reshape(-1, 2).max(axis=0)
    ext = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    if not ext > 0:
        return np.zeros((1, 1), dtype=np.int64)
    cell = ext / resolution
    nx = max(1, int(np.ceil((hi[0] - lo[0]) / cell)))
    ny = max(1, int(np.ceil((hi[1] - lo[1]) / cell)))
    G = (T - lo) / cell  # grid units; sample (i, j) sits at (i + ox, j + oy)
    ox, oy = _OFFSET
    i0 = np.clip(np.ceil(G[:, :, 0].min(axis=1) - ox), 0, nx - 1).astype(np.int64)
    i1 = np.clip(np.floor(G[:, :, 0].max(axis=1) - ox), -1, nx - 1).astype(np.int64)
    j0 = np.clip(np.ceil(G[:, :, 1].min(axis=1) - oy), 0, ny - 1).astype(np.int64)
    j1 = np.clip(np.floor(G[:, :, 1].max(axis=1) - oy), -1, ny - 1).astype(np.int64)
    wi = np.maximum(i1 - i0 + 1, 0)
    wj = np.maximum(j1 - j0 + 1, 0)
    cnt = wi * wj
    area2 = (G[:, 1, 0] - G[:, 0, 0]) * (G[:, 2, 1] - G[:, 0, 1]) - (G[:, 1, 1] - G[:, 0, 1]) * (
        G[:, 2, 0] - G[:, 0, 0]
    )
    keep = (cnt > 0) & (area2 != 0)
    idx = np.nonzero(keep)[0]
    cov = np.zeros(nx * ny, dtype=np.int64)
    csum = np.cumsum(cnt[idx])
    start = 0
    while start < idx.size:
        base = csum[start - 1] if start > 0 else 0
        stop = int(np.searchsorted(csum, base + max_pairs, side="right"))
        stop = max(stop, start + 1)
        tri = idx[start:stop]
        c = cnt[tri]
        rep = np.repeat(np.arange(tri.size), c)
        off = np.arange(rep.size) - np.repeat(np.cumsum(c) - c, c)
        ii = i0[tri][rep] + off % wi[tri][rep]
        jj = j0[tri][rep] + off // wi[tri][rep]
        px = ii + ox
        py = jj + oy
        g = G[tri][rep]
        sgn = np.sign(area2[tri])[rep]
        inside = np.ones(rep.size, dtype=bool)
        for a, b in ((0, 1), (1, 2), (2, 0)):
            e = (g[:, b, 0] - g[:, a, 0]) * (py - g[:, a, 1]) - (g[:, b, 1] - g[:, a, 1]) * (
                px - g[:, a, 0]
            )
            inside &= e * sgn > 0
        cov += np.bincount((jj * nx + ii)[inside], minlength=nx * ny)
        start = stop
    return cov.reshape(ny, nx)


def uv_validity(vertices, faces, uv, uv_faces=None, resolution: int = 1024) -> UVValidity:
    """Flipped-triangle fraction and overlap fraction of a UV layout.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) or (k, 2) float array
    uv_faces : (m, 3) int array, optional
    resolution : int
        Grid samples along the longer side of the UV bounding box for the overlap estimate
        (default 1024; the estimate is exact up to the samples falling in each triangle).

    Returns
    -------
    UVValidity
        ``flipped_fraction`` and ``overlap_fraction``, both in [0, 1], lower is better.
    """
    if int(resolution) != resolution or resolution < 8:
        raise ValueError(f"resolution: expected an integer >= 8, got {resolution}")
    P, T = _corners(vertices, faces, uv, uv_faces)
    _, auv, _, zero_uv, _ = _geometry(P, T, jacobian=False)
    pos = int(np.count_nonzero((auv > 0) & ~zero_uv))
    neg = int(np.count_nonzero((auv < 0) & ~zero_uv))
    n_flipped = min(pos, neg) if pos != neg else neg  # tie: counter-clockwise is the majority
    cov = uv_coverage(np.stack([t.T for t in T], axis=1), int(resolution))
    covered = int(np.count_nonzero(cov >= 1))
    overlap = float(np.count_nonzero(cov >= 2) / covered) if covered else 0.0
    return UVValidity(
        flipped_fraction=n_flipped / auv.shape[0],
        overlap_fraction=overlap,
        n_flipped=n_flipped,
        n_zero_uv_area=int(np.count_nonzero(zero_uv)),
        resolution=int(resolution),
    )


@dataclass
class UVSeams:
    """Seams, charts and packing of a UV atlas, measured on the original mesh's edges.

    Attributes
    ----------
    seam_length : float
        Sum of the 3D lengths of the seam edges divided by ``sqrt(surface area)`` (scale-free;
        0 for a seamless map). An interior edge is a seam when its faces give its two end
        points different UV positions.
    n_seam_edges : int
    n_charts : int
        Connected components of faces across interior edges that are not seams.
    packing_efficiency : float
        Total UV triangle area over the area of the square the atlas is normalised to (its
        bounding box scaled uniformly so that the longer side is 1). In (0, 1] for atlases
        without overlaps; overlapping area counts twice.
    """

    seam_length: float
    n_seam_edges: int
    n_charts: int
    packing_efficiency: float

    def as_dict(self) -> dict[str, float]:
        """``{"seam_length": ..., "charts": ..., "packing": ...}`` (result-table names)."""
        return {"seam_length": self.seam_length, "charts": float(self.n_charts),
                "packing": self.packing_efficiency}


def _edge_agreement(F: np.ndarray, UF: np.ndarray, UV: np.ndarray, tol: float):
    """Half-edges grouped by undirected mesh edge, and whether each agrees with its group's
    first half-edge on the UV positions of both end points.

    Returns
    -------
    face : (h,) int64, the face of each half-edge, sorted by edge
    first : (h,) bool, the first half-edge of its edge
    group : (h,) int64, index of the group's first half-edge
    agree : (h,) bool, same UV positions (within ``tol``) as the group's first half-edge
    count : (h,) int64, half-edges of the edge (1 boundary, 2 interior, > 2 non-manifold)
    a, b : (h,) int64, the edge's end points (a < b)
    """
    m = F.shape[0]
    n = int(F.max()) + 1 if m else 0
    k0, k1 = np.array([0, 1, 2]), np.array([1, 2, 0])
    va, vb = F[:, k0].reshape(-1), F[:, k1].reshape(-1)
    ua, ub = UF[:, k0].reshape(-1), UF[:, k1].reshape(-1)
    swap = va > vb
    va, vb = np.where(swap, vb, va), np.where(swap, va, vb)
    ua, ub = np.where(swap, ub, ua), np.where(swap, ua, ub)
    face = np.repeat(np.arange(m), 3)
    key = va.astype(np.int64) * n + vb
    order = np.argsort(key, kind="stable")
    key, face, va, vb, ua, ub = key[order], face[order], va[order], vb[order], ua[order], ub[order]
    first = np.ones(key.size, dtype=bool)
    first[1:] = key[1:] != key[:-1]
    starts = np.flatnonzero(first)
    group = starts[np.cumsum(first) - 1]
    count = np.diff(np.r_[starts, key.size])[np.cumsum(first) - 1]
    # compare positions, not indices: two UV entries at the same place are not a seam
    da = np.abs(UV[ua] - UV[ua[group]]).max(axis=1)
    db = np.abs(UV[ub] - UV[ub[group]]).max(axis=1)
    agree = (da <= tol) & (db <= tol)
    return face, first, group, agree, count, va, vb


def seam_edges(vertices, faces, uv, uv_faces=None, rtol: float = 1e-6) -> np.ndarray:
    """The seam edges of a UV atlas: interior mesh edges whose faces disagree on the UV
    positions of its end points.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) per-vertex or (k, 2) per-corner float array
    uv_faces : (m, 3) int array, optional (per-corner UVs)
    rtol : float
        UV positions closer than ``rtol`` times the atlas' longer side count as equal.

    Returns
    -------
    (s, 2) int64 ndarray
        Vertex pairs (``a < b``), sorted.
    """
    V, F = as_arrays(vertices, faces, name="mesh")
    UV, UF = _uv_arrays(V, F, uv, uv_faces)
    face, first, group, agree, count, va, vb = _edge_agreement(F, UF, UV, _uv_tol(UV, rtol))
    bad = ~agree & (count >= 2)
    seam_group = np.unique(group[bad])
    return np.stack([va[seam_group], vb[seam_group]], axis=1).astype(np.int64)


def _uv_arrays(V, F, uv, uv_faces):
    UV = as_points(uv, name="uv", dim=2)
    if uv_faces is None:
        if UV.shape[0] != V.shape[0]:
            raise ValueError(f"uv: per-vertex UVs need shape ({V.shape[0]}, 2), got {UV.shape}; "
                             "pass uv_faces for per-corner UVs")
        return UV, F
    UF = as_faces(uv_faces, UV.shape[0], name="uv_faces")
    if UF.shape != F.shape:
        raise ValueError(f"uv_faces: expected shape {F.shape} (one row per face), got {UF.shape}")
    return UV, UF


def _uv_tol(UV: np.ndarray, rtol: float) -> float:
    if UV.shape[0] == 0:
        return 0.0
    ext = float((UV.max(axis=0) - UV.min(axis=0)).max())
    return rtol * ext


def uv_seams(vertices, faces, uv, uv_faces=None, rtol: float = 1e-6) -> UVSeams:
    """Seam length, chart count and packing efficiency of a UV atlas.

    Everything is measured on the original mesh's edges, so a method cannot hide cuts by
    how it indexes its UVs: an interior edge (two or more faces) is a *seam* when its faces
    give its end points different UV positions; *charts* are the connected components of
    faces across the other interior edges.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) per-vertex or (k, 2) per-corner float array
    uv_faces : (m, 3) int array, optional
    rtol : float
        UV positions closer than ``rtol`` times the atlas' longer side count as equal.

    Returns
    -------
    UVSeams
        ``seam_length`` (3D seam length / sqrt(3D area), lower means fewer cuts),
        ``n_charts``, ``packing_efficiency`` (UV area / normalised square, higher is better).
    """
    # heavy: scipy.sparse
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    V, F = as_arrays(vertices, faces, name="mesh")
    UV, UF = _uv_arrays(V, F, uv, uv_faces)
    m = F.shape[0]
    face, first, group, agree, count, va, vb = _edge_agreement(F, UF, UV, _uv_tol(UV, rtol))
    interior = count >= 2
    seam_group = np.unique(group[~agree & interior])
    lengths = np.linalg.norm(V[va[seam_group]] - V[vb[seam_group]], axis=1)
    area3 = float(0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]),
                                       axis=1).sum())
    seam_len = float(lengths.sum() / np.sqrt(area3)) if area3 > 0 else 0.0
    link = interior & agree & ~first
    A = coo_matrix((np.ones(int(link.sum())), (face[link], face[group[link]])), shape=(m, m))
    n_charts = int(connected_components(A, directed=False)[0]) if m else 0
    T = UV[UF]
    auv = 0.5 * np.abs((T[:, 1, 0] - T[:, 0, 0]) * (T[:, 2, 1] - T[:, 0, 1])
                       - (T[:, 1, 1] - T[:, 0, 1]) * (T[:, 2, 0] - T[:, 0, 0]))
    used = T.reshape(-1, 2)
    side = float((used.max(axis=0) - used.min(axis=0)).max()) if used.size else 0.0
    packing = float(auv.sum() / side**2) if side > 0 else 0.0
    return UVSeams(seam_len, int(seam_group.size), n_charts, packing)
