"""The neural method: its losses on analytic cases, a tiny training run, inference on a
second resolution, checkpoints, and the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from dressmeup.data.shapes import make_test_mesh  # noqa: E402
from dressmeup.methods.uvparam.neural import losses as L  # noqa: E402

TINY = dict(n_patches=4, patch_width=16, patch_blocks=2, k_eig=16, patch_iters=40,
            mlp_width=32, mlp_depth=4, uv_iters=120, geo_landmarks=300, pairs_per_iter=5000,
            train_vertices=400)


def test_losses_on_analytic_cases():
    # flat patch: cosine loss 0; a closed sphere in one patch: ~1
    n = torch.tensor([[0.0, 0, 1]] * 4)
    a = torch.ones(4)
    p1 = torch.ones(4, 1)
    assert float(L.cosine_loss(p1, n, a)) == pytest.approx(0.0, abs=1e-6)
    n2 = torch.tensor([[0.0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0]])
    assert float(L.cosine_loss(p1, n2, a)) == pytest.approx(1.0, abs=1e-6)
    # isometric and angle/area losses vanish for an isometric map of a plane
    x = torch.tensor([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    uv = x[:, :2].clone()
    faces = torch.tensor([[0, 1, 2], [1, 3, 2]])
    pairs = torch.tensor([[0, 1], [0, 3], [1, 2]])
    g = (x[pairs[:, 0]] - x[pairs[:, 1]]).norm(dim=1)
    assert float(L.isometric_loss(uv, pairs, g)) == pytest.approx(0.0, abs=1e-7)
    assert float(L.angle_loss(uv, faces, L.triangle_cosines(x, faces))) == pytest.approx(0.0, abs=1e-7)
    assert float(L.area_loss(uv, faces, L.triangle_areas_3d(x, faces))) == pytest.approx(0.0, abs=1e-7)
    # doubling the UV: area loss (|2^2 a - a| / a)^2 = 9, angles unchanged
    assert float(L.area_loss(2 * uv, faces, L.triangle_areas_3d(x, faces))) == pytest.approx(9.0, rel=1e-6)
    assert float(L.angle_loss(2 * uv, faces, L.triangle_cosines(x, faces))) == pytest.approx(0.0, abs=1e-7)
    # geodesic loss: two far-apart groups in one patch cost more than in two patches
    G = torch.tensor([[0.0, 0.1, 1.0, 1.0], [0.1, 0, 1, 1], [1, 1, 0, 0.1], [1, 1, 0.1, 0]])
    m = torch.ones(4)
    one = L.geodesic_loss(torch.ones(4, 1), m, G)
    two = L.geodesic_loss(torch.tensor([[1.0, 0], [1, 0], [0, 1], [0, 1]]), m, G)
    assert float(two) < float(one)
    assert float(two) == pytest.approx(0.05, rel=1e-6)  # mean distance to own patch


@pytest.fixture(scope="module")
def tiny_model():
    from dressmeup.methods.uvparam.neural.train import train

    V, F = make_test_mesh("blob-400")
    return train(V, F, "fast", progress=False, **TINY)


def test_losses_decrease_on_a_tiny_run(tiny_model):
    h = tiny_model.history

    def drop(key, k=5):
        return np.mean(h[key][-k:]) < np.mean(h[key][:k])

    assert drop("patch_total") and drop("cos")
    assert drop("uv_total") and drop("cycle") and drop("iso")
    assert np.mean(h["uv_total"][-5:]) < 0.5 * np.mean(h["uv_total"][:5])
    assert h["n_charts_train"] >= 2


def test_inference_on_another_resolution_and_checkpoint(tiny_model, tmp_path):
    from dressmeup.methods.uvparam import get_method
    from dressmeup.methods.uvparam.neural.infer import infer
    from dressmeup.methods.uvparam.neural.model import save_model
    from dressmeup.metrics import qce, uv_validity

    path = tmp_path / "m.pt"
    save_model(tiny_model, path)
    V, F = make_test_mesh("blob-1.6k")
    res = get_method("neural", checkpoint=path).parameterize(V, F)
    ref = infer(tiny_model, V, F)
    np.testing.assert_allclose(res.uv, ref.uv, atol=1e-6)  # the checkpoint is the model
    assert np.all(np.isfinite(res.uv)) and res.uv_faces.shape == F.shape
    assert res.n_charts >= 2 and res.uv.min() >= -1e-9 and res.uv.max() <= 1 + 1e-9
    # training helped: an untrained pair of MLPs on the same charts distorts far more
    from dressmeup.methods.uvparam.neural.model import NeuralUVModel, build_modules

    _, f0, b0 = build_modules(tiny_model.config)
    untrained = NeuralUVModel(tiny_model.config, tiny_model.patchnet, f0.eval(), b0.eval())
    raw = infer(untrained, V, F)
    # (the tiny run's outcome depends on the CPU's float rounding: the ratio was below 0.75
    # where this bound was set and 0.795 on an AMD EPYC, 2026-12-02)
    assert qce(V, F, res.uv, res.uv_faces) < 0.85 * qce(V, F, raw.uv, raw.uv_faces)
    assert uv_validity(V, F, res.uv, res.uv_faces, resolution=256).flipped_fraction < 0.5


def test_neural_method_trains_when_no_checkpoint_and_open_mesh():
    from dressmeup.methods.uvparam import get_method

    V, F = make_test_mesh("sheet-300")
    res = get_method("neural", **TINY).parameterize(V, F)
    assert res.uv_faces.shape == F.shape and np.all(np.isfinite(res.uv))
    assert "seconds_train" in res.info


def test_bad_config_is_rejected():
    from dressmeup.methods.uvparam.neural.model import get_config

    with pytest.raises(ValueError, match="config"):
        get_config("huge")
    with pytest.raises(ValueError, match="unknown neural hyperparameter"):
        get_config("fast", n_patchez=3)


def test_cli_writes_a_submission(tmp_path):
    from dressmeup.cli import main

    out = tmp_path / "sub"
    assert main(["baseline", "uvparam", "--method", "lscm", "--meshes", "sheet-300", "sphere-300",
                 "--out", str(out)]) == 0
    meta = json.loads((out / "submission.json").read_text())
    assert meta["task"] == "uvparam" and meta["method"] == "lscm"
    with np.load(out / "sphere-300.npz") as z:
        V, F = make_test_mesh("sphere-300")
        assert z["uv_faces"].shape == F.shape and z["chart_ids"].shape == (len(F),)
        assert z["uv"].shape[1] == 2
    assert main(["baseline", "uvparam", "--method", "lscm", "--meshes", "cube-3k", "--out", str(out)]) == 2


def test_converged_rule():
    from dressmeup.methods.nn.convergence import converged

    falling = [(s, 1.0 / s) for s in range(10, 210, 10)]
    assert not converged(falling)                       # still improving a lot
    flat = [(s, 1.0 + 0.001 / s) for s in range(10, 210, 10)]
    assert converged(flat)                              # < 1 % over the last fifth
    assert not converged(flat[:10])                     # the last fifth is 2 evaluations
    # regression: one noisy evaluation after a dip used to stop training at 125 steps
    early = [(25, 0.056), (50, 0.054), (75, 0.049), (100, 0.039), (125, 0.040)]
    assert not converged(early)
    # a plateau inside the first pass over the training set is no convergence: the window
    # spans at least min_window steps (a real run: 1,874 training pairs, val ED at 640 steps)
    first_pass = [(0, 0.0976), (40, 0.0916), (80, 0.0927), (120, 0.0916), (160, 0.0917),
                  (200, 0.0923), (240, 0.0894), (280, 0.0918), (320, 0.0931), (360, 0.0892),
                  (400, 0.0888), (440, 0.0868), (480, 0.0895), (520, 0.0908), (560, 0.0901),
                  (600, 0.0871), (640, 0.0869)]
    assert converged(first_pass)
    assert not converged(first_pass, min_window=1874)
    assert converged(flat, min_window=150) and not converged(flat, min_window=200)  # nothing before
    # one lucky evaluation early (0.90) is no level: the level falls from 1.0 to 0.90 in the
    # last fifth, which the trailing means see and the raw bests would not
    lucky = [(s, 0.90 if s == 50 else 1.0) for s in range(10, 160, 10)]
    lucky += [(s, 1.0 - 0.1 * (s - 150) / 50) for s in range(160, 210, 10)]
    assert converged(lucky, min_tail=1) and not converged(lucky)


def test_training_on_a_set_and_half_checkpoint(tmp_path):
    from dressmeup.methods.uvparam.neural.infer import infer
    from dressmeup.methods.uvparam.neural.model import load_model, save_model
    from dressmeup.methods.uvparam.neural.train_set import mesh_sha, train_on_set

    train = [make_test_mesh("blob-400"), make_test_mesh("sheet-300")]
    val = [make_test_mesh("sphere-300")]
    seen = []
    model = train_on_set(train, val, "fast", budget_seconds=600, eval_every=10,
                         on_eval=lambda *a: seen.append(a), **{**TINY, "uv_iters": 60, "patch_iters": 20})
    h = model.history
    assert h["train_mesh_sha"] == [mesh_sha(*m) for m in train]
    assert len(h["val_patch"]) >= 1 and len(h["val_uv"]) >= 1
    assert set(h["stopped"]) == {"patchnet", "uv"} and h["uv_steps"] <= 60
    assert {s for s, *_ in seen} == {"patchnet", "uv"}
    assert np.mean(h["uv_total"][-10:]) < np.mean(h["uv_total"][:10])
    path = tmp_path / "set.pt"
    save_model(model, path, half=True)
    back = load_model(path)
    assert back.history["stopped"] == h["stopped"] and back.history["val_uv"] == h["val_uv"]
    V, F = make_test_mesh("torus-300")                  # never seen
    a, b = infer(model, V, F), infer(back, V, F)
    assert a.uv_faces.shape == F.shape and np.all(np.isfinite(b.uv))
    assert np.abs(a.uv - b.uv).max() < 0.05             # float16 weights: close, not equal


def test_set_training_rule_waits_for_its_least_window(monkeypatch):
    """With any improvement counted as too small (tol 1), the rule stops a stage as soon as
    its window allows: never before MIN_WINDOW_STEPS (then at the step limit), at once
    without the least window."""
    from dressmeup.methods.uvparam.neural import train_set

    train = [make_test_mesh("blob-400"), make_test_mesh("sheet-300")]
    val = [make_test_mesh("sphere-300")]
    kw = {**TINY, "uv_iters": 100, "patch_iters": 100, "tol": 1.0}
    assert train_set.MIN_WINDOW_STEPS > 100
    held = train_set.train_on_set(train, val, "fast", eval_every=4, **kw).history
    assert held["stopped"] == {"patchnet": "max_iters", "uv": "max_iters"}
    assert held["uv_steps"] == 100
    monkeypatch.setattr(train_set, "MIN_WINDOW_STEPS", 0)
    free = train_set.train_on_set(train, val, "fast", eval_every=4, **kw).history
    assert free["stopped"] == {"patchnet": "converged", "uv": "converged"}
    assert free["uv_steps"] < 100  # the 4 evaluations of the last fifth: step 80


class _Stop(Exception):
    """A training killed from outside."""


def test_set_training_resumes_from_its_checkpoint_as_if_never_stopped(tmp_path):
    import torch

    from dressmeup.errors import InputError
    from dressmeup.methods.uvparam.neural.train_set import train_on_set

    # three meshes: the checkpoints at steps 16 and 20 are inside a pass over them, so the
    # mesh order of the pass must come back with the random streams
    train = [make_test_mesh("blob-400"), make_test_mesh("sheet-300"), make_test_mesh("torus-300")]
    val = [make_test_mesh("sphere-300")]
    kw = {**TINY, "uv_iters": 40, "patch_iters": 24, "tol": 0.0}
    whole = train_on_set(train, val, "fast", eval_every=4, **kw)

    def killer(at):
        def on_eval(stage, step, _v):
            if (stage, step) == at:
                raise _Stop
        return on_eval

    ck = tmp_path / "train.ckpt"
    for at in (("patchnet", 20), ("uv", 24)):   # killed in each stage, then resumed
        with pytest.raises(_Stop):
            train_on_set(train, val, "fast", eval_every=4, checkpoint=ck,
                         checkpoint_every_s=0.0, on_eval=killer(at), **kw)
        assert ck.is_file()
    resumed = train_on_set(train, val, "fast", eval_every=4, checkpoint=ck,
                           checkpoint_every_s=0.0, **kw)
    for a, b in ((whole.patchnet, resumed.patchnet), (whole.forward_mlp, resumed.forward_mlp),
                 (whole.backward_mlp, resumed.backward_mlp)):
        for (k, x), (_, y) in zip(a.state_dict().items(), b.state_dict().items(), strict=True):
            assert torch.equal(x, y), k
    for key in ("uv_total", "patch_total", "val_patch", "val_uv", "stopped"):
        assert resumed.history[key] == whole.history[key], key
    # a finished checkpoint gives the model back without training
    again = train_on_set(train, val, "fast", eval_every=4, checkpoint=ck, **kw)
    assert again.history["uv_total"] == whole.history["uv_total"]
    with pytest.raises(InputError, match="other training meshes"):
        train_on_set(train[:1], val, "fast", eval_every=4, checkpoint=ck, **kw)


def test_decimation_for_training_keeps_a_valid_mesh():
    # regression: libigl 2.6's decimate returns (U, G, J, I), not (success, U, G, J, I); the
    # faces were read as vertices and the joint indices as faces
    from dressmeup.geometry.mesh import face_areas
    from dressmeup.geometry.simplify import decimate

    V, F = make_test_mesh("blob-6k")
    V2, F2 = decimate(V, F, 1000)
    assert V2.shape[1] == 3 and F2.shape[1] == 3 and 700 < len(V2) < 1300
    assert F2.min() >= 0 and F2.max() == len(V2) - 1
    assert abs(face_areas(V2, F2).sum() / face_areas(V, F).sum() - 1) < 0.05


def test_proxy_inference_agrees_with_full_inference(tiny_model):
    # PatchNet on a decimated proxy (large meshes): the same charts
    from dressmeup.methods.uvparam.neural.infer import infer
    from dressmeup.metrics import qce

    V, F = make_test_mesh("blob-6k")
    full = infer(tiny_model, V, F, proxy_vertices=None)
    prox = infer(tiny_model, V, F, proxy_vertices=1200)
    assert prox.info["proxy_vertices"] > 0 and full.info["proxy_vertices"] == 0
    # charts matched by overlap: nearly every face lands in the corresponding chart (a chart
    # of ~1 % of the faces may merge into a neighbour at this coarse a proxy)
    C = np.zeros((prox.n_charts, full.n_charts))
    np.add.at(C, (prox.chart_ids, full.chart_ids), 1)
    assert C.max(axis=1).sum() / len(F) > 0.95 and C.max(axis=0).sum() / len(F) > 0.95
    assert abs(prox.n_charts - full.n_charts) <= 1
    # (the tiny model's maps are too distorted for a QCE comparison to mean much; the perf
    # script compares proxy and full inference of a trained model on large meshes)
    assert np.isfinite(qce(V, F, prox.uv, prox.uv_faces))


def test_pretrained_track_is_checked_not_declared(tmp_path):
    from dressmeup.methods.uvparam import get_method
    from dressmeup.methods.uvparam.neural.model import save_model
    from dressmeup.methods.uvparam.neural.train_set import train_on_set

    seen = make_test_mesh("blob-400")
    model = train_on_set([seen], [make_test_mesh("sphere-300")], "fast", eval_every=5,
                         **{**TINY, "uv_iters": 10, "patch_iters": 5})
    path = tmp_path / "m.pt"
    save_model(model, path)
    method = get_method("neural", checkpoint=path)
    assert method.parameterize(*make_test_mesh("sheet-300")).info["track"] == "pretrained"
    assert method.parameterize(*seen).info["track"] == "per-mesh"     # a training mesh
    assert get_method("lscm").parameterize(*seen).info.get("track", "per-mesh") == "per-mesh"


def test_shipped_pretrained_models_load_and_run_without_training():
    from dressmeup.errors import InputError
    from dressmeup.methods.uvparam import get_method
    from dressmeup.methods.uvparam.neural.method import PRETRAINED, pretrained_path

    for name in PRETRAINED:
        assert pretrained_path(name).stat().st_size < 5_000_000      # float16, ~3.5 MB
    V, F = make_test_mesh("sheet-300")
    res = get_method("neural", pretrained="category").parameterize(V, F, category="dress")
    assert res.info["model"] == "dress" and res.info["track"] == "pretrained"
    assert "seconds_train" not in res.info and np.all(np.isfinite(res.uv))
    with pytest.raises(InputError, match="pretrained"):
        get_method("neural", pretrained="hats")
