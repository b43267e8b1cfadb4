"""Synthetic renderer and noise model against analytic cases."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.capture.camera import Camera
from dressmeup.capture.rig import Rig, look_at
from dressmeup.capture.synthetic import NoiseModel, SyntheticSubject, render_frames


def _plane_subject(z=2.0, half=3.0):
    V = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]], float)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    return SyntheticSubject(V, F, np.array([2, 2], np.uint8), [], vertex_colors=np.full((4, 3), 200, np.uint8))


def _camera(dist=None, w=80, h=60):
    return Camera("c", w, h, 60.0, 60.0, (w - 1) / 2, (h - 1) / 2, np.eye(4),
                  np.zeros(8) if dist is None else np.asarray(dist, float))


def test_plane_depth_is_exact_and_labelled():
    fr = render_frames(_plane_subject(2.0), Rig([_camera()]), None)[0]
    assert np.all(fr.depth == pytest.approx(2.0, abs=1e-6))
    assert np.all(fr.labels == 2)


def test_distorted_camera_depth_is_still_the_plane_after_undistortion():
    from dressmeup.fusion.filtering import undistort_frame
    from dressmeup.fusion.icp import backproject

    cam = _camera([-0.2, 0.05, 0.0, 0.0, 0.0, 0, 0, 0])
    rig = Rig([cam])
    # a tilted plane: depth varies over the image, so a wrong ray model would show
    V = np.array([[-3, -3, 1.85], [3, -3, 2.15], [3, 3, 2.15], [-3, 3, 1.85]], float)
    subj = SyntheticSubject(V, np.array([[0, 1, 2], [0, 2, 3]]), np.array([2, 2], np.uint8), [])
    fr = render_frames(subj, rig, None)[0]
    und = undistort_frame(fr, cam)
    P, _ = backproject(und)  # the frame carries the rendering camera
    # plane z = 2 + x / 20 (nearest-neighbour resampling costs up to half a pixel of slope)
    resid = P[:, 2] - (2.0 + P[:, 0] / 20.0)
    assert np.percentile(np.abs(resid), 95) < 0.002
    assert len(P) > 0.8 * cam.width * cam.height


def test_noise_sigma_grows_with_depth_squared():
    nm = NoiseModel(flying_probability=0.0, grazing_cos_none=0.0, grazing_cos_full=-1.0, dark_max_dropout=0.0,
                    depth_unit=0.0)
    rng = np.random.default_rng(0)
    for z in (1.0, 3.0):
        d = np.full((200, 200), z)
        out = nm.apply(d, np.ones_like(d), np.ones_like(d), rng)
        assert np.std(out - z) == pytest.approx(nm.sigma(z), rel=0.05)
    assert nm.sigma(3.0) - nm.sigma_base == pytest.approx(9 * (nm.sigma(1.0) - nm.sigma_base))


def test_dropouts_at_grazing_angles_and_dark_colours_and_quantisation():
    nm = NoiseModel(flying_probability=0.0)
    rng = np.random.default_rng(1)
    d = np.full((100, 100), 2.0)
    cos = np.full_like(d, 0.9)
    cos[:, :50] = 0.05  # grazing half
    lum = np.full_like(d, 0.8)
    lum[:50, 50:] = 0.0  # black quarter
    out = nm.apply(d, cos, lum, rng)
    assert np.all(out[:, :50] == 0)  # beyond grazing_cos_full: always dropped
    assert np.mean(out[:50, 50:] == 0) == pytest.approx(nm.dark_max_dropout, abs=0.05)
    assert np.mean(out[50:, 50:] == 0) < 0.01
    np.testing.assert_allclose(out * 1000, np.round(out * 1000), atol=1e-3)


def test_flying_pixels_appear_only_at_depth_edges():
    nm = NoiseModel(sigma_base=0.0, sigma_quadratic=0.0, flying_probability=1.0, grazing_cos_none=0.0,
                    grazing_cos_full=-1.0, dark_max_dropout=0.0)
    d = np.full((40, 40), 3.0)
    d[:, :20] = 2.0
    out = nm.apply(d, np.ones_like(d), np.ones_like(d), np.random.default_rng(2))
    changed = np.abs(out - d) > 0.0015
    assert changed[:, 19].mean() > 0.8  # foreground edge column turned into mixed depths
    assert not changed[:, :18].any() and not changed[:, 21:].any()
    assert np.all((out[:, 19] >= 2.0 - 1e-3) & (out[:, 19] <= 3.0 + 1e-3))


def test_mannequin_views_see_every_label(clean_frames):
    seen = set()
    for fr in clean_frames:
        seen |= set(np.unique(fr.labels).tolist())
        assert fr.color[fr.depth == 0].max() == 0
    assert seen == {0, 1, 2, 3}


def test_look_at_camera_renders_subject_in_view():
    cam = _camera()
    cam.camera_to_world = look_at([0, 0, -2.0], [0, 0, 0], [0, 1, 0])
    fr = render_frames(_plane_subject(0.0), Rig([cam]), None)[0]
    assert np.all(fr.depth == pytest.approx(2.0, abs=1e-6))


def test_parsing_errors_move_label_boundaries_but_not_the_silhouette():
    lab = np.zeros((100, 100), np.uint8)
    lab[10:90, 10:90] = 1
    lab[10:50, 10:90] = 2
    nm = NoiseModel(mask_boundary_px=3, mask_blobs=2)
    out = nm.corrupt_labels(lab, np.random.default_rng(0))
    assert np.array_equal(out > 0, lab > 0)
    changed = out != lab
    assert 0 < changed.mean() < 0.1
    assert NoiseModel().corrupt_labels(lab, np.random.default_rng(0)).tolist() == lab.tolist()
