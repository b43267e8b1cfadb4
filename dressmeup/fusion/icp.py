"""Multiway ICP: pairwise multi-scale registration of overlapping views + a pose graph.

Each view's depth is back-projected into its own camera frame, downsampled coarse to fine
(voxel grids, at most ``max_points`` points per scale) with normals facing its camera. Pairs
of views whose optical axes differ by less than ``max_view_angle_deg`` and whose coarse
clouds overlap are registered by point-to-plane ICP with a robust (Tukey) kernel, all pairs
at one scale before the next finer one, within a time limit; the pairwise results become
edges of an open3d pose graph (Levenberg-Marquardt with line-process pruning of wrong edges)
whose optimum, the reference camera held fixed, gives each camera a candidate pose.
:mod:`dressmeup.fusion.refine` decides which candidates to keep.
"""

from __future__ import annotations

import copy
import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dressmeup.capture.frame import RGBDFrame, frame_camera
from dressmeup.geometry.neighbors import NearestTree

__all__ = ["ICPConfig", "ViewClouds", "PairResult", "backproject", "view_clouds", "candidate_pairs",
           "register_pairs", "optimize_pose_graph", "pose_difference"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ICPConfig:
    """Refinement settings (registration here; acceptance in :mod:`dressmeup.fusion.refine`).

    Attributes
    ----------
    voxel_sizes : tuple of float, metres, coarse-to-fine downsampling of the clouds.
    max_correspondence : tuple of float, metres, ICP correspondence radius per scale.
    max_points : int, at most this many points per cloud and scale (a seeded random subset).
    colored : bool, finish with coloured ICP (geometry + photometric terms).
    min_overlap : float, a pair is registered when this share of the smaller coarse cloud
        lies within the coarse correspondence radius of the other (and kept as a graph edge
        when it still does after alignment).
    max_neighbors : int, each view is registered to at most this many others (the ones it
        overlaps most).
    rounds : int, alternations of pairwise registration and graph optimisation.
    max_iterations : int, ICP iterations per scale.
    max_view_angle_deg : float, only cameras whose optical axes differ by less than this are
        registered to each other (opposite cameras see different sides of the body).
    time_limit_s : float, wall-clock limit of the registration; finer scales that would not
        fit are skipped and the pairs keep their coarser result.
    min_improvement_mm, min_improvement_rel : a camera's refined pose is kept only when its
        robust view-to-view residual falls by more than ``max(min_improvement_mm,
        min_improvement_rel * before)``.
    min_shift_sigma : float, and only when the move is determined by the data: it must shift
        the camera's overlaps with its neighbours, along their normals (RMS), by at least this
        many times the spread of their residuals (see :mod:`dressmeup.fusion.refine`).
    max_rotation_deg, max_translation_m : a refined pose that moves a camera further than
        this from its calibration is refused.
    residual_radius : float, metres, points further than this from the other view have no
        counterpart there and do not count in the residual.
    seed : int, seed of the point subsets.
    """

    voxel_sizes: tuple[float, ...] = (0.02, 0.01, 0.005)
    max_correspondence: tuple[float, ...] = (0.08, 0.03, 0.006)
    max_points: int = 20_000
    colored: bool = False
    min_overlap: float = 0.1
    max_neighbors: int = 4
    rounds: int = 2
    max_iterations: int = 30
    max_view_angle_deg: float = 80.0
    time_limit_s: float = 60.0
    min_improvement_mm: float = 0.1
    min_improvement_rel: float = 0.05
    min_shift_sigma: float = 1.0
    max_rotation_deg: float = 3.0
    max_translation_m: float = 0.05
    residual_radius: float = 0.04
    seed: int = 0

    def __post_init__(self) -> None:
        if len(self.voxel_sizes) != len(self.max_correspondence) or not self.voxel_sizes:
            raise ValueError("ICPConfig: voxel_sizes and max_correspondence must have the same, non-zero length")
        if self.time_limit_s <= 0 or self.max_points < 100 or self.rounds < 1:
            raise ValueError("ICPConfig: time_limit_s > 0, max_points >= 100 and rounds >= 1 are required")


@dataclass
class ViewClouds:
    """One view's point clouds in its own camera frame, one per scale (open3d PointClouds).

    Attributes
    ----------
    serial : str
    clouds : list of open3d.geometry.PointCloud, coarse to fine, with normals facing the camera.
    """

    serial: str
    clouds: list

    def points(self, scale: int = -1) -> np.ndarray:
        """(k, 3) float64 points of one scale (camera frame)."""
        return np.asarray(self.clouds[scale].points)

    def normals(self, scale: int = -1) -> np.ndarray:
        """(k, 3) float64 unit normals of one scale (camera frame)."""
        return np.asarray(self.clouds[scale].normals)


@dataclass
class PairResult:
    """A pairwise registration: ``T`` maps camera ``i``'s frame into camera ``j``'s.

    Attributes
    ----------
    i, j : int, view indices. T : (4, 4) float64. fitness, rmse : open3d's figures at the
    last scale run. information : (6, 6) float64. scales : int, how many scales ran.
    overlap : float, the fitness at the coarsest scale (share of view i's points with a
    counterpart in view j within the coarse radius).
    """

    i: int
    j: int
    T: np.ndarray
    fitness: float
    rmse: float
    information: np.ndarray
    scales: int
    overlap: float = 0.0


def backproject(frame: RGBDFrame, stride: int = 1, world: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Points and colours of a pinhole (undistorted) depth frame, with the frame's camera.

    Parameters
    ----------
    frame : RGBDFrame carrying its camera, depth in metres.
    stride : int, take every ``stride``-th pixel in each direction.
    world : bool, world coordinates (else the camera frame).

    Returns
    -------
    points : (k, 3) float64, colors : (k, 3) float64 in [0, 1].
    """
    cam = frame_camera(frame)
    d = frame.depth[::stride, ::stride]
    v, u = np.nonzero(d > 0)
    z = d[v, u].astype(np.float64)
    u = u * stride
    v = v * stride
    pc = np.stack([(u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z], axis=1)
    if world:
        pc = pc @ cam.camera_to_world[:3, :3].T + cam.camera_to_world[:3, 3]
    col = frame.color[v, u].astype(np.float64) / 255.0
    return pc, col


def pose_difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Rotation angle (degrees) and translation distance (metres) between two rigid transforms."""
    d = np.linalg.inv(a) @ b
    ang = np.degrees(np.arccos(np.clip((np.trace(d[:3, :3]) - 1) / 2, -1, 1)))
    return float(ang), float(np.linalg.norm(a[:3, 3] - b[:3, 3]))


def view_clouds(frame: RGBDFrame, config: ICPConfig) -> ViewClouds:
    """Coarse-to-fine clouds of one view in its camera frame (see :class:`ViewClouds`)."""
    import open3d as o3d  # heavy: open3d

    h, w = frame.depth.shape
    stride = max(1, round(math.sqrt(h * w / 80_000)))  # VGA: every 2nd pixel, enough for 5 mm voxels
    pts, col = backproject(frame, stride, world=False)
    rng = np.random.default_rng(config.seed)
    clouds = []
    for voxel in config.voxel_sizes:
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
        pcd.colors = o3d.utility.Vector3dVector(col)
        pcd = pcd.voxel_down_sample(voxel)
        if len(pcd.points) > config.max_points:
            pcd = pcd.select_by_index(np.sort(rng.choice(len(pcd.points), config.max_points, replace=False)))
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=voxel * 3, max_nn=30))
        pcd.orient_normals_towards_camera_location(np.zeros(3))
        clouds.append(pcd)
    return ViewClouds(frame.serial, clouds)


