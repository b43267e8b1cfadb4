"""The numpy mesh cleanup against pymeshlab's filters of the same names (the slow reference)."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.fusion.cleanup import (
    CleanupConfig,
    cleanup_mesh,
    close_holes,
    merge_duplicate_vertices,
    repair_non_manifold_edges,
    split_non_manifold_vertices,
)

pymeshlab = pytest.importorskip("pymeshlab")


def _meshlab_cleanup(V, F, max_hole_edges):
    """The former cleanup: the same steps in pymeshlab."""
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32)), "m")
    ms.meshing_remove_duplicate_vertices()
    ms.meshing_remove_null_faces()
    ms.meshing_remove_duplicate_faces()
    ms.meshing_remove_unreferenced_vertices()
    ms.meshing_repair_non_manifold_edges()
    ms.meshing_repair_non_manifold_vertices()
    ms.meshing_close_holes(maxholesize=max_hole_edges, newfaceselected=False)
    ms.meshing_remove_unreferenced_vertices()
    return ms


def _topology(V, F):
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32)), "m")
    t = ms.get_topological_measures()
    return {k: t[k] for k in ("vertices_number", "faces_number", "boundary_edges", "non_two_manifold_edges",
                              "non_two_manifold_vertices", "number_holes", "connected_components_number")}


def _damaged_mesh():
    """Two spheres with every defect the cleanup repairs: a vertex repeated (a seam), a
    duplicate face, a zero-area face, small holes, a large hole left open, and two open
    patches touching at one boundary vertex (a non-manifold vertex)."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=3)
    V = np.array(s.vertices, dtype=np.float64)
    F = np.array(s.faces, dtype=np.int64)
    # a seam: vertex 0 copied, half of its faces use the copy
    V = np.vstack([V, V[:1]])
    at0 = np.flatnonzero((F == 0).any(axis=1))[:2]
    F[at0] = np.where(F[at0] == 0, len(V) - 1, F[at0])
    # small holes: one face (3 edges) and the fan of a vertex (5 or 6 edges)
    fan = np.flatnonzero((F == 200).any(axis=1))
    F = np.delete(F, np.concatenate([[100], fan]), axis=0)
    # a large hole: a cap of the sphere, 20+ edges (left open with max_hole_edges=12)
    F = F[V[F].mean(axis=1)[:, 2] < 0.8]
    F = np.vstack([F, F[5:6], [[1, 2, 1]]])  # a duplicate face, a null face
    # a second sphere with a cap cut off, touching the first's cap boundary at one vertex
    used = np.unique(F)
    top = used[np.argmax(V[used, 2])]  # on the cap's rim
    W = np.array(s.vertices, dtype=np.float64) * 0.5
    G = np.array(s.faces, dtype=np.int64)
    G = G[W[G].mean(axis=1)[:, 2] > -0.4]
    low = np.unique(G)
    b = low[np.argmin(W[low, 2])]  # on the second sphere's rim
    W = W + (V[top] - W[b])
    return np.vstack([V, W]), np.vstack([F, G + len(V)])


def test_numpy_cleanup_matches_meshlab_counts_and_leaves_a_manifold():
    V, F = _damaged_mesh()
    ref = _meshlab_cleanup(V, F, 12)
    V2, F2, _ = cleanup_mesh(V, F, None, CleanupConfig(min_component_fraction=0.0, max_hole_edges=12))
    ours, theirs = _topology(V2, F2), _topology(ref.current_mesh().vertex_matrix(),
                                                ref.current_mesh().face_matrix())
    assert ours["non_two_manifold_edges"] == 0 and ours["non_two_manifold_vertices"] == 0
    assert ours == theirs


def test_each_repair_step():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, -1, 0], [0, 0, 1]], np.float64)
    F = np.array([[0, 1, 2], [0, 4, 3]])
    V2, F2, C2 = merge_duplicate_vertices(V, F, np.arange(18, dtype=np.uint8).reshape(6, 3))
    assert len(V2) == 5 and F2.tolist() == [[0, 1, 2], [0, 3, 1]] and C2[3].tolist() == [12, 13, 14]
    # an edge held by three faces loses its smallest face
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0.5, 0, 0.1]], np.float64)
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    assert repair_non_manifold_edges(V, F).tolist() == [[0, 1, 2], [1, 0, 3]]
    # two triangles touching at a vertex: the vertex is split
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], np.float64)
    V2, F2, _ = split_non_manifold_vertices(V, np.array([[0, 1, 2], [0, 3, 4]]))
    assert len(V2) == 6 and np.array_equal(V2[5], V2[0]) and F2[0, 0] != F2[1, 0]
    # a square ring of 8 triangles: the inner hole is closed with the ring's orientation, the
    # outer border (also 4 edges) with the opposite one, as the back of a closed surface
    outer = np.array([[-2, -2], [2, -2], [2, 2], [-2, 2]], np.float64)
    inner = outer / 2
    V = np.column_stack([np.vstack([outer, inner]), np.zeros(8)])
    F = np.array([[i, (i + 1) % 4, 4 + i] for i in range(4)] + [[(i + 1) % 4, 4 + (i + 1) % 4, 4 + i]
                                                                  for i in range(4)])
    F2 = close_holes(V, F, 4)
    assert len(F2) == 12
    nz = np.cross(V[F2[:, 1]] - V[F2[:, 0]], V[F2[:, 2]] - V[F2[:, 0]])[:, 2]
    inner_fill = np.all(F2 >= 4, axis=1)
    assert inner_fill.sum() == 2 and np.all(nz[:8] > 0) and np.all(nz[inner_fill] > 0)
    assert np.all(nz[8:][~inner_fill[8:]] < 0)
    assert len(close_holes(V, F, 3)) == 8  # holes of 4 edges stay open below 4
