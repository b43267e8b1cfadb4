"""Distance metrics: P2S, Chamfer, ED, and the fusion-quality family (accuracy,
completeness, Chamfer-L1, F-score). Units are those of the input (metres in the toolkit);
every distance is computed and returned in float64."""

from __future__ import annotations

from dataclasses import dataclass, field
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
    "FusionQuality",
    "fusion_quality",
    "accuracy",
    "completeness",
    "chamfer_l1",
    "fscore",
    "DEFAULT_FSCORE_THRESHOLDS",
]

#: Tanks-and-Temples style thresholds in metres (1, 2, 5, 10 mm).
DEFAULT_FSCORE_THRESHOLDS = (0.001, 0.002, 0.005, 0.01)


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


# ------------------------------------------------------------------------ fusion quality
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


def _samples(obj: Any, name: str, n: int, seed: int) -> tuple[np.ndarray, np.ndarray | None]:
    V, F = surface_or_points(obj, name)
    if F is None:
        return V, None
    return sample_surface(V, F, n, seed=seed)[0], F


@dataclass
class FusionQuality:
    """Reconstruction quality of a predicted surface against the ground truth.

    Attributes
    ----------
    accuracy : float
        Mean distance from prediction samples to the ground truth (lower is better).
    completeness : float
        Mean distance from ground-truth samples to the prediction (lower is better).
    chamfer_l1 : float
        ``(accuracy + completeness) / 2`` (halved; the reconstruction convention).
    precision, recall, fscore : dict[float, float]
        Per threshold (metres): share of prediction samples within it of the ground truth,
        share of ground-truth samples within it of the prediction, and their harmonic mean.
    d_pred_to_gt, d_gt_to_pred : ndarray
        The per-sample distances behind the figures.
    """

    accuracy: float
    completeness: float
    chamfer_l1: float
    precision: dict[float, float] = field(default_factory=dict)
    recall: dict[float, float] = field(default_factory=dict)
    fscore: dict[float, float] = field(default_factory=dict)
    d_pred_to_gt: np.ndarray | None = field(default=None, repr=False)
    d_gt_to_pred: np.ndarray | None = field(default=None, repr=False)

    def as_dict(self) -> dict[str, float]:
        """Flat dictionary: accuracy, completeness, chamfer_l1, fscore@<mm>mm, ..."""
        out = {
            "accuracy": self.accuracy,
            "completeness": self.completeness,
            "chamfer_l1": self.chamfer_l1,
        }
        for t in self.fscore:
            mm = f"{t * 1000:g}"
            out[f"precision@{mm}mm"] = self.precision[t]
            out[f"recall@{mm}mm"] = self.recall[t]
            out[f"fscore@{mm}mm"] = self.fscore[t]
        return out


def _f(p: float, r: float) -> float:
    return 0.0 if p + r == 0 else 2.0 * p * r / (p + r)


def fusion_quality(
    pred: Any,
    gt: Any,
    thresholds: tuple[float, ...] = DEFAULT_FSCORE_THRESHOLDS,
    n_samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
) -> FusionQuality:
    """Accuracy, completeness, Chamfer-L1 and F-scores of a reconstruction.

    Meshes are sampled uniformly (``n_samples`` points, ``seed`` for ``pred`` and ``seed + 1``
    for ``gt``) and distances go to the other *surface* (exact point-to-triangle); a bare
    point set (e.g. a scan without faces) is used as is, and distances to it go to its
    nearest point.

    Parameters
    ----------
    pred, gt : mesh (trimesh or (V, F)) or (p, 3) float array
    thresholds : tuple of float
        F-score thresholds in metres (default 1, 2, 5, 10 mm).
    n_samples : int
    seed : int

    Returns
    -------
    FusionQuality
    """
    n = check_samples(n_samples)
    ts = tuple(float(t) for t in thresholds)
    if any(not t > 0 for t in ts):
        raise ValueError(f"thresholds: expected positive distances, got {thresholds}")
    ps, _ = _samples(pred, "pred", n, seed)
    gs, _ = _samples(gt, "gt", n, seed + 1)
    d_pg = distances_to(ps, gt)
    d_gp = distances_to(gs, pred)
    acc = float(d_pg.mean())
    comp = float(d_gp.mean())
    prec = {t: float(np.mean(d_pg < t)) for t in ts}
    rec = {t: float(np.mean(d_gp < t)) for t in ts}
    fs = {t: _f(prec[t], rec[t]) for t in ts}
    return FusionQuality(acc, comp, 0.5 * (acc + comp), prec, rec, fs, d_pg, d_gp)


def accuracy(pred: Any, gt: Any, n_samples: int = DEFAULT_SAMPLES, seed: int = 0) -> float:
    """Mean distance from prediction samples to the ground truth (see :func:`fusion_quality`)."""
    ps, _ = _samples(pred, "pred", check_samples(n_samples), seed)
    return float(distances_to(ps, gt).mean())


def completeness(pred: Any, gt: Any, n_samples: int = DEFAULT_SAMPLES, seed: int = 0) -> float:
    """Mean distance from ground-truth samples to the prediction (see :func:`fusion_quality`)."""
    gs, _ = _samples(gt, "gt", check_samples(n_samples), seed + 1)
    return float(distances_to(gs, pred).mean())


def chamfer_l1(pred: Any, gt: Any, n_samples: int = DEFAULT_SAMPLES, seed: int = 0) -> float:
    """``(accuracy + completeness) / 2`` (halved, unlike ``chamfer(squared=False)``)."""
    return fusion_quality(pred, gt, (0.01,), n_samples, seed).chamfer_l1


def fscore(
    pred: Any, gt: Any, threshold: float = 0.01, n_samples: int = DEFAULT_SAMPLES, seed: int = 0
) -> float:
    """F-score at ``threshold`` metres (Tanks and Temples): harmonic mean of precision
    (prediction samples within ``threshold`` of the ground truth) and recall (ground-truth
    samples within ``threshold`` of the prediction), in [0, 1], higher is better.

    Parameters
    ----------
    pred, gt : mesh (trimesh or (V, F)) or (p, 3) float array
    threshold : float
        Distance threshold in metres (default 0.01 = 10 mm).
    n_samples, seed : see :func:`fusion_quality`

    Returns
    -------
    float
    """
    return fusion_quality(pred, gt, (threshold,), n_samples, seed).fscore[float(threshold)]
