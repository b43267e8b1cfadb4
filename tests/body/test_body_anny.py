"""The default anny model: skin, skeleton, cache placement and equality with anny's own LBS.

The first run builds anny into the test cache (about 100 s on 2 cores); later runs load it
in a few seconds.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import torch

from dressmeup.body import SMPL22_JOINT_NAMES, get_body_model


@pytest.fixture(scope="module")
def model():
    return get_body_model("anny")


def test_cache_under_dressmeup_cache(model):
    root = Path(os.environ["DRESSMEUP_CACHE"]).resolve()
    assert Path(model.cache_path).resolve() == root / "anny"
    files = [p.name for p in Path(model.cache_path).rglob("*.safetensors")]
    assert any(f.startswith("build_compact_model_data_") for f in files)
    assert not any(f.startswith(("load_data_", "build_model_data_")) for f in files)  # pruned


def test_skin_and_skeleton(model):
    import trimesh

    assert model.joint_names == SMPL22_JOINT_NAMES
    assert model.n_vertices == 13348 and model.faces.max() == model.n_vertices - 1
    tm = trimesh.Trimesh(model.template_vertices, model.faces, process=False)
    assert tm.is_watertight and tm.volume > 0.03
    np.testing.assert_allclose(model.skinning_weights.sum(1), 1, atol=1e-9)
    J = model.template_joints
    names = list(SMPL22_JOINT_NAMES)
    # SMPL frame: y up, left on +x, feet pointing to +z.
    assert J[names.index("head"), 1] > J[names.index("pelvis"), 1] > J[names.index("left_knee"), 1]
    assert J[names.index("left_hip"), 0] > 0 > J[names.index("right_hip"), 0]
    assert J[names.index("left_foot"), 2] > J[names.index("left_ankle"), 2] + 0.05


def test_matches_anny_own_skinning(model):
    rng = np.random.default_rng(0)
    shape = rng.uniform(0, 1, (2, 6))
    pose = rng.normal(0, 0.35, (2, 22, 3))
    ours = model.forward(torch.tensor(shape), torch.tensor(pose))
    params = model.anny_pose(shape, pose, "local-ref")
    theirs = model.anny(pose_parameters=params, phenotype_kwargs=torch.tensor(shape),
                        pose_parameterization="local-ref")["vertices"]
    theirs = theirs[:, model.skin_vertex_ids].numpy() @ model._frame.T
    np.testing.assert_allclose(ours.vertices.numpy(), theirs, atol=1e-6)


def test_shape_gradients_and_height(model):
    shape = torch.full((1, 6), 0.5, dtype=torch.float64, requires_grad=True)
    pose = torch.zeros(1, 22, 3, dtype=torch.float64, requires_grad=True)
    out = model.forward(shape, pose)
    np.testing.assert_allclose(out.vertices.detach().numpy(), out.rest_vertices.detach().numpy(),
                               atol=1e-12)
    height = out.vertices[0, :, 1].max() - out.vertices[0, :, 1].min()
    height.backward()
    assert shape.grad[0, 4] > 0.1  # the height phenotype makes the body taller
    tall = model.default_params()
    tall.shape[4] = 1.0
    h_tall = np.ptp(model.posed(tall).vertices[:, 1])
    assert h_tall > float(height.detach()) + 0.05


@pytest.mark.parametrize("name", ["anny", "procedural"])
def test_rest_of_some_vertices_and_rest_extent_equal_the_whole_rest_body(name):
    """``rest_subset`` (anny blends only the rows asked for when the shape needs a gradient)
    and ``rest_extent`` (anny blends one coordinate) give the values and gradients of the
    whole rest body, bit for bit; ``forward(vertex_ids=...)`` uses the subset."""
    m = get_body_model(name)
    rng = np.random.default_rng(0)
    ids = torch.as_tensor(np.sort(rng.choice(m.n_vertices, 700, replace=False)))
    w = torch.as_tensor(rng.normal(size=(1, 700, 3)), dtype=torch.float32)
    for _ in range(3):
        z = rng.normal(0, 1.5, 6)
        grads = []
        for subset in (False, True):
            shape = torch.tensor(z, dtype=torch.float32, requires_grad=True)
            value = torch.sigmoid(shape)[None]
            V, J = m.rest_subset(value, ids) if subset else m.rest(value)
            V = V if subset else V[:, ids]
            (V * w).sum().backward()
            grads.append((V.detach(), J.detach(), shape.grad))
        for a, b in zip(*grads, strict=True):
            assert torch.equal(a, b)
    shapes = torch.as_tensor(rng.uniform(0, 1, (5, 6)))
    with torch.no_grad():
        V, _ = m.rest(shapes)
        extent = V[..., 1].max(1).values - V[..., 1].min(1).values
        assert torch.equal(m.rest_extent(shapes, 1), extent)
    out = m.forward(torch.sigmoid(torch.zeros(1, 6, requires_grad=True)), torch.zeros(1, 22, 3),
                    vertex_ids=ids)
    assert out.vertices.shape == out.rest_vertices.shape == (1, 700, 3)
