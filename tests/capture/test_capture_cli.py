"""The capture commands end to end on tiny synthetic sessions."""

from __future__ import annotations

import json
import shutil

import numpy as np

from dressmeup.cli import main


def test_synth_capture_fuse_and_build_dataset_skip_a_bad_session(tmp_path, capsys):
    s1 = tmp_path / "sessions" / "S00-P0"
    assert main(["synth-capture", "mannequin", "--out", str(s1), "--scale", "0.3", "--seed", "1"]) == 0
    rig = json.loads((s1 / "rig.json").read_text())
    assert len(rig["cameras"]) == 7 and rig["cameras"][0]["width"] == 192
    gt = np.load(s1 / "ground_truth" / "scan.npz")
    assert set(np.unique(gt["face_labels"])) == {1, 2, 3}

    scan = tmp_path / "scan"
    assert main(["fuse", str(s1), "--out", str(scan), "--voxel", "0.008"]) == 0
    info = json.loads((scan / "fusion.json").read_text())
    assert info["faces"] > 1000 and (scan / "scan.ply").is_file() and (scan / "rig.json").is_file()

    bad = tmp_path / "sessions" / "S01-P0"
    shutil.copytree(s1, bad)
    (bad / "cam2" / "color" / "000000.png").write_bytes(b"not a png")
    root = tmp_path / "dataset"
    args = ["build-dataset", str(tmp_path / "sessions"), "--out", str(root), "--voxel", "0.008",
            "--body", "none", "--target-faces", "1500", "--texture-size", "128"]
    assert main(args) == 1  # one session failed
    err = capsys.readouterr().err
    assert "S01-P0" in err and "cam2/color/000000.png" in err
    failures = json.loads((root / "build-failures.json").read_text())
    assert len(failures) == 1 and "S01-P0" in failures[0]["session"]
    import pandas as pd

    man = pd.read_parquet(root / "manifest.parquet")
    assert sorted(man["garment_id"]) == ["G-pants", "G-top"]
    sample = root / man.iloc[0]["garment_path"]
    assert sample.is_file() and (sample.parent / "garment.png").is_file()
    # resuming: nothing new to write for the good session
    main(args)
    out = capsys.readouterr().out
    assert "0 sample(s) written, 2 already present" in out


def test_fuse_reports_a_missing_session(tmp_path, capsys):
    assert main(["fuse", str(tmp_path / "nope"), "--out", str(tmp_path / "x")]) == 2
    assert "nope" in capsys.readouterr().err
