"""Laplacians, MDS, extrapolation and placement on analytic cases."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial.distance import cdist

from dressmeup.geometry.laplacian import cotan_laplacian, mass_matrix, uniform_laplacian
from dressmeup.methods.retarget.correspondence import extrapolate, place
from dressmeup.methods.retarget.embedding import geodesic_matrix, template_embedding
from dressmeup.methods.retarget.mds import classical_mds, landmark_mds


def grid(n=6):
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    V = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], axis=1)
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j
            F += [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
    return V, np.array(F)


def test_uniform_laplacian_rows_and_flat_interior():
    V, F = grid()
    L = uniform_laplacian(F, len(V))
    assert np.allclose(np.asarray(L.sum(axis=1)).ravel(), 0.0)
    interior = [i for i in range(len(V)) if 0 < V[i, 0] < 1 and 0 < V[i, 1] < 1]
    # regular grid with diagonals: the 6-ring is symmetric, so the umbrella vector vanishes
    assert np.abs((L @ V)[interior]).max() < 1e-12
    assert np.allclose(np.diag(L.toarray()), 1.0)


def test_cotan_laplacian_matches_igl_and_is_psd():
    igl = pytest.importorskip("igl")
    rng = np.random.default_rng(0)
    V, F = grid(5)
    V = V + 0.02 * rng.standard_normal(V.shape)
    L = cotan_laplacian(V, F)
    ref = -sp.csr_matrix(igl.cotmatrix(V, F))
    assert abs(L - ref).max() < 1e-10
    assert np.linalg.eigvalsh(L.toarray()).min() > -1e-10
    assert np.isclose(mass_matrix(V, F).sum(), 0.5 * np.linalg.norm(
        np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum())


def test_classical_and_landmark_mds_recover_euclidean_distances():
    rng = np.random.default_rng(1)
    X = rng.standard_normal((120, 3))
    D = cdist(X, X)
    Y = classical_mds(D, dim=3)
    assert np.allclose(cdist(Y, Y), D, atol=1e-4)
    # landmark MDS is exact for Euclidean data once the landmarks span the space
    lm = np.arange(0, 120, 6)
    Z = landmark_mds(D[lm], lm, dim=3)
    assert np.allclose(cdist(Z, Z), D, atol=1e-4)
    # extra dimensions carry nothing (zero eigenvalues)
    Y8 = classical_mds(D, dim=8)
    assert np.allclose(cdist(Y8, Y8), D, atol=1e-4)


def test_geodesics_on_plane_are_euclidean():
    V, F = grid(11)
    D = geodesic_matrix(V, F)
    assert np.allclose(D, D.T)
    E = cdist(V, V)
    # heat-method geodesics on a flat grid: within a few percent of the straight line
    far = E > 0.3
    assert np.median(np.abs(D[far] - E[far]) / E[far]) < 0.05


def test_extrapolate_is_exact_on_reference_points_and_interpolates():
    rng = np.random.default_rng(2)
    ref = rng.standard_normal((50, 3))
    emb = rng.standard_normal((50, 4)).astype(np.float32)
    assert np.allclose(extrapolate(emb, ref, ref[:10], k=8), emb[:10], atol=1e-6)
    # eq. 4.1 by hand for one query
    q = np.array([[0.1, 0.2, 0.3]])
    d = np.linalg.norm(ref - q, axis=1)
    nn = np.argsort(d)[:5]
    w = (1 / d[nn]) / (1 / d[nn]).sum()
    assert np.allclose(extrapolate(emb, ref, q, k=5)[0], w @ emb[nn], atol=1e-5)


def test_place_matches_eq_4_4_by_hand():
    rng = np.random.default_rng(3)
    T = rng.standard_normal((40, 3))
    E = rng.standard_normal((40, 6)).astype(np.float32)
    g = rng.standard_normal((5, 6)).astype(np.float32)
    x = place(g, E, T, k=7)
    for i in range(5):
        d = np.linalg.norm(E - g[i], axis=1)
        nn = np.argsort(d)[:7]
        w = (1 / d[nn]) / (1 / d[nn]).sum()
        assert np.allclose(x[i], w @ T[nn], atol=1e-4)


def test_template_embedding_is_cached_and_deterministic(tmp_path, monkeypatch):
    import trimesh

    monkeypatch.setenv("DRESSMEUP_CACHE", str(tmp_path))
    m = trimesh.creation.icosphere(subdivisions=2)
    a = template_embedding(m.vertices, m.faces, dim=8, method="full")
    assert a.seconds > 0 and a.embedding.shape == (len(m.vertices), 8)
    b = template_embedding(m.vertices, m.faces, dim=8, method="full")
    assert b.seconds == 0.0 and np.array_equal(a.embedding, b.embedding)
    assert len(list((tmp_path / "isomap").glob("*.npz"))) == 1
    # on a sphere the embedding distance tracks the geodesic (great-circle) distance
    U = m.vertices / np.linalg.norm(m.vertices, axis=1, keepdims=True)
    G = np.arccos(np.clip(U @ U.T, -1, 1))
    De = cdist(a.embedding, a.embedding)
    assert np.corrcoef(G.ravel(), De.ravel())[0, 1] > 0.95
