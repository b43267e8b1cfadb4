"""Nearest neighbours between point sets (scipy cKDTree; pykdtree for the fast single-thread
:class:`NearestTree`)."""

from __future__ import annotations

import os

import numpy as np

from dressmeup.geometry.mesh import as_points

# pykdtree queries on as many OpenMP threads as cores unless told otherwise, and its bundled
# OpenMP runtime reads OMP_NUM_THREADS once, when it is loaded: it is loaded here with that
# variable set to 1 and the caller's value put back at once, so torch's own runtime is
# untouched. Registration fits run one per core, as scipy's queries with ``workers=1`` did.
_omp_threads = os.environ.get("OMP_NUM_THREADS")
os.environ["OMP_NUM_THREADS"] = "1"
try:
    from pykdtree.kdtree import KDTree as _PyKDTree
finally:
    if _omp_threads is None:
        del os.environ["OMP_NUM_THREADS"]
    else:
        os.environ["OMP_NUM_THREADS"] = _omp_threads

__all__ = ["knn", "spatial_order", "build_tree", "NearestTree", "nearest_backend"]

#: Backend of :class:`NearestTree`: None picks pykdtree when installed, else scipy; benchmarks
#: and tests set "scipy" or "pykdtree" to compare the two on the same run.
BACKEND: str | None = None

#: Query sets at least this large are processed in spatial order (cache-friendly traversal).
ORDER_MIN_QUERIES = 4096


def build_tree(points: np.ndarray):
    """A scipy ``cKDTree`` built for speed (unbalanced, non-compact: twice as fast to build,
    as fast to query, same answers).

    Parameters
    ----------
    points : (r, d) float64 array (validated by the caller)

    Returns
    -------
    scipy.spatial.cKDTree
    """
    # heavy: scipy.spatial
    from scipy.spatial import cKDTree

    return cKDTree(points, balanced_tree=False, compact_nodes=False)


def spatial_order(points: np.ndarray) -> np.ndarray:
    """A permutation that puts nearby points next to each other (kd-tree leaf order).

    Queries issued in this order walk the same tree nodes one after the other, which roughly
    halves the time of nearest-neighbour and closest-point queries on large random sets.

    Parameters
    ----------
    points : (q, d) float array

    Returns
    -------
    (q,) int64 ndarray
    """
    return np.asarray(build_tree(np.asarray(points, dtype=np.float64)).indices, dtype=np.int64)


def knn(
    reference: np.ndarray, query: np.ndarray, k: int = 1, workers: int = -1
) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` nearest reference points of every query point (Euclidean).

    Parameters
    ----------
    reference : (r, d) float array
    query : (q, d) float array
        Same width ``d`` as ``reference``.
    k : int
        Number of neighbours, ``1 <= k <= r``.
    workers : int
        Threads for the query (-1: all cores).

    Returns
    -------
    dist : (q, k) float64 ndarray
        Distances, ascending along each row.
    idx : (q, k) int64 ndarray
        Indices into ``reference``.

    Raises
    ------
    ValueError
        Bad shapes, NaN/inf, or ``k`` out of range.
    """
    R = as_points(reference, name="reference", dim=None)
    Q = as_points(query, name="query", dim=R.shape[1])
    if int(k) != k or not 1 <= k <= R.shape[0]:
        raise ValueError(f"k: expected an integer in [1, {R.shape[0]}], got {k}")
    tree = build_tree(R)
    if Q.shape[0] >= ORDER_MIN_QUERIES:
        order = spatial_order(Q)
        d_o, i_o = tree.query(Q[order], k=int(k), workers=workers)
        dist = np.empty_like(d_o)
        idx = np.empty_like(i_o)
        dist[order] = d_o
        idx[order] = i_o
    else:
        dist, idx = tree.query(Q, k=int(k), workers=workers)
    dist = np.asarray(dist, dtype=np.float64).reshape(Q.shape[0], int(k))
    idx = np.asarray(idx, dtype=np.int64).reshape(Q.shape[0], int(k))
    return dist, idx


def _pykdtree_class():
    """pykdtree's ``KDTree`` class (loaded with this module, on one OpenMP thread)."""
    return _PyKDTree


def nearest_backend() -> str:
    """The library :class:`NearestTree` uses now: ``"pykdtree"`` or ``"scipy"``."""
    if BACKEND is not None:
        if BACKEND not in ("pykdtree", "scipy"):
            raise ValueError(f"neighbors.BACKEND: expected None, 'pykdtree' or 'scipy', "
                             f"got {BACKEND!r}")
        if BACKEND == "pykdtree" and _pykdtree_class() is None:
            raise ImportError("neighbors.BACKEND = 'pykdtree' but pykdtree is not installed: "
                              "pip install pykdtree")
        return BACKEND
    return "pykdtree" if _pykdtree_class() is not None else "scipy"


class NearestTree:
    """The nearest of fixed points to each query point, on one thread.

    The subset of ``scipy.spatial.cKDTree.query`` that registration's inner loops call every
    step (k = 1, an optional distance bound, one thread), answered by pykdtree when it is
    installed (about 1.6 times as fast per query on registration's sizes, the same neighbours:
    ``benchmarks/perf/nearest_tree.py``) and by scipy's cKDTree otherwise.

    Parameters
    ----------
    points : (n, d) float array, n >= 1; copied (the tree must not see later edits).
    """

    def __init__(self, points: np.ndarray):
        pts = np.array(points, dtype=np.float64, order="C", copy=True)
        if pts.ndim != 2 or pts.shape[0] < 1:
            raise ValueError(f"NearestTree: expected (n, d) points with n >= 1, got shape "
                             f"{pts.shape}")
        self.points, self.n, self.backend = pts, pts.shape[0], nearest_backend()
        if self.backend == "pykdtree":
            self._tree = _pykdtree_class()(pts)
        else:
            # heavy: scipy.spatial
            from scipy.spatial import cKDTree

            self._tree = cKDTree(pts)

    def query(self, x: np.ndarray, k: int = 1, distance_upper_bound: float = np.inf,
              workers: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Distance and index of each query point's nearest point.

        Parameters
        ----------
        x : (q, d) float array (same d as the points).
        k : must be 1; workers : must be 1 (the arguments scipy's callers pass).
        distance_upper_bound : points farther than this are not searched for: such a query
            gets distance ``inf`` and index ``n`` (scipy's convention), and costs less.

        Returns
        -------
        dist : (q,) float64; idx : (q,) int64.
        """
        if k != 1 or workers != 1:
            raise ValueError(f"NearestTree.query answers k=1 on one thread, got k={k}, "
                             f"workers={workers}: use scipy.spatial.cKDTree for more")
        X = np.ascontiguousarray(x, dtype=np.float64)
        if X.ndim != 2 or X.shape[1] != self.points.shape[1]:
            raise ValueError(f"NearestTree.query: expected (q, {self.points.shape[1]}) query "
                             f"points, got shape {X.shape}")
        bound = float(distance_upper_bound)
        if self.backend == "pykdtree":
            d, i = self._tree.query(X, k=1, distance_upper_bound=None if np.isinf(bound)
                                    else bound)
        else:
            d, i = self._tree.query(X, k=1, distance_upper_bound=bound, workers=1)
        return np.asarray(d, dtype=np.float64), np.asarray(i, dtype=np.int64)