def candidate_pairs(views: Sequence[ViewClouds], poses: Sequence[np.ndarray], config: ICPConfig
                    ) -> list[tuple[int, int]]:
    """Pairs of views worth registering: close viewing directions and overlapping coarse clouds.

    Parameters
    ----------
    views : the views' clouds. poses : (4, 4) camera-to-world per view.
    config : ICPConfig (``max_view_angle_deg``, ``min_overlap``, ``max_neighbors``).

    Returns
    -------
    list of (i, j) with i < j.
    """
    n = len(views)
    world = [views[k].points(0) @ poses[k][:3, :3].T + poses[k][:3, 3] for k in range(n)]
    trees = [NearestTree(p) if len(p) else None for p in world]
    overlap = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            zi, zj = poses[i][:3, 2], poses[j][:3, 2]
            if np.degrees(np.arccos(np.clip(zi @ zj, -1, 1))) > config.max_view_angle_deg:
                continue
            if trees[j] is None or not len(world[i]):
                continue
            small, big = (i, j) if len(world[i]) <= len(world[j]) else (j, i)
            d, _ = trees[big].query(world[small], distance_upper_bound=config.max_correspondence[0])
            overlap[i, j] = overlap[j, i] = float(np.mean(np.isfinite(d)))
    keep = set()
    for i in range(n):
        order = [j for j in np.argsort(-overlap[i]) if overlap[i, j] >= config.min_overlap]
        keep.update((min(i, j), max(i, j)) for j in order[: config.max_neighbors])
    return sorted(keep)


