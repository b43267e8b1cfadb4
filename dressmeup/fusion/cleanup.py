"""Mesh cleanup after fusion: components, duplicates, non-manifold repair, holes (numpy); decimation
and screened Poisson (pymeshlab)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from dressmeup.geometry.topology import large_components

__all__ = ["CleanupConfig", "cleanup_mesh", "largest_components", "merge_duplicate_vertices",
           "repair_non_manifold_edges", "split_non_manifold_vertices", "close_holes"]

log = logging.getLogger(__name__)


@dataclass
class CleanupConfig:
    """Cleanup settings.

    Attributes
    ----------
    min_component_fraction : float, connected components with fewer faces than this share of
        the largest component are removed (floating noise blobs).
    max_hole_edges : int, holes bounded by at most this many edges are closed (0: keep holes).
    repair_non_manifold : bool, split non-manifold vertices and remove non-manifold edges.
    target_faces : int or None, quadric decimation to this face count (None: keep).
    poisson_depth : int or None, replace the mesh by a screened Poisson reconstruction of its
        vertices at this octree depth (None: keep the TSDF surface; colours are then
        transferred from the nearest original vertex).
    """

    min_component_fraction: float = 0.02
    max_hole_edges: int = 60
    repair_non_manifold: bool = True
    target_faces: int | None = None
    poisson_depth: int | None = None


def largest_components(faces: np.ndarray, n_vertices: int, min_fraction: float) -> np.ndarray:
    """Mask of faces in connected components with at least ``min_fraction`` of the largest one.

    Parameters
    ----------
    faces : (m, 3) int, n_vertices : int, min_fraction : float in [0, 1].

    Returns
    -------
    (m,) bool
    """
    return large_components(faces, n_vertices, min_fraction)


def cleanup_mesh(vertices: np.ndarray, faces: np.ndarray, colors: np.ndarray | None = None,
                 config: CleanupConfig | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Clean a fused mesh.

    The repair runs on numpy arrays, each step the same as MeshLab's filter of that name
    (pymeshlab's took most of the cleanup's time on scans of millions of faces): small
    components removed, duplicate vertices merged (faces left degenerate dropped), null
    (zero-area) and duplicate faces removed, non-manifold edges repaired by removing their
    smallest faces, non-manifold vertices split (one copy per fan of faces), holes closed
    by ear cutting. Decimation and screened Poisson run in pymeshlab.

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int.
    colors : (n, 3) uint8 or None, per-vertex colours (kept through every step).
    config : CleanupConfig (defaults when None).

    Returns
    -------
    vertices : (n', 3) float64, faces : (m', 3) int64, colors : (n', 3) uint8 or None.
    """
    cfg = config or CleanupConfig()
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    C = None if colors is None else np.asarray(colors)[:, :3].astype(np.uint8)
    F = F[largest_components(F, len(V), cfg.min_component_fraction)]
    V, F, C, merged = _merge_duplicates(V, F, C)
    F = F[(F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 2] != F[:, 0])]
    F = F[~_null_faces(V, F)]
    # the edge table (one sort of all half-edges) is built once and rebuilt only when a rare
    # repair removed faces
    edges = _edges(F, len(V))
    keep = _unique_faces(F, edges)
    if not keep.all():
        F = F[keep]
        edges = _edges(F, len(V))
    if cfg.repair_non_manifold:
        keep = _manifold_edge_faces(V, F, edges)
        if not keep.all():
            F = F[keep]
            edges = _edges(F, len(V))
        V, F, C = split_non_manifold_vertices(V, F, C, edges, also=merged)
    if cfg.max_hole_edges > 0:
        F = close_holes(V, F, int(cfg.max_hole_edges), edges)
    V, F, C = _compact(V, F, C)
    if cfg.poisson_depth or cfg.target_faces:
        V, F, C = _meshlab_remesh(V, F, C, cfg)
    return V, F, C


