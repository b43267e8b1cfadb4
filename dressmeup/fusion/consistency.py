"""Depth consistency between cameras: does each camera's depth land where the others' does?

A camera whose intrinsics or pose are wrong still fuses into a scan, only a worse one. Each
camera's depth, back-projected with the camera its frames carry, is compared with the other
cameras' depth in the common (world) frame: the figure of a camera is the median distance of
its points to the nearest point of any other camera, over the points that have one within
the overlap radius (the region the cameras share). A camera whose figure is well above the
cameras' median is reported.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.capture.frame import RGBDFrame, frame_camera
from dressmeup.fusion.icp import backproject

__all__ = ["ConsistencyConfig", "ConsistencyReport", "depth_consistency"]


@dataclass
class ConsistencyConfig:
    """How depth consistency is measured and judged.

    Attributes
    ----------
    overlap_radius : float, metres; a point with another camera's point within this distance
        lies in the overlap (farther ones are surface the others did not see).
    min_overlap_points : int, a camera with fewer points in the overlap gets no figure (it
        overlaps too little to be judged).
    query_columns : int, every camera's points are taken at every k-th pixel, k chosen to
        give about this many columns (their spacing adds to the distances: a camera's figure
        compares with the other cameras' figures, not with the noise).
    outlier_ratio : float, a camera is an outlier when its figure exceeds this multiple of the
        median of the cameras' figures ...
    outlier_min_mm : float, ... and this many millimetres (noise alone never flags a camera).
    """

    overlap_radius: float = 0.05
    min_overlap_points: int = 200
    query_columns: int = 160
    outlier_ratio: float = 1.5
    outlier_min_mm: float = 5.0


@dataclass
class ConsistencyReport:
    """Per-camera depth consistency.

    Attributes
    ----------
    median_mm : dict serial -> median distance (mm) of the camera's points to the other
        cameras' depth (all of them) over the overlap, or None when it overlaps too little.
    overlap : dict serial -> share of the camera's points in the overlap.
    outliers : list of serials judged inconsistent, worst first.
    reference_mm : float or None, the median of the figures the last judgement compared with
        (the cameras not found inconsistent, measured against each other).
    rule : str, the outlier rule, in words.
    """

    median_mm: dict[str, float | None]
    overlap: dict[str, float]
    outliers: list[str]
    reference_mm: float | None
    rule: str
    config: ConsistencyConfig = field(default_factory=ConsistencyConfig)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: figures in mm rounded to 0.01, overlaps to 0.001."""
        return {"median_mm": {s: None if v is None else round(v, 2) for s, v in self.median_mm.items()},
                "overlap": {s: round(v, 3) for s, v in self.overlap.items()},
                "outliers": list(self.outliers),
                "reference_mm": None if self.reference_mm is None else round(self.reference_mm, 2),
                "rule": self.rule}


def _points(frames: list[RGBDFrame], stride: int) -> np.ndarray:
    """World points of the frames' depth at every ``stride``-th pixel: (k, 3) float64."""
    return np.concatenate([np.zeros((0, 3))] + [backproject(fr, stride)[0] for fr in frames])


def depth_consistency(frames: list[RGBDFrame], config: ConsistencyConfig | None = None) -> ConsistencyReport:
    """Each camera's depth against the other cameras' depth, in the world frame.

    Parameters
    ----------
    frames : list of RGBDFrame (undistorted, filtered), each carrying its camera; the frames
        of one serial are one camera.
    config : ConsistencyConfig

    Returns
    -------
    ConsistencyReport (no figures when fewer than two cameras have depth).
    """
    cfg = config or ConsistencyConfig()
    by_serial: dict[str, list[RGBDFrame]] = {}
    for fr in frames:
        by_serial.setdefault(fr.serial, []).append(fr)
    width = max(frame_camera(fr).width for fr in frames) if frames else 1
    stride = max(1, int(round(width / cfg.query_columns)))
    serials = list(by_serial)
    points = [_points(by_serial[s], stride) for s in serials]
    label = np.repeat(np.arange(len(serials)), [len(p) for p in points])
    P = np.concatenate(points) if points else np.zeros((0, 3))
    # one tree of every camera's points; each point's nearest point of another camera is among
    # its few nearest (its own camera's are a sampling step apart), else looked for further
    # unbalanced, without node shrinking: builds in about half the time, answers as fast here
    tree = cKDTree(P, balanced_tree=False, compact_nodes=False) if len(P) else None
    nearest_d = np.full(len(P), np.inf)
    nearest_cam = np.full(len(P), -1)
    todo = np.arange(len(P))
    for k in (8, 64):
        if tree is None or not len(todo):
            break
        dd, ii = tree.query(P[todo], k=min(k, len(P)), distance_upper_bound=cfg.overlap_radius)
        dd, ii = dd.reshape(len(todo), -1), ii.reshape(len(todo), -1)
        lab = np.where(ii < len(P), label[np.minimum(ii, len(P) - 1)], -1)
        other = (lab >= 0) & (lab != label[todo, None])
        first = other.argmax(axis=1)
        found = other.any(axis=1)
        rows = np.arange(len(todo))[found]
        nearest_d[todo[found]] = dd[rows, first[found]]
        nearest_cam[todo[found]] = lab[rows, first[found]]
        # undecided: all k neighbours within the radius were the point's own camera's
        todo = todo[~found & np.isfinite(dd[:, -1])]

    def figures(left_out: list[str]) -> tuple[dict[str, float | None], dict[str, float]]:
        med: dict[str, float | None] = {}
        share: dict[str, float] = {}
        skip = [serials.index(o) for o in left_out]
        for i, s in enumerate(serials):
            mine = label == i
            d, cam = nearest_d[mine], nearest_cam[mine]
            share[s] = float(np.isfinite(d).mean()) if len(d) else 0.0
            # points whose nearest counterpart belongs to a camera found inconsistent say nothing
            inside = d[np.isfinite(d) & ~np.isin(cam, skip)]
            med[s] = 1000 * float(np.median(inside)) if len(inside) >= cfg.min_overlap_points else None
        return med, share

    median, overlap = figures([])
    # worst first: a camera's errors also raise its neighbours' figures, so each next camera is
    # judged on its points whose nearest counterpart is not a camera already found inconsistent
    outliers: list[str] = []
    reference = None
    current = median
    while len(outliers) < len(serials) // 2:
        judged = {s: v for s, v in current.items() if v is not None and s not in outliers}
        if len(judged) < 3:
            break
        reference = float(np.median(list(judged.values())))
        worst = max(judged, key=judged.__getitem__)
        if not (judged[worst] > cfg.outlier_ratio * reference and judged[worst] > cfg.outlier_min_mm):
            break
        outliers.append(worst)
        current, _ = figures(outliers)
    rule = (f"median distance > {cfg.outlier_ratio:g} x the cameras' median and > {cfg.outlier_min_mm:g} mm, "
            f"worst camera first, each next one judged on its points nearest to the cameras not found (overlap: a point of another "
            f"camera within {1000 * cfg.overlap_radius:g} mm; a figure needs {cfg.min_overlap_points} such "
            f"points, a judgement 3 cameras with figures)")
    return ConsistencyReport(median, overlap, outliers, reference, rule, cfg)
