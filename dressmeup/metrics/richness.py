"""Richness score of a per-vertex embedding against geodesic distances (thesis eq.
4.15-4.17): does the embedding keep each vertex's geodesic nearest and farthest neighbours
in the same rank order?"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dressmeup.geometry.mesh import as_points

__all__ = ["RichnessResult", "richness", "richness_details"]


@dataclass
class RichnessResult:
    """Richness score and its per-vertex parts.

    Attributes
    ----------
    score : float
        Mean of ``per_vertex`` in [0, 1]; lower is better.
    per_vertex : (n,) float64 ndarray
        ``(near + far) / 2`` per vertex.
    near, far : (n,) float64 ndarray
        R_near_i and R_far_i.
    k : int
    """

    score: float
    per_vertex: np.ndarray = field(repr=False)
    near: np.ndarray = field(repr=False)
    far: np.ndarray = field(repr=False)
    k: int = 10


def _sorted_extreme(X: np.ndarray, m: int, largest: bool) -> np.ndarray:
    """Indices of the ``m`` smallest (or largest) entries of each row, in ascending order of
    (value, index) -- i.e. exactly the positions a stable ascending argsort puts there.

    Rows whose boundary value is tied with entries outside the selection fall back to a
    full stable argsort.
    """
    B, n = X.shape
    if largest:
        part = np.argpartition(X, n - m, axis=1)[:, n - m :]
    else:
        part = np.argpartition(X, m - 1, axis=1)[:, :m]
    vals = np.take_along_axis(X, part, axis=1)
    order = np.lexsort((part, vals), axis=1)
    part = np.take_along_axis(part, order, axis=1)
    vals = np.take_along_axis(vals, order, axis=1)
    if largest:
        t = vals[:, :1]
        ambiguous = np.count_nonzero(X >= t, axis=1) > m
    else:
        t = vals[:, -1:]
        ambiguous = np.count_nonzero(X <= t, axis=1) > m
    if np.any(ambiguous):
        rows = np.nonzero(ambiguous)[0]
        full = np.argsort(X[rows], axis=1, kind="stable")
        part[rows] = full[:, n - m :] if largest else full[:, :m]
    return part


#: Embeddings wider than this use BLAS Gram products with an exact re-check (see
#: :func:`_emb_extremes`); narrower ones use exact distances throughout.
GRAM_MIN_DIM = 8


def _exact_dist(E: np.ndarray, i: int, idx: np.ndarray) -> np.ndarray:
    diff = E[idx] - E[i]
    return np.sqrt(np.einsum("ij,ij->i", diff, diff))


def _emb_extremes(
    E: np.ndarray, sq: np.ndarray, s: int, e: int, k: int
) -> tuple[np.ndarray, np.ndarray]:
    """For rows ``s:e``: indices of the 2k nearest (self first) and the 2k - 1 farthest
    vertices in the embedding, each in ascending (distance, index) order.

    Narrow embeddings: exact distances (scipy ``cdist``) and :func:`_sorted_extreme`.
    Wide embeddings: squared distances from a BLAS Gram product locate the candidates, with
    a margin larger than their rounding error; the candidates' exact distances then decide,
    so the result equals the exact stable ranking.
    """
    n, d = E.shape
    r = np.arange(e - s)
    if d <= GRAM_MIN_DIM:
        # heavy: scipy.spatial
        from scipy.spatial.distance import cdist

        Eb = cdist(E[s:e], E, metric="euclidean")
        Eb[r, np.arange(s, e)] = -np.inf
        return _sorted_extreme(Eb, 2 * k, largest=False), _sorted_extreme(
            Eb, 2 * k - 1, largest=True
        )
    D2 = sq[s:e, None] + sq[None, :] - 2.0 * (E[s:e] @ E.T)
    # rounding error of a length-d dot product and the sums: <= (d + 4) eps (|x|^2 + |y|^2)
    margin = 4.0 * (d + 4) * np.finfo(np.float64).eps * (sq[s:e] + sq.max())
    D2[r, np.arange(s, e)] = -np.inf
    lo = np.partition(D2, 2 * k - 1, axis=1)[:, 2 * k - 1]
    hi = np.partition(D2, n - (2 * k - 1), axis=1)[:, n - (2 * k - 1)]
    small = np.empty((e - s, 2 * k), dtype=np.int64)
    large = np.empty((e - s, 2 * k - 1), dtype=np.int64)
    for row in range(e - s):
        i = s + row
        for out, cand, first in (
            (small, np.nonzero(D2[row] <= lo[row] + 2 * margin[row])[0], True),
            (large, np.nonzero(D2[row] >= hi[row] - 2 * margin[row])[0], False),
        ):
            dist = _exact_dist(E, i, cand)
            dist[cand == i] = -np.inf
            order = np.lexsort((cand, dist))
            m = out.shape[1]
            out[row] = cand[order[:m]] if first else cand[order[-m:]]
    return small, large


def richness_details(
    geodesic: np.ndarray, embedding: np.ndarray, k: int = 10, batch: int = 256
) -> RichnessResult:
    """Richness with per-vertex parts; see :func:`richness`."""
    E = as_points(embedding, name="embedding", dim=None)
    n = E.shape[0]
    G = np.asarray(geodesic)
    if G.ndim != 2 or G.shape != (n, n):
        raise ValueError(f"geodesic: expected shape ({n}, {n}) to match embedding, got {G.shape}")
    if not np.issubdtype(G.dtype, np.number):
        raise ValueError(f"geodesic: expected a numeric matrix, got dtype {G.dtype}")
    if int(k) != k or not 1 <= k or 2 * k + 1 > n:
        raise ValueError(f"k: expected an integer with 1 <= k and 2k + 1 <= n = {n}, got {k}")
    k = int(k)
    near = np.empty(n)
    far = np.empty(n)
    rank_near_geo = np.arange(1, k + 1)  # ranks of the k geodesically nearest
    rank_far_geo = np.arange(n - k, n)  # ranks of the k geodesically farthest (ascending)
    rank_small_emb = np.arange(0, 2 * k)  # embedding ranks of the 2k smallest (self = 0)
    rank_large_emb = np.arange(n - 2 * k + 1, n)  # embedding ranks of the 2k - 1 largest
    sq = np.einsum("ij,ij->i", E, E)
    for s in range(0, n, batch):
        e = min(n, s + batch)
        r = np.arange(e - s)
        Gb = np.array(G[s:e], dtype=np.float64)
        if np.isnan(Gb).any():
            raise ValueError("geodesic: contains NaN")
        Gb[r, np.arange(s, e)] = -np.inf  # self ranks 0, before any tie at distance 0
        g_near = _sorted_extreme(Gb, k + 1, largest=False)[:, 1:]
        g_far = _sorted_extreme(Gb, k, largest=True)
        e_small, e_large = _emb_extremes(E, sq, s, e, k)
        # near: embedding rank is known exactly when < 2k, otherwise the difference is >= k
        match = g_near[:, :, None] == e_small[:, None, :]
        found = match.any(axis=2)
        re = rank_small_emb[match.argmax(axis=2)]
        diff = np.where(found, np.minimum(np.abs(re - rank_near_geo), k), k)
        near[s:e] = diff.sum(axis=1) / (k * k)
        # far: embedding rank is known exactly when > n - 2k, otherwise the difference is >= k
        match = g_far[:, :, None] == e_large[:, None, :]
        found = match.any(axis=2)
        re = rank_large_emb[match.argmax(axis=2)]
        diff = np.where(found, np.minimum(np.abs(re - rank_far_geo), k), k)
        far[s:e] = diff.sum(axis=1) / (k * k)
    per = 0.5 * (near + far)
    return RichnessResult(float(per.mean()), per, near, far, k)


def richness(geodesic: np.ndarray, embedding: np.ndarray, k: int = 10) -> float:
    """Richness score of an embedding (thesis eq. 4.15-4.17; docs/spec.md section 1).

    For vertex i, all other vertices are ranked by geodesic distance and by Euclidean
    distance in the embedding (1 = nearest; ties broken by vertex index, i.e. a stable sort).
    Over the k geodesically nearest j, ``R_near_i = (1/k^2) sum min(|rank_geo(j) -
    rank_emb(j)|, k)``; the same over the k geodesically farthest gives ``R_far_i``;
    ``R_i = (R_near_i + R_far_i) / 2`` and the score is the mean over vertices.

    Parameters
    ----------
    geodesic : (n, n) float array
        Geodesic distance matrix (only the ordering of each row matters; ``inf`` allowed for
        unreachable vertices, NaN not).
    embedding : (n, d) float array
        Per-vertex embedding.
    k : int
        Neighbourhood size (default 10); needs ``2k + 1 <= n``.

    Returns
    -------
    float
        In [0, 1]; 0 means the embedding keeps both rankings exactly, lower is better.
    """
    return richness_details(geodesic, embedding, k).score
