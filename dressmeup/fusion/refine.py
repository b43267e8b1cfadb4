"""Extrinsic refinement that never makes a calibration worse.

Multiway ICP (:mod:`dressmeup.fusion.icp`) proposes a pose per camera. A proposal is kept
only when

- it moves the camera less than ``max_rotation_deg`` / ``max_translation_m`` from the pose
  it came with (a calibrated rig or a tracker is trusted to that extent), and
- it lowers the camera's robust view-to-view residual by a margin: the residual of a pair of
  views is the median point-to-plane distance from each view's finest cloud to the other's,
  over the points that have a counterpart within ``residual_radius``; a camera's residual is
  the median over the pairs it belongs to. The margin is ``max(min_improvement_mm,
  min_improvement_rel * before)``.

Proposals are judged together (a camera's residual depends on its neighbours' poses): the
worst failing proposal is withdrawn and the others judged again, until every proposal left
passes. Flat walls and floors let ICP slide a view along them without lowering its residual;
such moves are withdrawn.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.frame import RGBDFrame, frame_camera
from dressmeup.fusion.icp import (
    ICPConfig,
    ViewClouds,
    candidate_pairs,
    optimize_pose_graph,
    pose_difference,
    register_pairs,
    view_clouds,
)
from dressmeup.geometry.neighbors import NearestTree

__all__ = ["ICPReport", "refine_extrinsics", "view_residuals"]

log = logging.getLogger(__name__)


@dataclass
class ICPReport:
    """What the refinement did.

    Attributes
    ----------
    edges : list of (serial_a, serial_b, fitness, inlier_rmse) pairwise registrations used.
    corrections : dict serial -> (rotation_deg, translation_m) applied to each camera (zeros
        for cameras left where they were).
    proposed : dict serial -> (rotation_deg, translation_m) that ICP proposed.
    refused : dict serial -> why a proposal was not kept.
    residual_before_mm, residual_after_mm : dict serial -> robust view-to-view residual (mm).
    seconds : float, wall-clock time.
    """

    edges: list[tuple[str, str, float, float]] = field(default_factory=list)
    corrections: dict[str, tuple[float, float]] = field(default_factory=dict)
    proposed: dict[str, tuple[float, float]] = field(default_factory=dict)
    refused: dict[str, str] = field(default_factory=dict)
    residual_before_mm: dict[str, float] = field(default_factory=dict)
    residual_after_mm: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0

    def as_dict(self) -> dict:
        """JSON-ready dictionary."""
        return {"edges": [list(e) for e in self.edges],
                "corrections_deg_m": {k: list(v) for k, v in self.corrections.items()},
                "proposed_deg_m": {k: list(v) for k, v in self.proposed.items()},
                "refused": dict(self.refused),
                "residual_before_mm": dict(self.residual_before_mm),
                "residual_after_mm": dict(self.residual_after_mm), "seconds": self.seconds}


def _pair_residual(views: Sequence[ViewClouds], trees: Sequence[NearestTree], poses: Sequence[np.ndarray],
                   i: int, j: int, radius: float) -> float:
    """Median point-to-plane distance between views i and j (both directions), metres."""
    dists = []
    for a, b in ((i, j), (j, i)):
        rel = np.linalg.inv(poses[b]) @ poses[a]
        p = views[a].points() @ rel[:3, :3].T + rel[:3, 3]
        d, idx = trees[b].query(p, distance_upper_bound=radius)
        ok = np.isfinite(d)
        if ok.any():
            q, n = views[b].points()[idx[ok]], views[b].normals()[idx[ok]]
            dists.append(np.abs(np.einsum("ij,ij->i", p[ok] - q, n)))
    if not dists:
        return float("nan")
    return float(np.median(np.concatenate(dists)))


def view_residuals(views: Sequence[ViewClouds], poses: Sequence[np.ndarray],
                   pairs: Sequence[tuple[int, int]], radius: float = 0.04,
                   trees: Sequence[NearestTree] | None = None) -> np.ndarray:
    """Robust view-to-view residual of each view (see the module docstring).

    Parameters
    ----------
    views : clouds per view (camera frames). poses : (4, 4) camera-to-world per view.
    pairs : (i, j) pairs that overlap. radius : float, metres.
    trees : NearestTree per view over its finest points (built when None).

    Returns
    -------
    (n_views,) float64 metres; NaN for a view in no pair.
    """
    trees = trees or [NearestTree(v.points()) for v in views]
    per_view: list[list[float]] = [[] for _ in views]
    for i, j in pairs:
        r = _pair_residual(views, trees, poses, i, j, radius)
        if np.isfinite(r):
            per_view[i].append(r)
            per_view[j].append(r)
    return np.array([np.median(r) if r else np.nan for r in per_view])


def _plausible(r, poses: Sequence[np.ndarray], cfg: ICPConfig) -> bool:
    """False for a pairwise result further from the starting relative pose than two cameras
    moved within the bounds could explain (ICP slid or diverged)."""
    deg, _ = pose_difference(np.linalg.inv(poses[r.j]) @ poses[r.i], r.T)
    # the relative translation change, measured where the pair's cameras are
    moved = np.linalg.norm((np.linalg.inv(poses[r.j]) @ poses[r.i])[:3, 3] - r.T[:3, 3])
    return deg <= 2 * cfg.max_rotation_deg and moved <= 2 * cfg.max_translation_m + 0.02 * deg


def _judge(views, trees, pairs, start, proposed, keep, cfg, before):
    """Withdraw failing proposals one at a time (the worst first) until all left pass."""
    while True:
        poses = [proposed[k] if keep[k] else start[k] for k in range(len(start))]
        after = view_residuals(views, poses, pairs, cfg.residual_radius, trees)
        margin = np.maximum(cfg.min_improvement_mm / 1000.0, cfg.min_improvement_rel * before)
        excess = after - (before - margin)  # > 0: not enough improvement
        failing = [k for k in range(len(start)) if keep[k] and not excess[k] < 0]
        if not failing:
            return poses, after
        worst = max(failing, key=lambda k: excess[k] if np.isfinite(excess[k]) else np.inf)
        keep[worst] = False


def refine_extrinsics(frames: Sequence[RGBDFrame], config: ICPConfig | None = None,
                      reference: str | None = None) -> tuple[dict[str, Camera], ICPReport]:
    """Refine the cameras the frames carry, keeping only refinements that lower residuals.

    Parameters
    ----------
    frames : one undistorted, filtered RGBDFrame per camera (depth in metres), each carrying
        its camera.
    config : ICPConfig (defaults when None).
    reference : serial of the camera that does not move (default: the first frame's).

    Returns
    -------
    cameras : dict serial -> Camera (the kept refinements; the others as they came).
    report : ICPReport

    Raises
    ------
    ValueError when ``reference`` is not among the frames or two frames share a serial.
    """
    cfg = config or ICPConfig()
    t_start = time.perf_counter()
    serials = [f.serial for f in frames]
    if len(set(serials)) != len(serials):
        raise ValueError("frames: expected one frame per camera")
    cams = {f.serial: frame_camera(f) for f in frames}
    report = ICPReport()
    if len(frames) < 2:
        log.warning("ICP refinement needs >= 2 views; skipped")
        return cams, report
    reference = serials[0] if reference is None else reference
    if reference not in serials:
        raise ValueError(f"reference: camera {reference!r} has no frame (cameras: {serials})")
    ref = serials.index(reference)
    start = [cams[s].camera_to_world.copy() for s in serials]
    views = [view_clouds(f, cfg) for f in frames]
    trees = [NearestTree(v.points()) for v in views]
    poses = list(start)
    pairs: list[tuple[int, int]] = []
    last_round = 0.0
    deadline = t_start + cfg.time_limit_s
    for _round in range(cfg.rounds):
        t_round = time.perf_counter()
        if _round and t_round + last_round > deadline:
            break
        pairs = candidate_pairs(views, poses, cfg)
        results = [r for r in register_pairs(views, poses, pairs, cfg, deadline)
                   if r.overlap >= cfg.min_overlap and r.fitness > 0 and _plausible(r, poses, cfg)]
        if not results:
            log.warning("no overlapping camera pairs found; extrinsics left unchanged")
            break
        report.edges = [(serials[r.i], serials[r.j], r.fitness, r.rmse) for r in results]
        poses = optimize_pose_graph(poses, results, ref, cfg.max_correspondence[-1])
        last_round = time.perf_counter() - t_round
    pairs = pairs or candidate_pairs(views, start, cfg)
    before = view_residuals(views, start, pairs, cfg.residual_radius, trees)
    keep = [k != ref for k in range(len(frames))]
    for k, s in enumerate(serials):
        report.proposed[s] = pose_difference(start[k], poses[k])
        deg, m = report.proposed[s]
        if keep[k] and (deg > cfg.max_rotation_deg or m > cfg.max_translation_m):
            keep[k] = False
            report.refused[s] = (f"moves the camera {deg:.2f} deg / {1000 * m:.0f} mm, more than "
                                 f"{cfg.max_rotation_deg:g} deg / {1000 * cfg.max_translation_m:.0f} mm")
    proposals = list(keep)
    final, after = _judge(views, trees, pairs, start, poses, keep, cfg, before)
    out = {}
    for k, s in enumerate(serials):
        if proposals[k] and not keep[k]:
            report.refused[s] = ("does not lower the view-to-view residual by the margin"
                                 if max(report.proposed[s]) > 0 else
                                 "no reliable registration links it to the reference camera")
        out[s] = replace(cams[s], camera_to_world=final[k]) if keep[k] else cams[s]
        report.corrections[s] = pose_difference(start[k], final[k]) if keep[k] else (0.0, 0.0)
        report.residual_before_mm[s] = float(1000 * before[k])
        report.residual_after_mm[s] = float(1000 * after[k])
    report.seconds = time.perf_counter() - t_start
    return out, report
