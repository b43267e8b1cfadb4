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


def test_transfer_rejects_a_closest_surface_facing_away():
    """A garment point on a torso under a resting arm: the arm is nearer, but faces the
    other way, so with normals the torso's weights win."""
    import numpy as np

    from dressmeup.body.skinning import transfer_weights

    g = np.linspace(-0.1, 0.1, 6)
    xx, yy = np.meshgrid(g, g)
    grid = np.c_[xx.ravel(), yy.ravel()]
    quads = [(i * 6 + j, i * 6 + j + 1, (i + 1) * 6 + j + 1, (i + 1) * 6 + j)
             for i in range(5) for j in range(5)]
    up = np.array([[a, b, c] for a, b, c, d in quads] + [[a, c, d] for a, b, c, d in quads])
    torso = np.c_[grid, np.zeros(36)]                  # faces +z
    arm = np.c_[grid, np.full(36, 0.02)]               # faces -z (flipped winding), above it
    V = np.vstack([torso, arm])
    F = np.vstack([up, up[:, ::-1] + 36])
    W = np.zeros((72, 2))
    W[:36, 0] = 1.0
    W[36:, 1] = 1.0
    pts = np.array([[0.01, 0.02, 0.012], [-0.03, 0.0, 0.013],    # nearer to the arm
                    [0.0, 0.0, 0.003], [0.05, 0.05, 0.004], [-0.05, 0.02, 0.002]])
    nrm = np.tile([0.0, 0.0, 1.0], (5, 1))                      # garment outside the torso
    plain = transfer_weights(V, F, W, pts)
    checked = transfer_weights(V, F, W, pts, point_normals=nrm)
    np.testing.assert_allclose(plain, [[0, 1], [0, 1], [1, 0], [1, 0], [1, 0]])
    np.testing.assert_allclose(checked, [[1, 0]] * 5)
    # inward-oriented garment normals are flipped by the majority rule: same answer
    np.testing.assert_allclose(transfer_weights(V, F, W, pts, point_normals=-nrm), checked)


def test_facing_away_test_does_not_depend_on_which_face_wins_a_tie():
    """A garment point over a ridge is (almost) equally close to both roof faces; which face
    the closest-point query reports flips with the last bits of the body or the point. The
    facing test must not flip with it: with face normals, the point 1 nm on the -y side was
    judged 'facing away' from the -y face and its weights re-assigned (0.5/0.5 -> one
    vertex's), 1 nm on the +y side it was not."""
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, -1.0], [0.5, -1.0, -1.0]])
    F = np.array([[0, 1, 2], [1, 0, 3]])  # a roof, ridge along x at z = 0, normals up
    W = np.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5], [0.5, 0.5]])
    normals = np.array([[0.0, 1.0, 0.2], [0.0, 1.0, 1.0], [0.0, 1.0, 1.0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    out = []
    for side in (-1e-9, 1e-9):  # the point over the ridge leans towards the +y slope
        points = np.array([[0.5, side, 0.1], [0.5, 0.5, -0.3], [0.3, 0.4, -0.2]])
        out.append(transfer_weights(V, F, W, points, point_normals=normals)[0])
    np.testing.assert_allclose(out[0], out[1], atol=1e-6)
    np.testing.assert_allclose(out[0], [0.5, 0.5], atol=1e-6)
