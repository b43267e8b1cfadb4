"""Retargeting baselines run one job per pair through an executor: on a 2-worker Dask
LocalCluster the predictions are bit-identical to the in-process loop."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def tiny_data(tiny_retarget_data):
    return tiny_retarget_data


@pytest.mark.parametrize("name", ["skinning", "skinning+detail"])
def test_predict_pairs_on_dask_matches_in_process(dask_cluster, tiny_data, name):
    from dressmeup.data import Dataset
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.run import predict_pairs

    pairs = Dataset(tiny_data).retarget_pairs("test")
    serial, _ = predict_pairs(get_method(name), pairs)
    dask, seconds = predict_pairs(get_method(name), pairs, executor=dask_cluster)
    assert list(dask) == [p.pair_id for p in pairs] == list(serial)
    assert len(seconds) == len(pairs)
    for pid in serial:
        assert np.array_equal(serial[pid], dask[pid])


def test_predict_pairs_raises_a_pair_error(tiny_data):
    from dressmeup.data import Dataset
    from dressmeup.methods.retarget.run import predict_pairs

    class Broken:
        name = "broken"

        def retarget(self, *a):
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        predict_pairs(Broken(), Dataset(tiny_data).retarget_pairs("test"))


def test_baseline_retarget_command_on_an_existing_scheduler(dask_cluster, tiny_data, tmp_path):
    from dressmeup.cli import main
    from dressmeup.data import Dataset
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.run import predict_pairs

    addr = dask_cluster.client.scheduler.address
    out = tmp_path / "sub"
    assert main(["baseline", "retarget", "--method", "skinning", "--data", str(tiny_data),
                 "--edition", "synth-retarget-tiny-v5", "--out", str(out),
                 "--scheduler", addr]) == 0
    from dressmeup.bench import load_edition
    from dressmeup.bench.tasks.retarget.data import edition_pairs

    pairs = edition_pairs(load_edition("synth-retarget-tiny-v5"), Dataset(tiny_data))
    serial, _ = predict_pairs(get_method("skinning"), pairs)
    for pid, V in serial.items():
        with np.load(out / f"{pid}.npz") as z:
            assert np.array_equal(z["vertices"], V)
