"""Keypoints from scans: robust triangulation, the mediapipe route and its fallback."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.registration import keypoints as kp
from dressmeup.body.registration import register
from dressmeup.errors import InputError

NAMES = ("pelvis", "left_hip", "right_hip", "left_knee", "right_knee", "left_shoulder",
         "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
         "left_ankle", "right_ankle")


def test_triangulation_survives_swaps_outliers_and_misses():
    rng = np.random.default_rng(0)
    body = rng.uniform(-0.3, 0.3, (200, 3)) * (1, 3, 1)
    cams = kp.ring_cameras(body, n_views=8)
    truth = {n: rng.uniform(-0.25, 0.25, 3) * (1, 3, 1) for n in NAMES}
    dets = []
    for v, cam in enumerate(cams):
        det = {}
        for name in kp.MEDIAPIPE_TO_SMPL.values():
            uv, _ = cam.project(truth[name][None])
            det[name] = (*(uv[0] + rng.normal(0, 1.0, 2)), 0.9)
        if v in (3, 4):  # back views: left and right swapped
            for name in list(det):
                if name.startswith("left_"):
                    other = name.replace("left_", "right_")
                    det[name], det[other] = det[other], det[name]
        if v == 5:  # a wild detection
            det["left_knee"] = (5.0, 5.0, 0.95)
        if v == 6:  # an occluded joint
            det["right_wrist"] = (det["right_wrist"][0], det["right_wrist"][1], 0.05)
        dets.append(det)
    dets.append(None)  # a view with no person
    J, inliers = kp.triangulate(dets, cams + [cams[0]], NAMES)
    for name in kp.MEDIAPIPE_TO_SMPL.values():
        err = np.linalg.norm(J[NAMES.index(name)] - truth[name])
        assert err < 0.01, (name, err)
    assert np.isnan(J[NAMES.index("pelvis")]).all()  # never detected
    assert inliers["left_knee"] == 7 and inliers["right_wrist"] == 7


def test_without_the_extra_auto_falls_back_and_keypoints_route_says_why(monkeypatch):
    monkeypatch.setitem(sys.modules, "mediapipe", None)  # import fails as if not installed
    assert not kp.keypoints_available()
    model = get_body_model("procedural")
    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=np.zeros((22, 3)))
    scan = model.posed(truth).vertices
    tiny = dict(iterations=(2, 2, 2), hypothesis_steps=(1, 1, 1), hypotheses=("t-pose",),
                n_scan_points=500, n_body_points=300, verbose=False)
    res = register(scan, model, init_route="auto", return_result=True, **tiny)
    assert res.info["init"].startswith("hypothesis")
    with pytest.raises(InputError, match=r"\[keypoints\] extra"):
        register(scan, model, init_route="keypoints", **tiny)
    with pytest.raises(ImportError, match=r"\[keypoints\] extra"):
        kp.detect_2d([np.zeros((8, 8, 3), np.uint8)])
    with pytest.raises(InputError, match="init_route"):
        register(scan, model, init_route="psychic", **tiny)


def test_renders_frame_the_scan():
    model = get_body_model("procedural")
    V = model.posed(model.default_params()).vertices
    cams = kp.ring_cameras(V, n_views=4)
    for img in kp.render_views(V, cams) + kp.render_views((V, model.faces), cams[:1]):
        body = (img != 40).any(2)
        rows, cols = np.flatnonzero(body.any(1)), np.flatnonzero(body.any(0))
        # about half the frame or more (the camera keeps the nearest arm in the frame too),
        # nothing cut at the borders
        fill = max((np.ptp(rows) + 1) / img.shape[0], (np.ptp(cols) + 1) / img.shape[1])
        assert fill > 0.45
        assert rows.min() > 0 and rows.max() < img.shape[0] - 1
        assert cols.min() > 0 and cols.max() < img.shape[1] - 1


def test_mediapipe_finds_the_joints_of_a_rendered_anny_mesh():
    # the extra for real (CI installs it): 6 ray-cast views of an anny mesh
    pytest.importorskip("mediapipe")
    model = get_body_model("anny")
    params = model.default_params()
    params.pose[0] = (0.0, 0.8, 0.0)  # not facing a camera
    posed = model.posed(params)
    found = kp.detect_keypoints((posed.vertices, model.faces), model, n_views=6)
    ok = np.isfinite(found.joints[:, 0])
    assert found.detections >= 4 and ok.sum() >= 8
    err = np.linalg.norm(found.joints[ok] - posed.joints[ok], axis=1)
    assert np.median(err) < 0.06  # metres: landmarks sit a few cm from the joints


@pytest.mark.slow
def test_mediapipe_keypoints_on_an_anny_scan():
    pytest.importorskip("mediapipe")
    from dressmeup.body.synthetic import synthetic_scan
    from dressmeup.data.synth.garments import BodyFrame
    from dressmeup.data.synth.poses import pose_axis_angle

    model = get_body_model("anny")
    rest = model.posed(model.default_params())
    pose = pose_axis_angle("wide-stance", model.joint_names,
                           BodyFrame.from_joints(rest.joints, model.joint_names))
    pose[0] = (0.0, 2.5, 0.0)
    truth = BodyParams("anny", shape=np.full(6, 0.5), pose=pose)
    scan = synthetic_scan(model, truth, n_points=30000, seed=0)
    found = kp.detect_keypoints(scan, model)
    ok = np.isfinite(found.joints[:, 0])
    assert found.detections >= 6 and ok.sum() >= 10
    err = np.linalg.norm(found.joints[ok] - model.posed(truth).joints[ok], axis=1)
    assert np.median(err) < 0.06  # landmarks sit a few cm from the skeleton's joints
