"""Registration on synthetic scans of the procedural body with known parameters."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.registration import (
    add_registrar,
    available_registrars,
    get_registrar,
    prepare_scan,
    register,
)
from dressmeup.body.synthetic import named_pose, synthetic_scan, vertex_joint_errors
from dressmeup.errors import InputError

FAST = dict(iterations=(30, 120, 120), n_scan_points=2500, n_body_points=1500, verbose=False)


@pytest.fixture(scope="module")
def model():
    return get_body_model("procedural")


def _truth(model, pose_name, seed):
    rng = np.random.default_rng(seed)
    return BodyParams("procedural", shape=rng.uniform(0.3, 0.7, 6),
                      pose=named_pose(pose_name, yaw=rng.uniform(-0.3, 0.3)),
                      transl=rng.normal(0, 0.2, 3))


def test_naked_scan_with_holes(model):
    truth = _truth(model, "standing", 0)
    scan = synthetic_scan(model, truth, n_points=8000, noise=0.002, n_holes=3, seed=0)
    start = BodyParams("procedural", shape=np.full(6, 0.5), pose=np.zeros((22, 3)),
                       transl=truth.transl)
    res = register(scan, model, return_result=True, **FAST)
    v_err, j_err = vertex_joint_errors(model, res.params, truth)
    v0, _ = vertex_joint_errors(model, start, truth)
    assert v_err < 0.025 and j_err < 0.025  # metres
    assert v_err < 0.4 * v0
    assert set(res.losses) >= {"global_data", "pose_data", "shape_data"}


def test_keypoints_fix_a_hard_pose(model):
    truth = _truth(model, "sitting", 1)
    scan = synthetic_scan(model, truth, n_points=8000, noise=0.002, seed=1)
    kp = model.posed(truth).joints
    kp[[20, 21]] = np.nan  # a missing joint is simply left out
    fit = register(scan, model, keypoints=kp, **FAST)
    v_err, j_err = vertex_joint_errors(model, fit, truth)
    assert v_err < 0.03 and j_err < 0.03
    as_dict = {"pelvis": kp[0], "left_knee": kp[4]}
    with pytest.raises(InputError, match="unknown joint"):
        register(scan, model, keypoints={"nose": [0, 0, 0]}, **FAST)
    assert register(scan, model, keypoints=as_dict, iterations=(1, 1, 1), n_scan_points=500,
                    n_body_points=500, verbose=False).pose.shape == (22, 3)


def test_from_file_registrar_and_registry(model, tmp_path):
    truth = _truth(model, "walking", 2)
    path = truth.save(tmp_path / "fit.npz")
    got = register(np.zeros((20, 3)), model, registrar="from-file", path=path)
    np.testing.assert_array_equal(got.pose, truth.pose)
    assert {"optimization", "from-file"} <= set(available_registrars())

    class Constant:
        def fit(self, scan, model, init=None, keypoints=None):
            return truth

    add_registrar("constant", Constant)
    assert register(np.zeros((20, 3)), model, registrar="constant") is truth
    with pytest.raises(ValueError, match="known"):
        get_registrar("nope")


def test_scan_validation(model):
    with pytest.raises(InputError, match="scan"):
        prepare_scan(np.zeros((5, 2)))
    with pytest.raises(InputError, match="scan faces"):
        prepare_scan((np.zeros((4, 3)), np.array([[0, 1, 9]])))
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    pts = prepare_scan((V, np.array([[0, 1, 2]])), n_points=100)
    assert pts.shape == (100, 3) and np.all(pts[:, 2] == 0) and np.all(pts.sum(1) <= 1 + 1e-9)
