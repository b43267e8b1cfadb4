"""The procedural test body: closed skin, skeleton, shape behaviour and LBS forward."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from dressmeup.body import SMPL22_JOINT_NAMES, BodyParams, get_body_model
from dressmeup.errors import InputError


@pytest.fixture(scope="module")
def model():
    return get_body_model("procedural")


def _volume(V, F):
    return np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6


def test_closed_single_component_skin(model):
    import trimesh

    tm = trimesh.Trimesh(model.template_vertices, model.faces, process=False)
    assert 2000 <= model.n_vertices <= 9000
    assert tm.is_watertight and tm.is_winding_consistent
    assert len(tm.split(only_watertight=False)) == 1
    assert _volume(model.template_vertices, model.faces) > 0.03  # outward, human-sized (m^3)


def test_skeleton_and_weights(model):
    assert model.joint_names == SMPL22_JOINT_NAMES
    assert model.joint_parents[0] == -1
    assert all(model.joint_parents[k] < k for k in range(1, 22))
    W = model.skinning_weights
    assert W.shape == (model.n_vertices, 22)
    np.testing.assert_allclose(W.sum(1), 1.0, atol=1e-9)
    assert W.min() >= 0
    # Every joint drives some skin, and blending is smooth (many vertices share >1 joint).
    assert (W.max(0) > 0.4).all()
    assert ((W > 0.05).sum(1) > 1).mean() > 0.2


def test_zero_pose_is_rest_and_convention(model):
    shape = np.array([0.3, 0.6, 0.5, 0.7, 0.4, 0.5])
    out = model.forward(shape, np.zeros((22, 3)), transl=[[0.1, -0.2, 0.3]], scale=[1.5])
    rest = out.rest_vertices[0].numpy()
    np.testing.assert_allclose(out.vertices[0].numpy(), 1.5 * rest + [0.1, -0.2, 0.3], atol=1e-5)
    np.testing.assert_allclose(out.transforms[0].numpy(), np.broadcast_to(np.eye(4), (22, 4, 4)),
                               atol=1e-6)


def test_shape_changes_height_and_girth(model):
    base = model.posed(model.default_params())
    h0 = np.ptp(base.vertices[:, 1])
    assert 1.6 < h0 < 1.95
    tall = model.default_params()
    tall.shape[4] = 1.0
    h1 = np.ptp(model.posed(tall).vertices[:, 1])
    np.testing.assert_allclose(h1 / h0, 1.15, rtol=0.02)  # height: +-15 % scale
    heavy = model.default_params()
    heavy.shape[3] = 1.0
    assert _volume(model.posed(heavy).vertices, model.faces) > 1.3 * _volume(base.vertices, model.faces)
    # Heavier body: same skeleton.
    np.testing.assert_allclose(model.posed(heavy).joints, base.joints, atol=1e-9)


def _slow_lbs(model, shape, pose):
    """Reference: per-joint global transforms by explicit recursion with scipy rotations."""
    V = model.template_vertices + np.einsum("s,snk->nk", shape - 0.5, model.shape_dirs)
    J = model.template_joints + np.einsum("s,sjk->jk", shape - 0.5, model.joint_shape_dirs)
    G = []
    for k, p in enumerate(model.joint_parents):
        L = np.eye(4)
        L[:3, :3] = Rotation.from_rotvec(pose[k]).as_matrix()
        L[:3, 3] = J[k] - (J[p] if p >= 0 else 0)
        G.append(L if p < 0 else G[p] @ L)
    out = np.zeros_like(V)
    for i in range(V.shape[0]):
        M = sum(model.skinning_weights[i, k] * G[k] @ np.block([[np.eye(3), -J[k][:, None]],
                                                                 [np.zeros((1, 3)), 1]])
                for k in range(22))
        out[i] = M[:3, :3] @ V[i] + M[:3, 3]
    return out, np.array([g[:3, 3] for g in G])


def test_forward_matches_slow_reference(model):
    rng = np.random.default_rng(0)
    shape = rng.uniform(0, 1, 6)
    pose = rng.normal(0, 0.4, (22, 3))
    params = BodyParams("procedural", shape=shape, pose=pose, transl=[0, 0.1, 0], scale=1.1)
    out = model.posed(params)
    ref_v, ref_j = _slow_lbs(model, shape, pose)
    np.testing.assert_allclose(out.vertices, 1.1 * ref_v + [0, 0.1, 0], atol=1e-9)
    np.testing.assert_allclose(out.joints, 1.1 * ref_j + [0, 0.1, 0], atol=1e-9)


def test_batched_equals_single_and_gradients(model):
    rng = np.random.default_rng(1)
    shape = torch.tensor(rng.uniform(0, 1, (3, 6)), requires_grad=True)
    pose = torch.tensor(rng.normal(0, 0.3, (3, 22, 3)), requires_grad=True)
    out = model.forward(shape, pose)
    assert out.vertices.dtype == torch.float64 and out.vertices.shape == (3, model.n_vertices, 3)
    single = model.forward(shape[1:2], pose[1:2])
    torch.testing.assert_close(out.vertices[1], single.vertices[0])
    out.vertices.square().sum().backward()
    assert shape.grad.abs().sum() > 0 and pose.grad.abs().sum() > 0
    assert torch.isfinite(pose.grad).all()


def test_bad_inputs_name_the_argument(model):
    with pytest.raises(InputError, match="pose"):
        model.forward(np.full(6, 0.5), np.zeros((21, 3)))
    with pytest.raises(InputError, match="shape"):
        model.forward(np.full(7, 0.5), np.zeros((22, 3)))
    with pytest.raises(InputError, match="model"):
        model.posed(BodyParams("anny", shape=np.full(6, 0.5), pose=np.zeros((22, 3))))


def test_skin_is_kept_on_each_model_instance():
    from dressmeup.body.procedural import ProceduralBody
    from dressmeup.geometry.topology import largest_component

    a, b = ProceduralBody(), ProceduralBody()
    ids, faces = a.skin()
    assert a.skin()[0] is ids and a.skin()[1] is faces  # computed once per instance
    want_ids, want_faces = largest_component(a.faces, a.n_vertices, by="vertices")
    np.testing.assert_array_equal(ids, want_ids)
    np.testing.assert_array_equal(faces, want_faces)
    # another instance has its own skin: a different mesh gets a different answer (the old
    # memo keyed by id() could hand a new model an old model's skin)
    b.faces = b.faces[: len(b.faces) // 2]
    assert b.skin()[1].shape[0] < faces.shape[0]
    assert a.skin()[1] is faces
