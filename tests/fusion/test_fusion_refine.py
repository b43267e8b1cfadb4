"""Refinement that never hurts: proposals kept only within bounds and when residuals fall."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.capture.camera import Camera
from dressmeup.capture.frame import with_rig_cameras
from dressmeup.capture.rig import Rig, look_at, perturb_rig, ring_rig
from dressmeup.capture.synthetic import NoiseModel, SyntheticSubject, render_frames
from dressmeup.fusion.evaluate import extrinsic_errors
from dressmeup.fusion.icp import ICPConfig
from dressmeup.fusion.pipeline import prepare_frames
from dressmeup.fusion.refine import refine_extrinsics


@pytest.fixture(scope="module")
def noisy_half(mannequin):
    rig = ring_rig(7).scaled(0.5)
    return rig, prepare_frames(render_frames(mannequin, rig, NoiseModel(), seed=3))


def test_a_good_calibration_is_kept(noisy_half, mannequin):
    rig, frames = noisy_half
    cams, report = refine_extrinsics(frames, reference=rig.reference)
    refined = rig.with_cameras(list(cams.values()))
    err = extrinsic_errors(refined, rig, mannequin.vertices[::25])
    assert max(err.values()) < 0.0015  # nothing moved further than noise-level polish
    for s in rig.serials:
        assert report.residual_after_mm[s] <= report.residual_before_mm[s] + 1e-9
        moved = cams[s] is not frames[rig.serials.index(s)].camera
        if moved:  # a kept move lowered the residual by the margin
            assert report.residual_after_mm[s] < report.residual_before_mm[s] - 0.1


def test_moves_beyond_the_bound_are_refused(noisy_half):
    rig, frames = noisy_half
    drifted = perturb_rig(rig, 1.0, 0.01, seed=2)
    cams, report = refine_extrinsics(with_rig_cameras(frames, drifted),
                                     ICPConfig(max_rotation_deg=0.8), reference=rig.reference)
    far = [s for s, (deg, _) in report.proposed.items() if deg > 0.8]
    assert len(far) >= 3
    for s in far:
        assert "more than 0.8 deg" in report.refused[s]
        np.testing.assert_array_equal(cams[s].camera_to_world, drifted.camera(s).camera_to_world)
        assert report.corrections[s] == (0.0, 0.0)
    assert all(deg <= 0.8 for deg, _ in report.corrections.values())


def test_sliding_along_a_wall_is_refused():
    # a textured flat wall: a camera shifted parallel to it has the same residual, so ICP's
    # slides (or any move) cannot lower it by the margin and the poses stay as they came
    V = np.array([[-2, -1.5, 0], [2, -1.5, 0], [2, 1.5, 0], [-2, 1.5, 0]], float)
    wall = SyntheticSubject(V, np.array([[0, 1, 2], [0, 2, 3]]), np.array([2, 2], np.uint8), [],
                            vertex_colors=np.full((4, 3), 150, np.uint8))
    cams = [Camera(f"c{k}", 160, 120, 120.0, 120.0, 79.5, 59.5,
                   camera_to_world=look_at([0.3 * k - 0.3, 0.1 * k, 2.0], [0.3 * k - 0.3, 0.1 * k, 0], [0, 1, 0]))
            for k in range(3)]
    rig = Rig(cams)
    frames = prepare_frames(render_frames(wall, rig, NoiseModel(), seed=0))
    slid = rig.copy()
    for c in slid.cameras[1:]:
        c.camera_to_world = c.camera_to_world.copy()
        c.camera_to_world[:3, 3] += [0.02, -0.01, 0.0]  # in the wall's plane
    cams_out, report = refine_extrinsics(with_rig_cameras(frames, slid), reference="c0")
    for c in slid.cameras:
        np.testing.assert_array_equal(cams_out[c.serial].camera_to_world, c.camera_to_world)
    assert set(report.refused) <= {"c1", "c2"}