def _icp_step(clouds: Sequence[Sequence], pair: PairResult, s: int, config: ICPConfig) -> None:
    """One scale of ICP for one pair, updating ``pair.T`` (here: in the common frame) in place."""
    import open3d as o3d  # heavy: open3d

    reg = o3d.pipelines.registration
    src, tgt = clouds[pair.i][s], clouds[pair.j][s]
    dist = config.max_correspondence[s]
    crit = reg.ICPConvergenceCriteria(relative_fitness=1e-6, relative_rmse=1e-6,
                                      max_iteration=config.max_iterations)
    plane = reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=dist))
    result = None
    if config.colored and s == len(config.voxel_sizes) - 1:
        try:
            result = reg.registration_colored_icp(
                src, tgt, dist, pair.T, reg.TransformationEstimationForColoredICP(lambda_geometric=0.9), crit)
        except RuntimeError as exc:  # too few correspondences
            log.debug("coloured ICP %d-%d failed: %s", pair.i, pair.j, exc)
    if result is None:
        result = reg.registration_icp(src, tgt, dist, pair.T, plane, crit)
    if result.fitness > 0:
        pair.T = np.asarray(result.transformation).copy()
    pair.fitness, pair.rmse, pair.scales = float(result.fitness), float(result.inlier_rmse), s + 1
    if s == 0:
        pair.overlap = pair.fitness


