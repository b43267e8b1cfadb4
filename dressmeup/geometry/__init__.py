"""Mesh helpers the metrics and the stages above share, written once.

Submodules (import the function from its module, e.g.
``from dressmeup.geometry.proximity import closest_points``):

- :mod:`~dressmeup.geometry.mesh`: ``as_arrays``, ``as_points``, ``face_areas``,
  ``face_normals``, ``vertex_normals``, ``edges``
- :mod:`~dressmeup.geometry.sampling`: ``sample_surface`` (seeded, area-uniform)
- :mod:`~dressmeup.geometry.proximity`: ``closest_points`` (open3d BVH + exact float64)
- :mod:`~dressmeup.geometry.winding`: ``winding_number`` (libigl fast winding number)
- :mod:`~dressmeup.geometry.geodesic`: ``geodesic_distances`` (heat method or Dijkstra)
- :mod:`~dressmeup.geometry.neighbors`: ``knn`` (scipy cKDTree)

Heavy libraries (open3d, libigl, potpourri3d) are imported inside the functions that use
them, so importing this package stays cheap.
"""

from dressmeup.geometry.geodesic import geodesic_distances
from dressmeup.geometry.mesh import (
    as_arrays,
    as_points,
    edges,
    face_areas,
    face_normals,
    vertex_normals,
)
from dressmeup.geometry.neighbors import knn
from dressmeup.geometry.proximity import closest_points
from dressmeup.geometry.sampling import sample_surface
from dressmeup.geometry.winding import winding_number

__all__ = [
    "as_arrays",
    "as_points",
    "closest_points",
    "edges",
    "face_areas",
    "face_normals",
    "geodesic_distances",
    "knn",
    "sample_surface",
    "vertex_normals",
    "winding_number",
]
