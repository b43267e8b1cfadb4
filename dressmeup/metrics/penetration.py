"""Garment-body interpenetration: IR (area share of garment faces inside the body) and the
share of garment vertices below the body surface."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dressmeup.geometry.mesh import face_areas
from dressmeup.geometry.proximity import closest_points
from dressmeup.geometry.winding import winding_number
from dressmeup.metrics._common import mesh_arrays, points_of

__all__ = [
    "Interpenetration",
    "interpenetration_ratio",
    "interpenetration_details",
    "signed_distance",
    "penetrating_vertex_fraction",
]


@dataclass
class Interpenetration:
    """IR and the per-face data behind it.

    Attributes
    ----------
    ratio : float
        Share of garment area inside the body, in [0, 1] (lower is better).
    inside : (m,) bool ndarray
        Garment faces whose centroid has winding number >= 0.5 w.r.t. the body.
    winding : (m,) float64 ndarray
        Winding number of each garment face centroid.
    areas : (m,) float64 ndarray
        Garment face areas.
    """

    ratio: float
    inside: np.ndarray = field(repr=False)
    winding: np.ndarray = field(repr=False)
    areas: np.ndarray = field(repr=False)


def interpenetration_details(garment: Any, body: Any, threshold: float = 0.5) -> Interpenetration:
    """IR with per-face inside flags; see :func:`interpenetration_ratio`."""
    Vg, Fg = mesh_arrays(garment, "garment")
    Vb, Fb = mesh_arrays(body, "body")
    areas = face_areas(Vg, Fg)
    total = areas.sum()
    if not total > 0:
        raise ValueError("garment: total surface area is zero, IR is undefined")
    centroids = Vg[Fg].mean(axis=1)
    w = winding_number(Vb, Fb, centroids)
    inside = w >= threshold
    return Interpenetration(float(areas[inside].sum() / total), inside, w, areas)


def interpenetration_ratio(garment: Any, body: Any) -> float:
    """IR: share of the garment's surface area whose faces lie inside the body.

    A garment face is inside when its centroid has generalized winding number >= 0.5 with
    respect to the body (libigl fast winding number), so open or holed body scans work.
    Degenerate (zero-area) garment faces weigh nothing.

    Parameters
    ----------
    garment : trimesh.Trimesh or tuple (V (n, 3) float, F (m, 3) int)
    body : trimesh.Trimesh or tuple (V (k, 3) float, F (l, 3) int)
        Body surface with outward-oriented faces.

    Returns
    -------
    float
        In [0, 1] (tables print %); lower is better.
    """
    return interpenetration_details(garment, body).ratio


def signed_distance(points: Any, body: Any) -> np.ndarray:
    """Signed distance of points to a body surface: negative inside.

    The magnitude is the exact point-to-triangle distance; the sign comes from the
    generalized winding number (inside when >= 0.5), so holes do not flip it.

    Parameters
    ----------
    points : (q, 3) float array (a mesh gives its vertices)
    body : trimesh.Trimesh or tuple (V (k, 3) float, F (l, 3) int)

    Returns
    -------
    (q,) float64 ndarray
    """
    P = points_of(points, "points")
    Vb, Fb = mesh_arrays(body, "body")
    d = closest_points(Vb, Fb, P)[0]
    inside = winding_number(Vb, Fb, P) >= 0.5
    return np.where(inside, -d, d)


def penetrating_vertex_fraction(garment: Any, body: Any, eps: float = 0.0) -> float:
    """Share of garment vertices whose signed distance to the body is below ``-eps``.

    Parameters
    ----------
    garment : mesh or (n, 3) float array
        The garment (its vertices are tested).
    body : trimesh.Trimesh or tuple (V (k, 3) float, F (l, 3) int)
    eps : float
        Tolerance in metres (>= 0): vertices less than ``eps`` deep do not count.

    Returns
    -------
    float
        In [0, 1]; lower is better.
    """
    if not np.isfinite(eps) or eps < 0:
        raise ValueError(f"eps: expected a finite value >= 0, got {eps}")
    return float(np.mean(signed_distance(garment, body) < -eps))
