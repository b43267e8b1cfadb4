"""Metrics on real meshes from ../shared/data/meshes (skipped when absent)."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup import metrics as M
from dressmeup.geometry.mesh import face_areas, vertex_normals
from dressmeup.io.mesh import load_mesh

pytestmark = pytest.mark.realdata


def test_spot_uv_distortion_matches_per_face_svd(shared_meshes):
    m = load_mesh(shared_meshes / "spot.obj")
    V, F, uv, uvf = m.vertices, m.faces, m.uv, m.uv_faces
    E1 = V[F[:, 1]] - V[F[:, 0]]
    E2 = V[F[:, 2]] - V[F[:, 0]]
    E = np.stack([E1, E2], axis=2)  # (m, 3, 2)
    U = np.stack(
        [uv[uvf[:, 1]] - uv[uvf[:, 0]], uv[uvf[:, 2]] - uv[uvf[:, 0]]], axis=2
    )  # (m, 2, 2)
    J = U @ np.linalg.pinv(E)  # (m, 2, 3)
    sv = np.linalg.svd(J, compute_uv=False)
    q = sv[:, 0] / sv[:, 1]
    a = face_areas(V, F)
    d = M.qce_details(V, F, uv, uvf)
    assert d.n_zero_uv_area == 0
    np.testing.assert_allclose(d.per_face, q, rtol=1e-6)
    assert d.mean == pytest.approx(np.sum(a * q) / a.sum(), rel=1e-6)
    assert 1.0 < d.mean < 2.0  # Spot ships a low-distortion parameterisation
    validity = M.uv_validity(V, F, uv, uvf)
    sign = np.sign(np.linalg.det(U))
    assert validity.flipped_fraction == pytest.approx(
        min((sign > 0).sum(), (sign < 0).sum()) / len(F)
    )
    assert validity.overlap_fraction < 0.01  # Spot's atlas is overlap-free (some charts mirrored)


def test_cow_offsets_and_penetration(shared_meshes):
    m = load_mesh(shared_meshes / "cow.obj")
    V, F = m.vertices, m.faces
    scale = np.linalg.norm(V.max(0) - V.min(0))
    assert M.p2s(V, (V, F)) < 1e-12
    # vertices pushed 0.1 % of the size along their normals: P2S at most that offset
    off = 1e-3 * scale
    P = V + off * vertex_normals(V, F)
    d = M.p2s_details(P, (V, F))
    assert d.max() <= off * (1 + 1e-9) and d.mean() > 0.5 * off
    # a garment-like shell offset outwards does not penetrate; offset inwards it does
    N = vertex_normals(V, F)
    shell_out = (V + 5e-3 * scale * N, F)
    shell_in = (V - 5e-3 * scale * N, F)
    assert M.interpenetration_ratio(shell_out, (V, F)) < 0.02
    assert M.interpenetration_ratio(shell_in, (V, F)) > 0.98
    assert M.penetrating_vertex_fraction(shell_in[0], (V, F)) > 0.98
    assert M.normal_consistency(shell_out, (V, F)) > 0.98
    assert M.euclidean(shell_out, (V, F)) == pytest.approx(5e-3 * scale)
