"""Every metric against a slow, obviously correct reference on seeded random meshes
(to 1e-6 relative, distances in float64)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from dressmeup import metrics as M
from dressmeup.geometry.mesh import face_areas


# ----------------------------------------------------------------------------- references
def random_mesh(seed: int, n_faces: int = 80, n_vertices: int = 60):
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(n_vertices, 3))
    F = np.stack([rng.choice(n_vertices, 3, replace=False) for _ in range(n_faces)])
    return V, F


def bumpy_sphere(seed: int, subdivisions: int = 2, noise: float = 0.05):
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    rng = np.random.default_rng(seed)
    V = np.asarray(m.vertices) * (1 + noise * rng.standard_normal((len(m.vertices), 1)))
    return V, np.asarray(m.faces)


def ref_point_triangles(p, a, b, c):
    """Distance from p to each triangle: plane projection if inside, else best edge segment."""
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    best = np.full(len(a), np.inf)
    ok = nn > 0
    q = p - (np.einsum("ij,ij->i", p - a, n) / np.where(ok, nn, 1))[:, None] * n
    ws = [np.einsum("ij,ij->i", np.cross(y - x, q - x), n) for x, y in ((b, c), (c, a), (a, b))]
    inside = ok & (ws[0] >= 0) & (ws[1] >= 0) & (ws[2] >= 0)
    best[inside] = np.linalg.norm(p - q[inside], axis=1)
    for s0, s1 in ((a, b), (b, c), (c, a)):
        d = s1 - s0
        dd = np.einsum("ij,ij->i", d, d)
        t = np.clip(np.einsum("ij,ij->i", p - s0, d) / np.where(dd > 0, dd, 1), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (s0 + t[:, None] * d), axis=1))
    return best


def ref_closest(V, F, Q):
    """(distance, face id) by brute force over all faces."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    out = [ref_point_triangles(q, a, b, c) for q in Q]
    return np.array([o.min() for o in out]), np.array([o.argmin() for o in out])


def ref_winding(V, F, q):
    """Exact generalized winding number: sum of signed solid angles (Van Oosterom-Strackee)."""
    a, b, c = V[F[:, 0]] - q, V[F[:, 1]] - q, V[F[:, 2]] - q
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = (
        la * lb * lc
        + np.einsum("ij,ij->i", a, b) * lc
        + np.einsum("ij,ij->i", b, c) * la
        + np.einsum("ij,ij->i", c, a) * lb
    )
    return np.sum(2 * np.arctan2(det, den)) / (4 * np.pi)


def ref_vertex_normals(V, F):
    acc = np.zeros_like(V)
    for f in F:
        acc[f] += np.cross(V[f[1]] - V[f[0]], V[f[2]] - V[f[0]])
    norm = np.linalg.norm(acc, axis=1)
    return acc / np.where(norm > 0, norm, 1)[:, None], norm > 0


def ref_face_sv(V, F, uv, uvf):
    """Singular values of J = [u1 u2] pinv([e1 e2]) (2x3), by numpy SVD, face by face."""
    out = []
    for f, t in zip(F, uvf, strict=True):
        E = np.stack([V[f[1]] - V[f[0]], V[f[2]] - V[f[0]]], axis=1)  # 3x2
        U = np.stack([uv[t[1]] - uv[t[0]], uv[t[2]] - uv[t[0]]], axis=1)  # 2x2
        J = U @ np.linalg.pinv(E)
        out.append(np.linalg.svd(J, compute_uv=False)[:2])
    return np.array(out)


def ref_rank(row, j):
    """1-based rank of j among all entries of row except self (marked with None)."""
    others = [(v, idx) for idx, v in enumerate(row) if v is not None]
    return sorted(others).index((row[j], j)) + 1


