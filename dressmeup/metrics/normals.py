"""Normal consistency (NC): signed cosine between unit normals of two meshes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dressmeup.geometry.mesh import face_normals, vertex_normals
from dressmeup.geometry.proximity import closest_points
from dressmeup.geometry.sampling import sample_surface
from dressmeup.metrics._common import (
    DEFAULT_SAMPLES,
    TopologyMismatchError,
    check_samples,
    mesh_arrays,
)

__all__ = ["NormalConsistency", "normal_consistency", "normal_consistency_details"]


@dataclass
class NormalConsistency:
    """Normal consistency and the per-element cosines behind it.

    Attributes
    ----------
    value : float
        The NC figure (higher is better; 1 = identical orientation).
    mode : str
        ``"vertex"`` (same topology: per-vertex normals) or ``"surface"`` (different topology:
        surface samples matched to the other mesh's nearest face).
    cos : ndarray
        Same topology: (n,) per-vertex cosine (NaN where a normal is undefined). Different
        topology: (2 * n_samples,) cosines, pred-sample half first.
    """

    value: float
    mode: str
    cos: np.ndarray = field(repr=False)


def _same_topology(Vp: np.ndarray, Fp: np.ndarray, Vg: np.ndarray, Fg: np.ndarray) -> bool:
    return Vp.shape == Vg.shape and Fp.shape == Fg.shape and bool(np.array_equal(Fp, Fg))


def normal_consistency_details(
    pred: Any,
    gt: Any,
    absolute: bool = False,
    n_samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
    mode: str = "auto",
) -> NormalConsistency:
    """Normal consistency with per-element cosines; see :func:`normal_consistency`."""
    Vp, Fp = mesh_arrays(pred, "pred")
    Vg, Fg = mesh_arrays(gt, "gt")
    if mode not in ("auto", "vertex", "surface"):
        raise ValueError(f"mode: expected 'auto', 'vertex' or 'surface', got {mode!r}")
    same = _same_topology(Vp, Fp, Vg, Fg)
    if mode == "vertex" and not same:
        raise TopologyMismatchError("normal_consistency(mode='vertex') needs identical topology")
    if mode == "vertex" or (mode == "auto" and same):
        npred = vertex_normals(Vp, Fp)
        ngt = vertex_normals(Vg, Fg)
        ok = (np.linalg.norm(npred, axis=1) > 0) & (np.linalg.norm(ngt, axis=1) > 0)
        cos = np.full(Vp.shape[0], np.nan)
        cos[ok] = np.einsum("ij,ij->i", npred[ok], ngt[ok])
        if absolute:
            cos = np.abs(cos)
        if not np.any(ok):
            raise ValueError("pred/gt: no vertex has a defined normal (all faces degenerate?)")
        return NormalConsistency(float(np.mean(cos[ok])), "vertex", cos)
    n = check_samples(n_samples)
    nfp = face_normals(Vp, Fp)
    nfg = face_normals(Vg, Fg)
    pp, fp, _ = sample_surface(Vp, Fp, n, seed=seed)
    pg, fg, _ = sample_surface(Vg, Fg, n, seed=seed + 1)
    hit_g = closest_points(Vg, Fg, pp)[2]
    hit_p = closest_points(Vp, Fp, pg)[2]
    c_pg = np.einsum("ij,ij->i", nfp[fp], nfg[hit_g])
    c_gp = np.einsum("ij,ij->i", nfg[fg], nfp[hit_p])
    if absolute:
        c_pg, c_gp = np.abs(c_pg), np.abs(c_gp)
    value = 0.5 * (float(c_pg.mean()) + float(c_gp.mean()))
    return NormalConsistency(value, "surface", np.concatenate([c_pg, c_gp]))


def normal_consistency(
    pred: Any,
    gt: Any,
    absolute: bool = False,
    n_samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
    mode: str = "auto",
) -> float:
    """NC: signed cosine between unit normals of two meshes (docs/spec.md section 1).

    Same topology (same vertex count and identical faces): mean over vertices of
    ``n_pred . n_gt`` with area-weighted vertex normals (vertices without a defined normal,
    e.g. isolated ones, are excluded). Different topology: ``n_samples`` uniform surface
    samples of each mesh, each with its face normal, dotted with the normal of the face of
    the other mesh that holds the nearest point; the two directions' means are averaged.

    Parameters
    ----------
    pred, gt : trimesh.Trimesh or tuple (V (n, 3) float, F (m, 3) int)
    absolute : bool
        ``True`` gives ``|cos|`` (the Occupancy Networks convention, orientation-blind).
    n_samples : int
        Samples per mesh in the different-topology case (default 100,000).
    seed : int
        Sampling seed (``pred`` uses ``seed``, ``gt`` uses ``seed + 1``).
    mode : {"auto", "vertex", "surface"}
        Force one definition; ``"auto"`` picks by topology.

    Returns
    -------
    float
        In [-1, 1] (in [0, 1] with ``absolute``); higher is better.
    """
    return normal_consistency_details(pred, gt, absolute, n_samples, seed, mode).value
