"""Extrinsic refinement that never makes a calibration worse.

Multiway ICP (:mod:`dressmeup.fusion.icp`) proposes a pose per camera. A proposal is kept
only when

- it moves the camera less than ``max_rotation_deg`` / ``max_translation_m`` from the pose
  it came with (a calibrated rig or a tracker is trusted to that extent),
- it lowers the camera's robust view-to-view residual by a margin: the residual of a pair of
  views is the median point-to-plane distance from each view's finest cloud to the other's,
  over the points that have a counterpart within ``residual_radius``; a camera's residual is
  the median over the pairs it belongs to. The margin is ``max(min_improvement_mm,
  min_improvement_rel * before)``; and
- the data determine the move: the change of a pair's relative pose shifts the pair's
  overlap (the points with a counterpart at the starting poses) along the counterparts'
  normals by ``shift`` (RMS; ``shift^2 = d^T (H / N) d`` for the change ``d``, with ``H`` the
  pair's 6x6 point-to-plane information matrix over its ``N`` correspondences, evaluated
  exactly rather than linearised). A camera's significance is the median over its pairs
  of ``shift / sigma``, ``sigma`` the robust spread of the pair's residuals
  (1.4826 x their median absolute value at the judged poses); it must reach
  ``min_shift_sigma``. Depth sensors err coherently over a view (a structured-light
  sensor's disparity steps and radial depth distortion), so the effective number of
  independent residuals is small and a move that shifts the surfaces by less than their
  noise can be ICP fitting that error: on walls, floors and shelves it does, and it lowers
  the residual a little while turning the camera by up to a degree. A move along a
  direction the overlap does not constrain (sliding along a wall) shifts nothing and is
  refused too.

Proposals are judged together (a camera's residual and significance depend on its
neighbours' poses): every proposal that is not significant is withdrawn, otherwise the one
that misses the residual margin the most, and the others are judged again, until every
proposal left passes.
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
    significance : dict serial -> the proposal's shift / sigma when it was last judged (kept
        or withdrawn; see the module docstring), for the cameras whose proposal was judged.
    seconds : float, wall-clock time.
    """

    edges: list[tuple[str, str, float, float]] = field(default_factory=list)
    corrections: dict[str, tuple[float, float]] = field(default_factory=dict)
    proposed: dict[str, tuple[float, float]] = field(default_factory=dict)
    refused: dict[str, str] = field(default_factory=dict)
    residual_before_mm: dict[str, float] = field(default_factory=dict)
    residual_after_mm: dict[str, float] = field(default_factory=dict)
    significance: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0

    def as_dict(self) -> dict:
        """JSON-ready dictionary."""
        return {"edges": [list(e) for e in self.edges],
                "corrections_deg_m": {k: list(v) for k, v in self.corrections.items()},
                "proposed_deg_m": {k: list(v) for k, v in self.proposed.items()},
                "refused": dict(self.refused),
                "residual_before_mm": dict(self.residual_before_mm),
                "residual_after_mm": dict(self.residual_after_mm),
                "significance": dict(self.significance), "seconds": self.seconds}


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


def _pair_residuals(views: Sequence[ViewClouds], trees: Sequence[NearestTree], poses: Sequence[np.ndarray],
                    pairs: Sequence[tuple[int, int]], radius: float) -> dict[tuple[int, int], float]:
    """Residual of every pair (metres, NaN without counterparts)."""
    return {(i, j): _pair_residual(views, trees, poses, i, j, radius) for i, j in pairs}


def _per_view(per_pair: dict[tuple[int, int], float], n: int) -> np.ndarray:
    """Median over the pairs each view belongs to (NaN for a view in no pair)."""
    per_view: list[list[float]] = [[] for _ in range(n)]
    for (i, j), r in per_pair.items():
        if np.isfinite(r):
            per_view[i].append(r)
            per_view[j].append(r)
    return np.array([np.median(r) if r else np.nan for r in per_view])


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
    return _per_view(_pair_residuals(views, trees, poses, pairs, radius), len(views))


@dataclass
class _Overlap:
    """Correspondences of one pair at the starting poses: view ``a``'s finest points ``src``
    have their nearest counterparts ``dst`` in view ``b`` within the residual radius."""

    a: int
    b: int
    src: np.ndarray
    dst: np.ndarray


def _overlaps(views: Sequence[ViewClouds], trees: Sequence[NearestTree], poses: Sequence[np.ndarray],
              pairs: Sequence[tuple[int, int]], radius: float) -> dict[tuple[int, int], list[_Overlap]]:
    """Both directions' correspondences of every pair at ``poses``."""
    out = {}
    for i, j in pairs:
        out[(i, j)] = []
        for a, b in ((i, j), (j, i)):
            rel = np.linalg.inv(poses[b]) @ poses[a]
            d, idx = trees[b].query(views[a].points() @ rel[:3, :3].T + rel[:3, 3], distance_upper_bound=radius)
            ok = np.isfinite(d)
            out[(i, j)].append(_Overlap(a, b, np.nonzero(ok)[0], np.asarray(idx)[ok]))
    return out


