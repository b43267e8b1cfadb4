"""UV baselines run one job per mesh through an executor: on a 2-worker Dask LocalCluster
the submission holds the same UV maps as the in-process loop."""

from __future__ import annotations

import numpy as np


def test_uvparam_baseline_on_dask_matches_in_process(dask_cluster, tmp_path):
    from dressmeup.bench import runs

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
