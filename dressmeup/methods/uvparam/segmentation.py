"""Normal-cone region growing: a simple segmentation of a mesh into nearly flat charts.

Faces are grown into regions breadth-first from seeds; a neighbouring face joins a region
while the angle between its normal and the region's (area-weighted) mean normal stays under
``cone_angle``. Seeds are taken in order of decreasing face area (ties by index), so the
result is deterministic. Regions smaller than ``min_faces`` are then merged into the
neighbour they share most edges with, and every chart is split until it is a topological
disk (:func:`dressmeup.geometry.uv_atlas.make_disk_charts`), so LSCM, harmonic maps and SLIM
can flatten each one.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from dressmeup.geometry.mesh import as_arrays, face_areas, face_normals
from dressmeup.geometry.topology import face_adjacency
from dressmeup.geometry.uv_atlas import make_disk_charts, merge_small_charts

__all__ = ["normal_cone_segmentation"]


def normal_cone_segmentation(V, F, cone_angle: float = np.deg2rad(50.0), min_faces: int = 16,
                             max_faces: int | None = None) -> np.ndarray:
    """Segment a mesh into charts of bounded normal variation.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    cone_angle : float
        Maximum angle (radians) between a face normal and its region's mean normal.
    min_faces : int
        Smaller regions are merged into a neighbour.
    max_faces : int, optional
        Stop growing a region at this many faces.

    Returns
    -------
    (m,) int64 ndarray of chart ids ``0..c-1``; every chart is an edge-connected disk.

    Raises
    ------
    ValueError
        Invalid mesh or a non-positive ``cone_angle``.
    """
    V, F = as_arrays(V, F)
    if not (0 < cone_angle <= np.pi):
        raise ValueError(f"cone_angle: expected a value in (0, pi], got {cone_angle}")
    m = len(F)
    N = face_normals(V, F)
    A = face_areas(V, F)
    adj = face_adjacency(F)
    # CSR neighbour lists
    a = np.r_[adj[:, 0], adj[:, 1]]
    b = np.r_[adj[:, 1], adj[:, 0]]
    order = np.argsort(a, kind="stable")
    nbr = b[order]
    ptr = np.r_[0, np.cumsum(np.bincount(a, minlength=m))]
    cos_lim = float(np.cos(cone_angle))
    labels = np.full(m, -1, dtype=np.int64)
    seeds = np.lexsort((np.arange(m), -A))
    cap = max_faces or m
    region = 0
    Nl = N.tolist()
    Al = A.tolist()
    nbr_l = nbr.tolist()
    ptr_l = ptr.tolist()
    lab = labels.tolist()
    for s in seeds.tolist():
        if lab[s] >= 0:
            continue
        lab[s] = region
        sx, sy, sz = Nl[s][0] * Al[s], Nl[s][1] * Al[s], Nl[s][2] * Al[s]
        count = 1
        queue = deque([s])
        while queue and count < cap:
            f = queue.popleft()
            for j in nbr_l[ptr_l[f]:ptr_l[f + 1]]:
                if lab[j] >= 0:
                    continue
                norm = (sx * sx + sy * sy + sz * sz) ** 0.5 or 1.0
                nj = Nl[j]
                if (nj[0] * sx + nj[1] * sy + nj[2] * sz) / norm >= cos_lim:
                    lab[j] = region
                    w = Al[j]
                    sx, sy, sz = sx + nj[0] * w, sy + nj[1] * w, sz + nj[2] * w
                    count += 1
                    queue.append(j)
                    if count >= cap:
                        break
        region += 1
    labels = np.asarray(lab, dtype=np.int64)
    labels = merge_small_charts(F, labels, min_faces, adj)
    return make_disk_charts(V, F, labels)
