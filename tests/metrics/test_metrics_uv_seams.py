"""Seam length, charts and packing efficiency: analytic cases and slow references."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.metrics.uv import seam_edges, uv_seams


def slow_seams(V, F, UV, UF):
    """Reference: a plain loop over faces and a union-find over faces."""
    edges: dict = {}
    for f, (tri, utri) in enumerate(zip(F, UF, strict=True)):
        for k in range(3):
            a, b = int(tri[k]), int(tri[(k + 1) % 3])
            ua, ub = UV[utri[k]], UV[utri[(k + 1) % 3]]
            if a > b:
                a, b, ua, ub = b, a, ub, ua
            edges.setdefault((a, b), []).append((f, ua, ub))
    parent = list(range(len(F)))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    seams = []
    for (a, b), hs in edges.items():
        if len(hs) < 2:
            continue
        f0, ua0, ub0 = hs[0]
        seam = False
        for f, ua, ub in hs[1:]:
            if np.allclose(ua, ua0, rtol=0, atol=1e-9) and np.allclose(ub, ub0, rtol=0, atol=1e-9):
                parent[find(f)] = find(f0)
            else:
                seam = True
        if seam:
            seams.append((a, b))
    area = sum(0.5 * np.linalg.norm(np.cross(V[b] - V[a], V[c] - V[a])) for a, b, c in F)
    length = sum(np.linalg.norm(V[a] - V[b]) for a, b in seams) / np.sqrt(area)
    charts = len({find(i) for i in range(len(F))})
    T = UV[UF]
    uv_area = sum(0.5 * abs((t[1, 0] - t[0, 0]) * (t[2, 1] - t[0, 1]) - (t[1, 1] - t[0, 1]) * (t[2, 0] - t[0, 0]))
                  for t in T)
    side = (T.reshape(-1, 2).max(0) - T.reshape(-1, 2).min(0)).max()
    return sorted(seams), length, charts, uv_area / side**2


def grid(k):
    s = np.linspace(0.0, 1.0, k)
    X, Y = np.meshgrid(s, s, indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), np.zeros(k * k)], 1)
    idx = np.arange(k * k).reshape(k, k)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return V, F


# a unit cube: 8 corners, 6 quads split in two (outward orientation)
CUBE_V = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
CUBE_QUADS = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
CUBE_F = np.array([t for q in CUBE_QUADS for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))])


def test_single_chart_plane():
    V, F = grid(6)
    s = uv_seams(V, F, V[:, :2])
    assert (s.n_seam_edges, s.n_charts) == (0, 1)
    assert s.seam_length == 0.0
    assert s.packing_efficiency == pytest.approx(1.0)
    # per-corner UVs that duplicate every corner but keep positions: still no seam
    UF = np.arange(3 * len(F)).reshape(-1, 3)
    s2 = uv_seams(V, F, V[F.reshape(-1), :2], UF)
    assert (s2.n_seam_edges, s2.n_charts) == (0, 1)
    # a half-size atlas in a corner of [0, 1]^2 is normalised to its own square
    assert uv_seams(V, F, 0.5 * V[:, :2]).packing_efficiency == pytest.approx(1.0)


def test_cube_cut_into_six_squares():
    # every quad its own chart, laid out in a row: all 12 cube edges are seams
    uv, uf = [], []
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    for qi, _ in enumerate(CUBE_QUADS):
        base = len(uv)
        uv.extend(sq + [1.5 * qi, 0.0])
        uf += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    UV, UF = np.array(uv), np.array(uf)
    s = uv_seams(CUBE_V, CUBE_F, UV, UF)
    assert s.n_seam_edges == 12 and s.n_charts == 6
    assert s.seam_length == pytest.approx(12.0 / np.sqrt(6.0))
    side = 1.5 * 5 + 1.0
    assert s.packing_efficiency == pytest.approx(6.0 / side**2)


def test_cube_unfolded_as_a_cross():
    # the classic cross around the x=0 face: 5 of the 12 cube edges stay joined in UV,
    # 7 are cut, one chart in a 3 x 4 box
    def unfold(qi, P):
        x, y, z = P[:, 0], P[:, 1], P[:, 2]
        if qi == 0:                          # x = 0, the centre cell (1, 1)
            return np.c_[y + 1, z + 1]
        if qi == 2:                          # y = 0, unfolded to the left
            return np.c_[1 - x, z + 1]
        if qi == 3:                          # y = 1, to the right
            return np.c_[2 + x, z + 1]
        if qi == 4:                          # z = 0, below
            return np.c_[y + 1, 1 - x]
        if qi == 5:                          # z = 1, above
            return np.c_[y + 1, 2 + x]
        return np.c_[y + 1, 4 - z]           # x = 1, above the z = 1 face

    uv, uf = [], []
    for qi, q in enumerate(CUBE_QUADS):
        base = len(uv)
        uv.extend(unfold(qi, CUBE_V[list(q)]))
        uf += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    UV, UF = np.array(uv, float), np.array(uf)
    s = uv_seams(CUBE_V, CUBE_F, UV, UF)
    ref = slow_seams(CUBE_V, CUBE_F, UV, UF)
    assert s.n_charts == 1 and s.n_seam_edges == 7
    assert s.seam_length == pytest.approx(7.0 / np.sqrt(6.0))
    assert s.packing_efficiency == pytest.approx(6.0 / 16.0)
    assert [tuple(e) for e in seam_edges(CUBE_V, CUBE_F, UV, UF)] == ref[0]


def test_sphere_cut_at_the_equator():
    # a latitude-longitude sphere with an equator ring; each hemisphere projected to its
    # disk (x, y), the lower one shifted: the seam is exactly the equator polygon
    n_lon, n_lat = 24, 12  # n_lat even: ring n_lat/2 is the equator
    th = np.linspace(0, np.pi, n_lat + 1)[1:-1]
    ph = np.linspace(0, 2 * np.pi, n_lon, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    V = np.r_[[[0, 0, 1]], np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3),
              [[0, 0, -1]]]
    ring = lambda i: 1 + i * n_lon + np.arange(n_lon)  # noqa: E731
    F = [np.stack([np.zeros(n_lon, int), ring(0), np.roll(ring(0), -1)], 1)]
    for i in range(n_lat - 2):
        a, b = ring(i), ring(i + 1)
        F += [np.stack([a, b, np.roll(b, -1)], 1), np.stack([a, np.roll(b, -1), np.roll(a, -1)], 1)]
    last = len(V) - 1
    F.append(np.stack([np.full(n_lon, last), np.roll(ring(n_lat - 2), -1), ring(n_lat - 2)], 1))
    F = np.concatenate(F)
    upper = V[F][:, :, 2].mean(1) > 0
    UV = np.r_[V[:, :2], V[:, :2] + [3.0, 0.0]]
    UF = np.where(upper[:, None], F, F + len(V))
    s = uv_seams(V, F, UV, UF)
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()
    assert s.n_charts == 2 and s.n_seam_edges == n_lon
    assert s.seam_length == pytest.approx(2 * n_lon * np.sin(np.pi / n_lon) / np.sqrt(area))
    ref = slow_seams(V, F, UV, UF)
    assert s.seam_length == pytest.approx(ref[1]) and s.packing_efficiency == pytest.approx(ref[3])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_matches_slow_reference_on_random_cuts(seed):
    # a real mesh, per-chart LSCM-like per-corner UVs from a random face labelling
    from dressmeup.data.shapes import make_test_mesh

    V, F = make_test_mesh("torus-300" if seed == 0 else "skirt-300")
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, 4, len(F))
    # per-corner UVs: corners of faces with the same label share a UV entry per vertex;
    # a random displacement per label makes label boundaries seams
    UV = np.concatenate([V[:, :2] + rng.normal(size=2) for _ in range(4)])
    UF = F + labels[:, None] * len(V)
    s = uv_seams(V, F, UV, UF)
    ref = slow_seams(V, F, UV, UF)
    assert [tuple(e) for e in seam_edges(V, F, UV, UF)] == ref[0]
    assert s.n_seam_edges == len(ref[0])
    assert s.seam_length == pytest.approx(ref[1])
    assert s.n_charts == ref[2]
    assert s.packing_efficiency == pytest.approx(ref[3])


def test_cutting_every_face_is_visible():
    V, F = grid(5)
    UF = np.arange(3 * len(F)).reshape(-1, 3)
    UV = V[F.reshape(-1), :2] + np.repeat(np.arange(len(F)), 3)[:, None] * 2.0
    s = uv_seams(V, F, UV, UF)
    assert s.n_charts == len(F)
    interior = 3 * len(F) // 2 - 2 * 4  # (3m - boundary edges) / 2 with 16 boundary edges
    assert s.n_seam_edges == interior


def test_bad_input_names_the_array():
    V, F = grid(3)
    with pytest.raises(ValueError, match="uv_faces"):
        uv_seams(V, F, V[:, :2], F[:2])
