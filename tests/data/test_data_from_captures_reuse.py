"""build-dataset reuses the scan 'dressmeup fuse' made, fuses with the same defaults as 'fuse'
(refinement off unless asked for), and records what it did."""

from __future__ import annotations

import json

import pandas as pd

from dressmeup.cli import main


def test_build_dataset_reuses_the_fused_scan_and_records_it(tmp_path, capsys):
    s0 = tmp_path / "sessions" / "S00-P0"
    assert main(["synth-capture", "mannequin", "--out", str(s0), "--scale", "0.25",
                 "--seed", "1"]) == 0
    scan = tmp_path / "scans" / "S00-P0"
    assert main(["fuse", str(s0), "--out", str(scan), "--voxel", "0.01"]) == 0
    fused = json.loads((scan / "fusion.json").read_text())
    assert fused["icp"] is None  # refinement is opt-in
    root = tmp_path / "dataset"
    assert main(["build-dataset", str(tmp_path / "sessions"), "--out", str(root), "--voxel",
                 "0.01", "--body", "none", "--target-faces", "800", "--no-texture",
                 "--scans", str(tmp_path / "scans")]) == 0
    info = json.loads((root / "dataset.json").read_text())
    assert info["body_model"] is None  # --body none: no body model was used
    assert info["build"]["sessions"]["S00-P0"]["scan"].startswith("reused")
    man = pd.read_parquet(root / "manifest.parquet")
    assert (man["scan_vertices"] == fused["vertices"]).all()
    # without --scans it fuses again, refining when asked to, and says so
    root2 = tmp_path / "dataset2"
    assert main(["build-dataset", str(tmp_path / "sessions"), "--out", str(root2), "--voxel",
                 "0.01", "--body", "none", "--target-faces", "800", "--no-texture", "--refine"]) == 0
    info2 = json.loads((root2 / "dataset.json").read_text())
    assert info2["build"]["fusion"]["refine"] is True
    assert info2["build"]["sessions"]["S00-P0"]["scan"] == "fused, extrinsics refined (kept where residuals fell)"
