"""The clothed "scan" of a synthetic sample: the posed body merged with its draped garment.

Two kinds (generator parameter ``scan_body``):

- ``"whole"`` (every dataset before it existed): the entire body mesh plus the garment, so
  the naked body is in the scan also where the garment covers it;
- ``"uncovered"``: the body faces under the garment are left out, as a scanner sees a
  clothed person: a body vertex is *covered* when the ray along its outward normal meets the
  garment within ``reach`` metres, and a body face is kept only when none of its vertices is
  covered. Skin facing the inside of a loose skirt or a sleeve is covered too (a scanner
  would not see it either); skin the garment does not cover stays.

The ray test is exact float64 arithmetic in numpy (Moeller-Trumbore, element-wise, no
BVH), so the selection does not depend on the CPU's vector extensions or the thread count.
"""

from __future__ import annotations

import numpy as np

from dressmeup.geometry.mesh import vertex_normals

SCAN_BODY = ("whole", "uncovered")
#: how far along the skin normal a garment still covers it (metres): a loose dress stands
#: up to ~20 cm off the legs when sitting
COVER_REACH = 0.30


def covered_vertices(body_V: np.ndarray, body_F: np.ndarray, garment_V: np.ndarray,
                     garment_F: np.ndarray, reach: float = COVER_REACH,
                     chunk: int = 128) -> np.ndarray:
    """Body vertices whose outward normal ray meets the garment within ``reach``.

    Parameters
    ----------
    body_V : (n, 3) float64 posed body vertices (metres); body_F : (m, 3) int faces.
    garment_V : (k, 3) float64 garment vertices; garment_F : (l, 3) int faces.
    reach : ray length in metres.
    chunk : body vertices tested at once (memory ~ chunk * l * 8 bytes per array).

    Returns
    -------
    (n,) bool array.
    """

    V = np.asarray(body_V, np.float64)
    N = vertex_normals(V, body_F)
    tri = np.asarray(garment_V, np.float64)[np.asarray(garment_F, np.int64)]
    a = tri[:, 0]
    e1, e2 = tri[:, 1] - a, tri[:, 2] - a
    lo, hi = tri.min(1), tri.max(1)
    out = np.zeros(len(V), bool)
    # only the vertices whose ray segment's box meets the garment's box can be covered
    seg_lo = np.minimum(V, V + reach * N)
    seg_hi = np.maximum(V, V + reach * N)
    cand = np.flatnonzero(np.all(seg_hi >= lo.min(0), axis=1) & np.all(seg_lo <= hi.max(0), axis=1))
    for s in range(0, len(cand), chunk):
        idx = cand[s:s + chunk]
        o, d = V[idx][:, None, :], N[idx][:, None, :]  # (c, 1, 3)
        near = np.all(seg_hi[idx][:, None, :] >= lo[None], axis=2) & \
            np.all(seg_lo[idx][:, None, :] <= hi[None], axis=2)  # (c, l) boxes overlap
        p = _cross3(d, e2[None])
        det = _dot3(e1[None], p)
        ok = near & (np.abs(det) > 1e-18)
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        tv = o - a[None]
        u = _dot3(tv, p) * inv
        q = _cross3(tv, e1[None])
        v = _dot3(d, q) * inv
        t = _dot3(e2[None], q) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t <= reach)
        out[idx] = hit.any(1)
    return out


def _cross3(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Cross product over the last axis, element-wise (broadcasting)."""
    return np.stack([x[..., 1] * y[..., 2] - x[..., 2] * y[..., 1],
                     x[..., 2] * y[..., 0] - x[..., 0] * y[..., 2],
                     x[..., 0] * y[..., 1] - x[..., 1] * y[..., 0]], axis=-1)


def _dot3(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Dot product over the last axis in a fixed order (no BLAS, no pairwise sum)."""
    return x[..., 0] * y[..., 0] + x[..., 1] * y[..., 1] + x[..., 2] * y[..., 2]


def clothed_scan(body_V: np.ndarray, body_F: np.ndarray, garment_V: np.ndarray,
                 garment_F: np.ndarray, scan_body: str = "whole") -> tuple[np.ndarray, np.ndarray]:
    """Scan mesh of a body wearing a garment: ``(vertices (p, 3), faces (q, 3))``.

    ``scan_body="whole"``: body then garment, every face; ``"uncovered"``: the body faces
    with a covered vertex (:func:`covered_vertices`) left out and the body vertices no face
    uses dropped (remaining body vertices keep their order), then the garment.
    """
    if scan_body not in SCAN_BODY:
        raise ValueError(f"scan_body: expected one of {SCAN_BODY}, got {scan_body!r}")
    BV, BF = np.asarray(body_V), np.asarray(body_F, np.int64)
    GV, GF = np.asarray(garment_V), np.asarray(garment_F, np.int64)
    if scan_body == "uncovered":
        cov = covered_vertices(BV, BF, GV, GF)
        BF = BF[~cov[BF].any(1)]
        used = np.zeros(len(BV), bool)
        used[BF.ravel()] = True
        remap = np.cumsum(used) - 1
        BV, BF = BV[used], remap[BF]
    return np.vstack([BV, GV]), np.vstack([BF, GF + len(BV)])
