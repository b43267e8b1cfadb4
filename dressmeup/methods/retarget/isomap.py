"""Isomap embeddings of a body template and the coarse placement of a garment (thesis 4.3.1).

The pipeline, as plain functions on arrays:

1. :func:`skin_component` - the body surface used for geodesics (largest connected component).
2. :func:`geodesic_matrix` / :func:`landmark_geodesics` - heat-method geodesic distances on
   the template in its rest pose (potpourri3d).
3. :func:`classical_mds` (full, thesis) or :func:`landmark_mds` (de Silva & Tenenbaum's
   landmark MDS, the default past a few thousand vertices) to ``d`` dimensions.
4. :func:`template_embedding` - steps 1-3, cached per template under
   ``dressmeup.cache.cache_dir("isomap")``.
5. :func:`extrapolate` - thesis eq. 4.1: k-NN inverse-distance interpolation of the per-vertex
   embedding from a body (posed like the garment) to arbitrary points (garment vertices).
6. :func:`place` - thesis eq. 4.4: for each garment embedding, the inverse-distance weighted
   mean of the target vertices nearest in embedding space.

Everything is in metres; embeddings are float32 (they are distances in a metric space built
from metres, so they are in metres too).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from dressmeup.cache import cache_dir, hash_arrays
from dressmeup.geometry.mesh import as_arrays, as_points
from dressmeup.methods.retarget.base import RetargetMethod

log = logging.getLogger(__name__)

__all__ = [
    "skin_component", "geodesic_matrix", "landmark_geodesics", "classical_mds", "landmark_mds",
    "laplacian_eigenmaps", "TemplateEmbedding", "template_embedding", "extrapolate", "knn_embedding",
    "place",
]


# --------------------------------------------------------------------------------------------
# template surface and geodesics
# --------------------------------------------------------------------------------------------
def skin_component(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The largest connected component of a mesh (the skin of a body template).

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array

    Returns
    -------
    vertex_ids : (s,) int64
        Indices into ``V`` of the component's vertices, increasing.
    faces : (f, 3) int64
        The component's faces re-indexed into ``vertex_ids``.
    """
    V, F = as_arrays(V, F, name="template")
    n = V.shape[0]
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    graph = sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    counts = np.bincount(labels[used])
    best = int(np.argmax(counts))
    keep = (labels == best) & used
    ids = np.flatnonzero(keep).astype(np.int64)
    remap = -np.ones(n, dtype=np.int64)
    remap[ids] = np.arange(len(ids))
    faces = remap[F[keep[F[:, 0]]]]
    return ids, faces


def _heat_solver(V: np.ndarray, F: np.ndarray):
    import potpourri3d as pp3d

    return pp3d.MeshHeatMethodDistanceSolver(np.ascontiguousarray(V), np.ascontiguousarray(F))


def geodesic_matrix(V: np.ndarray, F: np.ndarray, dtype: type = np.float32) -> np.ndarray:
    """All-pairs geodesic distances with the heat method, symmetrised.

    Parameters
    ----------
    V : (n, 3) float array
        One connected surface (use :func:`skin_component` first).
    F : (m, 3) int array
    dtype : numpy dtype of the result (float32 halves the memory: n = 13k needs 0.7 GB).

    Returns
    -------
    (n, n) array of ``dtype``, zero diagonal, ``D == D.T``.
    """
    from dressmeup.progress import progress

    V, F = as_arrays(V, F, name="template")
    solver = _heat_solver(V, F)
    n = V.shape[0]
    D = np.empty((n, n), dtype=dtype)
    for s in progress(range(n), desc="geodesics", total=n):
        D[s] = solver.compute_distance(s)
    D += D.T
    D *= 0.5
    np.fill_diagonal(D, 0.0)
    return D


