"""What a camera of a rig sees: open3d ray-casting scenes and occlusion tests.

Shared by the synthetic renderer, garment extraction (label voting, texture baking) and the
fusion evaluation (ground truth restricted to the visible surface), so that all three agree
on what "visible from a camera" means.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def raycasting_scene(vertices: np.ndarray, faces: np.ndarray) -> Any:
    """Return an ``open3d.t.geometry.RaycastingScene`` holding one triangle mesh.

    Parameters
    ----------
    vertices : (n, 3) float (cast to float32), faces : (m, 3) int (cast to uint32).
    """
    # heavy: open3d (~0.8 s to import)
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(np.asarray(vertices, dtype=np.float32), np.asarray(faces, dtype=np.uint32))
    return scene


def visible_from(points: np.ndarray, center: np.ndarray, scene: Any,
                 tolerance: float = 0.01) -> np.ndarray:
    """Which points are not occluded from a camera centre.

    A point is visible when the ray from ``center`` towards it hits nothing, or hits the scene
    no nearer than ``tolerance`` before the point.

    Parameters
    ----------
    points : (n, 3) float, center : (3,) float, scene : RaycastingScene of the occluders.
    tolerance : float, metres.

    Returns
    -------
    (n,) bool
    """
    d = np.asarray(points, dtype=np.float64) - center
    dist = np.linalg.norm(d, axis=1)
    rays = np.concatenate([np.broadcast_to(center, d.shape), d], axis=1).astype(np.float32)
    t = scene.cast_rays(rays)["t_hit"].numpy().astype(np.float64)
    return ~np.isfinite(t) | (t * dist >= dist - tolerance)
