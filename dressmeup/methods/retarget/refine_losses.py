"""The refinement's per-sample inputs and its self-supervised losses (thesis 4.3.2, eq. 4.6-4.8).

- edge length (eq. 4.6-4.7): mean over the garment's edges of ``w_e | |e'| - |e| |``, with
  ``w_e = 0`` for edges near the elbows, armpits (shoulders), waist (pelvis, spine1) and
  knees of the source body (the joint masks of Fig. 4.16, :func:`joint_mask`), 1 elsewhere;
- correspondence (eq. 4.8): ``mean ||x_i - x'_i||`` where ``x'_i`` re-runs eq. 4.1 + 4.4 from
  the refined point ``v'_i`` on the target (:func:`correspondence_points`);
- bending: mean over interior edges of ``1 - n_1 . n_2`` (adjacent face normals);
- penetration (NOT in the thesis, added here): mean of ``relu(margin - (v'_i - p_i) . n_i)``
  with ``p_i`` the nearest target skin vertex and ``n_i`` its normal.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.geometry.topology import face_adjacency

__all__ = ["RefineSample", "joint_mask", "face_pairs", "subsample", "correspondence_points", "refine_losses",
           "MASK_JOINTS"]

MASK_JOINTS = ("left_elbow", "right_elbow", "left_shoulder", "right_shoulder", "pelvis", "spine1",
               "left_knee", "right_knee")


# --------------------------------------------------------------------------------------------
# per-sample preparation
# --------------------------------------------------------------------------------------------
@dataclass
class RefineSample:
    """Everything the network and the losses need for one (garment, source, target) triplet.

    Coordinates are relative to ``center`` (the target root joint); arrays are float32
    unless stated.

    Attributes
    ----------
    x : (n, 3) coarse positions; phi : (n, d) garment embedding; neighbors : (n, 3k) offsets of
    the k nearest target vertices; garment_points : (p, 3) input garment points (relative to
    the source root); body_points : (p, 3) target skin points; input_V : (n, 3) float64 input
    garment; faces : (m, 3) int64; edges : (e, 2) int64; edge_weights : (e,) joint mask;
    face_pairs : (b, 2) int64 faces sharing an interior edge; target_V : (t, 3) target skin;
    target_N : (t, 3) its normals; target_emb : (t, d); center : (3,) float64;
    seconds_correspondence : time of the coarse placement and neighbour search; truth : (n, 3)
    float64 ground-truth garment on the target (same frame), when known (validation, the
    supervised variant), else None.
    """

    x: np.ndarray
    phi: np.ndarray
    neighbors: np.ndarray
    garment_points: np.ndarray
    body_points: np.ndarray
    input_V: np.ndarray
    faces: np.ndarray
    edges: np.ndarray
    edge_weights: np.ndarray
    face_pairs: np.ndarray
    target_V: np.ndarray
    target_N: np.ndarray
    target_emb: np.ndarray
    center: np.ndarray
    seconds_correspondence: float = 0.0
    truth: np.ndarray | None = None
    _tree: Any = None

    def tree(self) -> cKDTree:
        """k-d tree over ``target_V`` (built once)."""
        if self._tree is None:
            self._tree = cKDTree(self.target_V)
        return self._tree


def joint_mask(points: np.ndarray, joints: np.ndarray, joint_names, radius: float,
               names=MASK_JOINTS) -> np.ndarray:
    """Which points lie within ``radius`` of the masked joints (thesis Fig. 4.16).

    Parameters
    ----------
    points : (n, 3) float array (garment vertices, on the source body).
    joints : (j, 3) float array (source body joints, same frame).
    joint_names : sequence of j names.
    radius : float, metres.
    names : joints to mask (absent ones are skipped).

    Returns
    -------
    (n,) bool ndarray.
    """
    ids = [i for i, n in enumerate(joint_names) if n in set(names)]
    if not ids or radius <= 0:
        return np.zeros(len(points), dtype=bool)
    d = np.linalg.norm(np.asarray(points)[:, None, :] - np.asarray(joints)[ids][None], axis=2)
    return (d < radius).any(axis=1)


def face_pairs(F: np.ndarray) -> np.ndarray:
    """Pairs of faces sharing an edge that exactly two faces hold: (b, 2) int64 (the pair order
    the shipped weights were trained with: :func:`dressmeup.geometry.topology.face_adjacency`
    with ``order="corner"``)."""

    return face_adjacency(F, manifold_only=True, order="corner")


def subsample(points: np.ndarray, n: int, seed: int) -> np.ndarray:
    """At most ``n`` rows of ``points`` (a fixed-seed choice without replacement; all when fewer)."""
    if len(points) <= n:
        return points
    return points[np.random.default_rng(seed).choice(len(points), n, replace=False)]


# --------------------------------------------------------------------------------------------
# differentiable losses
# --------------------------------------------------------------------------------------------
def correspondence_points(v, sample: RefineSample, k_extrapolate: int = 32, k_place: int = 32,
                          candidates: int = 64):
    """Re-run eq. 4.1 + eq. 4.4 from points ``v`` near the target (differentiable in ``v``).

    The embedding of ``v_i`` is the inverse-distance mean of the embeddings of its
    ``k_extrapolate`` nearest target vertices (eq. 4.1 on the target); its placement is the
    inverse-distance (in embedding space) mean of the ``k_place`` target vertices nearest to
    that embedding (eq. 4.4), searched among the ``candidates`` target vertices nearest to
    ``v_i`` in 3D (the embedding is geodesic, so its nearest neighbours are local). Neighbour
    sets are found without gradient; distances and weights carry it.

    Parameters
    ----------
    v : (n, 3) float torch tensor
    sample : RefineSample

    Returns
    -------
    x : (n, 3) torch tensor, the re-placed points.
    nearest : (n,) int64 numpy, the nearest target vertex of each ``v_i``.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    c = int(min(candidates, len(sample.target_V)))
    _, cand = sample.tree().query(v.detach().cpu().numpy().astype(np.float64), k=c)
    cand = np.asarray(cand).reshape(len(v), c)
    T = torch.as_tensor(sample.target_V, dtype=v.dtype)
    E = torch.as_tensor(sample.target_emb, dtype=v.dtype)
    ci = torch.as_tensor(cand)
    Tc = T[ci]  # (n, c, 3)
    ke = min(k_extrapolate, c)
    d = (v[:, None, :] - Tc[:, :ke]).norm(dim=2).clamp_min(1e-6)
    w = 1.0 / d
    w = w / w.sum(1, keepdim=True)
    phi = (w[..., None] * E[ci[:, :ke]]).sum(1)  # (n, dim)
    de = (phi[:, None, :] - E[ci]).norm(dim=2)  # (n, c)
    kp = min(k_place, c)
    with torch.no_grad():
        sel = torch.topk(de, kp, dim=1, largest=False).indices
    de_sel = torch.gather(de, 1, sel).clamp_min(1e-6)
    w2 = 1.0 / de_sel
    w2 = w2 / w2.sum(1, keepdim=True)
    x = (w2[..., None] * torch.gather(Tc, 1, sel[..., None].expand(-1, -1, 3))).sum(1)
    return x, cand[:, 0]


