"""Per-chart least-squares conformal maps (Levy et al. 2002) with libigl."""

from __future__ import annotations

import time

import numpy as np

from dressmeup.geometry.mesh import as_arrays
from dressmeup.geometry.uv_atlas import pack_charts, parameterize_charts
from dressmeup.methods.uvparam.base import UVResult
from dressmeup.methods.uvparam.segmentation import normal_cone_segmentation

__all__ = ["LSCMMethod", "lscm_flatten", "boundary_vertices"]


def boundary_vertices(Fc: np.ndarray) -> np.ndarray:
    """Ordered longest boundary loop of a chart (libigl), or ``[]`` for a closed chart."""
    # heavy: igl (~0.4 s to import)
    import igl

    return np.asarray(igl.boundary_loop(np.ascontiguousarray(Fc, dtype=np.int64)), dtype=np.int64)


def lscm_flatten(Vc: np.ndarray, Fc: np.ndarray) -> np.ndarray:
    """LSCM of one disk chart, pinning the two boundary vertices farthest apart.

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
    if len(bnd) < 2:
        bnd = np.arange(len(Vc))
    p = Vc[bnd]
    i = int(np.argmax(np.linalg.norm(p - p[0], axis=1)))
    j = int(np.argmax(np.linalg.norm(p - p[i], axis=1)))
    b = np.array([bnd[i], bnd[j]], dtype=np.int64)
    d = float(np.linalg.norm(Vc[b[0]] - Vc[b[1]])) or 1.0
    bc = np.array([[0.0, 0.0], [d, 0.0]])
    out = igl.lscm(np.ascontiguousarray(Vc), np.ascontiguousarray(Fc, dtype=np.int64), b, bc)
    uv = out[0] if isinstance(out, tuple) else out
    return np.asarray(uv, dtype=np.float64)


def _single_triangle(Vc: np.ndarray) -> np.ndarray:
    a, b, c = Vc
    e1 = b - a
    L1 = np.linalg.norm(e1) or 1.0
    x = e1 / L1
    w = c - a
    cx = float(w @ x)
    cy = float(np.linalg.norm(w - cx * x))
    return np.array([[0.0, 0.0], [L1, 0.0], [cx, cy]])


class LSCMMethod:
    """LSCM per chart of a normal-cone segmentation, packed with xatlas.

    Parameters
    ----------
    cone_angle : float
        Segmentation cone half-angle in degrees.
    min_faces : int
        Minimum chart size of the segmentation.
    pack : bool
        Pack the charts into [0, 1]^2 with xatlas (otherwise charts keep their 3D scale and
        may overlap each other).
    """

    name = "lscm"

    def __init__(self, cone_angle: float = 50.0, min_faces: int = 16, pack: bool = True):
        self.cone_angle = cone_angle
        self.min_faces = min_faces
        self.pack = pack

    def _flatten(self, Vc: np.ndarray, Fc: np.ndarray) -> np.ndarray:
        return lscm_flatten(Vc, Fc)

    def parameterize(self, V, F) -> UVResult:
        """Parameterise a mesh; see :class:`~dressmeup.methods.uvparam.base.UVResult`.

        Parameters
        ----------
        V : (n, 3) float array
        F : (m, 3) int array

        Returns
        -------
        UVResult
        """
        t0 = time.perf_counter()
        V, F = as_arrays(V, F)
        charts = normal_cone_segmentation(V, F, np.deg2rad(self.cone_angle), self.min_faces)
        t1 = time.perf_counter()
        uv, uv_faces = parameterize_charts(V, F, charts, self._flatten)
        t2 = time.perf_counter()
        if self.pack:
            uv, uv_faces = pack_charts(uv, uv_faces)
        t3 = time.perf_counter()
        return UVResult(uv, uv_faces, charts, t3 - t0,
                        {"n_charts": int(charts.max()) + 1, "seconds_segment": t1 - t0,
                         "seconds_flatten": t2 - t1, "seconds_pack": t3 - t2})