def ref_richness(G, X, k):
    n = len(X)
    D = np.linalg.norm(X[:, None] - X[None], axis=2)
    scores = []
    for i in range(n):
        g = [None if j == i else G[i, j] for j in range(n)]
        e = [None if j == i else D[i, j] for j in range(n)]
        order = sorted((g[j], j) for j in range(n) if j != i)
        near = [j for _, j in order[:k]]
        far = [j for _, j in order[-k:]]
        rn = sum(min(abs(ref_rank(g, j) - ref_rank(e, j)), k) for j in near) / k**2
        rf = sum(min(abs(ref_rank(g, j) - ref_rank(e, j)), k) for j in far) / k**2
        scores.append((rn + rf) / 2)
    return float(np.mean(scores))


# ----------------------------------------------------------------------------------- tests
@pytest.mark.parametrize("seed", [0, 1])
def test_p2s_vs_brute_force(seed):
    V, F = random_mesh(seed)
    Q = np.random.default_rng(seed + 10).normal(size=(120, 3)) * 1.3
    ref = ref_closest(V, F, Q)[0]
    np.testing.assert_allclose(M.p2s_details(Q, (V, F)), ref, rtol=1e-6)
    assert M.p2s(Q, trimesh.Trimesh(V, F, process=False)) == pytest.approx(ref.mean(), rel=1e-6)


def test_p2s_bidirectional_vs_brute_force():
    A, B = bumpy_sphere(0, 1), bumpy_sphere(1, 1, noise=0.1)
    from dressmeup.geometry.sampling import sample_surface

    pa = sample_surface(*A, 200, seed=5)[0]
    pb = sample_surface(*B, 200, seed=6)[0]
    ref = 0.5 * (ref_closest(*B, pa)[0].mean() + ref_closest(*A, pb)[0].mean())
    assert M.p2s_bidirectional(A, B, n_samples=200, seed=5) == pytest.approx(ref, rel=1e-6)


@pytest.mark.parametrize("squared", [True, False])
def test_chamfer_vs_brute_force(squared):
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(300, 3)), rng.normal(size=(200, 3)) + 0.2
    D = np.linalg.norm(a[:, None] - b[None], axis=2)
    p = 2 if squared else 1
    ref = np.mean(D.min(1) ** p) + np.mean(D.min(0) ** p)
    assert M.chamfer(a, b, squared=squared) == pytest.approx(ref, rel=1e-9)
    d_ab, d_ba = M.chamfer_details(a, b)
    np.testing.assert_allclose(d_ab, D.min(1), rtol=1e-12)
    np.testing.assert_allclose(d_ba, D.min(0), rtol=1e-12)


def test_chamfer_large_clouds_vs_brute_force():
    rng = np.random.default_rng(13)
    a, b = rng.normal(size=(4300, 3)), rng.normal(size=(4150, 3))  # both >= ORDER_MIN_QUERIES

    def brute(p, q):  # chunked full distance matrices
        return np.concatenate(
            [
                np.linalg.norm(p[s : s + 500, None] - q[None], axis=2).min(1)
                for s in range(0, len(p), 500)
            ]
        )

    d_ab, d_ba = brute(a, b), brute(b, a)
    got_ab, got_ba = M.chamfer_details(a, b)
    np.testing.assert_allclose(got_ab, d_ab, rtol=1e-12)
    np.testing.assert_allclose(got_ba, d_ba, rtol=1e-12)
    assert M.chamfer(a, b) == pytest.approx(np.mean(d_ab**2) + np.mean(d_ba**2), rel=1e-12)


def test_euclidean_vs_loop():
    V, F = random_mesh(4)
    W = V + np.random.default_rng(0).normal(size=V.shape) * 0.01
    ref = np.mean([np.sqrt(sum((W[i] - V[i]) ** 2)) for i in range(len(V))])
    assert M.euclidean(W, V) == pytest.approx(ref, rel=1e-12)
    assert M.euclidean((W, F), (V, F)) == pytest.approx(ref, rel=1e-12)
    with pytest.raises(M.TopologyMismatchError, match="vertices"):
        M.euclidean(W[:-1], V)
    with pytest.raises(M.TopologyMismatchError, match="faces differ"):
        M.euclidean(W, V, F, F[::-1])
    assert issubclass(M.TopologyMismatchError, ValueError)


