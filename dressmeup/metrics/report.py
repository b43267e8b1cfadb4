"""Every applicable metric for a prediction / ground-truth pair of meshes, in one call.

Used by ``dressmeup metrics PRED GT`` and by anything that wants the same table. Surface
samples are drawn once per mesh (``seed`` for the prediction, ``seed + 1`` for the ground
truth, as in :func:`~dressmeup.metrics.p2s_bidirectional` and
:func:`~dressmeup.metrics.fusion_quality`), so every sampled figure here equals the one the
single-metric functions give with the same arguments.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from dressmeup.geometry.proximity import closest_points
from dressmeup.geometry.sampling import sample_surface
from dressmeup.metrics._common import (
    DEFAULT_SAMPLES,
    TopologyMismatchError,
    check_samples,
    mesh_arrays,
)
from dressmeup.metrics.distance import chamfer_details, euclidean
from dressmeup.metrics.normals import normal_consistency_details
from dressmeup.metrics.penetration import interpenetration_ratio, penetrating_vertex_fraction
from dressmeup.metrics.reconstruction import DEFAULT_FSCORE_THRESHOLDS
from dressmeup.metrics.uv import ase_details, qce_details
from dressmeup.metrics.uv_layout import uv_validity

__all__ = ["MetricValue", "compare_meshes", "uv_report", "scale_mismatch"]

#: Extent ratio beyond which two meshes of the same thing are taken to be in different
#: units (centimetres against metres is 100, millimetres 1000; a garment on another body
#: changes its extent by tens of per cent).
UNIT_RATIO = 20.0


@dataclass
class MetricValue:
    """One figure of a report.

    Attributes
    ----------
    name : str
        Short name (``"P2S"``, ``"Chamfer"``, ...).
    value : float or None
        In SI units (metres, square metres) or unitless; ``None`` when not applicable.
    unit : str
        ``"m"``, ``"m^2"``, ``"fraction"`` or ``""``.
    better : str
        ``"lower"`` or ``"higher"`` (or ``"1"`` / ``"0"`` when an ideal value is the target).
    note : str
        Why a value is missing, or what the figure is computed on.
    """

    name: str
    value: float | None
    unit: str
    better: str
    note: str = ""

    def as_dict(self) -> dict[str, Any]:
        """Plain dictionary (JSON-ready)."""
        return asdict(self)


def compare_meshes(
    pred: Any,
    gt: Any,
    body: Any = None,
    n_samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
    pred_uv: tuple[np.ndarray, np.ndarray | None] | None = None,
    thresholds: tuple[float, ...] = DEFAULT_FSCORE_THRESHOLDS,
) -> list[MetricValue]:
    """All applicable metrics of ``pred`` against ``gt`` (and ``body`` for IR).

    Parameters
    ----------
    pred, gt : trimesh.Trimesh or tuple (V (n, 3) float, F (m, 3) int)
    body : mesh, optional
        When given, IR and the penetrating-vertex share of ``pred`` are added.
    n_samples : int
        Uniform surface samples per mesh (default 100,000).
    seed : int
        Sampling seed (pred: ``seed``, gt: ``seed + 1``).
    pred_uv : tuple (uv, uv_faces or None), optional
        UVs of ``pred``: adds QCE, ASE and UV validity.
    thresholds : tuple of float
        F-score thresholds in metres.

    Returns
    -------
    list of MetricValue
        In a fixed order: P2S, P2S (bidirectional), Chamfer, Chamfer-L1, F-scores, ED, NC,
        then IR / penetration and UV figures when applicable.
    """
    n = check_samples(n_samples)
    Vp, Fp = mesh_arrays(pred, "pred")
    Vg, Fg = mesh_arrays(gt, "gt")
    out = _distance_figures(Vp, Fp, Vg, Fg, n, seed, thresholds)
    try:
        out.append(MetricValue("ED", euclidean((Vp, Fp), (Vg, Fg)), "m", "lower"))
    except TopologyMismatchError as exc:
        out.append(MetricValue("ED", None, "m", "lower", f"not applicable: {exc}"))
    nc = normal_consistency_details((Vp, Fp), (Vg, Fg), n_samples=n, seed=seed)
    out.append(MetricValue("NC", nc.value, "", "higher", f"{nc.mode} normals"))
    if body is not None:
        out.append(
            MetricValue(
                "IR",
                interpenetration_ratio((Vp, Fp), body),
                "fraction",
                "lower",
                "garment area inside the body",
            )
        )
        out.append(
            MetricValue(
                "Penetrating vertices", penetrating_vertex_fraction(Vp, body), "fraction", "lower"
            )
        )
    if pred_uv is not None:
        out.extend(uv_report(Vp, Fp, pred_uv[0], pred_uv[1]))
    return out


def _distance_figures(Vp: np.ndarray, Fp: np.ndarray, Vg: np.ndarray, Fg: np.ndarray, n: int,
                      seed: int, thresholds: tuple[float, ...]) -> list[MetricValue]:
    """P2S (one way and both), Chamfer, Chamfer-L1 and the F-scores from one draw of ``n``
    surface samples per mesh (pred: ``seed``, gt: ``seed + 1``)."""
    pp = sample_surface(Vp, Fp, n, seed=seed)[0]
    pg = sample_surface(Vg, Fg, n, seed=seed + 1)[0]
    d_pg = closest_points(Vg, Fg, pp)[0]
    d_gp = closest_points(Vp, Fp, pg)[0]
    c_ab, c_ba = chamfer_details(pp, pg)
    out = [
        MetricValue("P2S", float(d_pg.mean()), "m", "lower", f"{n} pred samples to the GT surface"),
        MetricValue(
            "P2S (bidirectional)",
            0.5 * float(d_pg.mean() + d_gp.mean()),
            "m",
            "lower",
            "mean of both directions",
        ),
        MetricValue(
            "Chamfer",
            float(np.mean(c_ab**2) + np.mean(c_ba**2)),
            "m^2",
            "lower",
            "sum of two means of squared distances",
        ),
        MetricValue(
            "Chamfer-L1",
            0.5 * float(d_pg.mean() + d_gp.mean()),
            "m",
            "lower",
            "(accuracy + completeness) / 2",
        ),
    ]
    for t in thresholds:
        p, r = float(np.mean(d_pg < t)), float(np.mean(d_gp < t))
        f = 0.0 if p + r == 0 else 2 * p * r / (p + r)
        out.append(MetricValue(f"F-score@{t * 1000:g}mm", f, "fraction", "higher"))
    return out


def uv_report(
    vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, uv_faces: np.ndarray | None = None
) -> list[MetricValue]:
    """QCE, ASE and UV validity of one UV layout as report lines.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) or (k, 2) float array
    uv_faces : (m, 3) int array, optional

    Returns
    -------
    list of MetricValue
    """
    q = qce_details(vertices, faces, uv, uv_faces)
    a = ase_details(vertices, faces, uv, uv_faces)
    v = uv_validity(vertices, faces, uv, uv_faces)
    zero = f"; {q.n_zero_uv_area} faces with zero UV area excluded" if q.n_zero_uv_area else ""
    return [
        MetricValue(
            "QCE", q.mean, "", "lower", f"area-weighted mean, 1 is ideal; max {q.max:.4g}{zero}"
        ),
        MetricValue(
            "ASE",
            a.abs_mean,
            "",
            "lower",
            f"area-weighted mean |log ratio|, 0 is ideal; signed mean {a.mean:.4g}",
        ),
        MetricValue("UV flipped", v.flipped_fraction, "fraction", "lower"),
        MetricValue(
            "UV overlap",
            v.overlap_fraction,
            "fraction",
            "lower",
            f"grid estimate at {v.resolution} samples",
        ),
    ]


def scale_mismatch(V: np.ndarray, reference: np.ndarray, name: str = "prediction",
                   reference_name: str = "ground truth") -> str | None:
    """Why ``V`` looks like it is in other units than ``reference``, or None.

    Parameters
    ----------
    V, reference : (n, 3), (r, 3) float vertices.

    Returns
    -------
    A sentence naming both extents (bounding-box diagonals) when their ratio is beyond
    :data:`UNIT_RATIO` either way (e.g. millimetres against metres), else None.
    """
    a = float(np.linalg.norm(np.ptp(np.asarray(V, float), axis=0))) if len(V) else 0.0
    b = float(np.linalg.norm(np.ptp(np.asarray(reference, float), axis=0))) \
        if len(reference) else 0.0
    if a <= 0 or b <= 0 or not np.isfinite(a / b):
        return None
    ratio = a / b
    if 1.0 / UNIT_RATIO <= ratio <= UNIT_RATIO:
        return None
    return (f"the {name} spans {a:.4g} units, the {reference_name} {b:.4g} ({ratio:.3g} "
            "times): are they in different units (millimetres or centimetres against "
            "metres)? every file is in metres")
