"""Rig files: validation of intrinsics/extrinsics, ring geometry, calibration drift."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from dressmeup.capture.camera import check_rigid
from dressmeup.capture.rig import Rig, load_rig, look_at, perturb_rig, ring_rig, save_rig
from dressmeup.errors import InputError


def test_ring_rig_cameras_look_at_target_with_image_up_along_world_up():
    rig = ring_rig(7)
    assert len(rig.cameras) == 7 and rig.reference == "cam0"
    for cam in rig.cameras:
        uv, z = cam.project(rig.target[None])
        np.testing.assert_allclose(uv[0], [cam.cx, cam.cy], atol=1e-6)
        assert z[0] > 2.0
        # a point above the target appears higher in the image (smaller row)
        uv_up, _ = cam.project((rig.target + 0.5 * rig.up)[None])
        assert uv_up[0, 1] < cam.cy
        check_rigid(cam.camera_to_world)
    # horizontal field of view of 75 degrees at 640 px
    assert math.isclose(rig.cameras[0].fx, 320 / math.tan(math.radians(37.5)), rel_tol=1e-9)


def test_rig_json_round_trip(tmp_path):
    rig = ring_rig(3, distortion=[0.1, -0.05, 0.001, 0.002, 0.01, 0, 0, 0])
    p = save_rig(rig, tmp_path / "rig.json")
    back = load_rig(p)
    assert back.serials == rig.serials and back.reference == rig.reference
    for a, b in zip(rig.cameras, back.cameras, strict=True):
        np.testing.assert_allclose(a.camera_to_world, b.camera_to_world)
        np.testing.assert_allclose(a.distortion, b.distortion)
        assert (a.width, a.height, a.depth_scale) == (b.width, b.height, b.depth_scale)


@pytest.mark.parametrize("bad, message", [
    (np.diag([1.1, 1, 1, 1]), "not a rigid transform"),
    (np.diag([1, 1, -1, 1]), "reflection"),
    (np.eye(3), "shape (4, 4)"),
])
def test_non_rigid_extrinsics_are_rejected_naming_the_camera(tmp_path, bad, message):
    d = ring_rig(2).to_dict()
    d["cameras"][1]["camera_to_world"] = np.asarray(bad).tolist()
    (tmp_path / "rig.json").write_text(json.dumps(d))
    with pytest.raises(InputError) as err:
        load_rig(tmp_path / "rig.json")
    assert message in str(err.value) and "cameras[1]" in str(err.value) and "rig.json" in str(err.value)


def test_missing_fields_and_bad_intrinsics_are_named(tmp_path):
    d = ring_rig(1).to_dict()
    del d["cameras"][0]["fx"]
    (tmp_path / "a.json").write_text(json.dumps(d))
    with pytest.raises(InputError, match="missing field.*fx"):
        load_rig(tmp_path / "a.json")
    d = ring_rig(1).to_dict()
    d["cameras"][0]["depth_scale"] = 0
    (tmp_path / "b.json").write_text(json.dumps(d))
    with pytest.raises(InputError, match="depth_scale"):
        load_rig(tmp_path / "b.json")
    with pytest.raises(InputError, match="duplicate"):
        Rig(cameras=ring_rig(2).cameras[:1] * 2)


def test_perturb_rig_moves_every_camera_but_the_reference_by_exact_amounts():
    rig = ring_rig(5)
    out = perturb_rig(rig, rotation_deg=1.0, translation_m=0.01, seed=4)
    for a, b in zip(rig.cameras, out.cameras, strict=True):
        d = np.linalg.inv(a.camera_to_world) @ b.camera_to_world
        ang = math.degrees(math.acos(np.clip((np.trace(d[:3, :3]) - 1) / 2, -1, 1)))
        shift = np.linalg.norm(a.center - b.center)
        if a.serial == rig.reference:
            assert ang < 1e-6 and shift < 1e-12
        else:
            assert ang == pytest.approx(1.0, abs=1e-6) and shift == pytest.approx(0.01, abs=1e-12)


def test_look_at_rejects_parallel_up():
    with pytest.raises(ValueError):
        look_at([0, 2, 0], [0, 0, 0], [0, 1, 0])


def test_scaled_rig_keeps_the_field_of_view():
    rig = ring_rig(1)
    small = rig.scaled(0.5)
    c0, c1 = rig.cameras[0], small.cameras[0]
    assert (c1.width, c1.height) == (320, 288)
    assert c1.width / c1.fx == pytest.approx(c0.width / c0.fx)


def test_pose_rule_repairs_tracker_round_off_and_lists_every_camera_beyond(tmp_path):
    from dressmeup.capture.rig import read_rig

    rng = np.random.default_rng(1)
    d = ring_rig(3).to_dict()
    for c in d["cameras"][1:]:
        m = np.asarray(c["camera_to_world"])
        m[:3, :3] += rng.normal(scale=1e-4, size=(3, 3))  # |R^T R - I| of a few 1e-4
        c["camera_to_world"] = m.tolist()
    (tmp_path / "rig.json").write_text(json.dumps(d))
    reading = read_rig(tmp_path)
    assert reading.rig is not None and sorted(reading.repairs) == ["cam1", "cam2"]
    for cam in reading.rig.cameras:
        R = cam.camera_to_world[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert all(0 < r.correction_mm < 1 for r in reading.repairs.values())
    np.testing.assert_array_equal(reading.rig.cameras[0].camera_to_world, ring_rig(3).cameras[0].camera_to_world)
    for c in d["cameras"][1:]:
        c["camera_to_world"][0][0] += 0.01  # beyond 2e-3
    (tmp_path / "rig.json").write_text(json.dumps(d))
    with pytest.raises(InputError) as err:
        load_rig(tmp_path / "rig.json")
    assert "2 problems" in str(err.value)
    assert "cameras[1] (cam1)" in str(err.value) and "cameras[2] (cam2)" in str(err.value)
