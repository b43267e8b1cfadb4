"""Reconstruction quality, the fusion-quality family: accuracy, completeness, Chamfer-L1,
precision, recall and F-score (Tanks and Temples) of a predicted surface against the ground
truth, from one draw of surface samples per side. Units are those of the input (metres in the
toolkit); distances are float64 (:func:`dressmeup.metrics.distance.distances_to`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dressmeup.geometry.sampling import sample_surface
from dressmeup.metrics._common import DEFAULT_SAMPLES, check_samples, surface_or_points
from dressmeup.metrics.distance import distances_to

__all__ = [
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


def _samples(obj: Any, name: str, n: int, seed: int) -> tuple[np.ndarray, np.ndarray | None]:
    """``n`` surface samples of a mesh (and its faces), or a bare point set as is."""
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