def landmark_geodesics(V: np.ndarray, F: np.ndarray, n_landmarks: int,
                       seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Geodesic farthest-point landmarks and their distances to every vertex.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    n_landmarks : int
        Number of landmarks ``L`` (clipped to ``n``).
    seed : int
        Chooses the first landmark; the rest follow by farthest-point sampling.

    Returns
    -------
    landmarks : (L,) int64 vertex indices.
    distances : (L, n) float64 geodesic distances from each landmark.
    """
    from dressmeup.progress import progress

    V, F = as_arrays(V, F, name="template")
    n = V.shape[0]
    L = int(min(max(n_landmarks, 1), n))
    solver = _heat_solver(V, F)
    rng = np.random.default_rng(seed)
    landmarks = np.empty(L, dtype=np.int64)
    D = np.empty((L, n), dtype=np.float64)
    current = int(rng.integers(n))
    nearest = np.full(n, np.inf)
    for k in progress(range(L), desc="landmark geodesics", total=L):
        landmarks[k] = current
        D[k] = solver.compute_distance(current)
        nearest = np.minimum(nearest, D[k])
        nearest[landmarks[: k + 1]] = -1.0
        current = int(np.argmax(nearest))
    return landmarks, D


# --------------------------------------------------------------------------------------------
# multidimensional scaling
# --------------------------------------------------------------------------------------------
def _top_eigen(B: np.ndarray, d: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Largest ``d`` (algebraic) eigenpairs of a symmetric matrix, descending (exact, LAPACK).

    Geodesic "Gram" matrices have large negative eigenvalues (heat-method geodesics are not
    Euclidean: on the procedural body the most negative is -177 against +1611 for the top
    one and +0.014 for the 256th), so randomized or magnitude-based iterations converge
    badly; the exact subset solver (``eigh(subset_by_index=...)``) is used. It is O(n^3):
    about 2.5 min for n = 5.7k on a loaded 2-core machine; landmark MDS avoids it.
    ``seed`` is unused (kept for a stable signature). Eigenvector signs are normalised
    (largest-magnitude entry positive) for determinism.
    """
    from scipy.linalg import eigh

    n = B.shape[0]
    d = min(d, n)
    w, U = eigh(B, subset_by_index=[n - d, n - 1])
    w, U = w[::-1].copy(), U[:, ::-1].copy()
    idx = np.argmax(np.abs(U), axis=0)
    U = U * np.sign(U[idx, np.arange(U.shape[1])])
    return w, U


def classical_mds(D: np.ndarray, dim: int = 128, seed: int = 0) -> np.ndarray:
    """Classical (Torgerson) MDS of a distance matrix: Isomap when ``D`` is geodesic.

    Parameters
    ----------
    D : (n, n) float array
        Symmetric distances.
    dim : int
        Embedding dimension ``d``.
    seed : int
        Start vector of the iterative eigensolver (results are sign-normalised).

    Returns
    -------
    (n, d) float32 ndarray: ``U_d sqrt(lambda_d)`` of ``B = -1/2 J D^2 J``; dimensions with
    non-positive eigenvalues are zero.
    """
    D = np.asarray(D)
    if D.ndim != 2 or D.shape[0] != D.shape[1]:
        raise ValueError(f"D: expected a square (n, n) distance matrix, got shape {D.shape}")
    if dim < 1:
        raise ValueError(f"dim: expected a positive dimension, got {dim}")
    n = D.shape[0]
    B = np.square(D, dtype=np.float64)
    B -= B.mean(axis=0, keepdims=True)
    B -= B.mean(axis=1, keepdims=True)
    B *= -0.5
    d = min(dim, n)
    w, U = _top_eigen(B, d, seed)
    del B
    X = U * np.sqrt(np.clip(w, 0.0, None))
    out = np.zeros((n, dim), dtype=np.float32)
    out[:, :d] = X
    return out


def landmark_mds(landmark_distances: np.ndarray, landmarks: np.ndarray, dim: int = 128,
                 seed: int = 0) -> np.ndarray:
    """Landmark MDS (de Silva & Tenenbaum 2004): classical MDS of the landmarks, then
    distance-based triangulation of every other point.

    Parameters
    ----------
    landmark_distances : (L, n) float array
        Distances from each landmark to every point.
    landmarks : (L,) int array
        Which points are the landmarks (column indices of ``landmark_distances``).
    dim : int
        Embedding dimension (at most ``L - 1`` informative dimensions).
    seed : int

    Returns
    -------
    (n, dim) float32 ndarray; on the landmarks it equals :func:`classical_mds` of their
    distance sub-matrix (up to sign).
    """
    Dl = np.asarray(landmark_distances, dtype=np.float64)
    landmarks = np.asarray(landmarks, dtype=np.int64)
    if Dl.ndim != 2 or Dl.shape[0] != len(landmarks):
        raise ValueError(f"landmark_distances: expected shape (L={len(landmarks)}, n), got {Dl.shape}")
    L, n = Dl.shape
    sq = np.square(Dl)  # (L, n)
    DLL = sq[:, landmarks]
    DLL = 0.5 * (DLL + DLL.T)
    B = DLL - DLL.mean(axis=0, keepdims=True)
    B -= B.mean(axis=1, keepdims=True)
    B *= -0.5
    d = min(dim, L - 1)
    w, U = _top_eigen(B, d, seed)
    pos = w > 1e-12 * max(w[0], 1e-30)
    pinv = np.zeros_like(U)
    pinv[:, pos] = U[:, pos] / np.sqrt(w[pos])  # (L, d)
    mean_sq = DLL.mean(axis=1, keepdims=True)  # (L, 1)
    X = -0.5 * (sq - mean_sq).T @ pinv  # (n, d)
    out = np.zeros((n, dim), dtype=np.float32)
    out[:, :d] = X
    return out


def laplacian_eigenmaps(V: np.ndarray, F: np.ndarray, dim: int = 16) -> np.ndarray:
    """Laplacian eigenmaps: the low-frequency eigenvectors of the cotangent Laplacian.

    The low-dimensional alternative of the Richness study (section 4.6.2): a smooth,
    intrinsic embedding whose dimensions are the first non-constant eigenfunctions of the
    Laplace-Beltrami operator (generalised problem ``L x = lambda M x``).

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    dim : int

    Returns
    -------
    (n, dim) float32 ndarray.
    """
    from scipy.sparse.linalg import eigsh

    from dressmeup.geometry.laplacian import cotan_laplacian, mass_matrix

    L = cotan_laplacian(V, F)
    M = mass_matrix(V, F)
    w, U = eigsh(L.tocsc(), k=dim + 1, M=M.tocsc(), sigma=-1e-8, which="LM")
    order = np.argsort(w)
    return U[:, order[1:]].astype(np.float32)


# --------------------------------------------------------------------------------------------
# cached template embedding
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TemplateEmbedding:
    """The Isomap embedding of a body template's skin.

    Attributes
    ----------
    vertex_ids : (s,) int64, indices of the skin vertices in the full template.
    embedding : (s, d) float32, one row per skin vertex.
    method : "full" or "landmark".
    seconds : wall time spent computing it (0 when read from the cache).
    """

    vertex_ids: np.ndarray
    embedding: np.ndarray
    method: str
    seconds: float = 0.0


def template_embedding(template_V: np.ndarray, template_F: np.ndarray, dim: int = 128,
                       method: str = "auto", n_landmarks: int = 2000, seed: int = 0,
                       use_cache: bool = True) -> TemplateEmbedding:
    """Isomap embedding of a body template's skin, cached per template.

    Parameters
    ----------
    template_V : (n, 3) float array
        The template (rest pose) vertices of the body model.
    template_F : (m, 3) int array
    dim : int
        Embedding dimension (thesis: 128).
    method : {"auto", "full", "landmark"}
        ``full`` = all-pairs geodesics + classical MDS (thesis); ``landmark`` = landmark MDS
        with ``n_landmarks`` geodesic farthest-point landmarks; ``auto`` = full up to 3000
        skin vertices, landmark beyond (Richness difference measured in
        ``benchmarks/studies/richness.py`` and docs/baselines.md).
    n_landmarks : int
    seed : int
    use_cache : bool
        Read/write ``<cache>/isomap/<hash>.npz`` keyed by the template arrays and settings.

    Returns
    -------
    TemplateEmbedding
    """
    V, F = as_arrays(template_V, template_F, name="template")
    if method not in ("auto", "full", "landmark"):
        raise ValueError(f"method: expected 'auto', 'full' or 'landmark', got {method!r}")
    ids, faces = skin_component(V, F)
    Vs = V[ids]
    if method == "auto":
        method = "full" if len(ids) <= 3000 else "landmark"
    key = hash_arrays(Vs, faces, extra=f"isomap-v1|{dim}|{method}|{n_landmarks if method == 'landmark' else 0}|{seed}")
    path = cache_dir("isomap") / f"{key}.npz"
    if use_cache and path.is_file():
        with np.load(path) as z:
            return TemplateEmbedding(vertex_ids=z["vertex_ids"], embedding=z["embedding"], method=method)
    t0 = time.perf_counter()
    if method == "full":
        emb = classical_mds(geodesic_matrix(Vs, faces), dim=dim, seed=seed)
    else:
        lm, Dl = landmark_geodesics(Vs, faces, n_landmarks, seed=seed)
        emb = landmark_mds(Dl, lm, dim=dim, seed=seed)
    seconds = time.perf_counter() - t0
    log.info("isomap embedding (%s, %d vertices, d=%d) in %.1f s", method, len(ids), dim, seconds)
    if use_cache:
        import io

        from dressmeup.io.atomic import atomic_write_bytes

        buf = io.BytesIO()
        np.savez(buf, vertex_ids=ids, embedding=emb)
        atomic_write_bytes(path, buf.getvalue())
    return TemplateEmbedding(vertex_ids=ids, embedding=emb, method=method, seconds=seconds)


# --------------------------------------------------------------------------------------------
# extrapolation (eq. 4.1) and placement (eq. 4.4)
# --------------------------------------------------------------------------------------------
def _inverse_distance_weights(dist: np.ndarray, eps: float = 1e-9) -> np.ndarray:
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
    w = _inverse_distance_weights(dist)
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
    w = _inverse_distance_weights(dist)
    return np.einsum("nk,nkc->nc", w, target_points[idx])


# --------------------------------------------------------------------------------------------
# the `isomap` method
# --------------------------------------------------------------------------------------------
_EMB_MEMO: dict[str, TemplateEmbedding] = {}


def embedding_for(body_model, dim: int = 128, method: str = "auto", n_landmarks: int = 2000,
                  seed: int = 0) -> TemplateEmbedding:
    """The template embedding of ``body_model`` (memoised in-process, cached on disk).

    Parameters
    ----------
    body_model : BodyModel
        Its ``template_vertices`` and ``faces`` define the template.
    dim, method, n_landmarks, seed : see :func:`template_embedding`.

    Returns
    -------
    TemplateEmbedding over the model's skin (vertex ids into the full model).
    """
    key = f"{id(body_model)}|{dim}|{method}|{n_landmarks}|{seed}"
    if key not in _EMB_MEMO:
        _EMB_MEMO[key] = template_embedding(body_model.template_vertices, body_model.faces, dim=dim,
                                            method=method, n_landmarks=n_landmarks, seed=seed)
    return _EMB_MEMO[key]


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


class IsomapRetarget(RetargetMethod):
    """``isomap``: coarse placement by Isomap correspondences through the body template.

    Parameters
    ----------
    dim : int
        Embedding dimension (thesis: 128).
    k_extrapolate : int
        Neighbours of eq. 4.1 (thesis: 32).
    k_place : int
        Neighbours of eq. 4.4 (thesis: 32; the authors' demo: 3).
    embedding_method : {"auto", "full", "landmark"}
    n_landmarks : int
        Landmarks of landmark MDS.
    offset : float
        Metres to push each coarse point out along the interpolated target normal (thesis: 0;
        demo: 0.02).
    smooth_iterations : int
        Uniform 1-ring smoothing steps of the coarse garment (thesis: 0; demo: 5).
    correspondence_noise : float
        Standard deviation (metres) of Gaussian noise added to every coarse point, for the
        noise ablation of thesis Table 4.2 (default 0: none).
    seed : int
        Landmark choice and the noise.
    """

    name = "isomap"

    def __init__(self, dim: int = 128, k_extrapolate: int = 32, k_place: int = 32,
                 embedding_method: str = "auto", n_landmarks: int = 2000, offset: float = 0.0,
                 smooth_iterations: int = 0, correspondence_noise: float = 0.0, seed: int = 0) -> None:
        self.dim = dim
        self.k_extrapolate = k_extrapolate
        self.k_place = k_place
        self.embedding_method = embedding_method
        self.n_landmarks = n_landmarks
        self.offset = offset
        self.smooth_iterations = smooth_iterations
        self.correspondence_noise = correspondence_noise
        self.seed = seed

    def embedding(self, body_model) -> TemplateEmbedding:
        """The (cached) template embedding these hyperparameters use."""
        return embedding_for(body_model, dim=self.dim, method=self.embedding_method,
                             n_landmarks=self.n_landmarks, seed=self.seed)

    def coarse(self, garment_V, garment_F, source, target, body_model):
        """Coarse placement with everything the refinement needs.

        Returns
        -------
        (CoarseResult, source BodyContext, target BodyContext, TemplateEmbedding)
        """
        from dressmeup.methods.retarget.base import body_context, check_garment

        V, F = check_garment(garment_V, garment_F)
        emb = self.embedding(body_model)
        s, t = body_context(body_model, source), body_context(body_model, target)
        if not np.array_equal(emb.vertex_ids, s.skin_ids):
            raise ValueError("body_model: the embedding's skin does not match the model's skin component")
        res = coarse_retarget(V, s.skin_vertices, t.skin_vertices, emb.embedding,
                              self.k_extrapolate, self.k_place)
        x = res.positions
        if self.offset:
            dist, idx = knn_embedding(res.garment_embedding, emb.embedding, k=self.k_place)
            w = _inverse_distance_weights(dist)
            n = np.einsum("nk,nkc->nc", w, t.skin_normals()[idx])
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
            x = x + float(self.offset) * n
        if self.smooth_iterations:
            from dressmeup.geometry.laplacian import uniform_laplacian

            L = uniform_laplacian(F, V.shape[0])
            for _ in range(int(self.smooth_iterations)):
                x = x - L @ x
        if self.correspondence_noise:
            rng = np.random.default_rng(self.seed)
            x = x + rng.normal(0.0, float(self.correspondence_noise), size=x.shape)
        res.positions = x
        return res, s, t, emb

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """See :mod:`dressmeup.methods.retarget.base`; returns (n, 3) float64."""
        return self.coarse(garment_V, garment_F, source, target, body_model)[0].positions
