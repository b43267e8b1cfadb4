"""Cut each garment out of a labelled scan as its own mesh with clean boundaries."""

from __future__ import annotations

import numpy as np

from dressmeup.fusion.cleanup import largest_components

__all__ = ["submesh", "remove_ears", "smooth_boundary", "cut_garment"]


def submesh(vertices: np.ndarray, faces: np.ndarray, face_mask: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The faces selected by ``face_mask`` with their vertices re-indexed.

    Returns
    -------
    V (k, 3) float64, F (l, 3) int64, vertex_ids (k,) int64 indices into ``vertices``.
    """
    F = np.asarray(faces, dtype=np.int64)[np.asarray(face_mask, dtype=bool)]
    used, inv = np.unique(F, return_inverse=True)
    return np.asarray(vertices, dtype=np.float64)[used], inv.reshape(-1, 3).astype(np.int64), used


def _boundary_edges(F: np.ndarray) -> np.ndarray:
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, counts = np.unique(e, axis=0, return_counts=True)
    return uniq[counts == 1]


def remove_ears(faces: np.ndarray, max_rounds: int = 10) -> np.ndarray:
    """Mask of faces to keep after repeatedly removing faces with 2+ boundary edges (the
    saw-teeth a per-face labelling leaves along a cut).

    Parameters
    ----------
    faces : (m, 3) int
    max_rounds : int

    Returns
    -------
    (m,) bool
    """
    F = np.asarray(faces, dtype=np.int64)
    keep = np.ones(len(F), dtype=bool)
    if len(F) == 0:
        return keep
    e = np.sort(np.stack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=1), axis=2)  # (m, 3, 2)
    key = e[..., 0] * (int(F.max()) + 1) + e[..., 1]
    _, inv = np.unique(key.ravel(), return_inverse=True)
    inv = inv.reshape(-1, 3)
    for _ in range(max_rounds):
        counts = np.bincount(inv[keep].ravel(), minlength=int(inv.max()) + 1)
        n_boundary = (counts[inv] == 1).sum(axis=1)
        ear = keep & (n_boundary >= 2)
        if not ear.any():
            break
        keep &= ~ear
    return keep


def smooth_boundary(vertices: np.ndarray, faces: np.ndarray, iterations: int = 5, step: float = 0.5,
                    surface: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Smooth boundary loops (1-D Laplacian along each loop), projected back onto ``surface``.

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int, the garment.
    iterations : int, step : float in (0, 1].
    surface : (V, F) to project moved vertices onto (default: the garment itself before moving).

    Returns
    -------
    (n, 3) float64 vertices with smoothed boundaries.
    """
    # heavy: open3d (~0.8 s to import)
    import open3d as o3d

    V = np.asarray(vertices, dtype=np.float64).copy()
    F = np.asarray(faces, dtype=np.int64)
    b = _boundary_edges(F)
    if len(b) == 0 or iterations <= 0:
        return V
    sv, sf = surface if surface is not None else (V.copy(), F)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(np.asarray(sv, dtype=np.float32), np.asarray(sf, dtype=np.uint32))
    nbrs: dict[int, list[int]] = {}
    for a, c in b.tolist():
        nbrs.setdefault(a, []).append(c)
        nbrs.setdefault(c, []).append(a)
    ids = np.array([k for k, v in nbrs.items() if len(v) == 2], dtype=np.int64)
    if len(ids) == 0:
        return V
    n1 = np.array([nbrs[k][0] for k in ids.tolist()])
    n2 = np.array([nbrs[k][1] for k in ids.tolist()])
    for _ in range(int(iterations)):
        target = 0.5 * (V[n1] + V[n2])
        moved = V[ids] + step * (target - V[ids])
        cp = scene.compute_closest_points(moved.astype(np.float32))["points"].numpy().astype(np.float64)
        V[ids] = cp
    return V


def cut_garment(vertices: np.ndarray, faces: np.ndarray, face_labels: np.ndarray, label: int,
                min_component_fraction: float = 0.05, smooth_iterations: int = 5
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cut the faces with ``label`` out of a labelled scan as a clean garment mesh.

    Keeps connected components with at least ``min_component_fraction`` of the largest
    component's faces (sleeves survive, stray specks do not), removes saw-tooth ears along
    the cut and smooths the boundary loops on the scan surface.

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int, face_labels : (m,) int, label : int.
    min_component_fraction : float, smooth_iterations : int.

    Returns
    -------
    V (k, 3) float64, F (l, 3) int64, face_ids (l,) int64 indices of the kept scan faces.

    Raises
    ------
    ValueError when no face carries ``label``.
    """
    F = np.asarray(faces, dtype=np.int64)
    fl = np.asarray(face_labels)
    if fl.shape != (len(F),):
        raise ValueError(f"face_labels: expected shape ({len(F)},), got {fl.shape}")
    sel = np.nonzero(fl == label)[0]
    if len(sel) == 0:
        raise ValueError(f"label {label}: no face of the scan carries it (was the garment seen?)")
    Fs = F[sel]
    keep = largest_components(Fs, int(F.max()) + 1, min_component_fraction)
    sel, Fs = sel[keep], Fs[keep]
    keep = remove_ears(Fs)
    sel = sel[keep]
    V, Fg, _ = submesh(vertices, F, np.isin(np.arange(len(F)), sel))
    # submesh keeps face order of the mask, i.e. sorted sel
    sel = np.sort(sel)
    if smooth_iterations > 0:
        V = smooth_boundary(V, Fg, smooth_iterations, surface=(np.asarray(vertices, dtype=np.float64), F))
    return V, Fg, sel