def refine_losses(v, sample: RefineSample, margin: float = 0.003, use_joint_mask: bool = True,
                  k_extrapolate: int = 32, k_place: int = 32) -> dict[str, Any]:
    """The four self-supervised losses on a refined garment.

    Parameters
    ----------
    v : (n, 3) float torch tensor, refined vertices (same frame as ``sample.x``).
    sample : RefineSample
    margin : float, metres the penetration term wants between garment and skin.
    use_joint_mask : bool, zero the edge-length weight of edges near the masked joints.

    Returns
    -------
    dict of scalar tensors: ``length``, ``corres``, ``bend``, ``penetration``.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    dtype = v.dtype
    E = torch.as_tensor(sample.edges)
    rest = torch.as_tensor(np.linalg.norm(sample.input_V[sample.edges[:, 0]] - sample.input_V[sample.edges[:, 1]],
                                          axis=1), dtype=dtype)
    cur = (v[E[:, 0]] - v[E[:, 1]]).norm(dim=1)
    w = torch.as_tensor(sample.edge_weights if use_joint_mask else np.ones(len(sample.edges)), dtype=dtype)
    length = (w * (cur - rest).abs()).mean()

    x = torch.as_tensor(sample.x, dtype=dtype)
    xp, nearest = correspondence_points(v, sample, k_extrapolate, k_place)
    corres = (x - xp).norm(dim=1).mean()

    if len(sample.face_pairs):
        F = torch.as_tensor(sample.faces)
        a, b, c = v[F[:, 0]], v[F[:, 1]], v[F[:, 2]]
        n = torch.linalg.cross(b - a, c - a)
        n = n / n.norm(dim=1, keepdim=True).clamp_min(1e-12)
        P = torch.as_tensor(sample.face_pairs)
        bend = (1.0 - (n[P[:, 0]] * n[P[:, 1]]).sum(1)).mean()
    else:
        bend = v.sum() * 0.0

    p = torch.as_tensor(sample.target_V[nearest], dtype=dtype)
    nrm = torch.as_tensor(sample.target_N[nearest], dtype=dtype)
    sd = ((v - p) * nrm).sum(1)
    penetration = torch.relu(margin - sd).mean()
    return {"length": length, "corres": corres, "bend": bend, "penetration": penetration}
