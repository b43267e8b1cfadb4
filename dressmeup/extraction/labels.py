"""Garment labels on a fused mesh: visibility-aware voting from per-view label masks,
smoothing on the mesh graph, small-island cleanup, and a colour-clustering fallback."""

from __future__ import annotations

import logging
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from dressmeup.capture.frame import RGBDFrame, frame_camera
from dressmeup.capture.rig import Rig
from dressmeup.capture.visibility import raycasting_scene, visible_from
from dressmeup.geometry.laplacian import adjacency
from dressmeup.geometry.mesh import vertex_normals
from dressmeup.geometry.topology import face_adjacency

__all__ = [
    "LabelConfig", "vote_labels", "smooth_labels", "face_labels_from_vertices",
    "remove_label_islands", "label_mesh", "cluster_colors", "ColorFallbackWarning"
]

log = logging.getLogger(__name__)


class ColorFallbackWarning(UserWarning):
    """Garments were separated by colour clustering (no label masks): check the result."""


@dataclass
class LabelConfig:
    """Label transfer settings.

    Attributes
    ----------
    visibility_tolerance : float, metres; a vertex is visible from a camera when the first
        hit of the ray from the camera towards it is no closer than this.
    min_cos : float, views seeing a vertex at a cosine below this do not vote.
    boundary_pixels : float, votes from pixels closer than this to a label edge in the mask
        are down-weighted linearly (mask edges are where masks and geometry disagree most).
    smooth_iterations : int, iterations of label diffusion on the mesh graph.
    smooth_alpha : float in [0, 1), weight of the neighbours in each diffusion step.
    min_island_faces : int, connected same-label face regions smaller than this are merged
        into their surroundings.
    """

    visibility_tolerance: float = 0.01
    min_cos: float = 0.1
    boundary_pixels: float = 3.0
    smooth_iterations: int = 15
    smooth_alpha: float = 0.7
    min_island_faces: int = 200


def vote_labels(vertices: np.ndarray, faces: np.ndarray, frames: Sequence[RGBDFrame], rig: Rig,
                n_labels: int, config: LabelConfig | None = None) -> np.ndarray:
    """Per-vertex label votes from the views' label masks.

    Each camera that sees a vertex (depth test against the mesh itself, front-facing) votes for
    the label under its projection with weight cos^2(view angle), reduced near mask edges.
    Label 0 (unknown) does not vote.

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int, the fused mesh (rig world frame).
    frames : undistorted frames with ``labels`` (frames without labels are skipped).
    rig : Rig, the cameras of frames that carry none; n_labels : int (labels are 0 .. n_labels-1).
    config : LabelConfig

    Returns
    -------
    (n, n_labels) float64 vote weights (column 0 stays 0).
    """
    cfg = config or LabelConfig()
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    normals = vertex_normals(V, F)
    scene = raycasting_scene(V, F)
    votes = np.zeros((len(V), n_labels))
    for fr in frames:
        if fr.labels is None:
            continue
        cam = frame_camera(fr, rig)
        uv, z = cam.project(V)
        u = np.round(uv[:, 0]).astype(np.int64)
        v = np.round(uv[:, 1]).astype(np.int64)
        inside = (z > 0) & (u >= 0) & (v >= 0) & (u < cam.width) & (v < cam.height)
        to_cam = cam.center - V
        to_cam /= np.maximum(np.linalg.norm(to_cam, axis=1, keepdims=True), 1e-20)
        cos = np.einsum("ij,ij->i", normals, to_cam)
        cand = inside & (cos > cfg.min_cos)
        idx = np.nonzero(cand)[0]
        if len(idx) == 0:
            continue
        vis = visible_from(V[idx], cam.center, scene, cfg.visibility_tolerance)
        idx = idx[vis]
        lab = fr.labels[v[idx], u[idx]].astype(np.int64)
        w = cos[idx] ** 2
        if cfg.boundary_pixels > 0:
            edges = np.zeros(fr.labels.shape, dtype=np.uint8)
            lb = fr.labels
            edges[:, 1:] |= (lb[:, 1:] != lb[:, :-1])
            edges[1:, :] |= (lb[1:, :] != lb[:-1, :])
            dist = cv2.distanceTransform((1 - edges).astype(np.uint8), cv2.DIST_L2, 3)
            w = w * np.clip(dist[v[idx], u[idx]] / cfg.boundary_pixels, 0.05, 1.0)
        ok = (lab > 0) & (lab < n_labels)
        np.add.at(votes, (idx[ok], lab[ok]), w[ok])
    return votes


