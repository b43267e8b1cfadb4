"""Mesh Laplacians: vertex adjacency, the uniform (graph) Laplacian and the cotangent Laplacian.

Sign convention: every Laplacian here is *positive* semi-definite, ``L = D - W`` with rows
summing to zero, so ``L @ V`` points from the neighbourhood's (weighted) centroid to the
vertex ("Laplacian coordinates", thesis eq. 4.11). The normalised uniform Laplacian is
``I - D^-1 A`` exactly as in the thesis (section 4.3.3.2).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from dressmeup.geometry.mesh import as_arrays, as_faces

__all__ = ["adjacency", "uniform_laplacian", "cotan_weights", "cotan_laplacian", "mass_matrix"]


def adjacency(F: np.ndarray, n_vertices: int) -> sp.csr_matrix:
    """Symmetric 0/1 vertex adjacency of a triangle mesh.

    Parameters
    ----------
    F : (m, 3) int array
        Triangle indices.
    n_vertices : int
        Number of vertices ``n`` (isolated vertices get empty rows).

    Returns
    -------
    (n, n) scipy.sparse.csr_matrix of float64, ``A[i, j] = 1`` when ``i`` and ``j`` share
    an edge, zero diagonal.
    """
    F = as_faces(F, n_vertices, name="F")
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    keep = i != j
    i, j = i[keep], j[keep]
    A = sp.coo_matrix(
        (np.ones(2 * len(i)), (np.concatenate([i, j]), np.concatenate([j, i]))),
        shape=(n_vertices, n_vertices),
    ).tocsr()
    A.data[:] = 1.0  # duplicates (edges shared by two faces) summed above: reset to 1
    return A


def uniform_laplacian(F: np.ndarray, n_vertices: int, normalized: bool = True) -> sp.csr_matrix:
    """Uniform (umbrella) Laplacian.

    Parameters
    ----------
    F : (m, 3) int array
    n_vertices : int
    normalized : bool
        ``True`` gives ``I - D^-1 A`` (thesis eq. 4.11: ``delta_i = v_i - mean of neighbours``);
        ``False`` gives the combinatorial ``D - A``. Isolated vertices get a zero row.

    Returns
    -------
    (n, n) scipy.sparse.csr_matrix of float64.
    """
    A = adjacency(F, n_vertices)
    deg = np.asarray(A.sum(axis=1)).ravel()
    if not normalized:
        return (sp.diags(deg) - A).tocsr()
    inv = np.zeros_like(deg)
    inv[deg > 0] = 1.0 / deg[deg > 0]
    eye = sp.diags((deg > 0).astype(np.float64))
    return (eye - sp.diags(inv) @ A).tocsr()


def cotan_weights(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """Symmetric cotangent weight matrix ``W[i, j] = (cot a_ij + cot b_ij) / 2``.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array

    Returns
    -------
    (n, n) scipy.sparse.csr_matrix of float64 with zero diagonal. Degenerate triangles
    contribute zero weight (their cotangents are undefined).
    """
    V, F = as_arrays(V, F, name="mesh")
    n = V.shape[0]
    rows, cols, vals = [], [], []
    for k in range(3):
        i, j, o = F[:, (k + 1) % 3], F[:, (k + 2) % 3], F[:, k]  # edge (i, j), opposite o
        a = V[i] - V[o]
        b = V[j] - V[o]
        cross = np.linalg.norm(np.cross(a, b), axis=1)
        dot = np.einsum("ij,ij->i", a, b)
        cot = np.zeros_like(dot)
        ok = cross > 1e-20
        cot[ok] = dot[ok] / cross[ok]
        rows += [i, j]
        cols += [j, i]
        vals += [0.5 * cot, 0.5 * cot]
    W = sp.coo_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
    ).tocsr()
    W.sum_duplicates()
    return W


def cotan_laplacian(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """Cotangent Laplacian (stiffness matrix) ``L = D - W``, positive semi-definite.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array

    Returns
    -------
    (n, n) scipy.sparse.csr_matrix of float64; rows sum to zero. ``L @ V`` is the integrated
    mean-curvature normal (times 2); divide by the :func:`mass_matrix` diagonal for the
    pointwise operator. Equals ``-igl.cotmatrix(V, F)``.
    """
    W = cotan_weights(V, F)
    deg = np.asarray(W.sum(axis=1)).ravel()
    return (sp.diags(deg) - W).tocsr()


def mass_matrix(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """Lumped (barycentric) mass matrix: a third of the incident triangle areas per vertex.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array

    Returns
    -------
    (n, n) diagonal scipy.sparse.csr_matrix of float64.
    """
    V, F = as_arrays(V, F, name="mesh")
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    m = np.bincount(F.ravel(), weights=np.repeat(area / 3.0, 3), minlength=V.shape[0])
    return sp.diags(m).tocsr()
