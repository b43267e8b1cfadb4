"""Limbs aimed at the scan the body leaves unexplained (the limb search's extra candidates).

The limb search's cube grid (:mod:`.limbs`) can miss a configuration whose basin is
narrower than its spacing (about 10 degrees at the shoulder for an outstretched arm). So a
search may also aim each limb: scan points farther than a gap from the body are grouped
(:func:`unexplained_groups`), the limb is reduced to its two bones, and the configurations
of a finer grid whose bones run nearest through a group within reach
(:func:`aimed_candidates`) join the grid's candidates under the same score.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from dressmeup.body.registration.hypotheses import align_directions
from dressmeup.body.registration.init import capped_distances
from dressmeup.geometry.neighbors import NearestTree


def fibonacci_directions(n: int) -> np.ndarray:
    """(n, 3) unit vectors spread evenly over the sphere (Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    polar = np.arccos(1.0 - 2.0 * i / n)
    turn = math.pi * (1.0 + 5.0 ** 0.5) * i
    return np.c_[np.cos(turn) * np.sin(polar), np.cos(polar), np.sin(turn) * np.sin(polar)]


def unexplained_groups(P: np.ndarray, V: np.ndarray, gap: float = 0.05, link: float = 0.03,
                       min_points: int = 15, most: int = 3) -> list[np.ndarray]:
    """The groups of scan points the body leaves unexplained, largest first.

    Parameters
    ----------
    P : (p, 3) scan points (m); V : (b, 3) body points (m), current pose.
    gap : a scan point farther than this from every body point is unexplained (m); above
        a clothed scan's shell (1-3 cm) and the noise.
    link : unexplained points closer than this are in one group (m).
    min_points, most : smaller groups are ignored; at most ``most`` groups are returned.

    Returns
    -------
    groups : list of (m_k, 3) arrays of scan points.
    """
    d = capped_distances(NearestTree(V), P, gap)
    far = P[d >= gap]
    if len(far) < min_points:
        return []
    pairs = cKDTree(far).query_pairs(link, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(far), len(far)))
    _, label = connected_components(graph, directed=False)
    sizes = np.bincount(label)
    order = [k for k in np.argsort(-sizes, kind="stable") if sizes[k] >= min_points][:most]
    return [far[label == k] for k in order]


def segment_distances(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n, m) distances of points ``q`` (m, 3) to the segments ``a`` -> ``b`` ((n, 3) or
    (3,) each); through (n, 3) x (3, m) products, no (n, m, 3) array."""
    a = np.broadcast_to(a, b.shape) if a.ndim == 1 else a
    ab = b - a
    ab2 = np.maximum(np.einsum("nk,nk->n", ab, ab), 1e-12)
    # einsum, not @: these products are too small for BLAS threads to pay
    proj = np.einsum("nk,mk->nm", ab, q) - np.einsum("nk,nk->n", a, ab)[:, None]  # (q-a).ab
    w2 = ((q * q).sum(1)[None] - 2.0 * np.einsum("nk,mk->nm", a, q)
          + np.einsum("nk,nk->n", a, a)[:, None])
    t = np.clip(proj / ab2[:, None], 0.0, 1.0)
    return np.sqrt(np.maximum(w2 - 2.0 * t * proj + t * t * ab2[:, None], 0.0))


def aimed_candidates(W_up: np.ndarray, W_lo: np.ndarray,
                     J_up: np.ndarray, J_lo: np.ndarray, end: np.ndarray, hinge,
                     groups, most: int = 60, samples: int = 32, n_directions: int = 300,
                     twists: int = 24, bends_deg=tuple(range(0, 141, 10)),
                     seed: int = 0) -> list[tuple]:
    """(direction, twist rad, bend rad) candidates (parametrised as in
    :func:`.limbs.grid_candidates`) whose bones run through a group of unexplained scan points.

    The limb is reduced to its two bones, upper joint -> lower joint -> ``end``; on a finer
    grid (upper-bone directions x twists x bends) a configuration's distance to a group is
    the mean distance of the group's points (``samples`` of them) to the nearer bone. Per
    group within reach, the ``most`` nearest configurations are returned.

    Parameters
    ----------
    W_up, W_lo : (3, 3) current world rotations of the upper and lower joint; J_up, J_lo :
        (3,) their positions (m); the upper bone runs from J_up to J_lo.
    end : (3,) end of the lower bone (e.g. the centre of the hand's or foot's points),
        current pose (m); it moves with the lower bone.
    groups : list of (m_k, 3) scan points (m), e.g. :func:`unexplained_groups`.
    """
    length = float(np.linalg.norm(J_lo - J_up))
    c_up = (J_lo - J_up) / max(length, 1e-12)
    reach = length + float(np.linalg.norm(end - J_lo))
    rng = np.random.default_rng(seed)
    groups = [g[rng.choice(len(g), min(samples, len(g)), replace=False)] for g in groups]
    groups = [g for g in groups if np.linalg.norm(g - J_up, axis=1).min() <= reach]
    if not groups:
        return []
    D = fibonacci_directions(n_directions)
    d_all = np.repeat(D, twists, axis=0)
    t_all = np.tile(2 * math.pi * np.arange(twists) / twists, n_directions)
    align = np.repeat([align_directions(c_up, d) for d in D], twists, axis=0)
    # :func:`.limbs.limb_rotations`'s upper rotation for every candidate at once
    R_up = (Rotation.from_rotvec(d_all * t_all[:, None]) * Rotation.from_rotvec(align)
            * Rotation.from_matrix(W_up))
    j_lo = J_up + length * d_all
    local_end = W_lo.T @ (end - J_lo)  # in the lower joint's current frame
    upper = [segment_distances(g, J_up, j_lo) for g in groups]
    scores: list[list[np.ndarray]] = [[] for _ in groups]
    bends = np.radians(np.asarray(bends_deg, dtype=np.float64))
    for bend in bends:
        M = (R_up * Rotation.from_rotvec(np.asarray(hinge) * bend)).as_matrix()
        tip = j_lo + M @ local_end
        for k, g in enumerate(groups):
            scores[k].append(np.minimum(upper[k], segment_distances(g, j_lo, tip)).mean(1))
    out = []
    for per_bend in scores:
        flat = np.concatenate(per_bend)  # bend-major: index = bend * n + candidate
        for i in np.argsort(flat, kind="stable")[:most]:
            b, c = divmod(int(i), len(d_all))
            out.append((d_all[c], float(t_all[c]), float(bends[b])))
    return out
