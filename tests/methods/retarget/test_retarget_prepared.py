"""The per-garment preparation (fast paths), the loose-garment variant, the supervised variant
and the training loop (resume, leakage check), on tiny data with the procedural body."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.methods.retarget import get_method

FAST = dict(dim=32, embedding_method="landmark", n_landmarks=150)
TINY_NET = dict(FAST, width=32, depth=2, code_dim=16, pointnet_hidden=16, n_points=256, k_neighbors=8)


def ed(a, b):
    return float(np.linalg.norm(a - b, axis=1).mean())


def test_prepared_isomap_equals_general_path(tiny, body_model):
    V, F, s, t = tiny["V"], tiny["F"], tiny["source"], tiny["target"]
    general = get_method("isomap", precompute=False, **FAST).retarget(V, F, s, t, body_model)
    prepared = get_method("isomap", **FAST).retarget(V, F, s, t, body_model)
    assert np.allclose(general, prepared, atol=1e-12)


def test_prepared_garment_is_cached_by_content(tiny, body_model, tmp_path, monkeypatch):
    from dressmeup.methods.retarget import prepared as prep_mod
    from dressmeup.methods.retarget.base import body_context

    monkeypatch.setenv("DRESSMEUP_CACHE", str(tmp_path))
    monkeypatch.setattr(prep_mod, "_MEMO", {})
    m = get_method("isomap", **FAST)
    emb = m.embedding(body_model)
    ctx = body_context(body_model, tiny["source"])
    a = prep_mod.prepare_garment(tiny["V"], tiny["F"], ctx.skin_vertices, ctx.skin_normals(), emb.embedding)
    assert len(list((tmp_path / "retarget-prepared").glob("*.npz"))) == 1
    prep_mod._MEMO.clear()
    b = prep_mod.prepare_garment(tiny["V"].copy(), tiny["F"], ctx.skin_vertices, ctx.skin_normals, emb.embedding)
    assert b.key == a.key and np.array_equal(a.idx, b.idx) and np.allclose(a.weights, b.weights)
    moved = tiny["V"] + 0.001
    c = prep_mod.prepare_garment(moved, tiny["F"], ctx.skin_vertices, ctx.skin_normals(), emb.embedding)
    assert c.key != a.key


def test_offset_variant_keeps_the_distance_from_the_body(tiny, body_model):
    # the garment sits 1 cm outside the skin; eq. 4.4 puts it on the skin, the variant back out
    V, F, s, t, gt = tiny["V"], tiny["F"], tiny["source"], tiny["target"], tiny["gt"]
    same = get_method("isomap-offset", **FAST).retarget(V, F, s, s, body_model)
    faithful_same = get_method("isomap", **FAST).retarget(V, F, s, s, body_model)
    assert ed(same, V) < 0.5 * ed(faithful_same, V)
    moved = get_method("isomap-offset", **FAST).retarget(V, F, s, t, body_model)
    faithful = get_method("isomap", **FAST).retarget(V, F, s, t, body_model)
    assert ed(moved, gt) < ed(faithful, gt)


def test_offset_placement_is_the_gather_plus_the_offset_along_the_normal():
    # with_offset's one product over [skin | normals] against coarse() and normals() apart
    from dressmeup.methods.retarget.prepared import PreparedGarment

    rng = np.random.default_rng(3)
    n, s, k = 40, 25, 4
    w = rng.uniform(0.1, 1.0, (n, k))
    prep = PreparedGarment(key="k", phi=np.zeros((n, 2), np.float32), idx=rng.integers(0, s, (n, k)),
                           weights=w / w.sum(axis=1, keepdims=True), source_offset=rng.normal(0, 0.01, n))
    T, N = rng.normal(size=(s, 3)), rng.normal(size=(s, 3))
    placed = np.einsum("nk,nkc->nc", prep.weights, T[prep.idx])
    normal = np.einsum("nk,nkc->nc", prep.weights, N[prep.idx])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.allclose(prep.with_offset(T, N), placed + prep.source_offset[:, None] * normal, atol=1e-12)
    assert np.array_equal(prep.with_offset(T, N), prep.coarse(T) + prep.source_offset[:, None] * prep.normals(N))


def test_detail_transfer_prefactored_equals_least_squares(tiny):
    from dressmeup.geometry.laplacian import uniform_laplacian
    from dressmeup.methods.retarget.detail import DetailTransfer, choose_anchors, laplacian_solve

    V, F = tiny["V"], tiny["F"]
    R = V + np.random.default_rng(0).normal(0, 0.01, V.shape)
    L = uniform_laplacian(F, len(V))
    anchors = choose_anchors(F, len(V), 0.3, 0)
    ref = laplacian_solve(L, L @ V, anchors, R[anchors], 1.0)
    dt = DetailTransfer(V, F)
    assert np.allclose(dt.apply(R), ref, atol=1e-9)
    assert np.allclose(dt.apply(V), V, atol=1e-9)  # identity case, reusing the factorisation


@pytest.mark.parametrize("rows", [None, 5])  # the decoder's row blocks: one, and many
def test_refine_prepared_path_matches_network_forward(tiny, body_model, rows, monkeypatch):
    import torch

    from dressmeup.methods.retarget import refine_net

    if rows is not None:
        monkeypatch.setattr(refine_net, "DECODE_ROWS", rows)
    assert len(tiny["V"]) > 2 * refine_net.DECODE_ROWS or rows is None
    torch.set_num_threads(1)
    V, F, s, t = tiny["V"], tiny["F"], tiny["source"], tiny["target"]
    m = get_method("isomap-refine", **TINY_NET)
    m.network_ = m.new_network().eval()
    with torch.no_grad():  # a non-zero output layer, so that the comparison means something
        m.network_.decoder.out.weight.normal_(0, 0.1)
        m.network_.decoder.film.weight.normal_(0, 0.1)
    m.body_model_name_ = body_model.name
    fast = m.retarget(V, F, s, t, body_model)
    m.set_params(precompute=False)
    general = m.retarget(V, F, s, t, body_model)
    assert ed(general, get_method("isomap", **FAST).retarget(V, F, s, t, body_model)) > 1e-3
    assert np.allclose(fast, general, atol=1e-4)


def test_half_checkpoint_roundtrip(tiny, body_model, tmp_path):
    import torch

    torch.set_num_threads(1)
    V, F, s, t = tiny["V"], tiny["F"], tiny["source"], tiny["target"]
    m = get_method("isomap-refine", steps=2, **TINY_NET).fit([(V, F, s, t)], body_model)
    full, half = m.save(tmp_path / "f.pt"), m.save(tmp_path / "h.pt", half=True, info={"steps_done": 2})
    assert half.stat().st_size < 0.7 * full.stat().st_size
    a = get_method("isomap-refine", weights=str(full)).retarget(V, F, s, t, body_model)
    b = get_method("isomap-refine", weights=str(half)).retarget(V, F, s, t, body_model)
    assert np.allclose(a, b, atol=1e-3)


def test_training_resumes_to_the_same_weights(tiny, body_model, tmp_path):
    import torch

    from dressmeup.methods.retarget.train import train_network

    torch.set_num_threads(1)
    V, F, s, t = tiny["V"], tiny["F"], tiny["source"], tiny["target"]
    m = get_method("isomap-refine", steps=6, lr=1e-3, **TINY_NET)
    samples = m.prepare_many([(V, F, s, t), (V, F, t, s)], body_model)
    straight, _ = train_network(m, samples, steps=6)
    ck = tmp_path / "run.ckpt"
    train_network(m, samples, steps=3, checkpoint=ck, checkpoint_every=100)
    resumed, hist = train_network(m, samples, steps=6, checkpoint=ck)
    assert [r[0] for r in hist.train] == list(range(6))
    for (k, a), b in zip(straight.state_dict().items(), resumed.state_dict().values(), strict=True):
        assert torch.allclose(a, b, atol=1e-6), k


def test_validation_keeps_the_best_step(tiny, body_model):
    import torch

    from dressmeup.methods.retarget.train import train_network

    torch.set_num_threads(1)
    V, F, s, t, gt = tiny["V"], tiny["F"], tiny["source"], tiny["target"], tiny["gt"]
    m = get_method("isomap-refine", lr=1e-3, **TINY_NET)
    samples = m.prepare_many([(V, F, s, t)], body_model)
    val = m.prepare_many([(V, F, s, t, gt)], body_model)
    _, hist = train_network(m, samples, val, steps=4, val_every=2)
    eds = {step: e for step, _, e in hist.val}
    assert sorted(eds) == [0, 2, 4] and hist.best_step == min(eds, key=eds.get)


def test_supervised_variant_learns_towards_the_truth(tiny, body_model):
    import torch

    from dressmeup.methods.retarget.refine_sup import supervised_losses

    torch.set_num_threads(1)
    V, F, s, t, gt = tiny["V"], tiny["F"], tiny["source"], tiny["target"], tiny["gt"]
    m = get_method("isomap-refine-sup", steps=30, lr=3e-3, **TINY_NET)
    sample = m.prepare(V, F, s, t, body_model, truth=gt)
    zero = supervised_losses(torch.as_tensor(sample.truth), sample)
    assert all(float(v) < 1e-9 for v in zero.values())
    m.fit([(V, F, s, t, gt)], body_model)
    coarse = get_method("isomap", **FAST).retarget(V, F, s, t, body_model)
    assert ed(m.retarget(V, F, s, t, body_model), gt) < ed(coarse, gt)
    with pytest.raises(ValueError, match="ground truth"):
        get_method("isomap-refine-sup", steps=1, **TINY_NET).fit([(V, F, s, t)], body_model)


def test_leakage_check_by_content_not_id(tmp_path):
    from dressmeup.errors import InputError
    from dressmeup.methods.retarget.run import check_split_leakage

    rng = np.random.default_rng(0)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    base = rng.normal(size=(4, 3))

    class _S:
        def __init__(self, gid, V):
            self.garment_id, self._V = gid, V

        def garment(self):
            return type("G", (), {"vertices": self._V, "faces": F})()

    class _DS:
        def __init__(self, splits):
            self.splits = splits

        def filter(self, split):
            return type("V", (), {"samples": lambda _self: self.splits.get(split, [])})()

    clean = _DS({"train": [_S("A", base)], "test": [_S("B", 2.0 * base)]})
    assert check_split_leakage(clean)["train_garments"] == ["A"]
    renamed = _DS({"train": [_S("A", base)], "test": [_S("Z", base.copy())]})
    with pytest.raises(InputError, match="identical in content"):
        check_split_leakage(renamed)
    reposed = _DS({"train": [_S("A", base)], "val": [_S("Q", base @ np.linalg.qr(rng.normal(size=(3, 3)))[0])]})
    with pytest.raises(InputError, match="same garment under another id"):
        check_split_leakage(reposed)


def test_fast_variant_is_narrower_and_looks_for_its_own_weights(tiny, body_model, tmp_path, monkeypatch):
    from dressmeup.errors import MissingModelError
    from dressmeup.methods.retarget import refine

    fast, full = get_method("isomap-refine-fast"), get_method("isomap-refine")
    assert (fast.config.width, fast.config.code_dim, fast.config.pointnet_hidden,
            fast.config.k_neighbors) == (128, 64, 64, 16)
    assert (full.config.width, full.config.code_dim, full.config.pointnet_hidden,
            full.config.k_neighbors) == (512, 128, 128, 32)
    monkeypatch.setattr(refine, "WEIGHTS_DIR", tmp_path)
    with pytest.raises(MissingModelError, match="isomap_refine_fast_procedural"):
        fast.retarget(tiny["V"], tiny["F"], tiny["source"], tiny["target"], body_model)


@pytest.mark.slow
def test_supervised_baseline_trains_through_the_one_run_path(tmp_path):
    # dressmeup.runs trains trainable baselines without shipped weights; the supervised one needs
    # the target garments (it raised "no ground truth" before runs passed them)
    import torch

    from dressmeup.runs import build_data, run_retarget_baseline

    torch.set_num_threads(1)
    data = build_data("synth-retarget-tiny-v2", tmp_path / "data")  # has a train split
    out = run_retarget_baseline("isomap-refine-sup", "synth-retarget-tiny-v2", data, tmp_path / "sub",
                                train_steps=2, max_triplets=1, limit=1, **TINY_NET)
    assert (out / "submission.json").is_file()
