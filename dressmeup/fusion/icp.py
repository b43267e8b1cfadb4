"""Extrinsic refinement: multiway (coloured) ICP between overlapping views + pose graph.

Each camera's back-projected point cloud is registered to every other camera's cloud it
overlaps (coarse-to-fine point-to-plane ICP, then coloured ICP at the finest scale); the
pairwise results become edges of a pose graph whose optimisation (open3d's
Levenberg-Marquardt with line-process pruning of wrong edges) gives a world-frame correction
per camera, with the reference camera held fixed.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from dressmeup.capture.rig import Rig
from dressmeup.capture.session import RGBDFrame

__all__ = ["ICPConfig", "ICPReport", "backproject", "refine_extrinsics", "pose_difference"]

log = logging.getLogger(__name__)


@dataclass
class ICPConfig:
    """Refinement settings.

    Attributes
    ----------
    voxel_sizes : tuple of float, metres, coarse-to-fine downsampling of the clouds.
    max_correspondence : tuple of float, metres, ICP correspondence radius per scale.
    colored : bool, finish with coloured ICP (geometry + photometric terms).
    min_overlap : float, a pair becomes a graph edge when this share of the smaller cloud has
        a correspondence after alignment.
    rounds : int, alternations of pairwise registration and graph optimisation.
    max_iterations : int, ICP iterations per scale.
    max_view_angle_deg : float, only cameras whose optical axes differ by less than this are
        registered to each other (opposite cameras see different sides of the body).
    """

    voxel_sizes: tuple[float, ...] = (0.02, 0.01, 0.005)
    max_correspondence: tuple[float, ...] = (0.08, 0.03, 0.006)
    colored: bool = False
    min_overlap: float = 0.1
    rounds: int = 2
    max_iterations: int = 40
    max_view_angle_deg: float = 80.0


@dataclass
class ICPReport:
    """What the refinement did.

    Attributes
    ----------
    edges : list of (serial_a, serial_b, fitness, inlier_rmse) pairwise registrations kept.
    corrections : dict serial -> (rotation_deg, translation_m) applied to each camera.
    """

    edges: list[tuple[str, str, float, float]] = field(default_factory=list)
    corrections: dict[str, tuple[float, float]] = field(default_factory=dict)


def backproject(frame: RGBDFrame, rig: Rig, stride: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """World points and colours of a pinhole (undistorted) depth frame.

    Parameters
    ----------
    frame : RGBDFrame, depth in metres.
    rig : Rig (the frame's camera by serial).
    stride : int, take every ``stride``-th pixel in each direction.

    Returns
    -------
    points : (k, 3) float64 world coordinates, colors : (k, 3) float64 in [0, 1].
    """
    cam = rig.camera(frame.serial)
    d = frame.depth[::stride, ::stride]
    v, u = np.nonzero(d > 0)
    z = d[v, u].astype(np.float64)
    u = u * stride
    v = v * stride
    pc = np.stack([(u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z], axis=1)
    pw = pc @ cam.camera_to_world[:3, :3].T + cam.camera_to_world[:3, 3]
    col = frame.color[v, u].astype(np.float64) / 255.0
    return pw, col


def pose_difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Rotation angle (degrees) and translation distance (metres) between two rigid transforms."""
    d = np.linalg.inv(a) @ b
    ang = np.degrees(np.arccos(np.clip((np.trace(d[:3, :3]) - 1) / 2, -1, 1)))
    return float(ang), float(np.linalg.norm(a[:3, 3] - b[:3, 3]))


def _cloud(points: np.ndarray, colors: np.ndarray, voxel: float, center: np.ndarray):
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    pcd.colors = o3d.utility.Vector3dVector(colors)
    pcd = pcd.voxel_down_sample(voxel)
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=voxel * 3, max_nn=30))
    # orient normals towards the camera side (the centre of the rig is behind the surface)
    pcd.orient_normals_towards_camera_location(center)
    pcd.normals = o3d.utility.Vector3dVector(-np.asarray(pcd.normals))
    return pcd


