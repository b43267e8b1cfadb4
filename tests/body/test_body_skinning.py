"""Skinning helpers: weight transfer, LBS and its inverse, rotation conversions."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from dressmeup.body import get_body_model
from dressmeup.body.lbs import axis_angle_to_matrix, matrix_to_axis_angle
from dressmeup.body.skinning import lbs, transfer_weights, unpose


@pytest.fixture(scope="module")
def model():
    return get_body_model("procedural")


def test_rodrigues_matches_scipy():
    rng = np.random.default_rng(0)
    aa = rng.normal(0, 1.2, (50, 3))
    aa[0] = 0
    R = axis_angle_to_matrix(torch.tensor(aa)).numpy()
    np.testing.assert_allclose(R, Rotation.from_rotvec(aa).as_matrix(), atol=1e-10)
    back = matrix_to_axis_angle(torch.tensor(R)).numpy()
    np.testing.assert_allclose(Rotation.from_rotvec(back).as_matrix(), R, atol=1e-7)


def test_transfer_on_own_vertices_is_identity(model):
    W = transfer_weights(model.template_vertices, model.faces, model.skinning_weights,
                         model.template_vertices)
    np.testing.assert_allclose(W, model.skinning_weights, atol=1e-6)


def test_transfer_barycentric_blend():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    F = np.array([[0, 1, 2]])
    W = np.eye(3)
    # A point above the triangle at barycentric (0.2, 0.3, 0.5).
    p = 0.2 * V[0] + 0.3 * V[1] + 0.5 * V[2] + [0, 0, 0.4]
    np.testing.assert_allclose(transfer_weights(V, F, W, p[None]), [[0.2, 0.3, 0.5]], atol=1e-9)
    # Outside the triangle: clamps to the closest edge point (midpoint of edge 1-2).
    q = np.array([[1.0, 1.0, 0.0]])
    np.testing.assert_allclose(transfer_weights(V, F, W, q), [[0, 0.5, 0.5]], atol=1e-9)


def test_transfer_smoothing_keeps_partition_of_unity(model):
    import trimesh

    shell = trimesh.Trimesh(model.template_vertices + 0.02 * trimesh.Trimesh(
        model.template_vertices, model.faces, process=False).vertex_normals, model.faces,
        process=False)
    raw = transfer_weights(model.template_vertices, model.faces, model.skinning_weights,
                           shell.vertices)
    smooth = transfer_weights(model.template_vertices, model.faces, model.skinning_weights,
                              shell.vertices, faces=shell.faces, smooth_iterations=5)
    np.testing.assert_allclose(smooth.sum(1), 1, atol=1e-9)
    # Smoothing reduces the weight differences across mesh edges.
    e = shell.edges_unique
    assert (np.abs(smooth[e[:, 0]] - smooth[e[:, 1]]).sum()
            < np.abs(raw[e[:, 0]] - raw[e[:, 1]]).sum())
    assert np.abs(raw - model.skinning_weights).sum(1).mean() < 0.1


def test_lbs_reproduces_model_and_unpose_inverts(model):
    rng = np.random.default_rng(3)
    params = model.default_params()
    params.pose = rng.normal(0, 0.4, (22, 3))
    out = model.posed(params)
    posed = lbs(out.rest_vertices, model.skinning_weights, out.transforms)
    np.testing.assert_allclose(posed, out.vertices, atol=1e-9)
    back = unpose(posed, model.skinning_weights, out.transforms)
    np.testing.assert_allclose(back, out.rest_vertices, atol=1e-9)


def test_bad_shapes_raise():
    with pytest.raises(ValueError, match="transforms"):
        lbs(np.zeros((4, 3)), np.full((4, 2), 0.5), np.zeros((3, 4, 4)))
    with pytest.raises(ValueError, match="points"):
        transfer_weights(np.zeros((3, 3)), np.array([[0, 1, 2]]), np.eye(3), np.zeros((2, 2)))
