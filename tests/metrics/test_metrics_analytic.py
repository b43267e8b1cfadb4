"""Metrics on cases with known answers, and clear errors on bad input."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from dressmeup import metrics as M


def grid(nx: int = 11, ny: int = 21, sx: float = 1.0, sy: float = 2.0):
    """Flat triangulated grid in the z = 0 plane: (V, F)."""
    x, y = np.meshgrid(np.linspace(0, sx, nx), np.linspace(0, sy, ny))
    V = np.c_[x.ravel(), y.ravel(), np.zeros(nx * ny)]
    F = []
    for i in range(ny - 1):
        for j in range(nx - 1):
            a = i * nx + j
            F += [[a, a + 1, a + nx + 1], [a, a + nx + 1, a + nx]]
    return V, np.array(F)


def sphere(subdivisions: int = 4, radius: float = 1.0):
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return np.asarray(m.vertices), np.asarray(m.faces)


def unit_directions(n: int, seed: int = 0):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


# ------------------------------------------------------------------------------ distances
@pytest.mark.parametrize("d", [1.5, 2.0, 3.7])
def test_p2s_sphere_at_distance_d(d):
    V, F = sphere(6)  # inscribed polyhedron: its surface lies within 2e-4 of the unit sphere
    assert M.p2s(unit_directions(2000) * d, (V, F)) == pytest.approx(d - 1, abs=3e-4)


def test_p2s_exact_on_convex_polyhedron():
    # outside a convex polyhedron, c + t n (face centroid c, outward unit normal n) is at
    # exactly t from the surface: the whole body lies behind the face's plane
    V, F = sphere(2)
    c = V[F].mean(1)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    t = np.random.default_rng(0).random(len(F)) * 2
    np.testing.assert_allclose(M.p2s_details(c + t[:, None] * n, (V, F)), t, rtol=1e-12, atol=1e-12)


def test_chamfer_conventions():
    a = np.zeros((1, 3))
    b = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 1.0]])
    # a->b: 1 ; b->a: mean(25, 1) = 13 (squared) or mean(5, 1) = 3
    assert M.chamfer(a, b) == pytest.approx(1 + 13)
    assert M.chamfer(a, b, squared=False) == pytest.approx(1 + 3)


def test_identical_meshes_score_perfectly():
    V, F = sphere(3)
    assert M.p2s_bidirectional((V, F), (V, F), n_samples=5000) < 1e-12
    assert M.euclidean(V, V) == 0
    assert M.normal_consistency((V, F), (V, F)) == pytest.approx(1.0)
    fq = M.fusion_quality((V, F), (V, F), n_samples=5000)
    assert fq.accuracy < 1e-12 and fq.fscore[0.001] == 1.0


def test_fusion_quality_concentric_spheres():
    A, B = sphere(6, 1.0), sphere(6, 1.004)
    fq = M.fusion_quality(A, B, n_samples=20000)
    assert fq.accuracy == pytest.approx(0.004, abs=3e-4)
    assert fq.completeness == pytest.approx(0.004, abs=3e-4)
    assert fq.fscore[0.002] == 0.0 and fq.fscore[0.005] == 1.0
    assert fq.chamfer_l1 == pytest.approx(0.5 * (fq.accuracy + fq.completeness))


def test_normal_consistency_rotated_copy():
    V, F = sphere(3)
    # a flat patch tilted by 60 degrees: every normal has cos = 0.5 with the original
    G, FG = grid()
    ang = np.pi / 3
    R = np.array([[1, 0, 0], [0, np.cos(ang), -np.sin(ang)], [0, np.sin(ang), np.cos(ang)]])
    assert M.normal_consistency((G @ R.T, FG), (G, FG)) == pytest.approx(0.5)


# ------------------------------------------------------------------------------------- IR
def box_body(holes: bool = False):
    m = trimesh.creation.box(extents=[2, 2, 2])
    V, F = np.asarray(m.vertices), np.asarray(m.faces)
    for _ in range(3):
        V, F = trimesh.remesh.subdivide(V, F)
    if holes:  # remove the whole top side and a patch of the front side
        c = V[F].mean(1)
        F = F[
            (c[:, 2] < 0.99)
            & ~((c[:, 1] < -0.99) & (np.abs(c[:, 0]) < 0.4) & (np.abs(c[:, 2]) < 0.4))
        ]
    return V, F


def test_ir_shell_outside_inside_and_half():
    body = box_body()
    Vs, Fs = sphere(3, radius=1.8)  # encloses the box entirely, never inside
    assert M.interpenetration_ratio((Vs, Fs), body) == 0.0
    assert M.interpenetration_ratio((Vs * 0.5, Fs), body) == 1.0
    # a strip crossing the body's x = 1 side, exactly half of its area inside
    G, FG = grid(21, 11, sx=2.0, sy=1.0)
    strip = G + np.array([0.0, -0.5, 0.1])
    assert M.interpenetration_ratio((strip, FG), body) == pytest.approx(0.5)
    # a shell around the sphere with its lower half pushed inside: IR = share of the lower area
    Vb, Fb = sphere(4)
    Vg, Fg = sphere(3, radius=1.05)
    Vg = np.where(Vg[:, 2:3] < 0, Vg * (0.9 / 1.05), Vg)
    det = M.interpenetration_details((Vg, Fg), (Vb, Fb))
    below = (Vg[Fg][:, :, 2] < 0).all(1)
    above = (Vg[Fg][:, :, 2] >= 0).all(1)
    assert det.inside[below].all() and not det.inside[above].any()
    assert det.ratio == pytest.approx(det.areas[det.inside].sum() / det.areas.sum())
    share_below = det.areas[below].sum() / det.areas.sum()
    share_above = det.areas[above].sum() / det.areas.sum()
    assert share_below <= det.ratio <= 1 - share_above
    assert 0.4 < det.ratio < 0.5  # about half (the pushed-in half is smaller: 0.9^2 vs 1.05^2)


def test_ir_open_holed_body():
    body = box_body(holes=True)
    G, FG = grid(21, 11, sx=2.0, sy=1.0)
    strip = G + np.array([0.0, -0.5, 0.1])
    assert M.interpenetration_ratio((strip, FG), body) == pytest.approx(0.5)
    # a patch inside the body behind the hole in the front side is still inside
    front = G[:, [0, 2, 1]] * np.array([0.3, 1, 0.3]) + np.array([-0.3, -0.6, -0.15])  # y = -0.6
    assert M.interpenetration_ratio((front, FG), body) == pytest.approx(1.0)
    # and one just outside it, in front of the hole, is outside
    assert M.interpenetration_ratio((front - [0, 0.5, 0], FG), body) == 0.0
    # and penetrating vertices agree
    P = np.array([[0, 0, 0], [0.9, 0, -0.5], [0, 0.9, 0], [0, 0, 1.5], [1.5, 0, 0]])
    assert M.penetrating_vertex_fraction(P, body) == pytest.approx(3 / 5)
    assert M.penetrating_vertex_fraction(P, body, eps=0.5) == pytest.approx(1 / 5)


# ------------------------------------------------------------------------------------- UV
def test_identity_uv_on_plane():
    V, F = grid()
    d = M.qce_details(V, F, V[:, :2])
    assert d.mean == pytest.approx(1.0, abs=1e-12) and d.max == pytest.approx(1.0, abs=1e-12)
    assert M.ase(V, F, V[:, :2]) == pytest.approx(0.0, abs=1e-12)
    v = M.uv_validity(V, F, V[:, :2])
    assert v.flipped_fraction == 0 and v.overlap_fraction == 0


def test_identity_uv_of_a_rotated_plane():
    V, F = grid()
    R = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    assert M.qce(V @ R.T, F, V[:, :2]) == pytest.approx(1.0, abs=1e-9)
    assert M.ase(V @ R.T, F, V[:, :2]) == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("S", [[[1, 0.5], [0, 1]], [[2, 0], [0, 0.5]], [[1, 0.3], [-0.2, 0.7]]])
def test_known_affine_map(S):
    V, F = grid()
    S = np.array(S, float)
    sv = np.linalg.svd(S, compute_uv=False)
    d = M.qce_details(V, F, V[:, :2] @ S.T)
    np.testing.assert_allclose(d.per_face, sv[0] / sv[1], rtol=1e-9)
    assert d.mean == pytest.approx(sv[0] / sv[1], rel=1e-9)
    assert M.ase(V, F, V[:, :2] @ S.T) == pytest.approx(0.0, abs=1e-9)  # uniform area change


def test_scaled_uv_ase_zero_and_area_distortion():
    V, F = grid()
    assert M.ase(V, F, V[:, :2] * 37.0) == pytest.approx(0.0, abs=1e-12)
    # stretch only the upper half in u by 2: areas 2x there; normalised log ratios +-log(4/3)...
    uv = V[:, :2].copy()
    uv[:, 0] *= np.where(uv[:, 1] > 1.0 + 1e-9, 1.0, 1.0)  # unchanged
    top = V[F].mean(1)[:, 1] > 1.0
    # build per-corner UVs so each half can scale independently
    uvc = V[F][:, :, :2].copy()
    uvc[top] *= np.sqrt(2.0)  # area x2 on the top half
    d = M.ase_details(V, F, uvc.reshape(-1, 2), np.arange(F.size).reshape(-1, 3))
    s = 2.0 / 3.0  # total 3D area 2, total UV area 1 + 2 = 3
    np.testing.assert_allclose(d.per_face[top], np.log(2 * s), rtol=1e-9)
    np.testing.assert_allclose(d.per_face[~top], np.log(s), rtol=1e-9)
    assert d.abs_mean == pytest.approx(0.5 * (abs(np.log(2 * s)) + abs(np.log(s))), rel=1e-9)
    assert d.mean == pytest.approx(0.5 * (np.log(2 * s) + np.log(s)), rel=1e-9)


def test_zero_uv_area_counted_separately():
    V, F = grid(3, 3, 1, 1)
    uv = V[:, :2].copy()
    uvc = uv[F].copy()
    uvc[0] = [[0, 0], [0.5, 0], [1.0, 0]]  # collinear: zero UV area
    d = M.qce_details(V, F, uvc.reshape(-1, 2), np.arange(F.size).reshape(-1, 3))
    assert np.isinf(d.per_face[0]) and d.n_zero_uv_area == 1
    assert d.zero_uv_area_fraction == pytest.approx(1 / len(F))
    assert d.mean == pytest.approx(1.0) and d.max == pytest.approx(1.0)
    a = M.ase_details(V, F, uvc.reshape(-1, 2), np.arange(F.size).reshape(-1, 3))
    assert a.per_face[0] == -np.inf and a.n_zero_uv_area == 1 and np.isfinite(a.abs_mean)


def test_flips_and_overlaps():
    V, F = grid(11, 11, 1, 1)
    uv = V[:, :2].copy()
    # mirror the layout: every triangle flips, but it is then the majority (0 flipped)
    assert M.uv_validity(V, F, uv * [-1, 1]).flipped_fraction == 0
    # two copies of the same layout on top of each other: everything covered twice
    uv2 = np.r_[uv, uv]
    F2 = np.r_[F, F + len(V)]
    V2 = np.r_[V, V]
    assert M.uv_validity(V2, F2, uv2, resolution=256).overlap_fraction == pytest.approx(1.0)
    # second copy shifted by half its width: covered area 1.5, overlapped 0.5 -> 1/3
    r = M.uv_validity(V2, F2, np.r_[uv, uv + [0.5, 0]], resolution=512)
    assert r.overlap_fraction == pytest.approx(1 / 3, abs=3e-3)
    # flip 10 of 200 triangles by swapping two corners' UVs (per corner)
    uvc = uv[F].copy()
    uvc[:10] = uvc[:10][:, [0, 2, 1]]
    r = M.uv_validity(V, F, uvc.reshape(-1, 2), np.arange(F.size).reshape(-1, 3))
    assert r.flipped_fraction == pytest.approx(10 / len(F))
    assert r.overlap_fraction == 0  # a swapped corner order covers the same area


# ------------------------------------------------------------------------------- Richness
def test_richness_zero_for_flat_grid_positions():
    V, F = grid(12, 9, 1.1, 0.8)
    G = np.linalg.norm(V[:, None] - V[None], axis=2)  # geodesics on a flat grid are Euclidean
    assert M.richness(G, V, k=10) == 0.0
    # any distance-preserving embedding (rotation + translation, more dims) keeps it at 0 up to
    # float ties; a 2D copy (z dropped) is exact
    assert M.richness(G, V[:, :2], k=10) == 0.0


def test_richness_near_one_for_random_embedding():
    V, F = grid(20, 20, 1, 1)
    G = np.linalg.norm(V[:, None] - V[None], axis=2)
    r = M.richness_details(G, np.random.default_rng(0).normal(size=(len(V), 16)), k=10)
    assert r.score > 0.9
    assert 0 <= r.near.min() and r.far.max() <= 1


# ----------------------------------------------------------------------------- bad input
BAD_POINTS = [
    (np.zeros((0, 3)), "empty"),
    (np.zeros((5, 2)), r"shape \(n, 3\)"),
    (np.array([[0, 0, np.inf]]), "NaN or inf"),
    (np.array([[0, np.nan, 0]]), "NaN or inf"),
    ([["a", "b", "c"]], "numeric"),
]


@pytest.mark.parametrize("pts, match", BAD_POINTS)
def test_bad_points(pts, match):
    mesh = sphere(1)
    with pytest.raises(ValueError, match=match):
        M.p2s(pts, mesh)
    with pytest.raises(ValueError, match="^a"):
        M.chamfer(pts, np.zeros((3, 3)))


def test_bad_meshes():
    V, F = sphere(1)
    pts = np.zeros((4, 3))
    with pytest.raises(ValueError, match=r"surface faces.*\[0, 41\]"):
        M.p2s(pts, (V, F + 100))
    with pytest.raises(ValueError, match="surface: expected a mesh"):
        M.p2s(pts, V)
    with pytest.raises(ValueError, match="garment faces: expected at least one face"):
        M.interpenetration_ratio((V, np.zeros((0, 3), int)), (V, F))
    with pytest.raises(ValueError, match="body vertices.*NaN"):
        M.interpenetration_ratio((V, F), (V * np.nan, F))
    with pytest.raises(ValueError, match="pred faces"):
        M.normal_consistency((V, F[:, :2]), (V, F))
    with pytest.raises(ValueError, match="uv"):
        M.qce(V, F, V[:10, :2])
    with pytest.raises(ValueError, match="uv_faces"):
        M.ase(V, F, V[:, :2], F[:5])
    with pytest.raises(ValueError, match="uv_faces"):
        M.qce(V, F, V[:, :2], F + 100)
    with pytest.raises(ValueError, match="n_samples"):
        M.p2s_bidirectional((V, F), (V, F), n_samples=0)
    with pytest.raises(ValueError, match="eps"):
        M.penetrating_vertex_fraction(V, (V, F), eps=-1)
    with pytest.raises(M.TopologyMismatchError):
        M.euclidean(V, V[:-1])
    with pytest.raises(M.TopologyMismatchError):
        M.normal_consistency((V, F), (V, F[::-1]), mode="vertex")


def test_bad_richness_input():
    X = np.random.default_rng(0).normal(size=(30, 3))
    G = np.linalg.norm(X[:, None] - X[None], axis=2)
    with pytest.raises(ValueError, match="geodesic"):
        M.richness(G[:-1], X)
    with pytest.raises(ValueError, match="k"):
        M.richness(G, X, k=15)
    with pytest.raises(ValueError, match="k"):
        M.richness(G, X, k=0)
    with pytest.raises(ValueError, match="NaN"):
        M.richness(G * np.nan, X)
    with pytest.raises(ValueError, match="embedding"):
        M.richness(G, X * np.inf)


def test_degenerate_faces_are_tolerated():
    V, F = grid(5, 5, 1, 1)
    V2 = np.r_[V, [[5, 5, 0]]]
    F2 = np.r_[F, [[0, 0, 1], [len(V), len(V), len(V)]]]  # zero-area faces
    uv = V2[:, :2]
    d = M.qce_details(V2, F2, uv)
    assert d.n_degenerate == 2 and d.mean == pytest.approx(1.0)
    assert M.ase(V2, F2, uv) == pytest.approx(0.0, abs=1e-12)
    assert M.interpenetration_ratio((V2, F2), box_body()) == pytest.approx(1.0)
    assert M.p2s(np.array([[0.5, 0.5, 1.0]]), (V2, F2)) == pytest.approx(1.0)
