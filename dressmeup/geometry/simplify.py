"""Mesh simplification."""

from __future__ import annotations

import igl
import numpy as np


def decimate(V: np.ndarray, F: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Edge-collapse decimation (libigl) to about ``n_vertices``; the mesh itself when it has
    at most 1.5 ``n_vertices``. Unreferenced vertices are dropped.

    Returns
    -------
    V : (n2, 3) float64
    F : (m2, 3) int64
    """
    if len(V) <= 1.5 * n_vertices:
        return V, F
    target_faces = int(2 * n_vertices * len(F) / max(2 * len(V), 1))
    out = igl.decimate(np.ascontiguousarray(V), np.ascontiguousarray(F, dtype=np.int64), max(target_faces, 64))
    # libigl < 2.6 returns (success, U, G, J, I); 2.6 returns (U, G, J, I)
    U, G = (out[1], out[2]) if len(out) == 5 else (out[0], out[1])
    V2, F2 = np.asarray(U, dtype=np.float64), np.asarray(G, dtype=np.int64)
    if len(F2) == 0:
        return V, F
    used = np.unique(F2)
    remap = np.full(len(V2), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return V2[used], remap[F2]
