"""The Isomap embedding of a body template's skin (thesis 4.3.1, eq. 4.3 and the MDS step).

1. :func:`skin_component` - the body surface used for geodesics (largest connected component).
2. :func:`geodesic_matrix` / :func:`landmark_geodesics` - heat-method geodesic distances on
   the template in its rest pose (potpourri3d; :func:`heat_solver`).
3. MDS to ``d`` dimensions (:mod:`dressmeup.methods.retarget.mds`).
4. :func:`template_embedding` - steps 1-3, cached per template under
   ``dressmeup.cache.cache_dir("isomap")``; :func:`embedding_for` memoises it per body model.

Everything is in metres; embeddings are float32.
"""

from __future__ import annotations

import io
import logging
import time
from dataclasses import dataclass

import numpy as np

from dressmeup.cache import cache_dir, hash_arrays
from dressmeup.geometry.mesh import as_arrays
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.methods.retarget.mds import classical_mds, landmark_mds
from dressmeup.progress import progress

log = logging.getLogger(__name__)

__all__ = ["skin_component", "heat_solver", "geodesic_matrix", "landmark_geodesics", "TemplateEmbedding",
           "template_embedding", "embedding_for"]

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
    # heavy: scipy.sparse
    from dressmeup.geometry.topology import largest_component

    V, F = as_arrays(V, F, name="template")
    return largest_component(F, V.shape[0], by="vertices")


def heat_solver(V: np.ndarray, F: np.ndarray):
    """A potpourri3d heat-method geodesic solver on one connected surface ``(V (n, 3), F (m, 3))``."""
    # heavy: potpourri3d (~0.4 s to import)
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

    V, F = as_arrays(V, F, name="template")
    solver = heat_solver(V, F)
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

    V, F = as_arrays(V, F, name="template")
    n = V.shape[0]
    L = int(min(max(n_landmarks, 1), n))
    solver = heat_solver(V, F)
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
        buf = io.BytesIO()
        np.savez(buf, vertex_ids=ids, embedding=emb)
        atomic_write_bytes(path, buf.getvalue())
    return TemplateEmbedding(vertex_ids=ids, embedding=emb, method=method, seconds=seconds)


# --------------------------------------------------------------------------------------------
# per body model, memoised in-process
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
