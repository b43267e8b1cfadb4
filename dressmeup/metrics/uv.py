"""UV distortion and validity: QCE, ASE (Boundary First Flattening conventions), flipped
and overlapping UV area; seams, charts and packing efficiency (:func:`uv_seams`).

UVs come per vertex (``uv (n, 2)``, ``uv_faces=None``) or per corner as in OBJ files
(``uv (k, 2)`` with ``uv_faces (m, 3)`` indexing into it; seams are then free).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dressmeup.geometry.mesh import as_arrays, as_faces, as_points

__all__ = [
    "QCEResult",
    "ASEResult",
    "UVValidity",
    "qce",
    "qce_details",
    "ase",
    "ase_details",
    "uv_validity",
    "uv_jacobian_singular_values",
    "UVSeams",
    "uv_seams",
    "seam_edges",
]

#: Relative tolerance under which a triangle counts as having zero area (sine of its
#: smallest-vertex angle, scale-free).
ZERO_AREA_RTOL = 1e-12


def _corners(vertices, faces, uv, uv_faces):
    """Validated corner coordinates, component-major for speed: ``P`` is a list of three
    (3, m) arrays (the 3D corners), ``T`` a list of three (2, m) arrays (the UV corners)."""
    V, F = as_arrays(vertices, faces, name="mesh")
    UV = as_points(uv, name="uv", dim=2)
    if uv_faces is None:
        if UV.shape[0] != V.shape[0]:
            raise ValueError(
                f"uv: per-vertex UVs need shape ({V.shape[0]}, 2), got {UV.shape}; "
                "pass uv_faces for per-corner UVs"
            )
        UF = F
    else:
        UF = as_faces(uv_faces, UV.shape[0], name="uv_faces")
        if UF.shape != F.shape:
            raise ValueError(
                f"uv_faces: expected shape {F.shape} (one row per face), got {UF.shape}"
            )
    Vt = np.ascontiguousarray(V.T)
    Ut = np.ascontiguousarray(UV.T)
    P = [np.take(Vt, F[:, k], axis=1) for k in range(3)]
    T = [np.take(Ut, UF[:, k], axis=1) for k in range(3)]
    return P, T


def _geometry(P, T, jacobian: bool = True):
    """Per-face quantities: 3D double area, signed UV double area, degenerate masks, and the
    2x2 Jacobian entries (A, B, C, D) of the map from the 3D triangle's own orthonormal
    frame to UV (``None`` when ``jacobian`` is false)."""
    e1 = P[1] - P[0]
    e2 = P[2] - P[0]
    l1sq = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]
    l2sq = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]
    cx = e1[1] * e2[2] - e1[2] * e2[1]
    cy = e1[2] * e2[0] - e1[0] * e2[2]
    cz = e1[0] * e2[1] - e1[1] * e2[0]
    a3 = np.sqrt(cx * cx + cy * cy + cz * cz)  # 2 * area
    u1 = T[1] - T[0]
    u2 = T[2] - T[0]
    auv = u1[0] * u2[1] - u1[1] * u2[0]  # signed 2 * UV area
    deg3 = ~(a3 > ZERO_AREA_RTOL * np.sqrt(l1sq * l2sq))
    zero_uv = ~(
        np.abs(auv)
        > ZERO_AREA_RTOL
        * np.sqrt((u1[0] * u1[0] + u1[1] * u1[1]) * (u2[0] * u2[0] + u2[1] * u2[1]))
    )
    if not jacobian:
        return a3, auv, deg3, zero_uv, None
    with np.errstate(divide="ignore", invalid="ignore"):
        # local frame: x1 = (l1, 0), x2 = (a, h) with a = e1.e2 / l1, h = 2A / l1
        l1 = np.sqrt(l1sq)
        a = (e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / l1
        h = a3 / l1
        A = u1[0] / l1
        C = u1[1] / l1
        B = (u2[0] - a * A) / h
        D = (u2[1] - a * C) / h
    return a3, auv, deg3, zero_uv, (A, B, C, D)


def _sigma_max(A, B, C, D):
    """Largest singular value of [[A, B], [C, D]] in closed form (Q + R)."""
    e, f, g, h = A + D, A - D, C + B, C - B
    return 0.5 * (np.sqrt(e * e + h * h) + np.sqrt(f * f + g * g))


def uv_jacobian_singular_values(vertices, faces, uv, uv_faces=None) -> np.ndarray:
    """Singular values of each face's 3D-to-UV Jacobian.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) or (k, 2) float array
    uv_faces : (m, 3) int array, optional

    Returns
    -------
    (m, 2) float64 ndarray
        ``[sigma_max, sigma_min]`` per face (NaN for degenerate 3D triangles).
    """
    P, T = _corners(vertices, faces, uv, uv_faces)
    a3, auv, deg3, _, (A, B, C, D) = _geometry(P, T)
    smax = _sigma_max(A, B, C, D)
    with np.errstate(divide="ignore", invalid="ignore"):
        smin = np.abs(auv / a3) / smax
    smin = np.where(smax == 0, 0.0, smin)
    out = np.stack([smax, smin], axis=1)
    out[deg3] = np.nan
    return out


@dataclass
class QCEResult:
    """Quasi-conformal error and the per-face values behind it.

    Attributes
    ----------
    mean : float
        3D-area-weighted mean QCE over faces with non-zero 3D and UV area (1 is ideal).
    max : float
        Largest finite per-face QCE.
    per_face : (m,) float64 ndarray
        ``sigma_max / sigma_min``; ``inf`` for zero UV area, NaN for zero 3D area.
    n_zero_uv_area : int
        Faces whose UV triangle has zero area (infinite QCE, excluded from ``mean``/``max``).
    zero_uv_area_fraction : float
        Their share of the 3D surface area.
    n_degenerate : int
        Faces with zero 3D area (weight zero, excluded).
    """

    mean: float
    max: float
    per_face: np.ndarray = field(repr=False)
    n_zero_uv_area: int = 0
    zero_uv_area_fraction: float = 0.0
    n_degenerate: int = 0


def qce_details(vertices, faces, uv, uv_faces=None) -> QCEResult:
    """QCE with per-face values; see :func:`qce`."""
    P, T = _corners(vertices, faces, uv, uv_faces)
    a3, auv, deg3, zero_uv, (A, B, C, D) = _geometry(P, T)
    # closed-form 2x2 SVD: sigma_max = Q + R; sigma_min = |det| / sigma_max with det = A_uv / A_3d
    smax = _sigma_max(A, B, C, D)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        per = smax * smax * a3 / np.abs(auv)
    per[zero_uv] = np.inf
    per[deg3] = np.nan
    valid = ~deg3 & ~zero_uv
    w = a3[valid]
    total = a3[~deg3].sum()
    if not np.any(valid) or not w.sum() > 0:
        mean = mx = float("inf")
    else:
        mean = float(np.dot(w, per[valid]) / w.sum())
        mx = float(per[valid].max())
    zfrac = float(a3[zero_uv & ~deg3].sum() / total) if total > 0 else 0.0
    return QCEResult(
        mean, mx, per, int(np.count_nonzero(zero_uv & ~deg3)), zfrac, int(np.count_nonzero(deg3))
    )


def qce(vertices, faces, uv, uv_faces=None) -> float:
    """QCE: quasi-conformal error, area-weighted mean of sigma_max / sigma_min.

    Per triangle, the ratio of the singular values of the Jacobian of the affine map from the
    3D triangle (in its own orthonormal frame) to its UV triangle; 1 is ideal (conformal).
    The aggregate is the mean weighted by 3D face area (Boundary First Flattening). Triangles
    with zero UV area have infinite QCE: they are excluded from the mean and counted
    separately (:func:`qce_details`); zero-3D-area triangles have zero weight.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) float array (per vertex) or (k, 2) float array (per corner, with ``uv_faces``)
    uv_faces : (m, 3) int array, optional
        Per-corner UV indices into ``uv`` (OBJ ``f v/vt``).

    Returns
    -------
    float
        >= 1, lower is better (``inf`` when every triangle has zero UV area).
    """
    return qce_details(vertices, faces, uv, uv_faces).mean


@dataclass
class ASEResult:
    """Area scaling error and the per-face values behind it.

    Attributes
    ----------
    abs_mean : float
        Headline: 3D-area-weighted mean of ``|log(A_uv * s / A_3d)|`` (0 is ideal).
    mean : float
        3D-area-weighted signed mean (negative: UV shrinks on average where weighted).
    min, max : float
        Extreme finite per-face log ratios.
    scale : float
        ``s = total 3D area / total UV area``, applied to UV areas before the ratio.
    per_face : (m,) float64 ndarray
        Log ratio per face (``-inf`` for zero UV area, NaN for zero 3D area).
    n_zero_uv_area : int
        Faces with zero UV area, excluded from the aggregates.
    """

    abs_mean: float
    mean: float
    min: float
    max: float
    scale: float
    per_face: np.ndarray = field(repr=False)
    n_zero_uv_area: int = 0


def ase_details(vertices, faces, uv, uv_faces=None) -> ASEResult:
    """ASE with per-face values; see :func:`ase`."""
    P, T = _corners(vertices, faces, uv, uv_faces)
    a3, auv, deg3, zero_uv, _ = _geometry(P, T, jacobian=False)
    auv = np.abs(auv)
    tot_uv = auv.sum()
    tot_3d = a3.sum()
    if not tot_uv > 0:
        raise ValueError("uv: total UV area is zero, ASE is undefined")
    if not tot_3d > 0:
        raise ValueError("vertices: total 3D area is zero, ASE is undefined")
    s = tot_3d / tot_uv
    with np.errstate(divide="ignore", invalid="ignore"):
        per = np.log(auv * s / a3)
    per[zero_uv] = -np.inf
    per[deg3] = np.nan
    valid = ~deg3 & ~zero_uv
    w = a3[valid]
    lr = per[valid]
    return ASEResult(
        abs_mean=float(np.dot(w, np.abs(lr)) / w.sum()),
        mean=float(np.dot(w, lr) / w.sum()),
        min=float(lr.min()),
        max=float(lr.max()),
        scale=float(s),
        per_face=per,
        n_zero_uv_area=int(np.count_nonzero(zero_uv & ~deg3)),
    )


def ase(vertices, faces, uv, uv_faces=None) -> float:
    """ASE: area scaling error, 3D-area-weighted mean of |log(A_uv / A_3d)|.

    The UV is first scaled so that the total UV area equals the total 3D area (the figure is
    scale-free); per triangle the log ratio is 0 when area is preserved, negative when the UV
    shrinks it. The headline is the area-weighted mean of the absolute log ratio; the signed
    mean, min and max are in :func:`ase_details`. Triangles with zero UV area are excluded
    and counted separately.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) or (k, 2) float array
    uv_faces : (m, 3) int array, optional

    Returns
    -------
    float
        >= 0, lower is better.
    """
    return ase_details(vertices, faces, uv, uv_faces).abs_mean


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
    # heavy: scipy (~0.5 s to import)
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