def _pairwise(cfg: ICPConfig, clouds_by_scale, i: int, j: int):
    import open3d as o3d

    reg = o3d.pipelines.registration
    T = np.eye(4)
    result = None
    n = len(cfg.voxel_sizes)
    for s in range(n):
        src_s, tgt_s = clouds_by_scale[s][i], clouds_by_scale[s][j]
        crit = reg.ICPConvergenceCriteria(relative_fitness=1e-6, relative_rmse=1e-6, max_iteration=cfg.max_iterations)
        if cfg.colored and s == n - 1:
            try:
                result = reg.registration_colored_icp(src_s, tgt_s, cfg.max_correspondence[s], T,
                                                      reg.TransformationEstimationForColoredICP(lambda_geometric=0.9), crit)
            except RuntimeError as exc:  # too few correspondences
                log.debug("coloured ICP %d-%d failed: %s", i, j, exc)
                result = reg.registration_icp(src_s, tgt_s, cfg.max_correspondence[s], T,
                                              reg.TransformationEstimationPointToPlane(), crit)
        else:
            result = reg.registration_icp(src_s, tgt_s, cfg.max_correspondence[s], T,
                                          reg.TransformationEstimationPointToPlane(), crit)
        T = result.transformation
    info = reg.get_information_matrix_from_point_clouds(
        clouds_by_scale[-1][i], clouds_by_scale[-1][j], cfg.max_correspondence[-1], T)
    return T, result, info


def refine_extrinsics(frames: Sequence[RGBDFrame], rig: Rig, config: ICPConfig | None = None
                      ) -> tuple[Rig, ICPReport]:
    """Refine camera-to-world transforms by multiway ICP between overlapping views.

    Parameters
    ----------
    frames : one undistorted, filtered RGBDFrame per camera (depth in metres).
    rig : Rig, the initial calibration.
    config : ICPConfig (defaults when None).

    Returns
    -------
    (refined Rig copy, ICPReport). The reference camera (``rig.reference``) does not move.

    Raises
    ------
    ValueError when a frame's camera is not in the rig.
    """
    import open3d as o3d

    cfg = config or ICPConfig()
    if len(cfg.voxel_sizes) != len(cfg.max_correspondence):
        raise ValueError("config: voxel_sizes and max_correspondence must have the same length")
    reg = o3d.pipelines.registration
    out = rig.copy()
    serials = [f.serial for f in frames]
    for s in serials:
        rig.camera(s)
    if rig.reference not in serials or len(frames) < 2:
        log.warning("ICP refinement needs the reference camera and >= 2 views; skipped")
        return out, ICPReport()
    ref = serials.index(rig.reference)
    report = ICPReport()
    for _round in range(cfg.rounds):
        pts = [backproject(f, out) for f in frames]
        center = out.target
        clouds = [[_cloud(p, c, v, center) for p, c in pts] for v in cfg.voxel_sizes]
        graph = reg.PoseGraph()
        for _ in frames:
            graph.nodes.append(reg.PoseGraphNode(np.eye(4)))
        report.edges = []
        for i in range(len(frames)):
            for j in range(i + 1, len(frames)):
                zi = out.camera(serials[i]).camera_to_world[:3, 2]
                zj = out.camera(serials[j]).camera_to_world[:3, 2]
                if np.degrees(np.arccos(np.clip(zi @ zj, -1, 1))) > cfg.max_view_angle_deg:
                    continue
                T, res, info = _pairwise(cfg, clouds, i, j)
                n_small = min(len(clouds[-1][i].points), len(clouds[-1][j].points))
                overlap = res.fitness * len(clouds[-1][i].points) / max(n_small, 1)
                if overlap < cfg.min_overlap:
                    continue
                report.edges.append((serials[i], serials[j], float(res.fitness), float(res.inlier_rmse)))
                # edge maps node i's frame into node j's: T ~ inv(P_j) @ P_i
                graph.edges.append(reg.PoseGraphEdge(i, j, T, info, uncertain=abs(i - j) > 1))
        if not report.edges:
            log.warning("no overlapping camera pairs found; extrinsics left unchanged")
            break
        opt = reg.GlobalOptimizationOption(max_correspondence_distance=cfg.max_correspondence[-1],
                                           edge_prune_threshold=0.25, reference_node=ref)
        with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
            reg.global_optimization(graph, reg.GlobalOptimizationLevenbergMarquardt(),
                                    reg.GlobalOptimizationConvergenceCriteria(), opt)
        gauge = np.linalg.inv(np.asarray(graph.nodes[ref].pose))
        for k, f in enumerate(frames):
            cam = out.camera(f.serial)
            D = gauge @ np.asarray(graph.nodes[k].pose)
            cam.camera_to_world = D @ cam.camera_to_world
            # re-orthonormalise against round-off
            u, _, vt = np.linalg.svd(cam.camera_to_world[:3, :3])
            cam.camera_to_world[:3, :3] = u @ vt
    for c in out.cameras:
        report.corrections[c.serial] = pose_difference(rig.camera(c.serial).camera_to_world, c.camera_to_world)
    return out, report
