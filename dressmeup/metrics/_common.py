"""Input handling shared by the metric modules."""

from __future__ import annotations

from typing import Any

import numpy as np

from dressmeup.errors import InputError
from dressmeup.geometry.mesh import _is_trimesh, as_arrays, as_points

DEFAULT_SAMPLES = 100_000


class TopologyMismatchError(InputError):
    """Two meshes do not share a topology (vertex count or faces), so a per-vertex metric
    such as ED is undefined for them. The benchmark records NaN with this message."""


def has_faces(obj: Any) -> bool:
    """Whether ``obj`` is a mesh (a ``trimesh.Trimesh``-like object or a (V, F) tuple)."""
    if isinstance(obj, tuple) and len(obj) == 2:
        return True
    return _is_trimesh(obj) and getattr(obj, "faces", None) is not None and len(obj.faces) > 0


def mesh_arrays(obj: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Validated ``(V, F)`` of a mesh argument (trimesh-like object or ``(V, F)`` tuple)."""
    if not has_faces(obj):
        raise InputError(
            f"{name}: expected a mesh (trimesh.Trimesh or a (vertices, faces) tuple), got "
            f"{type(obj).__name__}{getattr(obj, 'shape', '')}"
        )
    return as_arrays(obj, name=name)


def points_of(obj: Any, name: str) -> np.ndarray:
    """Validated points of a point-set argument: an array, or a mesh's vertices."""
    if isinstance(obj, tuple) and len(obj) == 2:
        return as_arrays(obj, name=name)[0]
    return as_points(obj, name=name)


def surface_or_points(obj: Any, name: str) -> tuple[np.ndarray, np.ndarray | None]:
    """``(V, F)`` for a mesh, ``(P, None)`` for a bare point set."""
    if has_faces(obj):
        return as_arrays(obj, name=name)
    return as_points(obj, name=name), None


def check_samples(n_samples: int) -> int:
    if int(n_samples) != n_samples or n_samples < 1:
        raise InputError(f"n_samples: expected a positive integer, got {n_samples}")
    return int(n_samples)
