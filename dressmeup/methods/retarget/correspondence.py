"""Correspondences through the template embedding: thesis eq. 4.1 (extrapolate the embedding
from a body to garment points) and eq. 4.4 (place each garment point on the target by k-NN in
embedding space), and the coarse retargeting that chains them.

Everything is in metres; embeddings are float32.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.geometry.mesh import as_points

__all__ = ["inverse_distance_weights", "extrapolate", "knn_embedding", "place", "CoarseResult",
           "coarse_retarget"]


def inverse_distance_weights(dist: np.ndarray, eps: float = 1e-9) -> np.ndarray:
    """Rows of 1/d weights normalised to sum 1; an exact hit (d <= eps) takes all the weight."""
    dist = np.asarray(dist, dtype=np.float64)
    exact = dist <= eps
    w = 1.0 / np.maximum(dist, eps)
    hit = exact.any(axis=1)
    if hit.any():
        w[hit] = exact[hit].astype(np.float64)
    return w / w.sum(axis=1, keepdims=True)


def extrapolate(embedding: np.ndarray, reference_points: np.ndarray, query: np.ndarray,
                k: int = 32) -> np.ndarray:
    """Thesis eq. 4.1: embed points by k-NN inverse-distance interpolation.

    Parameters
    ----------
    embedding : (r, d) float array
        Embedding of each reference point (the template embedding of the skin vertices).
    reference_points : (r, 3) float array
        Where the reference points are (the skin of the body posed like the query).
    query : (q, 3) float array
        Points to embed (garment vertices).
    k : int
        Neighbours (thesis: 32).

    Returns
    -------
    (q, d) float32 ndarray. A query that coincides with a reference point gets exactly its
    embedding.
    """
    ref = as_points(reference_points, name="reference_points")
    query = as_points(query, name="query")
    emb = np.asarray(embedding)
    if emb.ndim != 2 or emb.shape[0] != ref.shape[0]:
        raise ValueError(f"embedding: expected shape ({ref.shape[0]}, d), got {emb.shape}")
    k = int(min(k, ref.shape[0]))
    dist, idx = cKDTree(ref).query(query, k=k)
    if k == 1:
        dist, idx = dist[:, None], idx[:, None]
    w = inverse_distance_weights(dist)
    return np.einsum("qk,qkd->qd", w, emb[idx].astype(np.float64)).astype(np.float32)


def knn_embedding(query_embedding: np.ndarray, reference_embedding: np.ndarray, k: int = 32,
                  method: str = "kdtree", chunk: int = 4096) -> tuple[np.ndarray, np.ndarray]:
    """Exact k nearest neighbours in embedding space.

    Parameters
    ----------
    query_embedding : (q, d) float array
    reference_embedding : (r, d) float array
    k : int
    method : {"kdtree", "brute"}
        ``kdtree``: scipy cKDTree (exact; fast although d = 128, because the embedded body is
        intrinsically a 2-D surface: about 10x faster than brute force for 30k x 13k, see
        ``benchmarks/perf/retarget.py``); ``brute``: chunked float32 torch matrix products.
    chunk : int
        Query rows per batch of ``brute`` (memory ``chunk * r * 4`` bytes).

    Returns
    -------
    dist : (q, k) float64, increasing along each row.
    idx : (q, k) int64 indices into ``reference_embedding``.
    """
    Q = np.ascontiguousarray(query_embedding, dtype=np.float32)
    R = np.ascontiguousarray(reference_embedding, dtype=np.float32)
    if Q.ndim != 2 or R.ndim != 2 or Q.shape[1] != R.shape[1]:
        raise ValueError(f"query_embedding/reference_embedding: expected (q, d) and (r, d) with the same d, "
                         f"got {Q.shape} and {R.shape}")
    k = int(min(k, R.shape[0]))
    if method == "kdtree":
        dist, idx = cKDTree(R.astype(np.float64)).query(Q.astype(np.float64), k=k)
        dist, idx = np.asarray(dist).reshape(len(Q), k), np.asarray(idx).reshape(len(Q), k)
        return dist.astype(np.float64), idx.astype(np.int64)
    if method != "brute":
        raise ValueError(f"method: expected 'kdtree' or 'brute', got {method!r}")
    # heavy: torch (~1.1 s to import)
    import torch

    Qt, Rt = torch.as_tensor(Q), torch.as_tensor(R)
    r2 = (Rt * Rt).sum(1)
    dists, idxs = [], []
    with torch.no_grad():
        for s in range(0, Qt.shape[0], chunk):
            q = Qt[s:s + chunk]
            d2 = (q * q).sum(1, keepdim=True) - 2.0 * q @ Rt.T + r2[None]
            val, ind = torch.topk(d2, k, dim=1, largest=False, sorted=True)
            dists.append(val.clamp_min(0).sqrt().double())
            idxs.append(ind)
    return torch.cat(dists).numpy(), torch.cat(idxs).numpy().astype(np.int64)


def place(garment_embedding: np.ndarray, target_embedding: np.ndarray, target_points: np.ndarray,
          k: int = 32) -> np.ndarray:
    """Thesis eq. 4.4: coarse position of each garment vertex on the target.

    ``x_i = sum_j u_j / ||phi_G^i - phi_T^j|| / sum_j 1 / ||phi_G^i - phi_T^j||`` over the
    ``k`` target vertices ``u_j`` nearest to ``phi_G^i`` in embedding space.

    Parameters
    ----------
    garment_embedding : (n, d) float array
    target_embedding : (t, d) float array
    target_points : (t, 3) float array
    k : int
        Thesis: 32 (the authors' demo uses 3).

    Returns
    -------
    (n, 3) float64 ndarray.
    """
    target_points = as_points(target_points, name="target_points")
    if np.shape(target_embedding)[0] != target_points.shape[0]:
        raise ValueError(f"target_embedding: expected {target_points.shape[0]} rows (one per target point), "
                         f"got {np.shape(target_embedding)[0]}")
    dist, idx = knn_embedding(garment_embedding, target_embedding, k=k)
    w = inverse_distance_weights(dist)
    return np.einsum("nk,nkc->nc", w, target_points[idx])



@dataclass
class CoarseResult:
    """Output of :func:`coarse_retarget`.

    Attributes
    ----------
    positions : (n, 3) float64, coarse garment vertices on the target (eq. 4.4).
    garment_embedding : (n, d) float32, eq. 4.1 on the source body.
    seconds_extrapolate, seconds_place : wall times of the two k-NN searches.
    """

    positions: np.ndarray
    garment_embedding: np.ndarray
    seconds_extrapolate: float
    seconds_place: float


def coarse_retarget(garment_V: np.ndarray, source_skin: np.ndarray, target_skin: np.ndarray,
                    embedding: np.ndarray, k_extrapolate: int = 32, k_place: int = 32,
                    target_embedding: np.ndarray | None = None) -> CoarseResult:
    """Correspondence-guided coarse retargeting (thesis 4.3.1, eq. 4.1 then eq. 4.4).

    Parameters
    ----------
    garment_V : (n, 3) float array, the garment on the source body.
    source_skin : (s, 3) float array, the source body's skin vertices (posed like the garment).
    target_skin : (t, 3) float array, the target's vertices.
    embedding : (s, d) float array, template embedding of the source skin vertices.
    k_extrapolate, k_place : int, neighbours of eq. 4.1 and eq. 4.4 (thesis: 32 and 32).
    target_embedding : (t, d) float array, optional
        Embedding of the target vertices; default ``embedding`` (the target is the same
        template). For a non-parametric target (a scan), extrapolate it first with
        :func:`extrapolate` from a body registered to the scan.

    Returns
    -------
    CoarseResult
    """
    t0 = time.perf_counter()
    phi = extrapolate(embedding, source_skin, garment_V, k=k_extrapolate)
    t1 = time.perf_counter()
    target_embedding = embedding if target_embedding is None else target_embedding
    x = place(phi, target_embedding, target_skin, k=k_place)
    t2 = time.perf_counter()
    return CoarseResult(positions=x, garment_embedding=phi, seconds_extrapolate=t1 - t0, seconds_place=t2 - t1)


