"""Mesh arrays: input coercion and validation, face areas and normals, vertex normals, edges.

Every public function of :mod:`dressmeup.geometry` and :mod:`dressmeup.metrics` goes through
:func:`as_arrays` (or :func:`as_points`) so that bad input fails at the entry with a message
that names the argument, the expected and the received shape.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dressmeup.errors import InputError

__all__ = ["as_arrays", "as_points", "face_areas", "face_normals", "vertex_normals", "edges"]


def _is_trimesh(obj: Any) -> bool:
    return hasattr(obj, "vertices") and hasattr(obj, "faces") and not isinstance(obj, np.ndarray)


def as_points(points: Any, name: str = "points", dim: int | None = 3) -> np.ndarray:
    """Validate a point array and return it as float64.

    Parameters
    ----------
    points : (n, dim) array_like of float
        Points; a ``trimesh.Trimesh`` or ``PointCloud`` gives its vertices.
    name : str
        Argument name used in error messages.
    dim : int or None
        Required number of columns (``None`` accepts any width >= 1).

    Returns
    -------
    (n, dim) float64 ndarray, C-contiguous.

    Raises
    ------
    ValueError
        Wrong shape, non-numeric, empty, NaN or inf values.
    """
    if _is_trimesh(points) or (hasattr(points, "vertices") and not isinstance(points, np.ndarray)):
        points = points.vertices
    try:
        arr = np.asarray(points)
    except Exception as exc:  # ragged lists and the like
        raise InputError(
            f"{name}: expected an (n, {dim or 'd'}) float array, got {type(points).__name__}"
        ) from exc
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise InputError(
            f"{name}: expected a numeric (n, {dim or 'd'}) array, got dtype {arr.dtype}"
        )
    if arr.ndim != 2 or (dim is not None and arr.shape[1] != dim) or arr.shape[1] < 1:
        raise InputError(f"{name}: expected shape (n, {dim or 'd'}), got {arr.shape}")
    if arr.shape[0] == 0:
        raise InputError(f"{name}: expected at least one point, got shape {arr.shape} (empty)")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr).all(axis=1)))
        raise InputError(f"{name}: {bad} of {arr.shape[0]} rows contain NaN or inf")
    return arr


def as_faces(faces: Any, n_vertices: int, name: str = "faces") -> np.ndarray:
    """Validate a triangle index array against ``n_vertices``; return it as int64.

    Parameters
    ----------
    faces : (m, 3) array_like of int
    n_vertices : int
        Number of vertices the indices point into.
    name : str
        Argument name used in error messages.

    Returns
    -------
    (m, 3) int64 ndarray.

    Raises
    ------
    ValueError
        Wrong shape, non-integer values, empty, or indices outside ``[0, n_vertices)``.
    """
    arr = np.asarray(faces)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(f"{name}: expected shape (m, 3) of triangle indices, got {arr.shape}")
    if arr.shape[0] == 0:
        raise InputError(f"{name}: expected at least one face, got shape {arr.shape} (empty)")
    if not np.issubdtype(arr.dtype, np.integer):
        if (
            np.issubdtype(arr.dtype, np.floating)
            and np.all(np.isfinite(arr))
            and np.all(arr == np.round(arr))
        ):
            arr = arr.astype(np.int64)
        else:
            raise InputError(f"{name}: expected integer indices, got dtype {arr.dtype}")
    arr = np.ascontiguousarray(arr, dtype=np.int64)
    lo, hi = int(arr.min()), int(arr.max())
    if lo < 0 or hi >= n_vertices:
        raise InputError(
            f"{name}: indices must lie in [0, {n_vertices - 1}] (there are {n_vertices} vertices), "
            f"got values in [{lo}, {hi}]"
        )
    return arr


def as_arrays(
    mesh_or_vertices: Any, faces: Any = None, name: str = "mesh"
) -> tuple[np.ndarray, np.ndarray]:
    """Coerce a mesh (arrays or a ``trimesh.Trimesh``) into validated arrays.

    Parameters
    ----------
    mesh_or_vertices : trimesh.Trimesh, (V, F) tuple, or (n, 3) array_like of float
        The mesh, or its vertices when ``faces`` is given.
    faces : (m, 3) array_like of int, optional
        Triangle indices; required unless ``mesh_or_vertices`` carries faces.
    name : str
        Argument name used in error messages.

    Returns
    -------
    V : (n, 3) float64 ndarray
    F : (m, 3) int64 ndarray

    Raises
    ------
    ValueError
        Naming ``name``: wrong shapes, NaN/inf, face indices out of range, empty mesh,
        or missing faces.
    """
    obj = mesh_or_vertices
    if faces is None:
        if _is_trimesh(obj):
            faces = obj.faces
            obj = obj.vertices
        elif isinstance(obj, tuple) and len(obj) == 2:
            obj, faces = obj
        else:
            raise InputError(
                f"{name}: expected a mesh (trimesh.Trimesh or (vertices, faces)); faces are missing"
            )
    V = as_points(obj, name=f"{name} vertices", dim=3)
    F = as_faces(faces, V.shape[0], name=f"{name} faces")
    return V, F


def _cross(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    a = V[F[:, 0]]
    return np.cross(V[F[:, 1]] - a, V[F[:, 2]] - a)


def face_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Triangle areas.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array

    Returns
    -------
    (m,) float64 ndarray, zero for degenerate triangles.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    return 0.5 * np.linalg.norm(_cross(V, F), axis=1)


def face_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Unit face normals (right-hand rule on the face's vertex order).

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array

    Returns
    -------
    (m, 3) float64 ndarray; rows of degenerate (zero-area) faces are zero.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    c = _cross(V, F)
    norm = np.linalg.norm(c, axis=1, keepdims=True)
    out = np.zeros_like(c)
    ok = norm[:, 0] > 0
    out[ok] = c[ok] / norm[ok]
    return out


def vertex_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals.

    Each vertex normal is the normalised sum of the (unnormalised) cross products of its
    incident faces, i.e. face normals weighted by face area.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array

    Returns
    -------
    (n, 3) float64 ndarray; zero rows for isolated vertices or vertices whose incident
    faces are all degenerate.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    c = _cross(V, F)
    acc = np.zeros((V.shape[0], 3))
    # bincount per coordinate is much faster than np.add.at
    idx = F.reshape(-1)
    rep = np.repeat(c, 3, axis=0)
    for d in range(3):
        acc[:, d] = np.bincount(idx, weights=rep[:, d], minlength=V.shape[0])
    norm = np.linalg.norm(acc, axis=1, keepdims=True)
    ok = norm[:, 0] > 0
    acc[ok] /= norm[ok]
    acc[~ok] = 0.0
    return acc


def edges(F: np.ndarray) -> np.ndarray:
    """Unique undirected edges of a triangle mesh.

    Parameters
    ----------
    F : (m, 3) int array

    Returns
    -------
    (e, 2) int64 ndarray, each row sorted (i < j), rows sorted lexicographically.
    """
    F = np.asarray(F, dtype=np.int64)
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=0)
    e = np.sort(e, axis=1)
    e = e[e[:, 0] != e[:, 1]]
    return np.unique(e, axis=0)


def weld_coincident(V: np.ndarray, F: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Merge vertices with identical coordinates and drop the faces that lose a corner.

    Parameters
    ----------
    V : (n, 3) vertices; F : (m, 3) int faces.

    Returns
    -------
    (V', F', vertex_map, kept): ``V'`` (n', 3) the first vertex of each group of equal
    coordinates, in the order of first occurrence; ``F'`` (m', 3) the kept faces re-indexed;
    ``vertex_map`` (n,) the new index of every old vertex; ``kept`` (m,) bool, which faces
    stayed. Without coincident vertices everything is returned unchanged (identity map).
    """
    V = np.asarray(V)
    F = np.asarray(F)
    _, first, inv = np.unique(V, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    vertex_map = rank[np.asarray(inv).ravel()]
    G = vertex_map[F]
    kept = (G[:, 0] != G[:, 1]) & (G[:, 1] != G[:, 2]) & (G[:, 0] != G[:, 2])
    return V[np.sort(first)], G[kept], vertex_map, kept