def smooth_labels(faces: np.ndarray, scores: np.ndarray, iterations: int = 15, alpha: float = 0.7) -> np.ndarray:
    """Diffuse per-vertex label scores on the mesh graph and return per-vertex labels.

    ``P <- (1 - alpha) P0 + alpha * mean over 1-ring neighbours of P`` with ``P0`` the
    row-normalised votes, so well-observed vertices keep their label, isolated outliers flip to
    their neighbourhood's, and unobserved vertices take the labels that diffuse to them.

    Parameters
    ----------
    faces : (m, 3) int, scores : (n, L) float non-negative votes.
    iterations : int, alpha : float in [0, 1).

    Returns
    -------
    (n,) int64 labels (0 where nothing reached the vertex).
    """
    S = np.asarray(scores, dtype=np.float64)
    n = len(S)
    total = S.sum(axis=1, keepdims=True)
    P0 = np.divide(S, total, out=np.zeros_like(S), where=total > 0)
    A = adjacency(np.asarray(faces, dtype=np.int64), n)
    deg = np.asarray(A.sum(axis=1)).ravel()
    dinv = 1.0 / np.maximum(deg, 1)
    P = P0.copy()
    observed = (total[:, 0] > 0)[:, None]
    for _ in range(int(iterations)):
        nb = (A @ P) * dinv[:, None]
        P = np.where(observed, (1 - alpha) * P0 + alpha * nb, nb)
    # vertices still unreached: propagate until every connected vertex has a label
    for _ in range(200):
        empty = P.sum(axis=1) == 0
        if not empty.any():
            break
        nb = (A @ P) * dinv[:, None]
        if not (nb[empty].sum(axis=1) > 0).any():
            break
        P[empty] = nb[empty]
    lab = np.argmax(P, axis=1)
    lab[P.sum(axis=1) == 0] = 0
    return lab.astype(np.int64)


def face_labels_from_vertices(faces: np.ndarray, vertex_labels: np.ndarray, n_labels: int) -> np.ndarray:
    """Majority label of each face's three vertices (ties: the first vertex's label).

    Returns
    -------
    (m,) int64
    """
    F = np.asarray(faces, dtype=np.int64)
    L = np.asarray(vertex_labels, dtype=np.int64)[F]
    counts = np.zeros((len(F), n_labels), dtype=np.int64)
    for k in range(3):
        np.add.at(counts, (np.arange(len(F)), L[:, k]), 1)
    out = np.argmax(counts, axis=1)
    return np.where(counts.max(axis=1) == 1, L[:, 0], out)


def remove_label_islands(faces: np.ndarray, face_labels: np.ndarray, min_faces: int = 200,
                         max_rounds: int = 5) -> np.ndarray:
    """Merge connected same-label face regions smaller than ``min_faces`` into their neighbours.

    Parameters
    ----------
    faces : (m, 3) int, face_labels : (m,) int, min_faces : int.

    Returns
    -------
    (m,) int64 cleaned labels.
    """

    F = np.asarray(faces, dtype=np.int64)
    lab = np.asarray(face_labels, dtype=np.int64).copy()
    if len(F) == 0 or min_faces <= 1:
        return lab

    adj = face_adjacency(F, order="corner")  # votes break ties in pair order
    for _ in range(max_rounds):
        same = lab[adj[:, 0]] == lab[adj[:, 1]]
        a = adj[same]
        g = coo_matrix((np.ones(len(a)), (a[:, 0], a[:, 1])), shape=(len(F), len(F)))
        _, comp = connected_components(g, directed=False)
        size = np.bincount(comp)
        small = size[comp] < min_faces
        if not small.any():
            break
        # each small region takes the most common label across its border
        border = adj[~same]
        changed = False
        votes: dict[int, dict[int, int]] = {}
        for f1, f2 in np.concatenate([border, border[:, ::-1]]):
            if small[f1] and size[comp[f2]] > size[comp[f1]]:
                d = votes.setdefault(int(comp[f1]), {})
                d[int(lab[f2])] = d.get(int(lab[f2]), 0) + 1
        for c, d in votes.items():
            new = max(d, key=d.get)
            sel = comp == c
            if lab[sel][0] != new:
                lab[sel] = new
                changed = True
        if not changed:
            break
    return lab