def test_normal_consistency_same_topology_vs_loop():
    V, F = bumpy_sphere(2)
    W = V + np.random.default_rng(1).normal(size=V.shape) * 0.05
    nv, okv = ref_vertex_normals(V, F)
    nw, okw = ref_vertex_normals(W, F)
    ok = okv & okw
    ref = np.mean(np.sum(nw[ok] * nv[ok], axis=1))
    det = M.normal_consistency_details((W, F), (V, F))
    assert det.mode == "vertex"
    assert det.value == pytest.approx(ref, rel=1e-9)
    assert M.normal_consistency((W, F), (V, F), absolute=True) == pytest.approx(
        np.mean(np.abs(np.sum(nw[ok] * nv[ok], axis=1))), rel=1e-9
    )
    # a prediction with reversed orientation (different faces -> surface mode) scores about -NC
    flipped = M.normal_consistency((W, F[:, ::-1]), (V, F), n_samples=2000)
    assert flipped < -0.8
    assert M.normal_consistency((W, F[:, ::-1]), (V, F), n_samples=2000, absolute=True) > 0.8


def test_normal_consistency_different_topology_vs_brute_force():
    A = bumpy_sphere(3, 1)
    B = bumpy_sphere(4, 2)
    from dressmeup.geometry.mesh import face_normals
    from dressmeup.geometry.sampling import sample_surface

    pa, fa, _ = sample_surface(*A, 150, seed=7)
    pb, fb, _ = sample_surface(*B, 150, seed=8)
    from dressmeup.geometry.proximity import closest_points

    na, nb = face_normals(*A), face_normals(*B)
    # the nearest point often lies on an edge or vertex shared by several faces: any face at
    # the minimal distance is a valid hit, so check that the hits are nearest faces ...
    hit_b = closest_points(*B, pa)[2]
    hit_a = closest_points(*A, pb)[2]
    for (V, F), P, hit in ((B, pa, hit_b), (A, pb, hit_a)):
        dmin = ref_closest(V, F, P)[0]
        dhit = np.array(
            [ref_point_triangles(p, *(V[F[h]][:, None, :]))[0] for p, h in zip(P, hit, strict=True)]
        )
        np.testing.assert_allclose(dhit, dmin, rtol=1e-6, atol=1e-12)
    # ... and that the figure is the formula over those hits
    ref = 0.5 * (np.mean(np.sum(na[fa] * nb[hit_b], 1)) + np.mean(np.sum(nb[fb] * na[hit_a], 1)))
    det = M.normal_consistency_details(A, B, n_samples=150, seed=7)
    assert det.mode == "surface"
    assert det.value == pytest.approx(ref, rel=1e-6)


def test_interpenetration_vs_exact_winding():
    body = bumpy_sphere(5, 2, noise=0.03)
    G = random_mesh(6, n_faces=150)
    Vg = G[0] * 1.2
    cent = Vg[G[1]].mean(1)
    inside = np.array([ref_winding(*body, c) >= 0.5 for c in cent])
    areas = face_areas(Vg, G[1])
    ref = areas[inside].sum() / areas.sum()
    assert 0.05 < ref < 0.95  # the test mesh really straddles the body
    det = M.interpenetration_details((Vg, G[1]), body)
    assert np.array_equal(det.inside, inside)
    assert det.ratio == pytest.approx(ref, rel=1e-12)


def test_penetrating_vertex_fraction_vs_reference():
    body = bumpy_sphere(7, 2, noise=0.03)
    P = np.random.default_rng(8).normal(size=(200, 3)) * 0.6
    d = ref_closest(*body, P)[0]
    inside = np.array([ref_winding(*body, p) >= 0.5 for p in P])
    sd = np.where(inside, -d, d)
    np.testing.assert_allclose(M.signed_distance(P, body), sd, rtol=1e-6)
    for eps in (0.0, 0.05):
        assert M.penetrating_vertex_fraction(P, body, eps=eps) == pytest.approx(np.mean(sd < -eps))


