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

FAST = dict(preset="fast", verbose=False)


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


def test_canonical_poses_point_the_limbs():
    from dressmeup.body.registration.hypotheses import CANONICAL_POSES, canonical_pose

    model = get_body_model("procedural")
    rest = model.posed(model.default_params())
    names = list(model.joint_names)
    for name, spec in CANONICAL_POSES.items():
        params = model.default_params()
        params.pose = canonical_pose(name, names, rest.joints)
        J = model.posed(params).joints
        arm = J[names.index("left_elbow")] - J[names.index("left_shoulder")]
        want = np.asarray(spec["arm"], float)
        assert arm @ want / np.linalg.norm(arm) / np.linalg.norm(want) > 0.99, name
        if "thigh" in spec and not spec.get("pelvis"):  # untilted: the world direction
            right = {**spec, **spec.get("right", {})}
            for side, sx, limbs in (("left", 1.0, spec), ("right", -1.0, right)):
                thigh = J[names.index(f"{side}_knee")] - J[names.index(f"{side}_hip")]
                want = np.asarray(limbs["thigh"], float) * (sx, 1.0, 1.0)
                cos = thigh @ want / np.linalg.norm(thigh) / np.linalg.norm(want)
                assert cos > 0.99, (name, side)
    # an asymmetric pose: the stride's front leg is the left one in stride-left
    stride = canonical_pose("stride-left", names, rest.joints)
    assert stride[names.index("left_knee"), 0] > stride[names.index("right_knee"), 0] > 0
    with pytest.raises(ValueError, match="unknown pose"):
        canonical_pose("moonwalk", names, rest.joints)


def test_hypotheses_find_a_sitting_pose_the_rest_pose_start_misses(model):
    # thighs forward, knees bent: the old start (rest pose + yaw search) fits it standing
    from dressmeup.body.registration.hypotheses import canonical_pose

    rest = model.posed(model.default_params())
    pose = canonical_pose("sitting", model.joint_names, rest.joints)
    pose[0] = (0.0, 2.0, 0.0)  # facing away from the start
    truth = BodyParams("procedural", shape=np.full(6, 0.45), pose=pose, transl=[0.1, 0.0, 0.2])
    scan = synthetic_scan(model, truth, n_points=6000, noise=0.002, seed=3)
    res = register(scan, model, return_result=True, **FAST)
    v_err, j_err = vertex_joint_errors(model, res.params, truth)
    old = register(scan, model, hypotheses=(), **FAST)
    v_old, _ = vertex_joint_errors(model, old, truth)
    assert res.info["init"].startswith("hypothesis sitting")
    assert v_err < 0.025 and j_err < 0.03
    assert v_err < 0.5 * v_old


def test_fit_metrics_flag_a_body_outside_the_scan(model):
    from dressmeup.body.registration.metrics import (
        BODY_PARTS,
        fit_metrics,
        format_metrics,
        vertex_parts,
    )

    truth = _truth(model, "standing", 4)
    posed = model.posed(truth)
    scan = synthetic_scan(model, truth, n_points=20000, noise=0.0, seed=4)
    parts = vertex_parts(model)
    assert set(np.unique(parts)) <= set(range(len(BODY_PARTS)))
    good = fit_metrics(posed.vertices, model.faces, scan, parts)
    assert good["body_to_scan_mm"] < 6 and good["scan_to_body_mm"] < 3
    assert good["outside_share"] < 0.01 and good["max_part_outside_mm"] < 5
    # the right arm pushed 4 cm outwards: outside the scan, and only that part
    V = posed.vertices.copy()
    arm = np.isin(parts, [list(BODY_PARTS).index(p) for p in ("right_upper_arm", "right_forearm")])
    from dressmeup.geometry.mesh import vertex_normals

    V[arm] += 0.04 * vertex_normals(posed.vertices, model.faces)[arm]
    bad = fit_metrics(V, model.faces, scan, parts)
    assert bad["max_part_outside_mm"] > 25 and bad["outside_share"] > 0.02
    worst = max(bad["parts"], key=lambda p: bad["parts"][p]["outside_p90_mm"])
    assert worst in ("right_upper_arm", "right_forearm")
    assert bad["parts"]["left_forearm"]["outside_p90_mm"] < 5
    assert "<- check" in format_metrics(bad) and "mm" in format_metrics(good)


