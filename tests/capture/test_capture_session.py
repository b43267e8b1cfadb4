"""Capture sessions: layout, reading and validation messages that name the file."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from dressmeup.capture.images import read_depth_png
from dressmeup.capture.session import open_session, validate_session
from dressmeup.errors import InputError


def _copy(session_dir, tmp_path):
    dst = tmp_path / "sess"
    shutil.copytree(session_dir, dst)
    return dst


def test_synthetic_session_is_valid_and_reads_back(session_dir, small_rig):
    assert validate_session(session_dir) == []
    s = open_session(session_dir)
    assert s.rig.serials == small_rig.serials
    assert [g.id for g in s.info.garments] == ["G-top", "G-pants"]
    assert s.has_labels()
    frames = s.load_frames(0)
    cam = small_rig.cameras[0]
    assert frames[0].depth.shape == (cam.height, cam.width) and frames[0].depth.dtype == np.float32
    assert frames[0].color.shape == (cam.height, cam.width, 3)
    valid = frames[0].depth[frames[0].depth > 0]
    # millimetre quantisation, subject about 2.2 m away
    np.testing.assert_allclose(valid * 1000, np.round(valid * 1000), atol=1e-3)
    assert 1.8 < np.median(valid) < 2.6
    assert set(np.unique(frames[0].labels)) <= {0, 1, 2, 3}


def test_missing_camera_folder_is_named(session_dir, tmp_path):
    d = _copy(session_dir, tmp_path)
    shutil.rmtree(d / "cam3")
    problems = validate_session(d)
    assert any("cam3" in p and "missing" in p for p in problems)
    with pytest.raises(InputError, match="cam3"):
        open_session(d)


def test_corrupt_png_is_named(session_dir, tmp_path):
    d = _copy(session_dir, tmp_path)
    bad = d / "cam2" / "depth" / "000000.png"
    bad.write_bytes(bad.read_bytes()[:100])
    with pytest.raises(InputError) as err:
        open_session(d)
    assert str(bad) in str(err.value) and "corrupt" in str(err.value)


def test_wrong_size_and_type_are_named(session_dir, tmp_path):
    import cv2

    d = _copy(session_dir, tmp_path)
    c = d / "cam1" / "color" / "000000.png"
    cv2.imwrite(str(c), np.zeros((10, 12, 3), np.uint8))
    dp = d / "cam4" / "depth" / "000000.png"
    cv2.imwrite(str(dp), np.zeros((5, 5), np.uint8))
    problems = "\n".join(validate_session(d))
    assert f"{c}: image is 12x10" in problems
    assert f"{dp}: depth must be a single-channel 16-bit PNG" in problems
    with pytest.raises(InputError, match="wrong|depth must"):
        read_depth_png(dp)


def test_undeclared_label_and_bad_session_json(session_dir, tmp_path):
    import cv2

    d = _copy(session_dir, tmp_path)
    lp = d / "cam0" / "labels" / "000000.png"
    lab = cv2.imread(str(lp), cv2.IMREAD_UNCHANGED)
    lab[0, 0] = 9
    cv2.imwrite(str(lp), lab)
    assert any("label value(s) [9]" in p for p in validate_session(d))
    info = json.loads((d / "session.json").read_text())
    info["subject_id"] = "bad id!"
    (d / "session.json").write_text(json.dumps(info))
    assert any("subject_id" in p for p in validate_session(d))


def test_missing_frame_of_a_multi_frame_session(session_dir, tmp_path):
    d = _copy(session_dir, tmp_path)
    info = json.loads((d / "session.json").read_text())
    info["frames"] = 2
    (d / "session.json").write_text(json.dumps(info))
    problems = validate_session(d, check_images=False)
    assert len([p for p in problems if "000001.png: file is missing" in p]) == 2 * 7
