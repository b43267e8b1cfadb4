"""xatlas (segment + parameterise + pack in one library): the production-tool baseline."""

from __future__ import annotations

import time

from dressmeup.geometry.mesh import as_arrays
from dressmeup.geometry.uv_packing import uv_components, xatlas_atlas
from dressmeup.methods.uvparam.base import UVResult

__all__ = ["XatlasMethod"]


class XatlasMethod:
    """xatlas with its default chart and pack options.

    Parameters
    ----------
    resolution : int
        Atlas resolution used for packing (0: xatlas picks one).
    padding : int
        Texels between charts.
    max_iterations : int
        xatlas chart-growing iterations (its default is 1).
    rotate_charts : bool
        xatlas' chart rotation while packing. Off by default: it also transposes charts
        (mirror images), so 30-50 % of the faces end up clockwise while the rest are
        counter-clockwise, which the flip metric counts as flipped.
    """

    name = "xatlas"

    def __init__(self, resolution: int = 1024, padding: int = 2, max_iterations: int = 1,
                 rotate_charts: bool = False):
        self.rotate_charts = rotate_charts
        self.resolution = resolution
        self.padding = padding
        self.max_iterations = max_iterations

    def parameterize(self, V, F) -> UVResult:
        """Parameterise a mesh.

        Parameters
        ----------
        V : (n, 3) float array
        F : (m, 3) int array

        Returns
        -------
        UVResult
            Per-corner UVs in [0, 1]^2; ``chart_ids`` from xatlas' charts.
        """
        t0 = time.perf_counter()
        V, F = as_arrays(V, F)
        atlas = xatlas_atlas(V, F, resolution=self.resolution, padding=self.padding, bilinear=True,
                             rotate_charts=self.rotate_charts, max_iterations=self.max_iterations)
        chart_ids = uv_components(atlas.uv_faces, len(atlas.uv))
        return UVResult(atlas.uv, atlas.uv_faces, chart_ids, time.perf_counter() - t0,
                        {"n_charts": atlas.n_charts})
