"""Dataset importers: tiny folders written the way each dataset's docs and tools describe them.

A moving camera renders the mannequin; each test writes the frames in one dataset's layout
(its pose convention, quaternion order, depth unit, invalid-depth value, timestamps) and
checks that the imported session gives back the true OpenCV camera-to-world poses, the
intrinsics and the depth, so a convention mixed up (world-to-camera for camera-to-world,
``w x y z`` for ``x y z w``, OpenGL axes) fails.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from dressmeup.capture.camera import Camera
from dressmeup.capture.importers import ImportOptions, import_capture
from dressmeup.capture.importers.common import associate, select_frames
from dressmeup.capture.rig import Rig, look_at
from dressmeup.capture.session import open_session
from dressmeup.capture.synthetic import render_frames
from dressmeup.errors import InputError


def _quat_xyzw(R):
    """Unit quaternion (x, y, z, w) of a rotation matrix."""
    w = np.sqrt(max(0.0, 1 + np.trace(R))) / 2
    x = np.copysign(np.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return np.array([x, y, z, w])


def _walk(mannequin, w, h, fx, fy, cx, cy, n=3):
    """A camera walking past the mannequin: true poses (OpenCV camera-to-world) and frames."""
    target = mannequin.vertices.mean(axis=0)
    cams = []
    for k in range(n):
        ang = 0.5 * k
        eye = target + np.array([2.0 * np.sin(ang), 0.25 * k, 2.0 * np.cos(ang)])
        cams.append(Camera(f"c{k}", w, h, fx, fy, cx, cy, camera_to_world=look_at(eye, target, [0, 1, 0])))
    return cams, render_frames(mannequin, Rig(cams), None)


def _check(out, cams, frames, depth_scale, stride=1):
    s = open_session(out)
    assert s.info.n_frames == 1 and len(s.rig.cameras) == len(cams[::stride])
    for cam_true, fr_true, cam in zip(cams[::stride], frames[::stride], s.rig.cameras, strict=True):
        np.testing.assert_allclose(cam.camera_to_world, cam_true.camera_to_world, atol=2e-5)
        assert (cam.fx, cam.fy, cam.cx, cam.cy) == pytest.approx((cam_true.fx, cam_true.fy, cam_true.cx, cam_true.cy))
        assert cam.depth_scale == pytest.approx(depth_scale)
        got = s.load_frame(cam.serial).depth
        np.testing.assert_allclose(got, fr_true.depth, atol=depth_scale * 0.6)
    return s


def _png_depth(path, depth_m, units_per_m, invalid=0):
    d = np.round(depth_m * units_per_m).astype(np.uint16)
    d[depth_m <= 0] = invalid
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), d)


def _color(path, rgb):
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))


def test_tum_timestamps_quaternions_and_5000_units(tmp_path, mannequin):
    cams, frames = _walk(mannequin, 640, 480, 535.4, 539.2, 320.1, 247.6)  # freiburg3
    src = tmp_path / "rgbd_dataset_freiburg3_walk"
    rgb_lines, depth_lines, gt_lines = ["# color images", "# file: x", "# timestamp filename"], ["# depth"], []
    t0 = 1305031102.0
    for k, (cam, fr) in enumerate(zip(cams, frames, strict=True)):
        t = t0 + 0.5 * k
        _color(src / "rgb" / f"{t:.6f}.png", fr.color)
        _png_depth(src / "depth" / f"{t + 0.011:.6f}.png", fr.depth, 5000)  # depth taken 11 ms later
        rgb_lines.append(f"{t:.6f} rgb/{t:.6f}.png")
        depth_lines.append(f"{t + 0.011:.6f} depth/{t + 0.011:.6f}.png")
        q = _quat_xyzw(cam.camera_to_world[:3, :3])
        tx, ty, tz = cam.camera_to_world[:3, 3]
        gt_lines.append(f"{t + 0.004:.4f} {tx:.6f} {ty:.6f} {tz:.6f} {q[0]:.7f} {q[1]:.7f} {q[2]:.7f} {q[3]:.7f}")
        gt_lines.append(f"{t + 0.2:.4f} 9 9 9 0 0 0 1")  # a mocap sample far from every image
    for name, lines in (("rgb.txt", rgb_lines), ("depth.txt", depth_lines), ("groundtruth.txt", gt_lines)):
        (src / name).write_text("\n".join(lines) + "\n")
    report = import_capture("tum", src, tmp_path / "s", ImportOptions(subject_id="room"))
    assert report.frames == 3 and not report.skipped
    s = _check(tmp_path / "s", cams, frames, 1 / 5000)
    assert s.info.subject_id == "room" and s.info.extra["source"]["format"] == "tum"
    import_capture("tum", src, tmp_path / "s2", ImportOptions(frames="::2"))
    _check(tmp_path / "s2", cams, frames, 1 / 5000, stride=2)


def test_7scenes_mm_65535_and_nearly_orthonormal_poses(tmp_path, mannequin):
    cams, frames = _walk(mannequin, 640, 480, 585.0, 585.0, 320.0, 240.0)
    seq = tmp_path / "chess" / "seq-01"
    rng = np.random.default_rng(0)
    for k, (cam, fr) in enumerate(zip(cams, frames, strict=True)):
        _color(seq / f"frame-{k:06d}.color.png", fr.color)
        _png_depth(seq / f"frame-{k:06d}.depth.png", fr.depth, 1000, invalid=65535)
        m = cam.camera_to_world.copy()
        m[:3, :3] += rng.normal(scale=1e-4, size=(3, 3))  # a tracker's round-off, ~3e-4 off
        (seq / f"frame-{k:06d}.pose.txt").write_text(
            "\n".join(" ".join(f"{v:.7e}" for v in row) for row in m) + "\n")
    with pytest.raises(InputError, match=r"seq-01"):
        import_capture("7scenes", tmp_path / "chess", tmp_path / "x")
    report = import_capture("7scenes", seq, tmp_path / "s")
    assert sorted(report.repairs) == ["frame-000000", "frame-000001", "frame-000002"]
    assert all(r.correction_mm < 1.0 for r in report.repairs.values())
    s = open_session(tmp_path / "s")
    for cam, cam_true in zip(s.rig.cameras, cams, strict=True):
        R = cam.camera_to_world[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)  # written orthonormal
        np.testing.assert_allclose(cam.camera_to_world, cam_true.camera_to_world, atol=1e-3)
    d = s.load_frame("frame-000000").depth
    assert d.max() < 10 and np.array_equal(d > 0, frames[0].depth > 0)  # 65535 became "none"


def test_poses_beyond_the_rule_are_refused_all_at_once(tmp_path, mannequin):
    cams, frames = _walk(mannequin, 640, 480, 585.0, 585.0, 320.0, 240.0)
    seq = tmp_path / "seq-02"
    for k, (cam, fr) in enumerate(zip(cams, frames, strict=True)):
        _color(seq / f"frame-{k:06d}.color.png", fr.color)
        _png_depth(seq / f"frame-{k:06d}.depth.png", fr.depth, 1000, invalid=65535)
        m = cam.camera_to_world.copy()
        if k:
            m[:3, :3] *= 1.01  # scaled: not a tracker's round-off
        (seq / f"frame-{k:06d}.pose.txt").write_text("\n".join(" ".join(map(str, row)) for row in m))
    with pytest.raises(InputError) as err:
        import_capture("7scenes", seq, tmp_path / "s")
    msg = str(err.value)
    assert "2 of 3 pose(s) refused" in msg
    assert "frame-000001.pose.txt" in msg and "frame-000002.pose.txt" in msg and "frame-000000" not in msg


def test_redwood_log_trajectory_jpeg_and_open3d_intrinsics(tmp_path, mannequin):
    cams, frames = _walk(mannequin, 128, 96, 110.0, 111.0, 63.5, 47.5)
    src = tmp_path / "livingroom"
    blocks = []
    for k, (cam, fr) in enumerate(zip(cams, frames, strict=True)):
        (src / "color").mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(src / "color" / f"{k:05d}.jpg"), cv2.cvtColor(fr.color, cv2.COLOR_RGB2BGR))
        _png_depth(src / "depth" / f"{k:05d}.png", fr.depth, 1000)
        blocks.append(f"{k} {k} {k + 1}\n" + "\n".join(" ".join(f"{v:.9f}" for v in row) for row in cam.camera_to_world))
    (src / "trajectory.log").write_text("\n".join(blocks) + "\n")
    (src / "camera_intrinsic.json").write_text(json.dumps(
        {"width": 128, "height": 96, "intrinsic_matrix": [110.0, 0, 0, 0, 111.0, 0, 63.5, 47.5, 1]}))
    report = import_capture("redwood", src, tmp_path / "s", ImportOptions(frames="0,2"))
    assert report.frames == 2
    _check(tmp_path / "s", cams, frames, 0.001, stride=2)


def test_arkitscenes_world_to_camera_axis_angle(tmp_path, mannequin):
    cams, frames = _walk(mannequin, 256, 192, 212.0, 212.0, 127.5, 95.5)
    src = tmp_path / "41069025"
    traj = []
    for k, (cam, fr) in enumerate(zip(cams, frames, strict=True)):
        t = 6845.5 + 0.1 * k
        name = f"41069025_{t:.3f}.png"
        _color(src / "lowres_wide" / name, fr.color)
        _png_depth(src / "lowres_depth" / name, fr.depth, 1000)
        (src / "lowres_wide_intrinsics").mkdir(parents=True, exist_ok=True)
        (src / "lowres_wide_intrinsics" / f"{name[:-4]}.pincam").write_text("256 192 212.0 212.0 127.5 95.5\n")
        w2c = cam.world_to_camera
        r, _ = cv2.Rodrigues(w2c[:3, :3])
        traj.append(f"{t + 0.004:.6f} " + " ".join(f"{v:.9f}" for v in [*r.ravel(), *w2c[:3, 3]]))
    (src / "lowres_wide.traj").write_text("\n".join(traj) + "\n")
    import_capture("arkitscenes", src, tmp_path / "s")
    _check(tmp_path / "s", cams, frames, 0.001)


def test_frame_selector_and_association_rules():
    assert select_frames(None, 4) == [0, 1, 2, 3]
    assert select_frames("::2", 5) == [0, 2, 4]
    assert select_frames("1:4", 10) == [1, 2, 3]
    assert select_frames("3,0", 5) == [3, 0]
    for bad in ("7", "a", "::0", "5:2"):
        with pytest.raises(InputError, match="--frames"):
            select_frames(bad, 5)
    # closest pairs first, each timestamp used once, nothing beyond the limit
    assert associate([0.0, 0.03, 1.0], [0.01, 0.02, 2.0], 0.02) == [(0, 0), (1, 1)]


def test_import_capture_cli_and_validate_session(tmp_path, mannequin, capsys):
    from dressmeup.cli import main

    cams, frames = _walk(mannequin, 128, 96, 110.0, 111.0, 63.5, 47.5, n=2)
    src = tmp_path / "rw"
    blocks = []
    for k, (cam, fr) in enumerate(zip(cams, frames, strict=True)):
        _color(src / "rgb" / f"{k:05d}.png", fr.color)
        _png_depth(src / "depth" / f"{k:05d}.png", fr.depth, 1000)
        blocks.append("0 0 1\n" + "\n".join(" ".join(map(str, row)) for row in cam.camera_to_world))
    (src / "poses.log").write_text("\n".join(blocks))
    assert main(["import-capture", "redwood", str(src), "--out", str(tmp_path / "s"),
                 "--intrinsics", "110,111,63.5,47.5"]) == 0
    assert "2 frame(s)" in capsys.readouterr().out
    assert main(["validate-session", str(tmp_path / "s")]) == 0
    assert "valid" in capsys.readouterr().out
    # break two cameras' poses and one image: every problem at once, camera named
    rig = json.loads((tmp_path / "s" / "rig.json").read_text())
    for c in rig["cameras"]:
        c["camera_to_world"][0][0] *= 1.5
    (tmp_path / "s" / "rig.json").write_text(json.dumps(rig))
    assert main(["validate-session", str(tmp_path / "s")]) == 1
    out = capsys.readouterr().out
    assert "cameras[0] (frame-000000)" in out and "cameras[1] (frame-000001)" in out
