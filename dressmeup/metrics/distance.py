"""Distance metrics: P2S, Chamfer, ED, and the distance of points to a surface or a point set
(:func:`distances_to`, behind the fusion-quality family of :mod:`dressmeup.metrics.reconstruction`).
Units are those of the input (metres in the toolkit); every distance is computed and returned
in float64."""

from __future__ import annotations

from typing import Any

import numpy as np

from dressmeup.geometry.mesh import as_faces
from dressmeup.geometry.neighbors import build_tree, knn
from dressmeup.geometry.proximity import closest_points
from dressmeup.geometry.sampling import sample_surface
from dressmeup.metrics._common import (
    DEFAULT_SAMPLES,
    TopologyMismatchError,
    check_samples,
    mesh_arrays,
    points_of,
    surface_or_points,
)

__all__ = [
    "p2s",
    "p2s_details",
    "p2s_bidirectional",
    "chamfer",
    "chamfer_details",
    "euclidean",
    "euclidean_details",
    "distances_to",
]


# ------------------------------------------------------------------------------------ P2S
def p2s_details(points: Any, surface: Any) -> np.ndarray:
    """Per-point exact distance from ``points`` to the triangle surface ``surface``.

    Parameters
    ----------
    points : (q, 3) float array
        Query points (a mesh argument gives its vertices).
    surface : trimesh.Trimesh or tuple (V (n, 3) float, F (m, 3) int)
        The reference surface.

    Returns
    -------
    (q,) float64 ndarray
        Point-to-triangle Euclidean distances (not point-to-vertex).

    Raises
    ------
    ValueError
        Bad shapes, NaN/inf, out-of-range faces or empty inputs.
    """
    P = points_of(points, "points")
    V, F = mesh_arrays(surface, "surface")
    return closest_points(V, F, P)[0]


def p2s(points: Any, surface: Any) -> float:
    """P2S: mean exact point-to-surface distance (docs/spec.md section 1).

    Parameters
    ----------
    points : (q, 3) float array
        Query points; benchmark use: uniform surface samples of the prediction.
    surface : trimesh.Trimesh or tuple (V (n, 3) float, F (m, 3) int)
        The surface (benchmark use: the ground truth).

    Returns
    -------
    float
        Mean distance, in the units of the input (lower is better).

    See Also
    --------
    p2s_details : per-point distances.
    p2s_bidirectional : both directions from surface samples.
    """
    return float(np.mean(p2s_details(points, surface)))


def p2s_bidirectional(a: Any, b: Any, n_samples: int = DEFAULT_SAMPLES, seed: int = 0) -> float:
    """Symmetric P2S: mean of P2S(samples of a -> b) and P2S(samples of b -> a).

    Parameters
    ----------
    a, b : trimesh.Trimesh or tuple (V (n, 3) float, F (m, 3) int)
        The two meshes (e.g. prediction and ground truth).
    n_samples : int
        Uniform surface samples drawn on each mesh (default 100,000).
    seed : int
        Sampling seed; ``a`` uses ``seed`` and ``b`` uses ``seed + 1``.

    Returns
    -------
    float
        ``(P2S(a->b) + P2S(b->a)) / 2`` (lower is better).
    """
    n = check_samples(n_samples)
    Va, Fa = mesh_arrays(a, "a")
    Vb, Fb = mesh_arrays(b, "b")
    pa = sample_surface(Va, Fa, n, seed=seed)[0]
    pb = sample_surface(Vb, Fb, n, seed=seed + 1)[0]
    return 0.5 * (
        float(closest_points(Vb, Fb, pa)[0].mean()) + float(closest_points(Va, Fa, pb)[0].mean())
    )


