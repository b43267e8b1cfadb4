"""Multidimensional scaling of geodesic distances (Isomap) and the low-dimensional alternative.

:func:`classical_mds` (full, thesis), :func:`landmark_mds` (de Silva & Tenenbaum's landmark
MDS, the default past a few thousand vertices) and :func:`laplacian_eigenmaps` (the
low-dimensional embedding of the Richness study, thesis 4.6.2).
"""

from __future__ import annotations

import numpy as np

__all__ = ["classical_mds", "landmark_mds", "laplacian_eigenmaps"]


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
    # heavy: scipy.linalg
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
    # heavy: scipy.sparse
    from scipy.sparse.linalg import eigsh

    from dressmeup.geometry.laplacian import cotan_laplacian, mass_matrix

    L = cotan_laplacian(V, F)
    M = mass_matrix(V, F)
    w, U = eigsh(L.tocsc(), k=dim + 1, M=M.tocsc(), sigma=-1e-8, which="LM")
    order = np.argsort(w)
    return U[:, order[1:]].astype(np.float32)

