"""build-dataset on Dask distributed (2-worker LocalCluster on loopback): one job per
session, samples written by the client in session order, resumable, no worker crash."""

from __future__ import annotations

import json
import os
import shutil

import pandas as pd
import pytest

pytest.importorskip("distributed")

from dressmeup.cli import main  # noqa: E402


def test_build_dataset_on_dask_writes_every_session_once_and_resumes(dask_cluster, tmp_path,
                                                                    capsys):
    s0 = tmp_path / "sessions" / "S00-P0"
    assert main(["synth-capture", "mannequin", "--out", str(s0), "--scale", "0.25",
                 "--seed", "1"]) == 0
    s1 = tmp_path / "sessions" / "S00-P1"  # the same capture as another pose
    shutil.copytree(s0, s1)
    info = json.loads((s1 / "session.json").read_text())
    (s1 / "session.json").write_text(json.dumps({**info, "pose_id": "P1"}))
    root = tmp_path / "dataset"
    args = ["build-dataset", str(tmp_path / "sessions"), "--out", str(root), "--voxel",
            "0.01", "--body", "none", "--target-faces", "800", "--no-texture"]
    from dressmeup.data.from_captures import build_dataset_from_sessions
    from dressmeup.extraction.pipeline import ExtractionConfig
    from dressmeup.fusion.pipeline import FusionConfig

    ex = dask_cluster
    pids = ex.client.run(os.getpid)
    report = build_dataset_from_sessions(
        [tmp_path / "sessions"], root, fusion_config=FusionConfig(voxel_size=0.01),
        extraction_config=ExtractionConfig(target_faces=800, texture=False), body="none",
        executor=ex)
    assert ex.client.run(os.getpid) == pids  # no worker crashed (and was restarted)
    assert (report.written, report.skipped, report.failed) == (4, 0, [])
    man = pd.read_parquet(root / "manifest.parquet")
    # the client writes in session order, garments in session.json order: as a serial run
    assert list(man["sample_id"]) == ["S00-G-top-P0", "S00-G-pants-P0", "S00-G-top-P1",
                                      "S00-G-pants-P1"]
    # resuming through the command line switch: nothing to do, no cluster needed for it
    assert main([*args, "--executor", "dask", "--workers", "2"]) == 0
    assert "0 sample(s) written, 4 already present" in capsys.readouterr().out
