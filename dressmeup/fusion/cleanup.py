"""Mesh cleanup after fusion with pymeshlab: components, holes, non-manifold repair, decimation."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

__all__ = ["CleanupConfig", "cleanup_mesh", "largest_components"]

log = logging.getLogger(__name__)


@dataclass
class CleanupConfig:
    """Cleanup settings.

    Attributes
    ----------
    min_component_fraction : float, connected components with fewer faces than this share of
        the largest component are removed (floating noise blobs).
    max_hole_edges : int, holes bounded by at most this many edges are closed (0: keep holes).
    repair_non_manifold : bool, split non-manifold vertices and remove non-manifold edges.
    target_faces : int or None, quadric decimation to this face count (None: keep).
    poisson_depth : int or None, replace the mesh by a screened Poisson reconstruction of its
        vertices at this octree depth (None: keep the TSDF surface; colours are then
        transferred from the nearest original vertex).
    """

    min_component_fraction: float = 0.02
    max_hole_edges: int = 60
    repair_non_manifold: bool = True
    target_faces: int | None = None
    poisson_depth: int | None = None


def largest_components(faces: np.ndarray, n_vertices: int, min_fraction: float) -> np.ndarray:
    """Mask of faces in connected components with at least ``min_fraction`` of the largest one.

    Parameters
    ----------
    faces : (m, 3) int, n_vertices : int, min_fraction : float in [0, 1].

    Returns
    -------
    (m,) bool
    """
    # heavy: scipy.sparse
    from dressmeup.geometry.topology import large_components

    return large_components(faces, n_vertices, min_fraction)


def cleanup_mesh(vertices: np.ndarray, faces: np.ndarray, colors: np.ndarray | None = None,
                 config: CleanupConfig | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Clean a fused mesh.

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int.
    colors : (n, 3) uint8 or None, per-vertex colours (kept through every step).
    config : CleanupConfig (defaults when None).

    Returns
    -------
    vertices : (n', 3) float64, faces : (m', 3) int64, colors : (n', 3) uint8 or None.
    """
    # heavy: pymeshlab (~0.3 s to import)
    import pymeshlab

    cfg = config or CleanupConfig()
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    keep = largest_components(F, len(V), cfg.min_component_fraction)
    F = F[keep]
    vc = None
    if colors is not None:
        c = np.asarray(colors, dtype=np.float64)[:, :3] / 255.0
        vc = np.concatenate([c, np.ones((len(c), 1))], axis=1)
    m = pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32),
                       **({"v_color_matrix": vc} if vc is not None else {}))
    ms = pymeshlab.MeshSet()
    ms.add_mesh(m, "fused")
    ms.meshing_remove_duplicate_vertices()
    ms.meshing_remove_null_faces()
    ms.meshing_remove_duplicate_faces()
    ms.meshing_remove_unreferenced_vertices()
    if cfg.repair_non_manifold:
        ms.meshing_repair_non_manifold_edges()
        ms.meshing_repair_non_manifold_vertices()
    if cfg.max_hole_edges > 0:
        try:
            ms.meshing_close_holes(maxholesize=int(cfg.max_hole_edges), newfaceselected=False)
        except pymeshlab.PyMeshLabException as exc:  # needs a manifold mesh; keep going without
            log.warning("hole closing skipped: %s", exc)
    if cfg.poisson_depth:
        ms.generate_surface_reconstruction_screened_poisson(depth=int(cfg.poisson_depth), preclean=True)
    if cfg.target_faces:
        ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(cfg.target_faces), preservenormal=True,
                                                    preserveboundary=True, qualitythr=0.4)
    ms.meshing_remove_unreferenced_vertices()
    out = ms.current_mesh()
    V2 = np.asarray(out.vertex_matrix(), dtype=np.float64)
    F2 = np.asarray(out.face_matrix(), dtype=np.int64)
    C2 = None
    if colors is not None:
        if out.has_vertex_color() and not cfg.poisson_depth:
            C2 = np.clip(np.round(out.vertex_color_matrix()[:, :3] * 255), 0, 255).astype(np.uint8)
        else:
            # heavy: scipy.spatial
            from scipy.spatial import cKDTree

            _, idx = cKDTree(V).query(V2)
            C2 = np.asarray(colors)[idx, :3].astype(np.uint8)
    return V2, F2, C2