def _shift(views: Sequence[ViewClouds], overlaps: Sequence[_Overlap], start: Sequence[np.ndarray],
           poses: Sequence[np.ndarray]) -> float:
    """RMS displacement along the counterparts' normals (metres) of a pair's overlap when
    the cameras go from ``start`` to ``poses`` (NaN without correspondences)."""
    disp = []
    for ov in overlaps:
        change = np.linalg.inv(poses[ov.b]) @ poses[ov.a] - np.linalg.inv(start[ov.b]) @ start[ov.a]
        p = views[ov.a].points()[ov.src]
        disp.append(np.einsum("ij,ij->i", p @ change[:3, :3].T + change[:3, 3], views[ov.b].normals()[ov.dst]))
    d = np.concatenate(disp) if disp else np.zeros(0)
    return float(np.sqrt(np.mean(d ** 2))) if len(d) else float("nan")


def _significance(views, overlaps, start, poses, per_pair, n: int) -> np.ndarray:
    """Per view: median over its pairs of shift / sigma (NaN for a view in no usable pair)."""
    per_view: list[list[float]] = [[] for _ in range(n)]
    for (i, j), ovs in overlaps.items():
        sigma = 1.4826 * per_pair.get((i, j), np.nan)
        z = _shift(views, ovs, start, poses) / sigma if sigma > 0 else np.nan
        if np.isfinite(z):
            per_view[i].append(z)
            per_view[j].append(z)
    return np.array([np.median(z) if z else np.nan for z in per_view])


def _plausible(r, poses: Sequence[np.ndarray], cfg: ICPConfig) -> bool:
    """False for a pairwise result further from the starting relative pose than two cameras
    moved within the bounds could explain (ICP slid or diverged)."""
    deg, _ = pose_difference(np.linalg.inv(poses[r.j]) @ poses[r.i], r.T)
    # the relative translation change, measured where the pair's cameras are
    moved = np.linalg.norm((np.linalg.inv(poses[r.j]) @ poses[r.i])[:3, 3] - r.T[:3, 3])
    return deg <= 2 * cfg.max_rotation_deg and moved <= 2 * cfg.max_translation_m + 0.02 * deg


def _judge(views, trees, pairs, start, proposed, keep, cfg, before):
    """Withdraw failing proposals until all left pass (see the module docstring).

    Returns the poses, the residuals after, each judged view's last significance and why
    each withdrawn proposal was withdrawn.
    """
    overlaps = _overlaps(views, trees, start, pairs, cfg.residual_radius)
    margin = np.maximum(cfg.min_improvement_mm / 1000.0, cfg.min_improvement_rel * before)
    judged: dict[int, float] = {}
    why: dict[int, str] = {}
    while True:
        poses = [proposed[k] if keep[k] else start[k] for k in range(len(start))]
        per_pair = _pair_residuals(views, trees, poses, pairs, cfg.residual_radius)
        after = _per_view(per_pair, len(start))
        sig = _significance(views, overlaps, start, poses, per_pair, len(start))
        judged.update((k, float(sig[k])) for k in range(len(start)) if keep[k])
        vague = [k for k in range(len(start)) if keep[k] and not sig[k] >= cfg.min_shift_sigma]
        for k in vague:  # all at once: one by one, the others' moves would stand out against them
            keep[k] = False
            why[k] = (f"not determined by the data: it shifts the overlaps by {sig[k]:.2f} x their "
                      f"noise, under {cfg.min_shift_sigma:g}")
        if vague:
            continue
        excess = after - (before - margin)  # > 0: not enough improvement
        failing = [k for k in range(len(start)) if keep[k] and not excess[k] < 0]
        if not failing:
            return poses, after, judged, why
        worst = max(failing, key=lambda k: excess[k] if np.isfinite(excess[k]) else np.inf)
        keep[worst] = False
        why[worst] = "does not lower the view-to-view residual by the margin"


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
    final, after, judged, why = _judge(views, trees, pairs, start, poses, keep, cfg, before)
    out = {}
    for k, s in enumerate(serials):
        if proposals[k] and not keep[k]:
            report.refused[s] = (why[k] if max(report.proposed[s]) > 0 else
                                 "no reliable registration links it to the reference camera")
        if k in judged:
            report.significance[s] = judged[k]
        out[s] = replace(cams[s], camera_to_world=final[k]) if keep[k] else cams[s]
        report.corrections[s] = pose_difference(start[k], final[k]) if keep[k] else (0.0, 0.0)
        report.residual_before_mm[s] = float(1000 * before[k])
        report.residual_after_mm[s] = float(1000 * after[k])
    report.seconds = time.perf_counter() - t_start
    return out, report