def register_pairs(views: Sequence[ViewClouds], poses: Sequence[np.ndarray],
                   pairs: Sequence[tuple[int, int]], config: ICPConfig, deadline: float
                   ) -> list[PairResult]:
    """Register every pair coarse to fine, one scale for all pairs at a time.

    The clouds are registered in the world frame shifted to their common centroid (ICP
    linearises rotations about the origin: about a camera metres away, a rotation and a
    translation are hard to tell apart and ICP drifts along symmetric shapes). A scale
    starts only when it is expected to end before ``deadline`` (a ``time.perf_counter()``
    value; each scale is assumed to take twice the previous one).

    Parameters
    ----------
    views : the views' clouds. poses : (4, 4) camera-to-world per view (the initial guess).
    pairs : (i, j) to register. config : ICPConfig. deadline : float.

    Returns
    -------
    list of PairResult, one per pair (``T`` between camera frames), with the information
    matrix of the last scale run.
    """

    import open3d as o3d  # heavy: open3d

    reg = o3d.pipelines.registration
    centre = np.mean([views[k].points(0).mean(axis=0) @ poses[k][:3, :3].T + poses[k][:3, 3]
                      for k in range(len(views)) if len(views[k].points(0))], axis=0)
    shift = np.eye(4)
    shift[:3, 3] = -centre
    to_common = [shift @ p for p in poses]
    clouds = [[copy.deepcopy(c).transform(to_common[k]) for c in v.clouds] for k, v in enumerate(views)]
    out = [PairResult(i, j, np.eye(4), 0.0, 0.0, np.zeros((6, 6)), 0) for i, j in pairs]
    last = None
    for s in range(len(config.voxel_sizes)):
        t0 = time.perf_counter()
        if last is not None and t0 + 2.0 * last > deadline:
            log.info("ICP: time limit, scales from %g m on skipped", config.voxel_sizes[s])
            break
        for pair in out:
            _icp_step(clouds, pair, s, config)
        last = time.perf_counter() - t0
    for pair in out:
        # common-frame correction -> camera i's frame into camera j's, where the graph needs
        # the information matrix too
        pair.T = np.linalg.inv(to_common[pair.j]) @ pair.T @ to_common[pair.i]
        s = max(pair.scales - 1, 0)
        pair.information = np.asarray(reg.get_information_matrix_from_point_clouds(
            views[pair.i].clouds[s], views[pair.j].clouds[s], config.max_correspondence[s], pair.T))
    return out


def optimize_pose_graph(poses: Sequence[np.ndarray], results: Sequence[PairResult], reference: int,
                        max_correspondence: float) -> list[np.ndarray]:
    """Camera poses that best agree with the pairwise registrations (reference held fixed).

    Only the views connected to the reference through ``results`` take part; the others keep
    their poses.

    Parameters
    ----------
    poses : (4, 4) camera-to-world per view (the graph's initial nodes).
    results : pairwise registrations (edges; ``T ~ inv(P_j) @ P_i``).
    reference : int, the view whose pose does not move.
    max_correspondence : float, metres, open3d's line-process scale.

    Returns
    -------
    list of (4, 4) float64 camera-to-world poses, rotations orthonormal.
    """
    import open3d as o3d  # heavy: open3d

    reg = o3d.pipelines.registration
    nodes = _connected(len(poses), [(r.i, r.j) for r in results], reference)
    slot = {k: n for n, k in enumerate(nodes)}
    out = [np.asarray(p, dtype=np.float64).copy() for p in poses]
    if len(nodes) < 2:
        return out
    graph = reg.PoseGraph()
    for k in nodes:
        graph.nodes.append(reg.PoseGraphNode(out[k]))
    for r in results:
        if r.i in slot and r.j in slot:
            graph.edges.append(reg.PoseGraphEdge(slot[r.i], slot[r.j], r.T, r.information,
                                                 uncertain=abs(r.i - r.j) > 1))
    opt = reg.GlobalOptimizationOption(max_correspondence_distance=max_correspondence,
                                       edge_prune_threshold=0.25, reference_node=slot[reference])
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        reg.global_optimization(graph, reg.GlobalOptimizationLevenbergMarquardt(),
                                reg.GlobalOptimizationConvergenceCriteria(), opt)
    gauge = out[reference] @ np.linalg.inv(np.asarray(graph.nodes[slot[reference]].pose))
    for k in nodes:
        p = gauge @ np.asarray(graph.nodes[slot[k]].pose)
        u, _, vt = np.linalg.svd(p[:3, :3])  # against round-off
        p[:3, :3] = u @ vt
        out[k] = p
    return out


def _connected(n: int, edges: Sequence[tuple[int, int]], start: int) -> list[int]:
    """Sorted nodes reachable from ``start`` through ``edges``."""
    seen, todo = {start}, [start]
    while todo:
        a = todo.pop()
        for i, j in edges:
            for b in ((j,) if i == a else (i,) if j == a else ()):
                if b not in seen:
                    seen.add(b)
                    todo.append(b)
    return sorted(seen)
