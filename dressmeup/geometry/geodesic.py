"""Geodesic distances on triangle meshes: heat method (potpourri3d) or Dijkstra on edges."""

from __future__ import annotations

import numpy as np

from dressmeup.geometry.mesh import as_arrays, edges
from dressmeup.progress import progress

__all__ = ["geodesic_distances", "edge_graph"]


def edge_graph(V: np.ndarray, F: np.ndarray):
    """Sparse symmetric graph of mesh edges weighted by their Euclidean length.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array

    Returns
    -------
    scipy.sparse.csr_matrix of shape (n, n)
    """
    # heavy: scipy.sparse
    from scipy.sparse import coo_matrix

    E = edges(F)
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    # zero-length edges would vanish from a sparse matrix: keep them connected
    w = np.maximum(w, np.finfo(np.float64).tiny)
    n = V.shape[0]
    g = coo_matrix((np.r_[w, w], (np.r_[E[:, 0], E[:, 1]], np.r_[E[:, 1], E[:, 0]])), shape=(n, n))
    return g.tocsr()


def geodesic_distances(
    V: np.ndarray, F: np.ndarray, sources: int | np.ndarray, method: str = "heat"
) -> np.ndarray:
    """Geodesic distances from source vertices to every vertex.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    sources : int or (s,) int array
        Source vertex indices.
    method : {"heat", "dijkstra"}
        ``"heat"``: the heat method of Crane et al. (2013) via potpourri3d (smooth, close to
        the exact geodesic, about 3 ms per source on 7k vertices). ``"dijkstra"``: shortest
        paths along mesh edges (scipy), an upper bound of the true geodesic. Vertices not
        reachable from a source get ``inf``.

    Returns
    -------
    (s, n) float64 ndarray

    Raises
    ------
    ValueError
        Bad arrays, source indices out of range or an unknown method.
    """
    V, F = as_arrays(V, F, name="mesh")
    src = np.atleast_1d(np.asarray(sources))
    if src.ndim != 1 or src.size == 0 or not np.issubdtype(src.dtype, np.integer):
        raise ValueError(
            f"sources: expected one or more integer vertex indices, got {np.asarray(sources)!r}"
        )
    if src.min() < 0 or src.max() >= V.shape[0]:
        raise ValueError(
            f"sources: indices must lie in [0, {V.shape[0] - 1}], got [{src.min()}, {src.max()}]"
        )
    src = src.astype(np.int64)
    if method == "dijkstra":
        # heavy: scipy.sparse
        from scipy.sparse.csgraph import dijkstra

        return np.asarray(
            dijkstra(edge_graph(V, F), directed=False, indices=src), dtype=np.float64
        ).reshape(src.size, V.shape[0])
    if method == "heat":
        # heavy: potpourri3d (~0.4 s to import)
        import potpourri3d as pp3d

        solver = pp3d.MeshHeatMethodDistanceSolver(V, F)
        out = np.empty((src.size, V.shape[0]), dtype=np.float64)
        for row, s in progress(enumerate(src), desc="geodesics (heat)", total=src.size):
            out[row] = solver.compute_distance(int(s))
        return out
    raise ValueError(f"method: expected 'heat' or 'dijkstra', got {method!r}")
