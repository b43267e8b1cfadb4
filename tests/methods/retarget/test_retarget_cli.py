"""``dressmeup baseline retarget`` writes a submission the benchmark core accepts."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def tiny_data(tiny_retarget_data):
    return tiny_retarget_data


@pytest.mark.parametrize("method", ["rigid", "skinning+detail"])
def test_cli_writes_valid_submission(tiny_data, tmp_path, method):
    from dressmeup.bench import load_edition, validate_submission
    from dressmeup.bench.tasks.retarget.data import edition_pairs
    from dressmeup.cli import main
    from dressmeup.data import Dataset

    out = tmp_path / "sub"
    status = main(["baseline", "retarget", "--method", method, "--data", str(tiny_data),
                   "--edition", "synth-retarget-tiny-v5", "--out", str(out)])
    assert status == 0
    report = validate_submission(out, "synth-retarget-tiny-v5", tiny_data)
    assert report.ok, report
    pairs = edition_pairs(load_edition("synth-retarget-tiny-v5"), Dataset(tiny_data))
    assert sorted(p.name for p in out.glob("*.npz")) == sorted(f"{p.pair_id}.npz" for p in pairs)
    for p in pairs:
        with np.load(out / f"{p.pair_id}.npz") as z:
            assert z["vertices"].shape == p.source.garment().vertices.shape


def test_cli_rejects_bad_param(tiny_data, tmp_path, capsys):
    from dressmeup.cli import main

    status = main(["baseline", "retarget", "--method", "skinning", "--param", "nope=1", "--data",
                   str(tiny_data), "--edition", "synth-retarget-tiny-v5", "--out", str(tmp_path / "s")])
    assert status == 2
    assert "unknown hyperparameter" in capsys.readouterr().err
