"""``simulate``: generator 4's dynamics from the source body to the target."""

from __future__ import annotations

import numpy as np


def test_path_goes_from_source_to_target_in_the_given_frames():
    from dressmeup.body import BodyParams
    from dressmeup.methods.retarget import get_method

    src = BodyParams(model="procedural", shape=np.zeros(6), pose=np.zeros((22, 3)))
    tgt = BodyParams(model="procedural", shape=np.full(6, 0.5), pose=np.full((22, 3), 0.2),
                     transl=np.array([0.0, 0.1, 0.0]))
    m = get_method("simulate", shape_frames=4, pose_frames=6, settle_frames=3)
    path = m.path(src, tgt)
    assert len(path) == 1 + 4 + 6 + 3
    assert path[0] is src and path[-1] is tgt
    # shape first (pose held at the source's), then the pose and translation
    assert np.allclose(path[4].shape, tgt.shape) and np.allclose(path[4].pose, src.pose)
    assert np.allclose(path[10].pose, tgt.pose) and np.allclose(path[10].transl, tgt.transl)
    mid = path[7]
    assert 0.0 < mid.pose[0, 0] < 0.2 and 0.0 < mid.transl[1] < 0.1


def test_simulated_garment_is_free_of_the_target_body(tiny_retarget_data):
    from dressmeup.body import get_body_model
    from dressmeup.data import Dataset
    from dressmeup.data.synth.dynamics import ClothDynamics
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.base import body_context

    pair = next(p for p in Dataset(tiny_retarget_data).retarget_pairs("test")
                if p.track == "cross")
    g = pair.source.garment()
    V, F = np.asarray(g.vertices, np.float64), np.asarray(g.faces, np.int64)
    model = get_body_model("procedural")
    out = get_method("simulate", shape_frames=6, pose_frames=12, settle_frames=3).retarget(
        V, F, pair.source.body(), pair.target.body(), model)
    assert out.shape == V.shape and np.isfinite(out).all()
    target = body_context(model, pair.target.body())
    up = np.array([0.0, 1.0, 0.0])
    dyn = ClothDynamics(V, F, target.skin_faces, up)
    assert dyn.intersection_free(out, target.skin_vertices)
    # it moved with the body: closer to the true target garment than the unchanged source
    gt = np.asarray(pair.target.garment().vertices, np.float64)
    assert np.mean(np.linalg.norm(out - gt, axis=1)) < np.mean(np.linalg.norm(V - gt, axis=1))