@pytest.mark.parametrize("per_corner", [False, True])
def test_qce_ase_vs_per_face_svd(per_corner):
    V, F = bumpy_sphere(9, 1, noise=0.2)
    rng = np.random.default_rng(9)
    if per_corner:
        uv = rng.random((F.size, 2))
        uvf = np.arange(F.size).reshape(-1, 3)
    else:
        uv = V[:, :2] + 0.3 * rng.random((len(V), 2))
        uvf = F
    sv = ref_face_sv(V, F, uv, uvf)
    a3 = face_areas(V, F)
    q = sv[:, 0] / sv[:, 1]
    args = (V, F, uv, uvf if per_corner else None)
    det = M.qce_details(*args)
    np.testing.assert_allclose(det.per_face, q, rtol=1e-6)
    assert det.mean == pytest.approx(np.sum(a3 * q) / a3.sum(), rel=1e-6)
    assert det.max == pytest.approx(q.max(), rel=1e-6)
    np.testing.assert_allclose(M.uv_jacobian_singular_values(*args), sv, rtol=1e-6)

    # ASE: per face log(A_uv * s / A_3d), s = total 3D / total UV area
    def cross2(p, q):
        return p[0] * q[1] - p[1] * q[0]

    auv = np.array([0.5 * abs(cross2(uv[t[1]] - uv[t[0]], uv[t[2]] - uv[t[0]])) for t in uvf])
    s = a3.sum() / auv.sum()
    lr = np.log(auv * s / a3)
    da = M.ase_details(*args)
    np.testing.assert_allclose(da.per_face, lr, rtol=1e-9, atol=1e-12)
    assert da.abs_mean == pytest.approx(np.sum(a3 * np.abs(lr)) / a3.sum(), rel=1e-9)
    assert da.mean == pytest.approx(np.sum(a3 * lr) / a3.sum(), rel=1e-9, abs=1e-12)
    assert (da.min, da.max) == pytest.approx((lr.min(), lr.max()), rel=1e-9)
    assert M.ase(*args) == da.abs_mean and M.qce(*args) == det.mean


def test_uv_flipped_fraction_vs_loop():
    V, F = bumpy_sphere(10, 1)
    uv = np.random.default_rng(10).random((len(V), 2))

    def cross2(p, q):
        return p[0] * q[1] - p[1] * q[0]

    signs = [np.sign(cross2(uv[f[1]] - uv[f[0]], uv[f[2]] - uv[f[0]])) for f in F]
    pos, neg = signs.count(1.0), signs.count(-1.0)
    res = M.uv_validity(V, F, uv * 0.3 + 0.1, resolution=256)
    assert res.flipped_fraction == pytest.approx(min(pos, neg) / len(F))


def test_uv_overlap_fraction_vs_monte_carlo():
    # a small random UV layout: Monte Carlo coverage counts with random points as the reference
    rng = np.random.default_rng(11)
    centers = rng.random((30, 2))
    T = centers[:, None, :] + rng.normal(size=(30, 3, 2)) * 0.08
    uv = T.reshape(-1, 2)
    uvf = np.arange(90).reshape(30, 3)
    V = np.c_[uv, np.zeros(90)]  # any 3D triangles will do
    lo, hi = uv.min(0), uv.max(0)
    S = lo + rng.random((200_000, 2)) * (hi - lo)
    cov = np.zeros(len(S), int)
    for t in T:
        a, b, c = t
        d = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        w1 = ((S[:, 0] - a[0]) * (c[1] - a[1]) - (S[:, 1] - a[1]) * (c[0] - a[0])) / d
        w2 = ((b[0] - a[0]) * (S[:, 1] - a[1]) - (b[1] - a[1]) * (S[:, 0] - a[0])) / d
        cov += (w1 >= 0) & (w2 >= 0) & (w1 + w2 <= 1)
    ref = np.mean(cov >= 2) / np.mean(cov >= 1)
    assert 0.05 < ref < 0.95
    res = M.uv_validity(V, uvf, uv, uvf, resolution=512)
    assert res.overlap_fraction == pytest.approx(ref, abs=0.01)


