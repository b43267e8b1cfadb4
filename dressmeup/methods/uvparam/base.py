"""The result type and shared plumbing of the UV-parameterisation methods."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["UVResult"]


@dataclass
class UVResult:
    """A per-corner UV map.

    Attributes
    ----------
    uv : (k, 2) float64
        UV coordinates (packed into ``[0, 1]^2`` when the method packs).
    uv_faces : (m, 3) int64
        Per-face indices into ``uv`` (same face order as the input mesh).
    chart_ids : (m,) int64
        Chart of each face, ``0..c-1``.
    seconds : float
        Wall time of :meth:`parameterize` (everything from the input arrays to the packed UVs).
    info : dict
        Method-specific extras (number of charts, timings of stages, ...).
    """

    uv: np.ndarray
    uv_faces: np.ndarray
    chart_ids: np.ndarray
    seconds: float
    info: dict = field(default_factory=dict)

    @property
    def n_charts(self) -> int:
        return int(self.chart_ids.max()) + 1 if len(self.chart_ids) else 0
