"""UV baselines run one job per mesh through an executor: on a 2-worker Dask LocalCluster
the submission holds the same UV maps as the in-process loop."""

from __future__ import annotations

import numpy as np


def test_uvparam_baseline_on_dask_matches_in_process(dask_cluster, tmp_path):
    from dressmeup import runs

    data = runs.build_data("synth-uvparam-mini-v1", tmp_path / "meshes")
    serial = runs.run_uvparam_baseline("lscm", "synth-uvparam-mini-v1", data, tmp_path / "s")
    dask = runs.run_uvparam_baseline("lscm", "synth-uvparam-mini-v1", data, tmp_path / "d",
                                     executor=dask_cluster)
    files = sorted(p.name for p in serial.glob("*.npz"))
    assert files and files == sorted(p.name for p in dask.glob("*.npz"))
    for name in files:
        with np.load(serial / name) as a, np.load(dask / name) as b:
            for key in ("uv", "uv_faces", "chart_ids"):
                assert np.array_equal(a[key], b[key]), (name, key)


def test_baseline_uvparam_command_on_an_existing_scheduler(dask_cluster, tmp_path):
    from dressmeup import runs
    from dressmeup.cli import main

    data = runs.build_data("synth-uvparam-mini-v1", tmp_path / "meshes")
    addr = dask_cluster.client.scheduler.address
    out = tmp_path / "sub"
    assert main(["baseline", "uvparam", "--method", "lscm", "--edition",
                 "synth-uvparam-mini-v1", "--data", str(data), "--out", str(out),
                 "--scheduler", addr]) == 0
    serial = runs.run_uvparam_baseline("lscm", "synth-uvparam-mini-v1", data, tmp_path / "s")
    for p in serial.glob("*.npz"):
        with np.load(p) as a, np.load(out / p.name) as b:
            assert np.array_equal(a["uv"], b["uv"])
    assert main(["baseline", "uvparam", "--method", "lscm", "--meshes", "sphere-2k", "--out",
                 str(tmp_path / "x"), "--executor", "dask"]) == 2
