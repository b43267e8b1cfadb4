"""Scoring a fused scan and extracted garments against a synthetic session's ground truth.

docs/spec.md section 1 "Fusion quality": accuracy (fused -> GT surface), completeness (GT -> fused),
``chamfer_l1 = (accuracy + completeness) / 2`` and F-scores, with the ground truth restricted
to the surface visible from at least one camera; completeness against the whole scan is
reported beside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dressmeup.capture.frame import RGBDFrame
from dressmeup.capture.rig import Rig
from dressmeup.capture.visibility import raycasting_scene, visible_from
from dressmeup.fusion.tsdf import integrate_grid
from dressmeup.geometry.sampling import sample_surface
from dressmeup.metrics.distance import distances_to

__all__ = ["score_surface", "face_label_accuracy", "extrinsic_errors", "SurfaceScore", "open3d_reference_mesh"]


@dataclass
class SurfaceScore:
    """Fusion quality figures (metres; F-scores in [0, 1]).

    Attributes
    ----------
    accuracy, completeness, chamfer_l1 : against the visible ground truth.
    fscore : dict threshold (m) -> F-score against the visible ground truth.
    completeness_all : completeness against the whole ground-truth surface.
    visible_fraction : share of the ground-truth area visible from >= 1 camera.
    """

    accuracy: float
    completeness: float
    chamfer_l1: float
    fscore: dict[float, float]
    completeness_all: float
    visible_fraction: float

    def as_dict(self) -> dict[str, float]:
        """Flat dictionary, distances in millimetres (``*_mm`` keys)."""
        out = {"accuracy_mm": 1000 * self.accuracy, "completeness_mm": 1000 * self.completeness,
               "chamfer_l1_mm": 1000 * self.chamfer_l1, "completeness_all_mm": 1000 * self.completeness_all,
               "visible_fraction": self.visible_fraction}
        out.update({f"fscore@{1000 * t:g}mm": v for t, v in self.fscore.items()})
        return out


def score_surface(pred_vertices: np.ndarray, pred_faces: np.ndarray, gt_vertices: np.ndarray,
                  gt_faces: np.ndarray, rig: Rig, n_samples: int = 100_000, seed: int = 0,
                  thresholds: tuple[float, ...] = (0.001, 0.002, 0.005, 0.01),
                  gt_face_mask: np.ndarray | None = None) -> SurfaceScore:
    """Fusion quality of a predicted mesh against a ground-truth mesh seen by ``rig``.

    Accuracy: pred samples -> whole GT surface (exact point-to-triangle). Completeness:
    visible GT samples -> pred surface. ``gt_face_mask`` restricts the ground truth to some
    faces (a garment) while visibility still accounts for occlusion by the whole GT mesh.

    Parameters
    ----------
    pred_vertices : (n, 3) float, pred_faces : (m, 3) int.
    gt_vertices : (p, 3) float, gt_faces : (q, 3) int.
    rig : Rig, the true cameras.
    n_samples : int, seed : int, thresholds : F-score distances in metres.
    gt_face_mask : (q,) bool or None.

    Returns
    -------
    SurfaceScore
    """

    GV = np.asarray(gt_vertices, dtype=np.float64)
    GF = np.asarray(gt_faces, dtype=np.int64)
    mask = np.ones(len(GF), dtype=bool) if gt_face_mask is None else np.asarray(gt_face_mask, dtype=bool)
    # sample the target part of the GT; visibility against the whole GT mesh
    sub_f = GF[mask]
    pts, _, _ = sample_surface(GV, sub_f, n_samples, seed=seed + 1)
    scene = raycasting_scene(GV, GF)
    fn_all = np.cross(GV[GF[:, 1]] - GV[GF[:, 0]], GV[GF[:, 2]] - GV[GF[:, 0]])
    fn_all /= np.maximum(np.linalg.norm(fn_all, axis=1, keepdims=True), 1e-20)
    cp = scene.compute_closest_points(pts.astype(np.float32))
    nrm = fn_all[cp["primitive_ids"].numpy().astype(np.int64)]

    vis = np.zeros(len(pts), dtype=bool)
    for cam in rig.cameras:
        uv, z = cam.project(pts)
        inside = (z > 0) & (uv[:, 0] >= -0.5) & (uv[:, 1] >= -0.5) & (uv[:, 0] < cam.width - 0.5) & (uv[:, 1] < cam.height - 0.5)
        facing = np.einsum("ij,ij->i", nrm, cam.center - pts) > 0
        idx = np.nonzero(inside & facing & ~vis)[0]
        if len(idx):
            vis[idx[visible_from(pts[idx], cam.center, scene, 0.002)]] = True
    PV = np.asarray(pred_vertices, dtype=np.float64)
    PF = np.asarray(pred_faces, dtype=np.int64)
    ps, _, _ = sample_surface(PV, PF, n_samples, seed=seed)
    target = (GV, sub_f)
    d_pg = distances_to(ps, target)
    d_gp_all = distances_to(pts, (PV, PF))
    d_gp = d_gp_all[vis]
    acc, comp = float(d_pg.mean()), float(d_gp.mean()) if len(d_gp) else float("nan")
    fs = {}
    for t in thresholds:
        p, r = float(np.mean(d_pg < t)), float(np.mean(d_gp < t)) if len(d_gp) else 0.0
        fs[float(t)] = 0.0 if p + r == 0 else 2 * p * r / (p + r)
    return SurfaceScore(acc, comp, 0.5 * (acc + comp), fs, float(d_gp_all.mean()), float(vis.mean()))


def face_label_accuracy(pred_vertices: np.ndarray, pred_faces: np.ndarray, pred_labels: np.ndarray,
                        gt_vertices: np.ndarray, gt_faces: np.ndarray, gt_labels: np.ndarray) -> float:
    """Share of predicted faces whose label equals the label of the nearest ground-truth face.

    Returns
    -------
    float in [0, 1]
    """

    PV = np.asarray(pred_vertices, dtype=np.float64)
    PF = np.asarray(pred_faces, dtype=np.int64)
    cent = PV[PF].mean(axis=1)
    scene = raycasting_scene(gt_vertices, gt_faces)
    gid = scene.compute_closest_points(cent.astype(np.float32))["primitive_ids"].numpy().astype(np.int64)
    return float(np.mean(np.asarray(gt_labels)[gid] == np.asarray(pred_labels)))


def extrinsic_errors(estimated: Rig, truth: Rig, points: np.ndarray) -> dict[str, float]:
    """Mean displacement (metres) of ``points`` caused by each camera's calibration error.

    For camera k the error maps a world point through the true world->camera transform and
    back through the estimated camera->world transform: ``E_k = C_est @ inv(C_true)``.

    Returns
    -------
    dict serial -> mean displacement in metres.
    """
    P = np.asarray(points, dtype=np.float64)
    out = {}
    for c in estimated.cameras:
        E = c.camera_to_world @ truth.camera(c.serial).world_to_camera
        out[c.serial] = float(np.linalg.norm(P @ E[:3, :3].T + E[:3, 3] - P, axis=1).mean())
    return out


def open3d_reference_mesh(frames: list[RGBDFrame], voxel_size: float = 0.004, trunc_voxels: float = 5.0,
                          depth_max: float = 5.0, color: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Open3D's own TSDF integration of frames as they are: the reference fusion is compared to.

    The raw depth of every frame (no undistortion, no filtering) is integrated with its
    camera into an open3d ``t.geometry.VoxelBlockGrid`` as Open3D's integration example
    does, and every voxel observed at least once is meshed (``weight_threshold=0``, as the
    legacy ``ScalableTSDFVolume`` meshes).

    Parameters
    ----------
    frames : RGBDFrame list, each carrying its camera; depth in metres.
    voxel_size : float, metres. trunc_voxels : float, truncation in voxels.
    depth_max : float, metres. color : bool, integrate colour too (as a coloured scan needs;
    the geometry is the same).

    Returns
    -------
    vertices : (n, 3) float64, faces : (m, 3) int64.
    """
    mesh = integrate_grid(frames, voxel_size, trunc_voxels, depth_max, color=color).extract_triangle_mesh(
        weight_threshold=0.0)
    return (mesh.vertex.positions.numpy().astype(np.float64),
            mesh.triangle.indices.numpy().astype(np.int64))
