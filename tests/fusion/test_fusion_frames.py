"""Frames carry their camera through fusion (no rig look-ups downstream)."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.capture.frame import RGBDFrame, frame_camera
from dressmeup.capture.rig import ring_rig
from dressmeup.errors import InputError


def test_frame_camera_prefers_the_frame_and_falls_back_to_the_rig(small_rig):
    cam = small_rig.cameras[0]
    other = small_rig.cameras[1]
    bare = RGBDFrame(cam.serial, 0, np.zeros((1, 1, 3), np.uint8), np.zeros((1, 1), np.float32))
    assert frame_camera(bare, small_rig) is small_rig.camera(cam.serial)
    with pytest.raises(InputError, match="carries no camera"):
        frame_camera(bare)
    carried = RGBDFrame(cam.serial, 0, bare.color, bare.depth, camera=other)
    assert frame_camera(carried, small_rig) is other


def test_prepared_frames_carry_the_attached_rig_and_fusion_the_refined_one(clean_frames, small_rig, mannequin):
    from dressmeup.capture.frame import with_rig_cameras
    from dressmeup.capture.rig import perturb_rig
    from dressmeup.capture.synthetic import render_frames
    from dressmeup.fusion.pipeline import FusionConfig, fuse_frames, prepare_frames

    drifted = perturb_rig(small_rig, 0.5, 0.005, seed=4)
    assert all(f.camera is not None for f in clean_frames)  # render_frames sets it
    prepared = prepare_frames(with_rig_cameras(clean_frames, drifted))
    for f in prepared:
        assert f.camera is drifted.camera(f.serial)  # the attached rig wins
    with pytest.raises(InputError, match="carries no camera"):
        prepare_frames([RGBDFrame("x", 0, clean_frames[0].color, clean_frames[0].depth)])
    # refinement needs pixels finer than its 5 mm voxels: half-size images, not the tiny ones
    rig = ring_rig(7).scaled(0.5)
    drifted = perturb_rig(rig, 1.0, 0.01, seed=4)
    res = fuse_frames(render_frames(mannequin, rig, None, seed=0), drifted,
                      FusionConfig(voxel_size=0.01, refine=True))
    for f in res.frames:
        np.testing.assert_array_equal(f.camera.camera_to_world, res.rig.camera(f.serial).camera_to_world)
    moved = [not np.allclose(res.rig.camera(s).camera_to_world, drifted.camera(s).camera_to_world)
             for s in drifted.serials]
    assert sum(moved) == 6  # every camera but the reference, and the frames follow them
    assert res.rig.reference == "cam0" and not moved[0]


def test_session_frames_carry_the_session_rig(session_dir):
    from dressmeup.capture.session import open_session

    s = open_session(session_dir)
    for f in s.load_frames(0):
        assert f.camera is s.rig.camera(f.serial)
