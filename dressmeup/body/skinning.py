"""Skinning helpers on numpy arrays: weight transfer, LBS posing and unposing.

Used by the retargeting baselines and the synthetic data to carry a garment (or any mesh
near a body) along with the body's pose.
"""

from __future__ import annotations

import numpy as np

from dressmeup.geometry.mesh import vertex_normals
from dressmeup.geometry.proximity import barycentric


def _check(arr, name: str, shape: tuple) -> np.ndarray:
    a = np.asarray(arr, dtype=np.float64)
    if a.ndim != len(shape) or any(s is not None and a.shape[i] != s for i, s in enumerate(shape)):
        want = "(" + ", ".join("?" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name}: expected shape {want}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return a


def closest_surface_points(V: np.ndarray, F: np.ndarray, points: np.ndarray):
    """Closest point on a triangle mesh for every query point.

    Parameters
    ----------
    V : (n, 3) float64 mesh vertices; F : (m, 3) int64 faces; points : (p, 3) float64.

    Returns
    -------
    dist : (p,) float64 distances; closest : (p, 3) float64 closest points;
    face_ids : (p,) int64 face of each closest point; bary : (p, 3) float64 barycentric
    coordinates of the closest point in its face.
    """
    # heavy: igl (~0.4 s to import)
    import igl

    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    P = np.ascontiguousarray(points, dtype=np.float64)
    sqr, fid, C = igl.point_mesh_squared_distance(P, V, F)
    fid = np.asarray(fid, dtype=np.int64).ravel()
    C = np.asarray(C)
    bary = barycentric(C, V[F[fid]])
    return np.sqrt(np.maximum(np.asarray(sqr).ravel(), 0)), C, fid, bary


def transfer_weights(
    body_V: np.ndarray,
    body_F: np.ndarray,
    body_W: np.ndarray,
    points: np.ndarray,
    faces: np.ndarray | None = None,
    smooth_iterations: int = 0,
    smooth_alpha: float = 0.5,
    point_normals: np.ndarray | None = None,
    n_candidates: int = 64,
) -> np.ndarray:
    """Transfer skinning weights from a body surface to points near it.

    Each point takes the barycentric blend of the weights at its closest body surface point.
    With ``point_normals``, a closest point on a body surface that faces the other way (an arm
    or hand resting on the torso under a garment: the garment's outer side meets the arm's
    underside) is rejected: such a point takes instead the weights of its nearest body vertex
    among ``n_candidates`` whose normal agrees with its own. The points' normals are flipped
    first if most of them disagree with the body (inward-oriented garment meshes).
    Optionally the result is smoothed on the points' own mesh (``faces``) with
    ``smooth_iterations`` steps of uniform Laplacian smoothing ``W <- (1-a) W + a mean(W_nbrs)``,
    which removes seams where neighbouring points snap to different body parts.

    Parameters
    ----------
    body_V : (n, 3) float64 body vertices (posed or rest, the frame of ``points``).
    body_F : (m, 3) int64 body faces.
    body_W : (n, j) float64 body skinning weights.
    points : (p, 3) float64 points (e.g. garment vertices).
    faces : (k, 3) int64 faces over ``points``, needed only for smoothing.
    smooth_iterations : number of smoothing steps (0: none).
    smooth_alpha : smoothing step size in (0, 1].
    point_normals : (p, 3) float64 normals of ``points`` (e.g. garment vertex normals), or None.
    n_candidates : body vertices searched for a point whose closest point faces away.

    Returns
    -------
    (p, j) float64 weights, rows non-negative and summing to 1.
    """
    body_V = _check(body_V, "body_V", (None, 3))
    body_W = _check(body_W, "body_W", (body_V.shape[0], None))
    points = _check(points, "points", (None, 3))
    body_F = np.asarray(body_F, dtype=np.int64)
    if body_F.ndim != 2 or body_F.shape[1] != 3 or body_F.size == 0:
        raise ValueError(f"body_F: expected shape (m, 3), got {body_F.shape}")
    if body_F.min() < 0 or body_F.max() >= body_V.shape[0]:
        raise ValueError("body_F: face indices out of range of body_V")
    if smooth_iterations < 0 or not (0 < smooth_alpha <= 1):
        raise ValueError("smooth_iterations must be >= 0 and smooth_alpha in (0, 1]")
    if points.shape[0] == 0:
        return np.zeros((0, body_W.shape[1]))
    _, _, fid, bary = closest_surface_points(body_V, body_F, points)
    W = np.einsum("pk,pkj->pj", bary, body_W[body_F[fid]])
    if point_normals is not None:
        N = _check(point_normals, "point_normals", (points.shape[0], 3))
        W = _reject_facing_away(body_V, body_F, body_W, points, N, fid, bary, W, n_candidates)
    if smooth_iterations:
        if faces is None:
            raise ValueError("faces: needed to smooth the transferred weights")
        # heavy: scipy.sparse
        import scipy.sparse as sp

        from dressmeup.geometry.laplacian import adjacency

        faces = np.asarray(faces, dtype=np.int64)
        if faces.ndim != 2 or faces.shape[1] != 3 or faces.max() >= points.shape[0]:
            raise ValueError(f"faces: expected (k, 3) indices into points, got {faces.shape}")
        A = adjacency(faces, points.shape[0])
        deg = np.asarray(A.sum(1)).ravel()
        M = sp.diags(1.0 / np.maximum(deg, 1)) @ A
        isolated = deg == 0
        for _ in range(int(smooth_iterations)):
            Wn = M @ W
            Wn[isolated] = W[isolated]
            W = (1 - smooth_alpha) * W + smooth_alpha * Wn
    W = np.maximum(W, 0.0)
    return W / np.maximum(W.sum(1, keepdims=True), 1e-12)