def test_registration_poses_and_scan_variants(model):
    from dressmeup.data.synth.poses import pose_axis_angle, pose_names

    generator = pose_names()
    assert generator[:3] == ["arms-down", "a-pose", "arms-raised"] and len(generator) == 10
    hard = pose_names("registration")
    assert {"t-pose", "wide-stance", "sitting-box", "arms-crossed", "one-knee-up",
            "bending-forward"} <= set(hard) and not set(hard) & set(generator)
    tuning = pose_names("registration-tuning")
    assert tuning == ["bowing", "picking-up", "stepping-up", "lunge", "marching", "leaning-over",
                      "half-squat-reach"]
    assert pose_names("all") == generator + hard + tuning

    class Frame:
        up, left, forward = np.eye(3)[1], np.eye(3)[0], np.eye(3)[2]
        joints: dict = {}

    for name in hard + tuning:
        assert np.isfinite(pose_axis_angle(name, model.joint_names, Frame)).all()
    truth = _truth(model, "sitting", 6)
    full = synthetic_scan(model, truth, n_points=6000, noise=0.0, seed=6)
    side = synthetic_scan(model, truth, n_points=6000, noise=0.0, seed=6, missing_side=(1, 0, 0))
    assert 0.5 * len(full) < len(side) < 0.9 * len(full)
    boxed = synthetic_scan(model, truth, n_points=6000, noise=0.0, seed=6, seat_box=True)
    extra = boxed[len(full):]
    assert len(extra) > 100 and extra[:, 1].min() >= model.posed(truth).vertices[:, 1].min() - 1e-9


def test_scale_into_shape_keeps_the_body_and_drops_the_scale(model):
    """The temporary size scale becomes shape: the unscaled rest body of the new shape is
    the scaled rest body of the old one (height within 2 %), the posed body stays where it
    was, and with scale 1 nothing happens."""
    truth = _truth(model, "standing", 7)
    P = synthetic_scan(model, truth, n_points=2000, seed=7)
    prob = _problem(model, P)
    prob.set_params(shape=np.full(6, 0.5), pose=truth.pose, transl=[0.1, 0.2, 0.3])
    assert prob.scale_into_shape() == 0.0
    assert float(prob.log_scale.detach()) == 0.0 and np.allclose(prob.shape_value().detach(), 0.5)

    prob.set_params(scale=1.08)
    centroid = prob.posed_numpy()[prob.body_ids].mean(0)
    rms = prob.scale_into_shape()
    assert float(prob.log_scale.detach()) == 0.0
    assert np.allclose(prob.posed_numpy()[prob.body_ids].mean(0), centroid, atol=1e-5)
    new = model.posed(BodyParams("procedural", shape=prob.shape_value().detach().numpy(),
                                 pose=np.zeros((22, 3)))).vertices
    old = model.posed(BodyParams("procedural", shape=np.full(6, 0.5),
                                 pose=np.zeros((22, 3)))).vertices
    assert np.ptp(new[:, 1]) == pytest.approx(1.08 * np.ptp(old[:, 1]), rel=0.02)
    assert rms < 0.01  # metres: the phenotype can make this size


def _problem(model, P, **settings):
    from dressmeup.body.registration.config import get_config
    from dressmeup.body.registration.problem import FitProblem

    return FitProblem.from_config(get_config(n_body_points=1500, **settings), model, P)


def test_steps_that_hold_the_shape_give_the_same_loss_and_pose_gradients(model):
    """A step that does not move the shape feeds it to the body model without a gradient
    (so a cached rest body is reused): the loss and the gradients of the parameters that
    move are bit for bit those of the full graph. ``run_adam`` holds the shape exactly when
    it is not among the tensors it moves."""
    import torch

    from dressmeup.body.registration.problem import Objective
    from dressmeup.body.registration.stages import run_adam

    truth = _truth(model, "standing", 8)
    P = synthetic_scan(model, truth, n_points=2000, seed=8)
    prob = _problem(model, P)
    prob.set_params(shape=np.full(6, 0.4), pose=0.9 * truth.pose, transl=truth.transl + 0.01)
    pose = Objective("pose")

    def loss_and_grads(hold: bool):
        for t in (prob.shape_z, prob.pose, prob.transl):
            t.grad = None
        loss, _ = prob.loss(pose, hold_shape=hold)
        loss.backward()
        return (loss.detach().clone(), prob.pose.grad.clone(), prob.transl.grad.clone(),
                prob.shape_z.grad)

    full, held = loss_and_grads(False), loss_and_grads(True)
    assert full[3] is not None and torch.any(full[3] != 0) and held[3] is None
    for a, b in zip(full[:3], held[:3], strict=True):
        assert torch.equal(a, b)
    shape = prob.shape_z.detach().clone()
    run_adam(prob, pose, 3, [prob.pose, prob.transl], [0.01, 0.01])
    assert torch.equal(prob.shape_z, shape) and prob.shape_z.grad is None
    run_adam(prob, Objective("shape"), 2, [prob.pose, prob.shape_z], [0.01, 0.01])
    assert not torch.equal(prob.shape_z, shape)