# -------------------------------------------------------------------------------- Chamfer
def chamfer_details(a: Any, b: Any) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-neighbour distances between two point sets, both ways.

    Parameters
    ----------
    a : (p, 3) float array
    b : (q, 3) float array
        Point sets (a mesh argument gives its vertices).

    Returns
    -------
    d_ab : (p,) float64 ndarray
        For each point of ``a`` the distance (not squared) to its nearest point of ``b``.
    d_ba : (q,) float64 ndarray
        For each point of ``b`` the distance to its nearest point of ``a``.
    """
    A = points_of(a, "a")
    B = points_of(b, "b")
    # one tree per cloud; each cloud is queried in its own tree's leaf order (cache-friendly)
    ta, tb = build_tree(A), build_tree(B)
    d_ab = np.empty(A.shape[0])
    d_ba = np.empty(B.shape[0])
    oa, ob = ta.indices, tb.indices
    d_ab[oa] = tb.query(A[oa], k=1, workers=-1)[0]
    d_ba[ob] = ta.query(B[ob], k=1, workers=-1)[0]
    return d_ab, d_ba


def chamfer(a: Any, b: Any, squared: bool = True) -> float:
    """Chamfer distance: mean over ``a`` of the squared distance to the nearest point of
    ``b`` plus the same from ``b`` to ``a`` (pytorch3d / kaolin convention: a sum of two
    means, not halved).

    Parameters
    ----------
    a : (p, 3) float array
    b : (q, 3) float array
        Point sets; benchmark use: 100,000 uniform surface samples per mesh.
    squared : bool
        ``True`` (default): squared distances (units^2). ``False``: plain distances.

    Returns
    -------
    float
        Lower is better.
    """
    d_ab, d_ba = chamfer_details(a, b)
    if squared:
        return float(np.mean(d_ab * d_ab) + np.mean(d_ba * d_ba))
    return float(np.mean(d_ab) + np.mean(d_ba))


# ------------------------------------------------------------------------------------- ED
def euclidean_details(
    pred_vertices: Any, gt_vertices: Any, pred_faces: Any = None, gt_faces: Any = None
) -> np.ndarray:
    """Per-vertex L2 distance between two meshes of identical topology.

    Parameters
    ----------
    pred_vertices, gt_vertices : (n, 3) float arrays (or meshes, whose faces are then compared)
    pred_faces, gt_faces : (m, 3) int arrays, optional
        When both are given (or both inputs are meshes) they must be identical.

    Returns
    -------
    (n,) float64 ndarray

    Raises
    ------
    TopologyMismatchError
        Different vertex counts or different faces.
    ValueError
        Bad shapes or NaN/inf.
    """
    if (
        pred_faces is None
        and hasattr(pred_vertices, "faces")
        and not isinstance(pred_vertices, np.ndarray)
    ):
        pred_faces = pred_vertices.faces
    if (
        gt_faces is None
        and hasattr(gt_vertices, "faces")
        and not isinstance(gt_vertices, np.ndarray)
    ):
        gt_faces = gt_vertices.faces
    if isinstance(pred_vertices, tuple) and len(pred_vertices) == 2:
        pred_vertices, pred_faces = pred_vertices
    if isinstance(gt_vertices, tuple) and len(gt_vertices) == 2:
        gt_vertices, gt_faces = gt_vertices
    P = points_of(pred_vertices, "pred_vertices")
    G = points_of(gt_vertices, "gt_vertices")
    if P.shape != G.shape:
        raise TopologyMismatchError(
            f"ED needs identical topology: pred has {P.shape[0]} vertices, gt has {G.shape[0]}"
        )
    if pred_faces is not None and gt_faces is not None:
        pf = as_faces(pred_faces, P.shape[0], name="pred_faces")
        gf = as_faces(gt_faces, G.shape[0], name="gt_faces")
        if pf.shape != gf.shape or not np.array_equal(pf, gf):
            raise TopologyMismatchError(
                f"ED needs identical topology: the faces differ (pred {pf.shape[0]} faces, gt {gf.shape[0]} faces"
                + (
                    f", {int(np.count_nonzero(np.any(pf != gf, axis=1)))} rows differ)"
                    if pf.shape == gf.shape
                    else ")"
                )
            )
    return np.linalg.norm(P - G, axis=1)


def euclidean(
    pred_vertices: Any, gt_vertices: Any, pred_faces: Any = None, gt_faces: Any = None
) -> float:
    """ED: mean per-vertex L2 distance; defined only for identical topology.

    Parameters
    ----------
    pred_vertices, gt_vertices : (n, 3) float arrays, or meshes
    pred_faces, gt_faces : (m, 3) int arrays, optional

    Returns
    -------
    float
        Lower is better.

    Raises
    ------
    TopologyMismatchError
        Different vertex counts, or different faces when faces are known for both.
    """
    return float(np.mean(euclidean_details(pred_vertices, gt_vertices, pred_faces, gt_faces)))


# ---------------------------------------------------------------- to a surface or points
def distances_to(points: np.ndarray, target: Any) -> np.ndarray:
    """Distance of each point to ``target``: to its surface when it is a mesh, else to its
    nearest point.

    Parameters
    ----------
    points : (q, 3) float array
    target : mesh (trimesh or (V, F)) or (r, 3) float array

    Returns
    -------
    (q,) float64 ndarray
    """
    P = points_of(points, "points")
    T, F = surface_or_points(target, "target")
    if F is None:
        return knn(T, P, 1)[0][:, 0]
    return closest_points(T, F, P)[0]
