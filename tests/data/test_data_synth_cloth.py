"""The cloth solver of generator 3.x (synth.cloth, synth.contact, synth.quasistatic) on small
generated primitives: gradients against finite differences, contact detection against
brute force, convergence to the tolerance, and the path settings."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from dressmeup.data.synth import cloth
from dressmeup.data.synth.contact import BodySurface, self_contacts
from dressmeup.data.synth.quasistatic import DressSettings, path_bodies


def _sheet(n: int = 6, size: float = 0.1, z: float = 0.0):
    """A square sheet ``(n x n)`` vertices in the plane z, triangulated."""
    u = np.linspace(-size / 2, size / 2, n)
    X, Y = np.meshgrid(u, u, indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), np.full(n * n, z)], axis=1)
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, i * n + j + 1, (i + 1) * n + j, (i + 1) * n + j + 1
            F += [[a, b, d], [a, d, c]]
    return V, np.asarray(F, np.int64)


def _ball(radius: float = 0.05):
    m = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)


def test_gradient_matches_finite_differences():
    rng = np.random.default_rng(0)
    V, F = _sheet()
    BV, BF = _ball()
    BV = BV + [0.0, 0.0, -0.052]  # the sheet touches the ball's top
    model = cloth.ClothModel(V, F)
    x = V + rng.normal(scale=0.002, size=V.shape)
    support = np.zeros(len(V))
    support[0] = 1.0
    loads = cloth.Loads(BV, BF, V + 0.001, support, np.array([0.0, 0.0, 1.0]))
    body = BodySurface(BV, BF).contact(x, 0.01)
    pairs = self_contacts(x, F, V, model.rest_gap, 0.016)
    lin = cloth._Linearized(model, loads, body, pairs)
    e, g, H = lin.gradient_hessian(x)
    assert e == pytest.approx(lin.energy(x), rel=1e-12)
    h = 1e-7
    for i, k in [(0, 2), (7, 0), (20, 1), (35, 2)]:
        xp, xm = x.copy(), x.copy()
        xp[i, k] += h
        xm[i, k] -= h
        fd = (lin.energy(xp) - lin.energy(xm)) / (2 * h)
        assert g[i, k] == pytest.approx(fd, rel=1e-4, abs=1e-6)
    # the Hessian is symmetric positive semi-definite (projected springs, contact blocks)
    Hd = H.toarray()
    assert np.allclose(Hd, Hd.T, atol=1e-9 * np.abs(Hd).max())
    assert np.linalg.eigvalsh(Hd).min() > -1e-9 * np.abs(Hd).max()


def test_self_contacts_against_brute_force():
    V1, F1 = _sheet(z=0.0)
    V2, F2 = _sheet(z=0.003)
    V = np.concatenate([V1, V2])
    F = np.concatenate([F1, F2 + len(V1)])
    rest = np.concatenate([V1, V2 + [0.0, 0.0, 1.0]])  # far apart at rest: a real contact
    pairs = self_contacts(V, F, rest, 0.025, 0.004)
    vt = pairs.kind == 0
    # brute force: every vertex of one sheet is 3 mm from the other sheet's triangles
    assert set(pairs.ids[vt, 0]) == set(range(len(V)))
    assert np.allclose(pairs.distance[vt], 0.003)
    assert np.all(np.abs(pairs.normals[vt, 2]) == pytest.approx(1.0))
    # sorted (deterministic sums), and each pair's coefficients map to the gap vector
    keys = pairs.ids[vt, 0] * 10**6 + pairs.ids[vt, 1]
    assert np.all(np.diff(keys) >= 0)
    gap = np.einsum("pk,pkd->pd", pairs.coef, V[pairs.ids])
    assert np.allclose(np.linalg.norm(gap, axis=1), pairs.distance)
    # neighbours at rest are no contact; 30 mm apart is none either
    assert len(self_contacts(V1, F1, V1, 0.025, 0.004).ids) == 0
    far = np.concatenate([V1, V2 + [0.0, 0.0, 0.03]])
    assert len(self_contacts(far, F, rest, 0.025, 0.016).ids) == 0


def test_crossing_edges_are_an_edge_edge_pair():
    V = np.array([[-0.01, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, -0.01, 0.002], [0.0, 0.01, 0.002],
                  [0.0, 0.0, 0.05], [0.0, 0.0, -0.05]])
    F = np.array([[0, 1, 4], [2, 3, 5]])
    rest = V * 10
    pairs = self_contacts(V, F, rest, 0.001, 0.004)
    ee = pairs.kind == 1
    assert ee.sum() == 1
    assert pairs.distance[ee][0] == pytest.approx(0.002)
    assert sorted(pairs.ids[ee][0]) == [0, 1, 2, 3]


def test_body_contact_sides():
    BV, BF = _ball()
    x = np.array([[0.0, 0.0, 0.053], [0.0, 0.0, 0.045], [0.0, 0.2, 0.0]])
    bc = BodySurface(BV, BF).contact(x, 0.01)
    assert bc.signed[0] > 0 > bc.signed[1] and bc.signed[2] > 0.1
    for v in (0, 1):  # every plane of a vertex pushes it outwards
        n = bc.normals[bc.vertex == v]
        assert len(n) and np.all(n @ np.array([0.0, 0.0, 1.0]) > 0.9)
    assert 2 not in bc.vertex  # out of reach
    assert np.all((bc.weight > 0) & (bc.weight <= 1))


def test_solve_drapes_a_sheet_over_a_ball_to_the_tolerance():
    V, F = _sheet(n=8, size=0.14, z=0.06)
    BV, BF = _ball()
    model = cloth.ClothModel(V, F)
    loads = cloth.Loads(BV, BF, V, np.zeros(len(V)), np.array([0.0, 0.0, 1.0]))
    res = cloth.solve(model, V, loads, tolerance=1e-2, max_iterations=300)
    st = res.stats
    assert st["converged"] and st["iterations"] > 0
    assert st["grad_norm"] < 1e-2 or (st["grad_norm"] < 0.1 and st["energy_change"] < 1e-5)
    # it fell onto the ball and stays outside it (margin 5 mm, penalty: a little inside it)
    bc = BodySurface(BV, BF).contact(res.vertices, 0.01)
    assert bc.signed.min() > -0.001
    assert res.vertices[:, 2].max() < 0.06
    # the energy went down from the start
    body = BodySurface(BV, BF).contact(V, 0.01)
    lin = cloth._Linearized(model, loads, body, self_contacts(V, F, V, model.rest_gap, 0.016))
    assert st["energy"] < lin.energy(V)


def test_dress_settings():
    s = DressSettings()
    two = s.longer(2.0)
    assert two.body_step == s.body_step / 2 and two.final_tolerance == s.final_tolerance / 2
    assert two.cloth.tolerance == s.cloth.tolerance / 2
    assert DressSettings.from_dict({"body_step": 0.01, "cloth": {"youngs": 100.0}}).cloth.youngs \
        == 100.0
    with pytest.raises(ValueError, match="cloth.nonsense"):
        DressSettings.from_dict({"cloth": {"nonsense": 1}})
    jittered = DressSettings(start_jitter=0.005, start_seed=3).start(np.zeros((10, 3)))
    assert np.allclose(np.linalg.norm(jittered, axis=1), 0.005)


def test_path_bodies_step_size():
    start = np.zeros((4, 3))
    end = start + [0.0, 0.0, 0.1]
    bodies = path_bodies(lambda t: start + t * (end - start), start, np.zeros((1, 3)),
                         DressSettings(body_step=0.03))
    assert len(bodies) == 4  # ceil(0.1 / 0.03)
    assert np.allclose(bodies[-1], end)
    # body vertices far from the garment do not count
    far = path_bodies(lambda t: start + t * (end - start), start, np.full((1, 3), 5.0),
                      DressSettings(body_step=0.03))
    assert len(far) == 1