def _meshlab_remesh(V: np.ndarray, F: np.ndarray, colors: np.ndarray | None, cfg: CleanupConfig
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Screened Poisson and / or quadric decimation in pymeshlab (colours kept or transferred)."""
    # heavy: pymeshlab (~0.3 s to import)
    import pymeshlab

    vc = None
    if colors is not None:
        vc = np.concatenate([colors / 255.0, np.ones((len(colors), 1))], axis=1)
    m = pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32),
                       **({"v_color_matrix": vc} if vc is not None else {}))
    ms = pymeshlab.MeshSet()
    ms.add_mesh(m, "fused")
    if cfg.poisson_depth:
        ms.generate_surface_reconstruction_screened_poisson(depth=int(cfg.poisson_depth), preclean=True)
    if cfg.target_faces:
        ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(cfg.target_faces), preservenormal=True,
                                                    preserveboundary=True, qualitythr=0.4)
    ms.meshing_remove_unreferenced_vertices()
    out = ms.current_mesh()
    V2 = np.asarray(out.vertex_matrix(), dtype=np.float64)
    F2 = np.asarray(out.face_matrix(), dtype=np.int64)
    C2 = None
    if colors is not None:
        if out.has_vertex_color() and not cfg.poisson_depth:
            C2 = np.clip(np.round(out.vertex_color_matrix()[:, :3] * 255), 0, 255).astype(np.uint8)
        else:
            # heavy: scipy.spatial
            from scipy.spatial import cKDTree

            _, idx = cKDTree(V).query(V2)
            C2 = np.asarray(colors)[idx, :3].astype(np.uint8)
    return V2, F2, C2


def _face_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Twice the area of each face: (m,) float64."""
    a = V[F[:, 0]]
    return np.linalg.norm(np.cross(V[F[:, 1]] - a, V[F[:, 2]] - a), axis=1)


def _null_faces(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(m,) bool, faces of exactly zero area."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    u, w = b - a, c - a
    return ((u[:, 1] * w[:, 2] == u[:, 2] * w[:, 1]) & (u[:, 2] * w[:, 0] == u[:, 0] * w[:, 2])
            & (u[:, 0] * w[:, 1] == u[:, 1] * w[:, 0]))


def _compact(V: np.ndarray, F: np.ndarray, C: np.ndarray | None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Drop unreferenced vertices (order kept)."""
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    if used.all():
        return V, F, C
    remap = np.cumsum(used) - 1
    return V[used], remap[F], None if C is None else C[used]


def merge_duplicate_vertices(V: np.ndarray, F: np.ndarray, C: np.ndarray | None = None
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Merge vertices with exactly equal coordinates (the lowest index stays).

    Parameters
    ----------
    V : (n, 3) float64, F : (m, 3) int64, C : (n, 3) uint8 or None.

    Returns
    -------
    V : (n', 3) float64, F : (m, 3) int64 re-indexed (degenerate faces kept), C or None.
    """
    V, F, C, _ = _merge_duplicates(V, F, C)
    return V, F, C


def _merge_duplicates(V: np.ndarray, F: np.ndarray, C: np.ndarray | None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """:func:`merge_duplicate_vertices`, and the new ids of the vertices that absorbed others."""
    none = np.zeros(0, dtype=np.int64)
    if len(V) < 2:
        return V, F, C, none
    bits = np.ascontiguousarray(V + 0.0).view(np.uint64)  # + 0.0: -0.0 and 0.0 are one value
    h = (bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)) ^ (bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F)) \
        ^ (bits[:, 2] * np.uint64(0x165667B19E3779F9))
    order = np.argsort(h, kind="stable")
    hs = h[order]
    same = np.concatenate([[False], hs[1:] == hs[:-1], [False]]).astype(np.int8)
    if not same.any():
        return V, F, C, none
    target = np.arange(len(V))
    # runs of equal hashes are candidates; equal coordinates within a run are duplicates
    starts, ends = np.flatnonzero(np.diff(same) == 1), np.flatnonzero(np.diff(same) == -1)
    for s0, e0 in zip(starts, ends, strict=True):
        ids = np.sort(order[s0:e0 + 1])
        _, first, inv = np.unique(V[ids], axis=0, return_index=True, return_inverse=True)
        target[ids] = ids[first[inv.ravel()]]
    keep = target == np.arange(len(V))
    if keep.all():
        return V, F, C, none
    remap = np.cumsum(keep) - 1
    merged = np.unique(remap[target[~keep]])
    return V[keep], remap[target[F]], None if C is None else C[keep], merged


def _unique_faces(F: np.ndarray, edges: tuple[np.ndarray, ...]) -> np.ndarray:
    """(m,) bool, False for a face repeating the vertex triple of a lower-numbered face.

    Two faces with one vertex triple share all three edges, so only pairs of faces on a
    common edge are compared (the edge table ``_edges(F, n)``)."""
    m = len(F)
    order, _, start, count = edges
    first = np.repeat(order[start] % m, count)
    other = order % m
    pair = np.flatnonzero(first != other)  # every later face of an edge against its first face
    a, b = first[pair], other[pair]
    total = F.sum(axis=1)
    close = total[a] == total[b]  # the same triple has the same sum: compare those only
    a, b = a[close], b[close]
    S = np.sort(F, axis=1)
    same = np.flatnonzero((S[a] == S[b]).all(axis=1))
    keep = np.ones(m, dtype=bool)
    if not len(same):
        return keep
    # faces of an edge held by three or more can repeat each other without repeating its first
    groups = np.unique(np.concatenate([a[same], b[same]]))
    _, firsts = np.unique(S[groups], axis=0, return_index=True)
    keep[groups] = False
    keep[groups[firsts]] = True
    return keep


def _edges(F: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Undirected edges of a mesh, grouped.

    Returns
    -------
    order : (3m,) int64, half-edge ids (face ``h % m``, slot ``h // m``) sorted by edge;
    key : (3m,) int64 edge key (``lo * n + hi``) of each sorted half-edge;
    start : (e,) int64, where each edge's run begins in ``order``; count : (e,) int64.
    """
    a = F.T.ravel()
    b = F[:, [1, 2, 0]].T.ravel()
    key = np.minimum(a, b) * n_vertices + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    key = key[order]
    start = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
    count = np.diff(np.append(start, len(key)))
    return order, key, start, count


def repair_non_manifold_edges(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Remove faces from edges shared by more than two faces, smallest first, until none is.

    Parameters
    ----------
    V : (n, 3) float64, F : (m, 3) int64.

    Returns
    -------
    (m', 3) int64, the faces kept (order kept).
    """
    return F[_manifold_edge_faces(V, F, _edges(F, len(V)))]


def _manifold_edge_faces(V: np.ndarray, F: np.ndarray, edges: tuple[np.ndarray, ...]) -> np.ndarray:
    """(m,) bool, the faces :func:`repair_non_manifold_edges` keeps."""
    m = len(F)
    order, _, start, count = edges
    alive = np.ones(m, dtype=bool)
    bad = np.flatnonzero(count > 2)
    if not len(bad):
        return alive
    faces_of = [order[start[e]:start[e] + count[e]] % m for e in bad]
    candidates = np.unique(np.concatenate(faces_of))
    area = _face_areas(V, F[candidates])
    for f in candidates[np.argsort(area, kind="stable")]:
        # the face goes while one of its edges is still shared by more than two live faces
        if any(f in fs and alive[fs].sum() > 2 for fs in faces_of):
            alive[f] = False
    return alive


def split_non_manifold_vertices(V: np.ndarray, F: np.ndarray, C: np.ndarray | None = None,
                                edges: tuple[np.ndarray, ...] | None = None, also: np.ndarray | None = None
                                ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Give every fan of faces around a vertex its own copy of the vertex.

    A vertex is non-manifold when its faces form several fans (groups joined through edges
    they share). Marching-cubes output has a single fan around every interior vertex (its
    faces lie in the four cells around one grid edge), so the fans are counted around the
    vertices on a boundary or a non-manifold edge and those in ``also`` (vertices merged
    from several, which may join closed fans); any other vertex is taken to have one fan.

    Parameters
    ----------
    V : (n, 3) float64, F : (m, 3) int64, C : (n, 3) uint8 or None.
    edges : the edge table of ``F`` when already built (``_edges(F, n)``), else None.
    also : (k,) int, more vertices whose fans are counted, or None.

    Returns
    -------
    V : (n + s, 3) float64, F : (m, 3) int64, C or None (copies carry their vertex's colour).
    """
    n, m = len(V), len(F)
    order, key, start, count = edges if edges is not None else _edges(F, n)
    odd = count != 2
    cand = np.zeros(n, dtype=bool)
    cand[key[start[odd]] // n] = True
    cand[key[start[odd]] % n] = True
    if also is not None:
        cand[np.asarray(also, dtype=np.int64)] = True
    if not cand.any():
        return V, F, C
    corner = np.flatnonzero(cand[F.T.ravel()])  # corner id c: face c % m, slot c // m
    node = -np.ones(3 * m, dtype=np.int64)
    node[corner] = np.arange(len(corner))
    # corners of one vertex in two faces sharing a (manifold) edge at that vertex are one fan;
    # the half-edge in slot s of a face runs from its corner s to its corner s + 1
    two = start[count == 2]
    ek = key[two]
    two = two[cand[ek // n] | cand[ek % n]]
    h1, h2 = order[two], order[two + 1]
    f1, s1, f2, s2 = h1 % m, h1 // m, h2 % m, h2 // m
    a_vertex = F[f1, s1]
    s2a = np.where(F[f2, s2] == a_vertex, s2, (s2 + 1) % 3)
    s2b = np.where(s2a == s2, (s2 + 1) % 3, s2)
    c1 = np.concatenate([s1 * m + f1, (s1 + 1) % 3 * m + f1])
    c2 = np.concatenate([s2a * m + f2, s2b * m + f2])
    ok = (node[c1] >= 0) & (node[c2] >= 0)
    g = sp.coo_matrix((np.ones(int(ok.sum())), (node[c1[ok]], node[c2[ok]])), shape=(len(corner),) * 2)
    _, fan = connected_components(g, directed=False)
    vert = F.T.ravel()[corner]
    # the fan holding a vertex's lowest-numbered fan keeps the vertex; every other fan gets a copy
    code, inv = np.unique(vert * len(corner) + fan, return_inverse=True)
    pair = np.stack([code // len(corner), code % len(corner)], axis=1)
    first = np.concatenate([[True], pair[1:, 0] != pair[:-1, 0]])
    if first.all():
        return V, F, C
    extra = pair[~first]
    pair_id = pair[:, 0].copy()
    pair_id[~first] = n + np.arange(len(extra))
    Fflat = F.T.ravel().copy()
    Fflat[corner] = pair_id[inv.ravel()]
    F2 = np.ascontiguousarray(Fflat.reshape(3, m).T)
    V2 = np.concatenate([V, V[extra[:, 0]]])
    C2 = None if C is None else np.concatenate([C, C[extra[:, 0]]])
    return V2, F2, C2


def close_holes(V: np.ndarray, F: np.ndarray, max_edges: int, edges: tuple[np.ndarray, ...] | None = None
                ) -> np.ndarray:
    """Close holes bounded by at most ``max_edges`` edges by ear cutting, without new vertices.

    A hole is a loop of boundary edges (edges of one face); the filling faces take the
    orientation of the faces around it. Ears are cut convex and sharpest first (convexity
    judged against the loop's Newell normal), avoiding a diagonal that is already an edge of
    the mesh (it would become non-manifold) while another ear is left. Loops through a
    vertex with several boundary edges leaving it are left open.

    Parameters
    ----------
    V : (n, 3) float64, F : (m, 3) int64, max_edges : int.
    edges : the edge table of the faces (``_edges``; vertex ids may have changed since by
        splitting, the grouping of half-edges not), else None.

    Returns
    -------
    (m + k, 3) int64, the faces followed by the filling faces.
    """
    n, m = len(V), len(F)
    order, _, start, count = edges if edges is not None else _edges(F, n)
    h = order[start[count == 1]]
    if not len(h) or max_edges < 3:
        return F
    f, s = h % m, h // m
    a, b = F[f, s], F[f, (s + 1) % 3]
    branching = np.bincount(a, minlength=n) > 1
    nxt = np.full(n, -1, dtype=np.int64)
    nxt[a] = b
    nxt_l, branch_l = nxt.tolist(), branching.tolist()
    visited = [False] * n
    holes = []
    for v0 in a.tolist():
        if visited[v0]:
            continue
        loop, v, ok = [], v0, True
        while not visited[v]:
            visited[v] = True
            ok = ok and not branch_l[v]
            if len(loop) <= max_edges:
                loop.append(v)
            v = nxt_l[v]
            if v < 0:
                ok = False
                break
        if ok and v == v0 and 3 <= len(loop) <= max_edges:
            holes.append(loop[::-1])
    if not holes:
        return F
    # the edges at the holes' vertices, for the diagonal test
    on_hole = np.zeros(n, dtype=bool)
    on_hole[np.concatenate(holes)] = True
    near = F[on_hole[F].any(axis=1)]
    e = np.concatenate([near[:, [0, 1]], near[:, [1, 2]], near[:, [2, 0]]])
    edge_keys = set((e.min(axis=1) * n + e.max(axis=1)).tolist())
    new_faces: list[tuple[int, int, int]] = []
    for ring in holes:
        new_faces.extend(_ear_cut(V, ring, edge_keys, n))
    return np.concatenate([F, np.asarray(new_faces, dtype=np.int64)])


def _ear_cut(V: np.ndarray, ring: list[int], edge_keys: set[int], n: int) -> list[tuple[int, int, int]]:
    """Triangles filling the polygon ``ring`` (vertex ids in the filling's orientation).

    Each corner's ear score is computed once and updated for the two neighbours of a cut ear
    (holes are small: plain Python beats numpy's per-call cost here)."""
    if len(ring) == 3:  # most holes of a fused scan: one missing triangle
        return [(ring[0], ring[1], ring[2])]
    w = list(ring)
    pos = {v: tuple(map(float, V[v])) for v in w}
    P = V[w]
    normal = tuple(map(float, np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)))
    added: set[int] = set()

    def score(a: int, b: int, c: int) -> float:
        pa, pb, pc = pos[a], pos[b], pos[c]
        e1 = (pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2])
        e2 = (pc[0] - pb[0], pc[1] - pb[1], pc[2] - pb[2])
        n1, n2 = math.sqrt(e1[0] ** 2 + e1[1] ** 2 + e1[2] ** 2), math.sqrt(e2[0] ** 2 + e2[1] ** 2 + e2[2] ** 2)
        cos = (e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / max(n1 * n2, 1e-30)
        angle = math.acos(min(1.0, max(-1.0, cos)))
        # convex when (b - a) x (c - b) = -(e1 x e2) points along the loop's normal
        cr = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
        convex = cr[0] * normal[0] + cr[1] * normal[1] + cr[2] * normal[2] < 0
        k = min(a, c) * n + max(a, c)
        return (angle if convex else 2 * math.pi - angle) + (4 * math.pi if k in edge_keys or k in added else 0.0)

    k = len(w)
    scores = [score(w[i - 1], w[i], w[(i + 1) % k]) for i in range(k)]
    out = []
    while len(w) > 3:
        k = len(w)
        i = min(range(k), key=scores.__getitem__)
        pa, pb = w[i - 1], w[(i + 1) % k]
        out.append((pa, w[i], pb))
        added.add(min(pa, pb) * n + max(pa, pb))
        del w[i], scores[i]
        k -= 1
        for j in ((i - 1) % k, i % k):
            scores[j] = score(w[j - 1], w[j], w[(j + 1) % k])
    out.append((w[0], w[1], w[2]))
    return out
