"""PatchNet: a DiffusionNet that softly assigns every vertex to one of K patches.

Input per vertex: the normalised position and the vertex normal (6 channels); output: a
softmax over K patches. Trained self-supervised with the flatness and compactness losses of
eq. 3.1-3.2 (:mod:`.losses`). Hard charts come from :func:`assign_charts`: per-face
probabilities are the mean of their vertices', averaged ``consolidation_steps`` times with
their edge neighbours, then arg-maxed; disconnected islands become their own charts, charts
under ``min_chart_fraction`` of the faces are merged into the neighbour they share most
edges with, and charts that are not topological disks are cut until they are (a closed
patch, e.g. a ring around a torus tube, cannot be flattened without a cut).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from dressmeup.geometry.mesh import vertex_normals
from dressmeup.geometry.topology import face_adjacency
from dressmeup.geometry.uv_atlas import connected_charts, make_disk_charts, merge_small_charts
from dressmeup.methods.nn.diffusion_net import DiffusionNet

__all__ = ["normalize_vertices", "patchnet_inputs", "build_patchnet", "face_probabilities",
           "assign_charts"]


def normalize_vertices(V: np.ndarray) -> np.ndarray:
    """Centre on the bounding-box centre and scale the bounding-box diagonal to 1.

    Parameters
    ----------
    V : (n, 3) float array

    Returns
    -------
    (n, 3) float64 ndarray
    """
    lo, hi = V.min(axis=0), V.max(axis=0)
    diag = float(np.linalg.norm(hi - lo)) or 1.0
    return (V - 0.5 * (lo + hi)) / diag


def patchnet_inputs(Vn: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Per-vertex PatchNet input ``[x, y, z, nx, ny, nz]``, (n, 6) float32."""
    return np.concatenate([Vn, vertex_normals(Vn, F)], axis=1).astype(np.float32)


def build_patchnet(n_patches: int, width: int = 128, n_blocks: int = 4, seed: int = 0):
    """DiffusionNet 6 -> ``n_patches`` with a softmax output (a ``torch.nn.Module``)."""
    return DiffusionNet(6, n_patches, width=width, n_blocks=n_blocks, last_activation="softmax",
                        seed=seed)


def face_probabilities(vertex_probs: np.ndarray, F: np.ndarray, consolidation_steps: int = 2,
                       adjacency: np.ndarray | None = None) -> np.ndarray:
    """Per-face patch probabilities: vertex mean, then neighbour averaging.

    Parameters
    ----------
    vertex_probs : (n, K) float array
    F : (m, 3) int array
    consolidation_steps : int
        Times each face's probabilities are replaced by the mean over itself and its edge
        neighbours.
    adjacency : (p, 2) int array, optional

    Returns
    -------
    (m, K) float64 ndarray
    """
    P = np.asarray(vertex_probs, dtype=np.float64)[F].mean(axis=1)
    if consolidation_steps > 0:
        m = len(F)
        adj = face_adjacency(F) if adjacency is None else adjacency
        A = sp.coo_matrix((np.ones(2 * len(adj)), (np.r_[adj[:, 0], adj[:, 1]], np.r_[adj[:, 1], adj[:, 0]])),
                          shape=(m, m)).tocsr() + sp.identity(m, format="csr")
        A = sp.diags(1.0 / np.asarray(A.sum(axis=1)).ravel()) @ A
        for _ in range(consolidation_steps):
            P = A @ P
    return P


def assign_charts(Vn: np.ndarray, F: np.ndarray, vertex_probs: np.ndarray,
                  consolidation_steps: int = 2, min_chart_fraction: float = 0.01,
                  min_chart_faces: int = 8) -> np.ndarray:
    """Hard charts from PatchNet's soft assignment.

    Parameters
    ----------
    Vn : (n, 3) float array
    F : (m, 3) int array
    vertex_probs : (n, K) float array
    consolidation_steps : int
    min_chart_fraction : float
        Charts with fewer than this share of the faces are merged into a neighbour (a share,
        so the result does not depend on the resolution).
    min_chart_faces : int
        Absolute lower bound of the merge threshold.

    Returns
    -------
    (m,) int64 ndarray of chart ids; every chart is an edge-connected disk.
    """
    adj = face_adjacency(F)
    P = face_probabilities(vertex_probs, F, consolidation_steps, adj)
    labels = np.argmax(P, axis=1)
    ids = connected_charts(F, labels, adj)
    ids = merge_small_charts(F, ids, max(min_chart_faces, int(min_chart_fraction * len(F))), adj)
    return make_disk_charts(Vn, F, ids)
