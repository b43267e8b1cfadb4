"""A camera whose depth disagrees with the other cameras' is named, in the log and fusion.json."""

from __future__ import annotations

import json
import logging
from dataclasses import replace

import numpy as np

from dressmeup.capture.session import open_session
from dressmeup.fusion.consistency import depth_consistency
from dressmeup.fusion.pipeline import FusionConfig, fuse_frames, prepare_frames, save_scan


def _fuse(session_dir, tmp_path, caplog, rig):
    session = open_session(session_dir)
    frames = session.load_frames(0)
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="dressmeup.fusion.pipeline"):
        res = fuse_frames(frames, rig, FusionConfig(voxel_size=0.008))
    save_scan(res, tmp_path)
    info = json.loads((tmp_path / "fusion.json").read_text())
    return info["depth_consistency"], [r.getMessage() for r in caplog.records]


def test_a_camera_with_a_wrong_focal_length_is_named(session_dir, tmp_path, caplog):
    rig = open_session(session_dir).rig
    ok, messages = _fuse(session_dir, tmp_path / "ok", caplog, rig)
    assert ok["outliers"] == [] and not [m for m in messages if "depth lies" in m]
    assert all(v is not None and v < 10 for v in ok["median_mm"].values())

    bad_serial = rig.serials[2]
    cams = [replace(c, fx=3 * c.fx) if c.serial == bad_serial else c for c in rig.cameras]
    bad, messages = _fuse(session_dir, tmp_path / "bad", caplog, rig.with_cameras(cams))
    assert bad["outliers"] == [bad_serial]
    warned = [m for m in messages if "depth lies" in m]
    assert len(warned) == 1 and bad_serial in warned[0]
    others = [v for s, v in bad["median_mm"].items() if s != bad_serial]
    assert bad["median_mm"][bad_serial] > 1.5 * np.median(others)
    assert f"{bad['median_mm'][bad_serial]:.1f} mm" in warned[0]


def test_figures_are_nearest_point_medians_of_the_other_cameras(clean_frames):
    """Against a brute-force reference on the clean small rig."""
    frames = prepare_frames(clean_frames)
    report = depth_consistency(frames)
    from dressmeup.fusion.consistency import ConsistencyConfig, _points

    cfg = ConsistencyConfig()
    stride = max(1, round(frames[0].depth.shape[1] / cfg.query_columns))
    pts = {f.serial: _points([f], stride) for f in frames}
    for s, q in pts.items():
        others = np.concatenate([p for o, p in pts.items() if o != s])
        d = np.sqrt(((q[:, None, :] - others[None, :, :]) ** 2).sum(-1)).min(axis=1)
        inside = d[d < cfg.overlap_radius]
        assert report.overlap[s] == len(inside) / len(q)
        assert abs(report.median_mm[s] - 1000 * np.median(inside)) < 1e-9


def test_no_frames_no_figures():
    report = depth_consistency([])
    assert report.median_mm == {} and report.outliers == [] and report.reference_mm is None
