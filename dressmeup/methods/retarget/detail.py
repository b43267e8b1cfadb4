"""Laplacian detail transfer (thesis 4.3.3.2): re-impose the input garment's fine geometry
on a retargeted garment of the same topology.

Solve, per coordinate, the sparse least-squares problem

    min_X  || L X - L V_in ||^2  +  w^2 || X[a] - V_ret[a] ||^2

where ``L`` is the Laplacian of the *input* garment (uniform ``I - D^-1 A`` as in the thesis,
or cotangent as in the authors' demo), ``delta = L V_in`` its Laplacian coordinates, and ``a``
a set of anchor vertices pinned to the retargeted garment (the thesis' one-hot rows
``1_i``; the demo picks 30 % of the vertices at random with weight 1). The normal equations
are factorised once (sparse LU) and solved for the three coordinates.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from dressmeup.geometry.laplacian import adjacency, cotan_laplacian, uniform_laplacian
from dressmeup.geometry.mesh import as_arrays, as_points

__all__ = ["choose_anchors", "detail_transfer", "laplacian_solve", "DetailTransfer"]


def choose_anchors(F: np.ndarray, n_vertices: int, fraction: float = 0.3, seed: int = 0) -> np.ndarray:
    """Random anchor vertices, at least one per connected component.

    Parameters
    ----------
    F : (m, 3) int array
    n_vertices : int
    fraction : float in (0, 1]
    seed : int

    Returns
    -------
    (a,) int64 sorted unique vertex indices.
    """
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction: expected a value in (0, 1], got {fraction}")
    rng = np.random.default_rng(seed)
    count = max(1, int(round(fraction * n_vertices)))
    picked = rng.choice(n_vertices, size=count, replace=False)
    _, labels = connected_components(adjacency(F, n_vertices), directed=False)
    first = np.unique(labels, return_index=True)[1]  # one vertex of every component
    return np.unique(np.concatenate([picked, first])).astype(np.int64)


def laplacian_solve(L: sp.spmatrix, delta: np.ndarray, anchors: np.ndarray, anchor_positions: np.ndarray,
                    anchor_weights: np.ndarray | float = 1.0) -> np.ndarray:
    """Least-squares solve of ``[L; diag(w) S] X = [delta; diag(w) P]``.

    Parameters
    ----------
    L : (n, n) sparse matrix
    delta : (n, 3) float array, target Laplacian coordinates.
    anchors : (a,) int array, anchored vertex indices.
    anchor_positions : (a, 3) float array.
    anchor_weights : float or (a,) float array.

    Returns
    -------
    (n, 3) float64 ndarray.
    """
    n = L.shape[0]
    anchors = np.asarray(anchors, dtype=np.int64)
    w = np.broadcast_to(np.asarray(anchor_weights, dtype=np.float64), anchors.shape)
    S = sp.csr_matrix((w, (np.arange(len(anchors)), anchors)), shape=(len(anchors), n))
    A = sp.vstack([L.tocsr(), S]).tocsc()
    b = np.vstack([np.asarray(delta, dtype=np.float64), w[:, None] * np.asarray(anchor_positions, dtype=np.float64)])
    AtA = (A.T @ A).tocsc()
    Atb = A.T @ b
    lu = spla.splu(AtA)
    return lu.solve(Atb)


class DetailTransfer:
    """Laplacian detail transfer of one garment, factorised once, applied to any retargeting.

    The normal equations ``(L^T L + S^T W^2 S) X = L^T delta + S^T W^2 R[a]`` have a matrix
    that depends on the input garment and the anchors only, so it is factorised (sparse LU) at
    construction; :meth:`apply` builds the right-hand side from the retargeted anchors and
    back-substitutes (the per-target cost of the non-learned path).

    Parameters
    ----------
    input_V : (n, 3) float array, metres; F : (m, 3) int array.
    laplacian : {"uniform", "cotan"}; anchor_fraction : float; anchor_weight : float; seed : int.
        See :func:`detail_transfer`.
    """

    def __init__(self, input_V: np.ndarray, F: np.ndarray, laplacian: str = "uniform",
                 anchor_fraction: float = 0.3, anchor_weight: float = 1.0, seed: int = 0) -> None:
        V, F = as_arrays(input_V, F, name="input garment")
        if laplacian == "uniform":
            L = uniform_laplacian(F, V.shape[0])
        elif laplacian == "cotan":
            L = cotan_laplacian(V, F)
        else:
            raise ValueError(f"laplacian: expected 'uniform' or 'cotan', got {laplacian!r}")
        n = V.shape[0]
        self.anchors = choose_anchors(F, n, anchor_fraction, seed)
        self.anchor_weight = float(anchor_weight)
        w2 = self.anchor_weight ** 2
        L = L.tocsr()
        S = sp.csr_matrix((np.ones(len(self.anchors)), (np.arange(len(self.anchors)), self.anchors)),
                          shape=(len(self.anchors), n))
        self._lu = spla.splu((L.T @ L + w2 * (S.T @ S)).tocsc())
        self._rhs_detail = np.asarray(L.T @ (L @ V), dtype=np.float64)
        self.shape = V.shape

    def apply(self, retargeted_V: np.ndarray) -> np.ndarray:
        """The retargeted garment with the input's details: (n, 3) float64."""
        R = as_points(retargeted_V, name="retargeted_V")
        if R.shape != self.shape:
            raise ValueError(f"retargeted_V: expected shape {self.shape} (same topology as the input), got {R.shape}")
        rhs = self._rhs_detail.copy()
        rhs[self.anchors] += self.anchor_weight ** 2 * R[self.anchors]
        return self._lu.solve(rhs)


def detail_transfer(input_V: np.ndarray, F: np.ndarray, retargeted_V: np.ndarray, laplacian: str = "uniform",
                    anchor_fraction: float = 0.3, anchor_weight: float = 1.0, seed: int = 0) -> np.ndarray:
    """Transfer the input garment's Laplacian coordinates onto a retargeted garment.

    Parameters
    ----------
    input_V : (n, 3) float array
        The garment as given (its details are the source).
    F : (m, 3) int array
        Shared faces.
    retargeted_V : (n, 3) float array
        The garment after retargeting (its positions are the anchors).
    laplacian : {"uniform", "cotan"}
        Thesis: uniform; demo: cotangent.
    anchor_fraction : float
        Share of vertices anchored (demo: 0.3), at least one per connected component.
    anchor_weight : float
        Weight of each anchor row (demo: 1).
    seed : int
        Chooses the anchors.

    Returns
    -------
    (n, 3) float64 ndarray. When ``retargeted_V == input_V`` the result equals the input
    exactly (up to round-off): the identity case. To retarget one garment onto many targets,
    build a :class:`DetailTransfer` once and call its ``apply``.
    """
    return DetailTransfer(input_V, F, laplacian, anchor_fraction, anchor_weight, seed).apply(retargeted_V)
