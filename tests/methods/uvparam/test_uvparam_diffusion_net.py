"""DiffusionNet and its operators: vertex-order invariance, resolution agreement, eigenbasis."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from dressmeup.data.shapes import make_test_mesh  # noqa: E402
from dressmeup.methods.nn.diffusion_net import DiffusionNet  # noqa: E402
from dressmeup.methods.nn.diffusion_ops import (  # noqa: E402
    compute_operators,
    tangent_gradient_operators,
)
from dressmeup.methods.uvparam.neural.patchnet import normalize_vertices, patchnet_inputs  # noqa: E402


def run(net, V, F):
    Vn = normalize_vertices(V)
    ops = compute_operators(Vn, F, k_eig=32, use_cache=False)
    with torch.no_grad():
        return net(torch.from_numpy(patchnet_inputs(Vn, F)), ops.to_torch()).numpy()


def test_invariant_to_vertex_order():
    V, F = make_test_mesh("blob-600")
    net = DiffusionNet(6, 5, width=32, n_blocks=2, seed=3)
    out = run(net, V, F)
    perm = np.random.default_rng(1).permutation(len(V))
    inv = np.argsort(perm)
    out_p = run(net, V[perm], inv[F])
    np.testing.assert_allclose(out_p, out[perm], atol=2e-4 * np.abs(out).max())


def test_close_outputs_on_two_resolutions():
    # the same shape at ~1.5k and ~6k vertices: outputs at matching points agree closely,
    # much more closely than outputs at unrelated points differ
    Vc, Fc = make_test_mesh("blob-1.5k")
    Vf, Ff = make_test_mesh("blob-6k")
    net = DiffusionNet(6, 4, width=32, n_blocks=2, seed=0)
    # give the diffusion times a spread like a trained network's
    for blk in net.blocks:
        blk.diffusion.diffusion_time.data = torch.linspace(0.0, 0.05, 32)
    oc, of = run(net, Vc, Fc), run(net, Vf, Ff)
    from scipy.spatial import cKDTree

    _, nn = cKDTree(normalize_vertices(Vf)).query(normalize_vertices(Vc))
    err = np.linalg.norm(oc - of[nn], axis=1).mean()
    spread = np.linalg.norm(oc - oc[np.random.default_rng(0).permutation(len(oc))], axis=1).mean()
    assert err < 0.1 * spread


def test_galerkin_eigenbasis_matches_exact():
    V, F = make_test_mesh("blob-3k")
    Vn = normalize_vertices(V)
    ex = compute_operators(Vn, F, k_eig=24, use_cache=False)
    ga = compute_operators(Vn, F, k_eig=24, use_cache=False, exact_limit=100, n_coarse=500)
    np.testing.assert_allclose(ga.evals[1:], ex.evals[1:], rtol=0.06)
    assert np.all(ga.evals[1:] >= ex.evals[1:] * (1 - 1e-6))  # Rayleigh-Ritz: upper bounds
    # low-frequency heat diffusion agrees
    x = np.random.default_rng(0).normal(size=(len(V), 3))

    def heat(o, t):
        return o.evecs @ (np.exp(-o.evals[:, None] * t) * (o.evecs.T @ (o.mass[:, None] * x)))

    a, b = heat(ex, 0.05), heat(ga, 0.05)
    assert np.linalg.norm(a - b) / np.linalg.norm(a) < 0.05


def test_gradient_of_a_linear_function_on_a_plane_is_exact():
    k = 9
    s = np.linspace(0, 1, k)
    X, Y = np.meshgrid(s, s, indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), np.zeros(k * k)], 1)
    from dressmeup.data.shapes import _grid_faces

    F = _grid_faces(k, k, False, False)
    gx, gy = tangent_gradient_operators(V, F, reg=0.0)
    f = 2.0 * V[:, 0] - 3.0 * V[:, 1]
    g = np.stack([gx @ f, gy @ f], 1)
    # the frame is arbitrary but orthonormal: the gradient norm is sqrt(13) everywhere
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), np.sqrt(13.0), rtol=1e-9)


def test_operator_cache_round_trip(tmp_path, monkeypatch):
    monkeypatch.setenv("DRESSMEUP_CACHE", str(tmp_path))
    V, F = make_test_mesh("sphere-300")
    a = compute_operators(V, F, k_eig=16)
    b = compute_operators(V, F, k_eig=16)
    assert a.seconds > 0 and b.seconds == 0.0
    np.testing.assert_array_equal(a.evecs, b.evecs)
    assert (a.grad_x != b.grad_x).nnz == 0
    assert len(list((tmp_path / "diffusion_net_ops").glob("*.npz"))) == 1


def test_diffusion_times_learn_from_their_initial_value():
    # regression: the times start at 0 and used to be clamped inside the autograd graph,
    # where the gradient is exactly 0, so they never moved during training
    V, F = make_test_mesh("blob-600")
    Vn = normalize_vertices(V)
    ops = compute_operators(Vn, F, k_eig=16, use_cache=False).to_torch()
    x = torch.from_numpy(patchnet_inputs(Vn, F)).float()
    target = torch.from_numpy(Vn[:, :1] ** 2).float()
    net = DiffusionNet(6, 1, width=8, n_blocks=2, seed=0)
    times0 = [blk.diffusion.diffusion_time.detach().clone() for blk in net.blocks]
    opt = torch.optim.Adam(net.parameters(), lr=1e-2)
    for step in range(5):
        opt.zero_grad()
        loss = ((net(x, ops) - target) ** 2).mean()
        loss.backward()
        if step == 0:
            grads = [blk.diffusion.diffusion_time.grad for blk in net.blocks]
            assert all(g is not None and float(g.abs().max()) > 0 for g in grads)
        opt.step()
    for blk, t0 in zip(net.blocks, times0, strict=True):
        t = blk.diffusion.diffusion_time.detach()
        assert float((t - t0).abs().max()) > 1e-4
    with torch.no_grad():
        net(x, ops)
    assert all(float(blk.diffusion.diffusion_time.detach().min()) > 0.0 for blk in net.blocks)
