"""dressmeup.geometry against slow, obviously correct references and analytic cases."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from dressmeup.geometry import (
    as_arrays,
    closest_points,
    edges,
    face_areas,
    face_normals,
    geodesic_distances,
    knn,
    sample_surface,
    vertex_normals,
    winding_number,
)
from dressmeup.geometry.proximity import closest_point_on_triangles


def random_mesh(seed: int, n_faces: int = 60):
    """A random triangle soup with shared vertices (some faces share, some do not)."""
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(n_faces, 3))
    F = np.stack([rng.choice(n_faces, 3, replace=False) for _ in range(n_faces)])
    return V, F


def ref_point_triangle(p, a, b, c):
    """Reference distance from p (3,) to triangles (a, b, c) (each (m, 3)): the plane
    projection when it falls inside the triangle, else the best of the three edge segments."""
    a, b, c = np.atleast_2d(a), np.atleast_2d(b), np.atleast_2d(c)
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    best = np.full(len(a), np.inf)
    ok = nn > 0
    q = p - (np.einsum("ij,ij->i", p - a, n) / np.where(ok, nn, 1))[:, None] * n
    w0 = np.einsum("ij,ij->i", np.cross(c - b, q - b), n)
    w1 = np.einsum("ij,ij->i", np.cross(a - c, q - c), n)
    w2 = np.einsum("ij,ij->i", np.cross(b - a, q - a), n)
    inside = ok & (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
    best[inside] = np.linalg.norm(p - q[inside], axis=1)
    for s0, s1 in ((a, b), (b, c), (c, a)):
        d = s1 - s0
        dd = np.einsum("ij,ij->i", d, d)
        t = np.clip(np.einsum("ij,ij->i", p - s0, d) / np.where(dd > 0, dd, 1), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (s0 + t[:, None] * d), axis=1))
    return best.min()


def ref_closest_distance(V, F, Q):
    return np.array([ref_point_triangle(q, V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]) for q in Q])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_closest_points_matches_brute_force(seed):
    V, F = random_mesh(seed)
    Q = np.random.default_rng(100 + seed).normal(size=(150, 3)) * 1.5
    d, pts, fid = closest_points(V, F, Q)
    ref = ref_closest_distance(V, F, Q)
    assert d.dtype == np.float64
    np.testing.assert_allclose(d, ref, rtol=1e-6, atol=1e-12)
    # the closest point lies on the face reported, at the distance reported
    np.testing.assert_allclose(np.linalg.norm(Q - pts, axis=1), d, rtol=1e-12)
    for i in range(0, 150, 17):
        assert ref_point_triangle(pts[i], *V[F[fid[i]]][:, None, :]) < 1e-9


def test_closest_points_large_query_sets_in_spatial_order():
    # >= ORDER_MIN_QUERIES queries are processed in kd-tree order: results must come back in
    # the caller's order
    from dressmeup.geometry.neighbors import ORDER_MIN_QUERIES

    V, F = random_mesh(4, n_faces=40)
    Q = np.random.default_rng(7).normal(size=(ORDER_MIN_QUERIES + 100, 3))
    d, pts, fid = closest_points(V, F, Q)
    np.testing.assert_allclose(d, ref_closest_distance(V, F, Q), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(Q - pts, axis=1), d, rtol=1e-12)


def test_closest_point_on_triangles_regions_and_degenerate():
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    P = np.array(
        [
            [0.2, 0.2, 1.0],
            [-1, -1, 0],
            [2, -1, 0],
            [-1, 2, 0],
            [0.5, -1, 0],
            [-1, 0.5, 0],
            [1, 1, 0],
        ]
    )
    expect = np.array(
        [[0.2, 0.2, 0], [0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0, 0], [0, 0.5, 0], [0.5, 0.5, 0]]
    )
    out = closest_point_on_triangles(P, *(np.repeat(x[None], len(P), 0) for x in (a, b, c)))
    np.testing.assert_allclose(out, expect, atol=1e-15)
    # a degenerate (collinear) triangle behaves like a segment
    a2, b2, c2 = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([2.0, 0, 0])
    out = closest_point_on_triangles(np.array([[1.5, 1.0, 0]]), a2[None], b2[None], c2[None])
    np.testing.assert_allclose(out, [[1.5, 0, 0]], atol=1e-12)


def test_closest_points_far_from_origin_keeps_float64_precision():
    V, F = random_mesh(3)
    shift = np.array([1000.0, -2000.0, 500.0])
    Q = np.random.default_rng(5).normal(size=(50, 3))
    d0 = closest_points(V, F, Q)[0]
    d1 = closest_points(V + shift, F, Q + shift)[0]
    np.testing.assert_allclose(d1, ref_closest_distance(V + shift, F, Q + shift), rtol=1e-6)
    np.testing.assert_allclose(d1, d0, rtol=1e-5)


def test_areas_normals_edges():
    V = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [1, 0, 0]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 1, 4]])  # last one degenerate
    np.testing.assert_allclose(face_areas(V, F), [2, 2, 0])
    np.testing.assert_allclose(face_normals(V, F), [[0, 0, 1], [1, 0, 0], [0, 0, 0]])
    vn = vertex_normals(V, F)
    np.testing.assert_allclose(vn[0], np.array([1, 0, 1]) / np.sqrt(2))
    np.testing.assert_allclose(vn[1], [0, 0, 1])
    np.testing.assert_allclose(np.linalg.norm(vn, axis=1)[:4], 1)
    E = edges(F)
    assert E.tolist() == [[0, 1], [0, 2], [0, 3], [0, 4], [1, 2], [1, 4], [2, 3]]


def test_vertex_normals_area_weighted_reference():
    V, F = random_mesh(7)
    ref = np.zeros_like(V)
    for f in F:
        ref[f] += np.cross(V[f[1]] - V[f[0]], V[f[2]] - V[f[0]])  # = 2 * area * unit normal
    used = np.linalg.norm(ref, axis=1) > 0
    ref[used] /= np.linalg.norm(ref[used], axis=1, keepdims=True)
    np.testing.assert_allclose(vertex_normals(V, F), ref, atol=1e-12)


def test_sample_surface_seeded_uniform_and_on_surface():
    m = trimesh.creation.box(extents=[1.0, 2.0, 4.0])
    V, F = as_arrays(m)
    p1, f1, b1 = sample_surface(V, F, 20000, seed=3)
    p2, f2, b2 = sample_surface(V, F, 20000, seed=3)
    assert np.array_equal(p1, p2) and np.array_equal(f1, f2)
    assert not np.array_equal(p1, sample_surface(V, F, 20000, seed=4)[0])
    np.testing.assert_allclose(b1.sum(1), 1)
    assert (b1 >= 0).all()
    np.testing.assert_allclose(np.einsum("qk,qkd->qd", b1, V[F[f1]]), p1)
    # share of samples on the two 2x4 faces (x = +-0.5) is their area share 16/28
    share = np.mean(np.isclose(np.abs(p1[:, 0]), 0.5))
    assert abs(share - 16 / 28) < 0.015
    # uniform inside a triangle: mean barycentric is 1/3 each
    np.testing.assert_allclose(b1.mean(0), [1 / 3] * 3, atol=0.01)


def test_winding_number_closed_and_holed():
    m = trimesh.creation.icosphere(subdivisions=3)
    V, F = as_arrays(m)
    q = np.array([[0.0, 0, 0], [0.5, 0.2, 0.1], [1.5, 0, 0], [0, 3, 0]])
    w = winding_number(V, F, q)
    np.testing.assert_allclose(w, [1, 1, 0, 0], atol=0.02)
    # remove a cap of faces: inside still reads >= 0.5, outside < 0.5
    keep = V[F].mean(1)[:, 2] < 0.8
    w2 = winding_number(V, F[keep], q)
    assert (w2[:2] >= 0.5).all() and (w2[2:] < 0.5).all()


def test_geodesics_on_flat_grid():
    n = 11
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    V = np.c_[x.ravel(), y.ravel(), np.zeros(n * n)]
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j
            F += [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
    F = np.array(F)
    src = [0, 60]
    euc = np.linalg.norm(V[src][:, None] - V[None], axis=2)
    dj = geodesic_distances(V, F, src, method="dijkstra")
    ht = geodesic_distances(V, F, src, method="heat")
    assert dj.shape == ht.shape == (2, n * n)
    assert (dj >= euc - 1e-12).all()  # edge paths never beat the straight line
    assert np.abs(dj - euc).max() < 0.3  # worst case (2 - sqrt 2)/2 against the diagonal
    assert np.abs(ht - euc).max() < 0.1  # heat method on a coarse grid: a few %
    # Dijkstra along the grid's axis is exact
    np.testing.assert_allclose(dj[0, :n], V[:n, 0], atol=1e-12)
    with pytest.raises(ValueError, match="method"):
        geodesic_distances(V, F, src, method="exact")
    with pytest.raises(ValueError, match="sources"):
        geodesic_distances(V, F, [n * n])


def test_knn_matches_brute_force():
    rng = np.random.default_rng(0)
    R, Q = rng.normal(size=(300, 3)), rng.normal(size=(80, 3))
    d, i = knn(R, Q, 4)
    D = np.linalg.norm(Q[:, None] - R[None], axis=2)
    ref = np.sort(D, axis=1)[:, :4]
    np.testing.assert_allclose(d, ref, rtol=1e-12)
    np.testing.assert_allclose(D[np.arange(80)[:, None], i], ref, rtol=1e-12)
    assert knn(R, Q, 1)[0].shape == (80, 1)
    # a large query set goes through the spatially ordered path
    Q2 = rng.normal(size=(5000, 3))
    d2, i2 = knn(R, Q2, 2)
    D2 = np.linalg.norm(Q2[:, None] - R[None], axis=2)
    np.testing.assert_allclose(d2, np.sort(D2, axis=1)[:, :2], rtol=1e-12)
    np.testing.assert_allclose(D2[np.arange(5000)[:, None], i2], d2, rtol=1e-12)
    with pytest.raises(ValueError, match="k"):
        knn(R, Q, 0)


@pytest.mark.parametrize(
    "V, F, match",
    [
        (np.zeros((0, 3)), np.zeros((0, 3), int), "empty"),
        (np.zeros((3, 2)), [[0, 1, 2]], r"shape \(n, 3\)"),
        (np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]]), [[0, 1, 2]], "NaN or inf"),
        (np.eye(3), [[0, 1, 3]], "indices must lie"),
        (np.eye(3), [[0, 1]], r"shape \(m, 3\)"),
        (np.eye(3), np.zeros((0, 3), int), "at least one face"),
        (np.eye(3), [[0.5, 1, 2]], "integer"),
    ],
)
def test_as_arrays_rejects_bad_input(V, F, match):
    with pytest.raises(ValueError, match=match):
        as_arrays(V, F, name="thing")
    with pytest.raises(ValueError, match="thing"):
        as_arrays(V, F, name="thing")


def test_faces_around_faces_against_a_loop():
    from dressmeup.geometry.proximity import faces_around_faces

    V, F = random_mesh(3)
    ring = faces_around_faces(F, len(V))
    for f in range(len(F)):
        want = sorted(g for g in range(len(F)) if set(F[g]) & set(F[f]))
        assert ring[f][ring[f] >= 0].tolist() == want  # distinct, ascending
        assert np.all(ring[f][len(want):] == -1)
    assert np.any(ring[:, -1] >= 0)  # no column of padding only


def grid_with_ties():
    """A flat 6 x 6 grid and queries above its vertices and edges (several faces equally
    close) and elsewhere: (V (36, 3), F (50, 3), Q (80, 3)), metres."""
    n = 6
    u, v = np.meshgrid(np.arange(n, dtype=np.float64), np.arange(n, dtype=np.float64))
    V = np.c_[u.ravel(), v.ravel(), np.zeros(n * n)] * 0.1
    q = np.arange(n * n).reshape(n, n)
    F = np.r_[np.c_[q[:-1, :-1].ravel(), q[:-1, 1:].ravel(), q[1:, 1:].ravel()],
              np.c_[q[:-1, :-1].ravel(), q[1:, 1:].ravel(), q[1:, :-1].ravel()]]
    rng = np.random.default_rng(0)
    on_grid = V[rng.choice(len(V), 20)] + (0, 0, 0.05)  # above vertices
    mid = (V[F[:, 0]] + V[F[:, 1]]) / 2 + (0, 0, 0.03)     # above edges
    return V, F, np.r_[on_grid, mid[:20], rng.uniform(0, 0.5, (40, 3))]


def assert_nearest_lowest_id(V, F, Q, d, fid):
    """d is the exact distance, fid the lowest id among the faces at that distance."""
    np.testing.assert_allclose(d, ref_closest_distance(V, F, Q), rtol=0, atol=1e-15)
    for i in range(len(Q)):
        dd = np.array([np.ravel(ref_point_triangle(Q[i], *V[f][:, None, :]))[0] for f in F])
        assert fid[i] == np.flatnonzero(dd <= dd.min() + 1e-15)[0]


def test_exact_faces_remember_the_ring_by_content_not_by_shape():
    """The face ring is cached per mesh: a second face array of the same shape (the same
    faces in another order) gets its own ring, so the tie rule still finds its lowest id."""
    V, F, Q = grid_with_ties()
    F2 = F[np.random.default_rng(2).permutation(len(F))]
    for faces in (F, F2, F):
        d, _, fid = closest_points(V, faces, Q, exact_faces=True)
        assert_nearest_lowest_id(V, faces, Q, d, fid)


def test_exact_faces_do_not_depend_on_the_bvh_pick():
    """A grid queried above its shared vertices and edges: every incident face is equally
    close, the float32 BVH picks one of them, ``exact_faces`` the lowest id; shifting the
    whole problem (other float32 roundings) changes nothing in float64."""
    V, F, Q = grid_with_ties()
    d, p, fid = closest_points(V, F, Q, exact_faces=True)
    assert_nearest_lowest_id(V, F, Q, d, fid)
    for shift in (1e-7, 3e-6, 123.456):
        d2, p2, fid2 = closest_points(V + shift, F, Q + shift, exact_faces=True)
        np.testing.assert_array_equal(fid2, fid)
        np.testing.assert_allclose(p2 - shift, p, rtol=0, atol=1e-9)


def test_weld_coincident_merges_equal_vertices_and_drops_collapsed_faces():
    from dressmeup.geometry.mesh import weld_coincident

    # a quad (0, 1, 2, 3) with vertex 4 a copy of vertex 2, and a sliver face (1, 2, 4)
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1, 1, 0]], float)
    F = np.array([[0, 1, 2], [0, 4, 3], [1, 2, 4]])
    W, G, vmap, kept = weld_coincident(V, F)
    assert np.array_equal(W, V[:4])
    assert vmap.tolist() == [0, 1, 2, 3, 2]
    assert kept.tolist() == [True, True, False]
    assert G.tolist() == [[0, 1, 2], [0, 2, 3]]
    # nothing to weld: everything unchanged
    W2, G2, vmap2, kept2 = weld_coincident(V[:4], F[:1])
    assert np.array_equal(W2, V[:4]) and np.array_equal(G2, F[:1])
    assert vmap2.tolist() == [0, 1, 2, 3] and kept2.all()