def label_mesh(vertices: np.ndarray, faces: np.ndarray, frames: Sequence[RGBDFrame], rig: Rig,
               n_labels: int, config: LabelConfig | None = None) -> np.ndarray:
    """Face labels of a fused mesh from the views' label masks (vote, smooth, clean islands).

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int.
    frames : undistorted frames with label masks.
    rig : Rig, the cameras of frames that carry none; n_labels : int (max label + 1).
    config : LabelConfig

    Returns
    -------
    (m,) int64 face labels (1 = skin, 2.. garments, 0 = never seen).

    Raises
    ------
    ValueError when no frame has a label mask.
    """
    cfg = config or LabelConfig()
    if not any(f.labels is not None for f in frames):
        raise ValueError("frames: no label masks; use cluster_colors() as a fallback")
    votes = vote_labels(vertices, faces, frames, rig, n_labels, cfg)
    vl = smooth_labels(faces, votes, cfg.smooth_iterations, cfg.smooth_alpha)
    fl = face_labels_from_vertices(faces, vl, n_labels)
    return remove_label_islands(faces, fl, cfg.min_island_faces)


def cluster_colors(vertices: np.ndarray, faces: np.ndarray, colors: np.ndarray, garment_labels: Sequence[int],
                   up: np.ndarray | None = None, seed: int = 0, height_weight: float = 100.0,
                   config: LabelConfig | None = None) -> np.ndarray:
    """Fallback without label masks: separate garments from skin by colour.

    Skin is found by the classic YCrCb skin-tone box (Cr 135-180, Cb 85-135); the other
    vertices are clustered by k-means (k = number of garments) on CIELAB colour and height
    along ``up`` (``height_weight`` Lab units per metre, so clusters stay spatially
    coherent), and clusters are given to ``garment_labels`` from the highest down (list tops
    first). Then the same graph smoothing and island cleanup as :func:`label_mesh`. It fails
    on skin-coloured garments, bare skin of unusual tones, and garments that overlap in height
    with similar colours: a :class:`ColorFallbackWarning` says so every time it is used.

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int, colors : (n, 3) uint8.
    garment_labels : label values to assign, ordered top to bottom.
    up : (3,) float world up (default +y).
    seed : int, k-means seed.

    Returns
    -------
    (m,) int64 face labels.
    """
    warnings.warn("no label masks: garments separated from skin by colour, which fails on "
                  "skin-coloured garments and garments of similar colour at similar heights; "
                  "check the result or provide label masks", ColorFallbackWarning, stacklevel=2)
    cfg = config or LabelConfig()
    V = np.asarray(vertices, dtype=np.float64)
    C = np.asarray(colors, dtype=np.uint8).reshape(-1, 1, 3)
    ycc = cv2.cvtColor(C, cv2.COLOR_RGB2YCrCb).reshape(-1, 3).astype(np.float64)
    skin = (ycc[:, 1] >= 135) & (ycc[:, 1] <= 180) & (ycc[:, 2] >= 85) & (ycc[:, 2] <= 135) & (ycc[:, 0] > 60)
    up = np.array([0.0, 1.0, 0.0]) if up is None else np.asarray(up, dtype=np.float64)
    h = V @ up
    n_labels = max([1, *garment_labels]) + 1
    assign = np.full(len(V), 1, dtype=np.int64)
    cloth = np.nonzero(~skin)[0]
    k = len(garment_labels)
    if k == 1:
        assign[cloth] = int(garment_labels[0])
    elif k > 1 and len(cloth) >= k:
        lab = cv2.cvtColor(C[cloth], cv2.COLOR_RGB2LAB).reshape(-1, 3).astype(np.float32)
        lab[:, 0] *= 100.0 / 255.0
        lab[:, 1:] -= 128.0
        feats = np.concatenate([0.3 * lab, (height_weight * (h[cloth] - h.mean()))[:, None]], axis=1)
        cv2.setRNGSeed(int(seed))
        _, cl, _ = cv2.kmeans(feats.astype(np.float32), k, None,
                              (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3), 5,
                              cv2.KMEANS_PP_CENTERS)
        cl = cl.ravel()
        order = sorted(range(k), key=lambda c: -float(h[cloth][cl == c].mean()) if (cl == c).any() else 0.0)
        for rank, c in enumerate(order):
            assign[cloth[cl == c]] = int(garment_labels[rank])
    votes = np.zeros((len(V), n_labels))
    votes[np.arange(len(V)), assign] = 1.0
    vl = smooth_labels(faces, votes, cfg.smooth_iterations, cfg.smooth_alpha)
    fl = face_labels_from_vertices(faces, vl, n_labels)
    return remove_label_islands(faces, fl, cfg.min_island_faces)
