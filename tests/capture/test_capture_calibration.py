"""ChArUco calibration on synthetic board images rendered from known camera poses."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from dressmeup.capture.calibration import (
    BoardSpec,
    board_pose_facing,
    calibrate_rig,
    detect_board_pose,
    render_board_view,
)
from dressmeup.capture.rig import ring_rig
from dressmeup.errors import InputError
from dressmeup.fusion.icp import pose_difference


def _write_shots(tmp_path, rig, spec, pairs, heights=(0.0,)):
    k = 0
    for a, b in pairs:
        ca, cb = rig.camera(a), rig.camera(b)
        n = (ca.center + cb.center) / 2 - rig.target
        n -= rig.up * (n @ rig.up)
        for h in heights:
            P = board_pose_facing(rig.target + h * rig.up, n, rig.up)
            shot = tmp_path / f"shot{k}"
            k += 1
            shot.mkdir(parents=True)
            for cam in rig.cameras:
                cv2.imwrite(str(shot / f"{cam.serial}.png"), render_board_view(spec, cam, P))


def test_board_pose_from_a_rendered_view_matches_the_truth():
    rig = ring_rig(1, radius=1.5)
    spec = BoardSpec()
    cam = rig.cameras[0]
    P = board_pose_facing(rig.target, cam.center - rig.target, rig.up)
    T = detect_board_pose(render_board_view(spec, cam, P), cam, spec)
    origin = np.eye(4)
    origin[:3, 3] = [-spec.size[0] / 2, -spec.size[1] / 2, 0]
    ang, dist = pose_difference(T, cam.world_to_camera @ P @ origin)
    assert ang < 0.3 and dist < 0.005


def test_calibration_recovers_a_ring_from_chained_shots(tmp_path):
    truth = ring_rig(4, radius=1.5)
    spec = BoardSpec()
    _write_shots(tmp_path, truth, spec, [("cam0", "cam1"), ("cam1", "cam2"), ("cam2", "cam3")],
                 heights=(-0.25, 0.0, 0.25))
    template = truth.copy()
    for c in template.cameras[1:]:  # unknown extrinsics: start from identity
        c.camera_to_world = np.eye(4)
    rig, seen = calibrate_rig(tmp_path, template, spec)
    assert sorted(seen["shot0"]) == ["cam0", "cam1"]
    for c in rig.cameras:
        ang, dist = pose_difference(c.camera_to_world, truth.camera(c.serial).camera_to_world)
        # chained through up to three board views at 45 degrees, each about 0.3 degrees off
        assert ang < 0.6 and dist < 0.015, (c.serial, ang, dist)


def test_unlinked_camera_is_reported(tmp_path):
    truth = ring_rig(4, radius=1.5)
    spec = BoardSpec()
    _write_shots(tmp_path, truth, spec, [("cam0", "cam1")])
    with pytest.raises(InputError, match="cam2"):
        calibrate_rig(tmp_path, truth, spec)
