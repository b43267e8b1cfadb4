"""``lscm-on-charts``: LSCM on the charts the neural method cuts, so that flattening is
compared at equal seams.

The neural method (thesis chapter 3) both segments a mesh into charts and flattens them; its
QCE therefore mixes the two. This method takes the neural method's charts (the same
pretrained model, so the same seams) and flattens each with LSCM (Levy et al. 2002), packed
with xatlas like the other baselines: the difference between the two rows is the flattening
alone.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from dressmeup.geometry.mesh import as_arrays
from dressmeup.geometry.uv_atlas import pack_charts, parameterize_charts
from dressmeup.methods.uvparam.base import UVResult
from dressmeup.methods.uvparam.lscm import lscm_flatten
from dressmeup.methods.uvparam.neural.method import NeuralMethod

__all__ = ["LSCMOnChartsMethod"]


class LSCMOnChartsMethod:
    """LSCM per chart of the neural method's segmentation.

    Parameters
    ----------
    pretrained : the neural method's shipped model whose charts are used (``"category"``:
        chosen by the mesh's category, as the neural baseline row does).
    pack : pack the charts into [0, 1]^2 with xatlas.
    **neural : other settings of :class:`~dressmeup.methods.uvparam.neural.method.NeuralMethod`.
    """

    name = "lscm-on-charts"

    def __init__(self, pretrained: str | None = "category", pack: bool = True,
                 **neural: Any) -> None:
        self.pretrained = pretrained
        self.pack = pack
        self.neural = neural

    def parameterize(self, V, F, category: str | None = None) -> UVResult:
        """Parameterise a mesh (see :class:`~dressmeup.methods.uvparam.base.UVResult`).

        Parameters
        ----------
        V : (n, 3) float array
        F : (m, 3) int array
        category : the mesh's category (for ``pretrained="category"``).

        Returns
        -------
        UVResult whose ``info["track"]`` is the neural method's (``pretrained`` when its model
        never saw the mesh).
        """
        t0 = time.perf_counter()
        V, F = as_arrays(V, F)
        seg = NeuralMethod(pretrained=self.pretrained, **self.neural).parameterize(
            V, F, category=category)
        charts = np.asarray(seg.chart_ids, dtype=np.int64)
        t1 = time.perf_counter()
        uv, uv_faces = parameterize_charts(V, F, charts, lscm_flatten)
        if self.pack:
            uv, uv_faces = pack_charts(uv, uv_faces)
        t2 = time.perf_counter()
        return UVResult(uv, uv_faces, charts, t2 - t0,
                        {"n_charts": int(charts.max()) + 1, "seconds_segment": t1 - t0,
                         "seconds_flatten": t2 - t1,
                         "track": seg.info.get("track", "per-mesh")})
