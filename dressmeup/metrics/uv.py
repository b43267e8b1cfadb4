"""UV distortion: QCE and ASE (Boundary First Flattening conventions), from the singular
values of each triangle's UV Jacobian. Validity of a layout (flipped and overlapping area)
and its seams, charts and packing: :mod:`dressmeup.metrics.uv_layout`.

UVs come per vertex (``uv (n, 2)``, ``uv_faces=None``) or per corner as in OBJ files
(``uv (k, 2)`` with ``uv_faces (m, 3)`` indexing into it; seams are then free).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dressmeup.geometry.mesh import as_arrays, as_faces, as_points

__all__ = [
    "QCEResult",
    "ASEResult",
    "qce",
    "qce_details",
    "ase",
    "ase_details",
    "uv_jacobian_singular_values",
]

#: Relative tolerance under which a triangle counts as having zero area (sine of its
#: smallest-vertex angle, scale-free).
ZERO_AREA_RTOL = 1e-12


def _corners(vertices, faces, uv, uv_faces):
    """Validated corner coordinates, component-major for speed: ``P`` is a list of three
    (3, m) arrays (the 3D corners), ``T`` a list of three (2, m) arrays (the UV corners)."""
    V, F = as_arrays(vertices, faces, name="mesh")
    UV = as_points(uv, name="uv", dim=2)
    if uv_faces is None:
        if UV.shape[0] != V.shape[0]:
            raise ValueError(
                f"uv: per-vertex UVs need shape ({V.shape[0]}, 2), got {UV.shape}; "
                "pass uv_faces for per-corner UVs"
            )
        UF = F
    else:
        UF = as_faces(uv_faces, UV.shape[0], name="uv_faces")
        if UF.shape != F.shape:
            raise ValueError(
                f"uv_faces: expected shape {F.shape} (one row per face), got {UF.shape}"
            )
    Vt = np.ascontiguousarray(V.T)
    Ut = np.ascontiguousarray(UV.T)
    P = [np.take(Vt, F[:, k], axis=1) for k in range(3)]
    T = [np.take(Ut, UF[:, k], axis=1) for k in range(3)]
    return P, T


def _geometry(P, T, jacobian: bool = True):
    """Per-face quantities: 3D double area, signed UV double area, degenerate masks, and the
    2x2 Jacobian entries (A, B, C, D) of the map from the 3D triangle's own orthonormal
    frame to UV (``None`` when ``jacobian`` is false)."""
    e1 = P[1] - P[0]
    e2 = P[2] - P[0]
    l1sq = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]
    l2sq = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]
    cx = e1[1] * e2[2] - e1[2] * e2[1]
    cy = e1[2] * e2[0] - e1[0] * e2[2]
    cz = e1[0] * e2[1] - e1[1] * e2[0]
    a3 = np.sqrt(cx * cx + cy * cy + cz * cz)  # 2 * area
    u1 = T[1] - T[0]
    u2 = T[2] - T[0]
    auv = u1[0] * u2[1] - u1[1] * u2[0]  # signed 2 * UV area
    deg3 = ~(a3 > ZERO_AREA_RTOL * np.sqrt(l1sq * l2sq))
    zero_uv = ~(
        np.abs(auv)
        > ZERO_AREA_RTOL
        * np.sqrt((u1[0] * u1[0] + u1[1] * u1[1]) * (u2[0] * u2[0] + u2[1] * u2[1]))
    )
    if not jacobian:
        return a3, auv, deg3, zero_uv, None
    with np.errstate(divide="ignore", invalid="ignore"):
        # local frame: x1 = (l1, 0), x2 = (a, h) with a = e1.e2 / l1, h = 2A / l1
        l1 = np.sqrt(l1sq)
        a = (e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / l1
        h = a3 / l1
        A = u1[0] / l1
        C = u1[1] / l1
        B = (u2[0] - a * A) / h
        D = (u2[1] - a * C) / h
    return a3, auv, deg3, zero_uv, (A, B, C, D)


def _sigma_max(A, B, C, D):
    """Largest singular value of [[A, B], [C, D]] in closed form (Q + R)."""
    e, f, g, h = A + D, A - D, C + B, C - B
    return 0.5 * (np.sqrt(e * e + h * h) + np.sqrt(f * f + g * g))


def uv_jacobian_singular_values(vertices, faces, uv, uv_faces=None) -> np.ndarray:
    """Singular values of each face's 3D-to-UV Jacobian.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) or (k, 2) float array
    uv_faces : (m, 3) int array, optional

    Returns
    -------
    (m, 2) float64 ndarray
        ``[sigma_max, sigma_min]`` per face (NaN for degenerate 3D triangles).
    """
    P, T = _corners(vertices, faces, uv, uv_faces)
    a3, auv, deg3, _, (A, B, C, D) = _geometry(P, T)
    smax = _sigma_max(A, B, C, D)
    with np.errstate(divide="ignore", invalid="ignore"):
        smin = np.abs(auv / a3) / smax
    smin = np.where(smax == 0, 0.0, smin)
    out = np.stack([smax, smin], axis=1)
    out[deg3] = np.nan
    return out


@dataclass
class QCEResult:
    """Quasi-conformal error and the per-face values behind it.

    Attributes
    ----------
    mean : float
        3D-area-weighted mean QCE over faces with non-zero 3D and UV area (1 is ideal).
    max : float
        Largest finite per-face QCE.
    per_face : (m,) float64 ndarray
        ``sigma_max / sigma_min``; ``inf`` for zero UV area, NaN for zero 3D area.
    n_zero_uv_area : int
        Faces whose UV triangle has zero area (infinite QCE, excluded from ``mean``/``max``).
    zero_uv_area_fraction : float
        Their share of the 3D surface area.
    n_degenerate : int
        Faces with zero 3D area (weight zero, excluded).
    """

    mean: float
    max: float
    per_face: np.ndarray = field(repr=False)
    n_zero_uv_area: int = 0
    zero_uv_area_fraction: float = 0.0
    n_degenerate: int = 0


def qce_details(vertices, faces, uv, uv_faces=None) -> QCEResult:
    """QCE with per-face values; see :func:`qce`."""
    P, T = _corners(vertices, faces, uv, uv_faces)
    a3, auv, deg3, zero_uv, (A, B, C, D) = _geometry(P, T)
    # closed-form 2x2 SVD: sigma_max = Q + R; sigma_min = |det| / sigma_max with det = A_uv / A_3d
    smax = _sigma_max(A, B, C, D)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        per = smax * smax * a3 / np.abs(auv)
    per[zero_uv] = np.inf
    per[deg3] = np.nan
    valid = ~deg3 & ~zero_uv
    w = a3[valid]
    total = a3[~deg3].sum()
    if not np.any(valid) or not w.sum() > 0:
        mean = mx = float("inf")
    else:
        mean = float(np.dot(w, per[valid]) / w.sum())
        mx = float(per[valid].max())
    zfrac = float(a3[zero_uv & ~deg3].sum() / total) if total > 0 else 0.0
    return QCEResult(
        mean, mx, per, int(np.count_nonzero(zero_uv & ~deg3)), zfrac, int(np.count_nonzero(deg3))
    )


def qce(vertices, faces, uv, uv_faces=None) -> float:
    """QCE: quasi-conformal error, area-weighted mean of sigma_max / sigma_min.

    Per triangle, the ratio of the singular values of the Jacobian of the affine map from the
    3D triangle (in its own orthonormal frame) to its UV triangle; 1 is ideal (conformal).
    The aggregate is the mean weighted by 3D face area (Boundary First Flattening). Triangles
    with zero UV area have infinite QCE: they are excluded from the mean and counted
    separately (:func:`qce_details`); zero-3D-area triangles have zero weight.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) float array (per vertex) or (k, 2) float array (per corner, with ``uv_faces``)
    uv_faces : (m, 3) int array, optional
        Per-corner UV indices into ``uv`` (OBJ ``f v/vt``).

    Returns
    -------
    float
        >= 1, lower is better (``inf`` when every triangle has zero UV area).
    """
    return qce_details(vertices, faces, uv, uv_faces).mean


@dataclass
class ASEResult:
    """Area scaling error and the per-face values behind it.

    Attributes
    ----------
    abs_mean : float
        Headline: 3D-area-weighted mean of ``|log(A_uv * s / A_3d)|`` (0 is ideal).
    mean : float
        3D-area-weighted signed mean (negative: UV shrinks on average where weighted).
    min, max : float
        Extreme finite per-face log ratios.
    scale : float
        ``s = total 3D area / total UV area``, applied to UV areas before the ratio.
    per_face : (m,) float64 ndarray
        Log ratio per face (``-inf`` for zero UV area, NaN for zero 3D area).
    n_zero_uv_area : int
        Faces with zero UV area, excluded from the aggregates.
    """

    abs_mean: float
    mean: float
    min: float
    max: float
    scale: float
    per_face: np.ndarray = field(repr=False)
    n_zero_uv_area: int = 0


def ase_details(vertices, faces, uv, uv_faces=None) -> ASEResult:
    """ASE with per-face values; see :func:`ase`."""
    P, T = _corners(vertices, faces, uv, uv_faces)
    a3, auv, deg3, zero_uv, _ = _geometry(P, T, jacobian=False)
    auv = np.abs(auv)
    tot_uv = auv.sum()
    tot_3d = a3.sum()
    if not tot_uv > 0:
        raise ValueError("uv: total UV area is zero, ASE is undefined")
    if not tot_3d > 0:
        raise ValueError("vertices: total 3D area is zero, ASE is undefined")
    s = tot_3d / tot_uv
    with np.errstate(divide="ignore", invalid="ignore"):
        per = np.log(auv * s / a3)
    per[zero_uv] = -np.inf
    per[deg3] = np.nan
    valid = ~deg3 & ~zero_uv
    w = a3[valid]
    lr = per[valid]
    return ASEResult(
        abs_mean=float(np.dot(w, np.abs(lr)) / w.sum()),
        mean=float(np.dot(w, lr) / w.sum()),
        min=float(lr.min()),
        max=float(lr.max()),
        scale=float(s),
        per_face=per,
        n_zero_uv_area=int(np.count_nonzero(zero_uv & ~deg3)),
    )


def ase(vertices, faces, uv, uv_faces=None) -> float:
    """ASE: area scaling error, 3D-area-weighted mean of |log(A_uv / A_3d)|.

    The UV is first scaled so that the total UV area equals the total 3D area (the figure is
    scale-free); per triangle the log ratio is 0 when area is preserved, negative when the UV
    shrinks it. The headline is the area-weighted mean of the absolute log ratio; the signed
    mean, min and max are in :func:`ase_details`. Triangles with zero UV area are excluded
    and counted separately.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) or (k, 2) float array
    uv_faces : (m, 3) int array, optional

    Returns
    -------
    float
        >= 0, lower is better.
    """
    return ase_details(vertices, faces, uv, uv_faces).abs_mean