def _reject_facing_away(body_V: np.ndarray, body_F: np.ndarray, body_W: np.ndarray,
                        points: np.ndarray, normals: np.ndarray, fid: np.ndarray, bary: np.ndarray,
                        W: np.ndarray, n_candidates: int) -> np.ndarray:
    """Re-assign the points whose closest body point faces against their own normal.

    The body normal at the closest point is the barycentric blend of its face's vertex
    normals, which is the same whichever face a closest point on a shared edge or vertex is
    reported in (a face normal is not: which face wins such a tie depends on the last bits of
    the body vertices, and flipped the test for garment points near armpits and crotches
    between two builds of the same body).
    """
    # heavy: scipy.spatial
    from scipy.spatial import cKDTree

    vert_n = vertex_normals(body_V, body_F)
    at = np.einsum("pk,pkc->pc", bary, vert_n[body_F[fid]])
    dots = np.einsum("pc,pc->p", normals, at)
    if np.count_nonzero(dots < 0) > np.count_nonzero(dots > 0):
        normals, dots = -normals, -dots
    bad = np.flatnonzero(dots < 0)
    if bad.size == 0:
        return W
    k = int(min(max(n_candidates, 1), body_V.shape[0]))
    _, idx = cKDTree(body_V).query(points[bad], k=k)
    idx = idx.reshape(bad.size, k)
    agree = np.einsum("bkc,bc->bk", vert_n[idx], normals[bad]) > 0
    found = agree.any(axis=1)
    chosen = idx[np.arange(bad.size), np.argmax(agree, axis=1)]
    W = W.copy()
    W[bad[found]] = body_W[chosen[found]]
    return W


def _blend(weights: np.ndarray, transforms: np.ndarray, n: int) -> np.ndarray:
    weights = _check(weights, "weights", (n, None))
    transforms = _check(transforms, "transforms", (weights.shape[1], 4, 4))
    return np.einsum("pj,jkl->pkl", weights, transforms)


def lbs(points: np.ndarray, weights: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """Pose rest-pose points with linear blend skinning.

    Parameters
    ----------
    points : (p, 3) float64 rest-pose points.
    weights : (p, j) float64 skinning weights (rows sum to 1).
    transforms : (j, 4, 4) float64 LBS matrices (e.g. ``model.posed(params).transforms``).

    Returns
    -------
    (p, 3) float64 posed points (apply ``scale`` and ``transl`` afterwards if needed).
    """
    points = _check(points, "points", (None, 3))
    T = _blend(weights, transforms, points.shape[0])
    return np.einsum("pkl,pl->pk", T[:, :3, :3], points) + T[:, :3, 3]


def unpose(points: np.ndarray, weights: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """Inverse of :func:`lbs`: bring posed points back to the rest pose.

    Each point is mapped by the inverse of its blended matrix, so
    ``lbs(unpose(x, W, A), W, A) == x`` up to rounding.

    Parameters
    ----------
    points : (p, 3) float64 posed points (with ``scale``/``transl`` already removed).
    weights : (p, j) float64 skinning weights.
    transforms : (j, 4, 4) float64 LBS matrices.

    Returns
    -------
    (p, 3) float64 rest-pose points.
    """
    points = _check(points, "points", (None, 3))
    T = _blend(weights, transforms, points.shape[0])
    R = T[:, :3, :3]
    return np.linalg.solve(R, (points - T[:, :3, 3])[..., None])[..., 0]


inverse_lbs = unpose
