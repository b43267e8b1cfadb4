"""Scans with another up axis: the frame turn, the upright check, parameters turned back."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.registration import register
from dressmeup.body.registration.scan import (
    UP_ROTATIONS,
    check_upright,
    rotate_keypoints,
    rotate_scan,
    up_rotation,
)
from dressmeup.body.registration.support import find_supports
from dressmeup.body.rigid import rotate_params
from dressmeup.body.synthetic import named_pose, synthetic_scan
from dressmeup.errors import InputError

FAST = dict(iterations=(20, 60, 40), n_scan_points=2000, n_body_points=1200, verbose=False,
            hypotheses=("a-pose", "sitting"), hypothesis_steps=(8, 6, 10), hypothesis_keep=1,
            yaw_candidates=4, hypothesis_yaws=1, limb_search=False, shape_search=False)


@pytest.fixture(scope="module")
def model():
    return get_body_model("procedural")


def _body(pose="walking", yaw=0.4):
    return BodyParams("procedural", shape=np.array([0.3, 0.7, 0.45, 0.6, 0.5, 0.35]),
                      pose=named_pose(pose, yaw=yaw), transl=[0.2, -0.1, 0.3], scale=1.07)


def test_rotate_params_turns_the_posed_body_rigidly(model):
    """Vertices and joints of the turned parameters are the turned vertices and joints
    (root rotation about the shaped rest root joint, scale about the origin)."""
    body = _body()
    body.pose[5] = (0.3, -0.2, 0.1)  # a knee-like bend: only the root may change
    before = model.posed(body)
    for R in (Rotation.from_rotvec([0.3, -1.2, 0.7]).as_matrix(), up_rotation("z")):
        turned = rotate_params(body, model, R)
        after = model.posed(turned)
        np.testing.assert_allclose(after.vertices, before.vertices @ R.T, atol=1e-9)
        np.testing.assert_allclose(after.joints, before.joints @ R.T, atol=1e-9)
        np.testing.assert_array_equal(turned.pose[1:], body.pose[1:])
        assert turned.scale == body.scale and np.array_equal(turned.shape, body.shape)
    with pytest.raises(ValueError, match="rotation"):
        rotate_params(body, model, np.diag([1.0, 1.0, -1.0]))  # a mirror


def test_up_rotations_take_each_axis_to_y():
    for name, R in UP_ROTATIONS.items():
        axis = np.zeros(3)
        axis["xyz".index(name[-1])] = -1.0 if name.startswith("-") else 1.0
        np.testing.assert_allclose(R @ axis, [0.0, 1.0, 0.0], atol=1e-15)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
        assert np.isclose(np.linalg.det(R), 1.0)
    with pytest.raises(InputError, match="up: expected one of"):
        up_rotation("up")


def test_scan_and_keypoints_turn_with_their_kind():
    R = up_rotation("-x")
    V, F = np.eye(3), np.array([[0, 1, 2]])
    V2, F2 = rotate_scan((V, F), R)
    np.testing.assert_allclose(V2, V @ R.T)
    assert F2 is not None and np.array_equal(F2, F)
    np.testing.assert_allclose(rotate_scan(V, R), V @ R.T)
    kp = rotate_keypoints({"pelvis": [-1.0, 0.0, 0.0]}, R)  # -x is up
    np.testing.assert_allclose(kp["pelvis"], [0.0, 1.0, 0.0], atol=1e-15)
    arr = rotate_keypoints(np.array([[np.nan] * 3, [-1.0, 0.0, 0.0]]), R)
    assert np.isnan(arr[0]).all() and np.allclose(arr[1], [0.0, 1.0, 0.0])
    assert rotate_keypoints(None, R) is None


@pytest.mark.parametrize("pose", ["standing", "walking", "sitting", "arms_raised"])
def test_upright_check_passes_upright_bodies_and_refuses_lying_ones(model, pose):
    body = BodyParams("procedural", shape=np.full(6, 0.5), pose=named_pose(pose))
    V = model.posed(body).vertices
    check_upright(V)  # y up: accepted
    with pytest.raises(InputError, match=r"--up z"):
        check_upright(V @ up_rotation("z"))  # the body's up (+y) on +z: a z-up scan


def test_support_plane_turned_holds_the_turned_points():
    rng = np.random.default_rng(0)
    floor = np.c_[rng.uniform(-0.5, 0.5, 6000), rng.normal(0, 0.001, 6000),
                  rng.uniform(-0.5, 0.5, 6000)]
    ball = rng.normal(size=(2000, 3))
    ball = 0.15 * ball / np.linalg.norm(ball, axis=1, keepdims=True) + (0.0, 0.4, 0.0)
    P = np.vstack([floor, ball])
    (plane,) = find_supports(P, seed=0)
    R = Rotation.from_rotvec([0.4, 0.9, -0.3]).as_matrix()
    on = plane.contains(P)
    assert on[:6000].mean() > 0.99 and not on[6000:].any()
    np.testing.assert_array_equal(plane.rotated(R).contains(P @ R.T), on)


def test_a_z_up_scan_fits_like_the_y_up_one(model):
    """The fit of a z-up scan with ``up="z"`` is the y-up scan's fit, turned into the scan's
    frame; without ``up`` the scan is refused, naming the option."""
    truth = _body("standing", yaw=0.3)
    P = synthetic_scan(model, truth, n_points=6000, noise=0.002, seed=0)
    R = up_rotation("z")
    P_z = P @ R  # z-up: R maps it back to y-up
    upright = register(P, model, **FAST)
    turned = register(P_z, model, up="z", **FAST)
    np.testing.assert_allclose(model.posed(turned).vertices,
                               model.posed(upright).vertices @ R, atol=1e-4)
    with pytest.raises(InputError, match="does not look upright"):
        register(P_z, model, **FAST)
