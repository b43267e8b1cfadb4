"""SLIM (Rabinovich et al. 2017, libigl): symmetric-Dirichlet-minimising maps per chart.

The low-distortion reference. Each chart of a (coarser) normal-cone segmentation is
initialised with a Tutte embedding (uniform weights, boundary on a circle: bijective) and
then optimised with SLIM for ``iterations`` steps, which keeps it free of flips.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from dressmeup.methods.uvparam.harmonic import circle_boundary
from dressmeup.methods.uvparam.lscm import LSCMMethod, _single_triangle, boundary_vertices

__all__ = ["SLIMMethod", "tutte_flatten", "slim_flatten"]


def tutte_flatten(Vc: np.ndarray, Fc: np.ndarray) -> np.ndarray:
    """Tutte embedding (uniform weights) of a disk chart with its boundary on a circle.

    Returns
    -------
    (v, 2) float64
    """

    n = len(Vc)
    bnd = boundary_vertices(Fc)
    bc = circle_boundary(Vc, bnd)
    e = np.concatenate([Fc[:, [0, 1]], Fc[:, [1, 2]], Fc[:, [2, 0]]])
    W = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
    W = ((W + W.T) > 0).astype(np.float64)
    L = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    interior = np.setdiff1d(np.arange(n), bnd)
    uv = np.zeros((n, 2))
    uv[bnd] = bc
    if interior.size:
        Lii = L[interior][:, interior].tocsc()
        rhs = -L[interior][:, bnd] @ bc
        uv[interior] = np.column_stack([spsolve(Lii, rhs[:, 0]), spsolve(Lii, rhs[:, 1])])
    return uv


def slim_flatten(Vc: np.ndarray, Fc: np.ndarray, iterations: int = 20) -> np.ndarray:
    """SLIM (symmetric Dirichlet) map of one disk chart, from a Tutte initialisation.

    Returns
    -------
    (v, 2) float64
    """
    # heavy: igl (~0.4 s to import)
    import igl

    if len(Fc) == 1:
        return _single_triangle(Vc)
    uv0 = tutte_flatten(Vc, Fc)
    # orient counter-clockwise first: SLIM needs a positively oriented start
    a, b, c = uv0[Fc[:, 0]], uv0[Fc[:, 1]], uv0[Fc[:, 2]]
    s = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    if np.sum(s) < 0:
        uv0[:, 0] *= -1
    data = igl.slim_precompute(
        np.asfortranarray(Vc, dtype=np.float64), np.asfortranarray(Fc, dtype=np.int32),
        np.asfortranarray(uv0), igl.MappingEnergyType.SYMMETRIC_DIRICHLET,
        np.zeros(0, dtype=np.int32), np.zeros((0, 2), order="F"), 0.0)
    uv = igl.slim_solve(data, int(iterations))
    uv = np.asarray(uv, dtype=np.float64)
    if not np.all(np.isfinite(uv)):
        return uv0
    return uv


class SLIMMethod(LSCMMethod):
    """SLIM per chart of a normal-cone segmentation (wide cone: fewer, larger charts), packed with xatlas.

    Parameters
    ----------
    cone_angle : float
        Segmentation cone half-angle in degrees (default 70: SLIM copes with curved charts).
    min_faces : int
    iterations : int
        SLIM iterations per chart.
    pack : bool
    """

    name = "slim"

    def __init__(self, cone_angle: float = 70.0, min_faces: int = 16, iterations: int = 20,
                 pack: bool = True):
        super().__init__(cone_angle=cone_angle, min_faces=min_faces, pack=pack)
        self.iterations = iterations

    def _flatten(self, Vc: np.ndarray, Fc: np.ndarray) -> np.ndarray:
        return slim_flatten(Vc, Fc, self.iterations)