@pytest.mark.parametrize("seed", [0, 1])
def test_richness_vs_slow_reference(seed):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(60, 3))
    G = np.linalg.norm(X[:, None] - X[None], axis=2) + rng.random((60, 60)) * 0.5
    G = (G + G.T) / 2
    E = X + rng.normal(size=X.shape) * 0.3
    for k in (1, 5, 10):
        assert M.richness(G, E, k=k) == pytest.approx(ref_richness(G, E, k), rel=1e-12)


def test_richness_wide_embedding_vs_slow_reference():
    # wide embeddings take the Gram-product path with an exact re-check
    from dressmeup.metrics.richness import GRAM_MIN_DIM

    rng = np.random.default_rng(4)
    n, d = 70, GRAM_MIN_DIM + 24
    X = rng.normal(size=(n, 3))
    G = np.linalg.norm(X[:, None] - X[None], axis=2)
    E = np.c_[X, 0.3 * rng.normal(size=(n, d - 3))] + 100.0  # offset: Gram cancellation
    E[5] = E[6]  # duplicate embedding rows: exact ties broken by index
    E[20] = E[40]
    for k in (1, 6, 12):
        got = M.richness_details(G, E, k=k, batch=16)
        assert got.score == pytest.approx(ref_richness(G, E, k), rel=1e-12)


def test_richness_ties_broken_by_index():
    # integer-valued distances: many ties in both rankings, resolved by vertex index
    rng = np.random.default_rng(2)
    n = 40
    G = rng.integers(0, 4, (n, n)).astype(float)
    G = np.minimum(G, G.T)
    E = rng.integers(0, 3, (n, 2)).astype(float)  # duplicate embedding points: exact ties
    for k in (3, 8):
        got = M.richness_details(G, E, k=k, batch=7)  # odd batch size on purpose
        assert got.score == pytest.approx(ref_richness(G, E, k), rel=1e-12)


def test_fusion_quality_vs_brute_force():
    A, B = bumpy_sphere(11, 1), bumpy_sphere(12, 1, noise=0.08)
    from dressmeup.geometry.sampling import sample_surface

    pa = sample_surface(*A, 300, seed=0)[0]
    pb = sample_surface(*B, 300, seed=1)[0]
    d_ab = ref_closest(*B, pa)[0]
    d_ba = ref_closest(*A, pb)[0]
    fq = M.fusion_quality(A, B, thresholds=(0.01, 0.05), n_samples=300, seed=0)
    assert fq.accuracy == pytest.approx(d_ab.mean(), rel=1e-6)
    assert fq.completeness == pytest.approx(d_ba.mean(), rel=1e-6)
    assert fq.chamfer_l1 == pytest.approx((d_ab.mean() + d_ba.mean()) / 2, rel=1e-6)
    for t in (0.01, 0.05):
        p, r = np.mean(d_ab < t), np.mean(d_ba < t)
        assert fq.fscore[t] == pytest.approx(2 * p * r / (p + r) if p + r else 0.0)
    assert M.fscore(A, B, 0.05, n_samples=300, seed=0) == pytest.approx(fq.fscore[0.05])
    assert M.accuracy(A, B, n_samples=300) == pytest.approx(fq.accuracy)
    assert M.completeness(A, B, n_samples=300) == pytest.approx(fq.completeness)
    # a point-cloud ground truth uses nearest-point distances
    D = np.linalg.norm(pa[:, None] - pb[None], axis=2)
    fq2 = M.fusion_quality(A, pb, thresholds=(0.05,), n_samples=300, seed=0)
    assert fq2.accuracy == pytest.approx(D.min(1).mean(), rel=1e-9)
    assert set(fq.as_dict()) >= {
        "accuracy",
        "completeness",
        "chamfer_l1",
        "fscore@10mm",
        "fscore@50mm",
    }
