"""Seeded uniform sampling of points on a triangle surface."""

from __future__ import annotations

import numpy as np

from dressmeup.errors import InputError
from dressmeup.geometry.mesh import as_arrays, face_areas

__all__ = ["sample_surface", "barycentric_to_points"]


def sample_surface(
    V: np.ndarray, F: np.ndarray, n: int, seed: int | np.random.Generator | None = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample ``n`` points uniformly (by area) on a triangle surface.

    Faces are drawn with probability proportional to their area (degenerate faces are never
    drawn); the point inside a face is uniform (square-root barycentric trick).

    Parameters
    ----------
    V : (n_v, 3) float array
    F : (m, 3) int array
    n : int
        Number of samples (>= 1).
    seed : int or numpy.random.Generator, optional
        Seed of the generator (default 0): the same seed gives the same samples.

    Returns
    -------
    points : (n, 3) float64 ndarray
    face_ids : (n,) int64 ndarray
    bary : (n, 3) float64 ndarray
        Barycentric coordinates (rows sum to 1) with respect to ``F[face_ids]``.

    Raises
    ------
    ValueError
        Bad mesh arrays or ``n < 1``; an ``InputError`` (a ``ValueError``) for a surface of
        zero total area.
    """
    V, F = as_arrays(V, F, name="mesh")
    if int(n) != n or n < 1:
        raise ValueError(f"n: expected a positive number of samples, got {n}")
    n = int(n)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    areas = face_areas(V, F)
    total = areas.sum()
    if not total > 0:
        raise InputError("mesh: every face has zero area (all its triangles are degenerate), "
                         "so no point can be sampled on its surface")
    cdf = np.cumsum(areas)
    cdf /= cdf[-1]
    face_ids = np.searchsorted(cdf, rng.random(n), side="right")
    face_ids = np.minimum(face_ids, F.shape[0] - 1).astype(np.int64)
    # guard against landing on a zero-area face through floating point at cdf plateaus
    r1 = np.sqrt(rng.random(n))
    r2 = rng.random(n)
    bary = np.stack([1.0 - r1, r1 * (1.0 - r2), r1 * r2], axis=1)
    points = barycentric_to_points(V, F, face_ids, bary)
    return points, face_ids, bary


def barycentric_to_points(
    V: np.ndarray, F: np.ndarray, face_ids: np.ndarray, bary: np.ndarray
) -> np.ndarray:
    """Points from face ids and barycentric coordinates.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    face_ids : (q,) int array
    bary : (q, 3) float array

    Returns
    -------
    (q, 3) float64 ndarray
    """
    V = np.asarray(V, dtype=np.float64)
    tri = V[np.asarray(F)[np.asarray(face_ids)]]
    return np.einsum("qk,qkd->qd", np.asarray(bary, dtype=np.float64), tri)
