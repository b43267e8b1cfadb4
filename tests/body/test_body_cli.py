"""The ``dressmeup register`` command on a procedural-body scan."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.registration.scan import up_rotation
from dressmeup.body.rigid import rotate_params
from dressmeup.body.synthetic import named_pose
from dressmeup.cli import main


def test_register_command(tmp_path, capsys):
    """A z-up scan: refused without --up (the message names it), fitted with --up z in
    the scan's frame."""
    model = get_body_model("procedural")
    upright = BodyParams("procedural", shape=np.full(6, 0.5), pose=named_pose("standing"),
                         transl=[0.0, 0.1, 0.0])
    truth = rotate_params(upright, model, up_rotation("z").T)  # its up (+y) on +z
    scan = tmp_path / "scan.ply"
    trimesh.Trimesh(model.posed(truth).vertices, model.faces, process=False).export(scan)
    out = tmp_path / "body.npz"
    args = ["register", str(scan), "--model", "procedural", "--out", str(out),
            "--preset", "fast", "--iterations", "10,40,20"]
    assert main(args) == 2
    assert "--up z" in capsys.readouterr().err and not out.exists()
    assert main(args + ["--up", "z"]) == 0
    fit = BodyParams.load(out)
    assert fit.model == "procedural" and fit.pose.shape == (22, 3)
    err = np.linalg.norm(model.posed(fit).joints - model.posed(truth).joints, axis=1).mean()
    assert err < 0.05
    printed = capsys.readouterr().out
    assert "wrote" in printed and "start: hypothesis" in printed
    # figures without ground truth, in mm, and the picture next to the result
    assert "body -> scan" in printed and " mm" in printed and "final losses" not in printed
    metrics = json.loads((tmp_path / "body.metrics.json").read_text())
    assert metrics["body_to_scan_mm"] < 50 and set(metrics["parts"]) >= {"torso", "head"}
    png = tmp_path / "body.fit.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and (png.stat().st_mode & 0o777) == 0o644
    # from-file registrar: import instead of fitting
    out2 = tmp_path / "copy.npz"
    assert main(["register", str(scan), "--model", "procedural", "--out", str(out2),
                 "--registrar", "from-file", "--params", str(out)]) == 0
    np.testing.assert_array_equal(BodyParams.load(out2).pose, fit.pose)


def test_register_command_errors(tmp_path, capsys):
    assert main(["register", str(tmp_path / "none.ply"), "--model", "procedural",
                 "--out", str(tmp_path / "b.npz")]) == 2
    assert "scan not found" in capsys.readouterr().err
    np.save(tmp_path / "p.npy", np.random.default_rng(0).normal(size=(50, 3)))
    # the scan is read before the body model is built (an anny build takes minutes)
    assert main(["register", str(tmp_path / "p.npy"), "--model", "smpl",
                 "--model-path", str(tmp_path), "--out", str(tmp_path / "b.npz")]) == 2
    err = capsys.readouterr().err
    assert "SMPL_NEUTRAL.pkl" in err and "licence" in err
    assert main(["register", str(tmp_path / "p.npy"), "--model", "procedural",
                 "--iterations", "1,2", "--out", str(tmp_path / "b.npz")]) == 2
    assert "--iterations" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # argparse names the choices
        main(["register", str(tmp_path / "p.npy"), "--model", "procedural", "--preset",
              "slow", "--out", str(tmp_path / "b.npz")])
    assert "--preset: invalid choice: 'slow'" in capsys.readouterr().err


def test_shape_restart_line_names_the_kept_start():
    from dressmeup.cli.body import shape_restart_line

    info = {"shape_search": {"fitted": 2.3577, "gender 0 height 0.79": 2.3289,
                             "gender 1 height 0.91": 1.9555, "kept": "gender 1 height 0.91"}}
    line = shape_restart_line(info)
    assert "gender 1 height 0.91" in line and "2.358 -> 1.956" in line
    info["shape_search"]["kept"] = "fitted"
    assert shape_restart_line(info) == ""
    assert shape_restart_line({}) == ""
