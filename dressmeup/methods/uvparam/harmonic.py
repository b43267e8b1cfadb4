"""Per-chart harmonic maps with the boundary fixed on a circle (Eck et al. 1995), libigl."""

from __future__ import annotations

import numpy as np

from dressmeup.methods.uvparam.lscm import LSCMMethod, _single_triangle, boundary_vertices

__all__ = ["HarmonicMethod", "harmonic_flatten", "circle_boundary"]


def circle_boundary(Vc: np.ndarray, bnd: np.ndarray) -> np.ndarray:
    """Place an ordered boundary loop on a circle, spaced by arc length; radius = perimeter / 2 pi.

    Returns
    -------
    (len(bnd), 2) float64
    """
    p = Vc[bnd]
    seg = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
    total = float(seg.sum()) or 1.0
    t = 2 * np.pi * np.r_[0.0, np.cumsum(seg)[:-1]] / total
    r = total / (2 * np.pi)
    return np.stack([r * np.cos(t), r * np.sin(t)], axis=1)


def harmonic_flatten(Vc: np.ndarray, Fc: np.ndarray) -> np.ndarray:
    """Cotangent-weight harmonic map of one disk chart onto a disk.

    Parameters
    ----------
    Vc : (v, 3) float64
    Fc : (f, 3) int64

    Returns
    -------
    (v, 2) float64
    """
    # heavy: igl (~0.4 s to import)
    import igl

    if len(Fc) == 1:
        return _single_triangle(Vc)
    bnd = boundary_vertices(Fc)
    if len(bnd) < 3:
        raise ValueError("harmonic_flatten: the chart has no boundary loop (is it closed?)")
    bc = circle_boundary(Vc, bnd)
    if len(bnd) == len(Vc):
        return bc[np.argsort(bnd)]
    uv = igl.harmonic(np.ascontiguousarray(Vc), np.ascontiguousarray(Fc, dtype=np.int64), bnd, bc, 1)
    return np.asarray(uv, dtype=np.float64)


class HarmonicMethod(LSCMMethod):
    """Harmonic map per chart (boundary on a circle) of a normal-cone segmentation, packed with xatlas.

    Parameters are those of :class:`~dressmeup.methods.uvparam.lscm.LSCMMethod`.
    """

    name = "harmonic"

    def _flatten(self, Vc: np.ndarray, Fc: np.ndarray) -> np.ndarray:
        return harmonic_flatten(Vc, Fc)
