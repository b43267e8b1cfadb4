"""Bad options and files on the command line are one-line errors before any work starts
(never a traceback, never minutes of work or gigabytes of memory): the known bad inputs
that need no dataset."""

from __future__ import annotations

import io
import time

import numpy as np
import pytest

from dressmeup.cli import main

TRI_PLY = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
           "end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n")


def run(argv, capsys) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of the command line; a usage error is status 2."""
    t0 = time.perf_counter()
    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:
        status = exc.code
    out, err = capsys.readouterr()
    assert time.perf_counter() - t0 < 60, "a refused input must fail fast"
    assert "Traceback" not in err, err
    return status, out, err


@pytest.fixture
def tri(tmp_path):
    p = tmp_path / "tri.ply"
    p.write_text(TRI_PLY)
    return p


@pytest.mark.parametrize("argv, says", [
    (["register", "{tri}", "--model", "smpl", "--gender", "robot", "--out", "{t}/f.npz"],
     "invalid choice: 'robot'"),
    (["fuse", "{t}/session", "--out", "{t}/scan", "--voxel", "-1"],
     "--voxel: expected a finite number in [0.0005, 1]"),
    (["fuse", "{t}/session", "--out", "{t}/scan", "--voxel", "nan"], "--voxel"),
    (["synth-capture", "mannequin", "--out", "{t}/s", "--frames", "-1"],
     "--frames: expected an integer >= 1"),
    (["metrics", "{tri}", "{tri}", "--samples", "2000000000"],
     "--samples: expected an integer from 1 to 20,000,000 (surface_samples"),
    (["synth", "{t}/o", "--garments", "1000000", "--body-model", "procedural"],
     "samples to generate 15,000,000, over the limit of 1,000,000 (samples)"),
    (["synth", "{t}/o", "--edge-length", "0.0001", "--body-model", "procedural"],
     "(mesh_faces)"),
    (["report", "{t}/res", "--out", "{t}/site", "--images-per-side", "-1"],
     "--images-per-side: expected an integer >= 0"),
    (["report", "{t}/res", "--out", "{t}/site", "--max-images", "-5"], "--max-images"),
    (["build-dataset", "{t}/s", "--out", "{t}/d", "--texture-size", "1000000"],
     "(image_pixels"),
    (["baseline", "train-retarget", "--data", "{t}/d", "--out", "{t}/w.pt", "--steps", "0"],
     "--steps"),
    (["metrics", "{tri}", "{tri}", "--seed", "-1"], "--seed"),
    (["serve", "--root", "{t}/srv", "--port", "70000"], "--port"),
    (["submit", "{t}/sub", "-e", "x", "--server", "ftp://x", "--token", "t"], "--server"),
    (["register", "{tri}", "--registrar", "nope", "--out", "{t}/f.npz"], "--registrar"),
    (["register", "{tri}", "--format", "nope", "--out", "{t}/f.npz"],
     "--format and --params go with --registrar from-file"),
    (["baseline", "uvparam", "--method", "xatlas", "--meshes", "sphere-2k", "--param",
      "nope=1", "--out", "{t}/sub"], "unknown hyperparameter(s) ['nope']"),
    (["report", "{t}", "--data", "{t}/missing", "--out", "{t}/site"], "--data"),
    (["server", "list", "--root", "{t}/srv", "--database", "nope://x"], "--database nope://x"),
    (["synth-capture", "mannequin", "--out", "{t}/s", "--scale", "1e-9"], "--scale"),
])
def test_bad_options_are_usage_errors(argv, says, capsys, tmp_path, tri):
    argv = [a.format(t=tmp_path, tri=tri) for a in argv]
    status, _, err = run(argv, capsys)
    assert status == 2 and says in err, err


@pytest.mark.parametrize("command", [
    ["report", "{t}/res", "--out", "{t}/o"],
    ["synth", "{t}/o", "--body-model", "procedural"],
    ["import-dataset", "thuman", "{t}/scans", "--out", "{t}/o"],
    ["score", "{t}/sub", "-e", "x", "-d", "{t}/d", "--out", "{t}/o"],
    ["fuse", "{t}/session", "--out", "{t}/o"],
    ["baseline", "uvparam", "--method", "xatlas", "--out", "{t}/o"],
])
def test_an_existing_file_as_output_folder_is_refused(command, capsys, tmp_path):
    (tmp_path / "o").write_text("not a folder")
    status, _, err = run([a.format(t=tmp_path) for a in command], capsys)
    assert status == 2 and "is an existing file; give a folder" in err, err
    assert (tmp_path / "o").read_text() == "not a folder"


def test_retarget_help_lists_every_method(capsys):
    from dressmeup.methods.retarget import METHODS, POSTPROCESSES

    status, out, _ = run(["baseline", "retarget", "--help"], capsys)
    text = " ".join(out.split())
    assert status == 0 and len(METHODS) + len(POSTPROCESSES) >= 8
    for name in [*METHODS, *POSTPROCESSES]:
        assert name in text.replace("- ", "-"), name


def test_metrics_refuses_a_mesh_of_zero_area_and_warns_on_units(capsys, tmp_path, tri):
    flat = tmp_path / "flat.ply"
    flat.write_text(TRI_PLY.replace("0 1 0\n0 0 1", "2 0 0\n3 0 0"))
    status, _, err = run(["metrics", flat, tri, "--samples", "500"], capsys)
    assert status == 2 and "every face has zero area" in err
    status, _, err = run(["metrics", tri, tri, "--samples", "500", "--body", flat], capsys)
    assert status == 2 and "--body" in err and "zero area" in err
    mm = tmp_path / "mm.ply"
    lines = TRI_PLY.splitlines()
    mm.write_text("\n".join(lines[:9] + ["0 0 0", "1000 0 0", "0 1000 0", "0 0 1000"]
                            + lines[13:]) + "\n")
    status, out, err = run(["metrics", mm, tri, "--samples", "500"], capsys)
    assert status == 0 and "warning" in err and "millimetres" in err and "P2S" in out


def _npy_header(path, shape):
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False,
                                               "shape": shape})
    path.write_bytes(buf.getvalue())


@pytest.mark.parametrize("damage, says", [
    ("bomb", "array_bytes"), ("truncated", "truncated"), ("objects", "Python objects"),
    ("2d", "expected (p, 3) points"), ("nan", "finite points"),
])
def test_register_refuses_bad_point_scans_before_any_fit(damage, says, capsys, tmp_path):
    scan = tmp_path / "scan.npy"
    if damage == "bomb":
        _npy_header(scan, (1 << 33, 3))
    elif damage == "truncated":
        np.save(scan, np.zeros((100, 3)))
        scan.write_bytes(scan.read_bytes()[:-40])
    elif damage == "objects":
        np.save(scan, np.array([None, {}], dtype=object), allow_pickle=True)
    elif damage == "2d":
        np.save(scan, np.zeros((100, 2)))
    else:
        np.save(scan, np.full((100, 3), np.nan))
    status, _, err = run(["register", scan, "--model", "procedural", "--out",
                          tmp_path / "fit.npz"], capsys)
    assert status == 2 and says in err, err


def test_register_refuses_a_billion_laughs_init(capsys, tmp_path):
    from tests.io.test_io_bombs import laughs

    scan = tmp_path / "scan.npy"
    np.save(scan, np.random.default_rng(0).normal(size=(500, 3)))
    init = tmp_path / "init.pkl"
    init.write_bytes(laughs())
    status, _, err = run(["register", scan, "--model", "procedural", "--out",
                          tmp_path / "fit.npz", "--init", init], capsys)
    assert status == 2 and "pickle_objects" in err and "init.pkl" in err


@pytest.mark.parametrize("content", ["random", "npz", "laughs"])
def test_uv_checkpoint_that_is_not_one_is_named(content, capsys, tmp_path):
    from tests.io.test_io_bombs import laughs

    ckpt = tmp_path / "c.pt"
    if content == "random":
        ckpt.write_bytes(np.random.default_rng(0).bytes(2000))
    elif content == "npz":
        np.savez(ckpt, x=np.zeros(3))
    else:
        ckpt.write_bytes(laughs())
    status, _, err = run(["baseline", "uvparam", "--method", "neural", "--meshes",
                          "sphere-2k", "--checkpoint", ckpt, "--out", tmp_path / "sub"],
                         capsys)
    assert status == 2 and "c.pt" in err and "checkpoint" in err, err
    assert not (tmp_path / "sub").exists()


def test_register_refuses_an_up_axis_the_scan_does_not_have(capsys, tmp_path):
    from dressmeup.body import get_body_model

    model = get_body_model("procedural")
    scan = tmp_path / "scan.npy"
    np.save(scan, model.posed(model.default_params()).vertices)  # y up
    status, _, err = run(["register", scan, "--model", "procedural", "--up", "z", "--out",
                          tmp_path / "fit.npz"], capsys)
    assert status == 2 and "turned by --up z" in err and "--up y" in err, err


def test_fuse_refuses_more_views_than_the_session_has(capsys, tmp_path):
    session = tmp_path / "session"
    assert main(["synth-capture", "mannequin", "--out", str(session), "--scale", "0.1"]) == 0
    capsys.readouterr()
    status, _, err = run(["fuse", session, "--out", tmp_path / "scan", "--min-weight", "8"],
                         capsys)
    assert status == 2 and "the session has 7 views" in err
