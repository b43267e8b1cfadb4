"""`dressmeup edition create`: an edition pinned by the manifest sha256 of a user-built
dataset (written in the test with the real DatasetWriter), usable for validation, refused
on any other data."""

from __future__ import annotations

import json
import shutil

import pandas as pd
import pytest

from dressmeup.bench import load_edition, validate_submission
from dressmeup.bench.edition import create_edition
from dressmeup.cli import main
from dressmeup.errors import InputError
from dressmeup.io.hashing import sha256_file

from .conftest import gt_predictions, make_submission


def test_cli_creates_a_pinned_edition_that_validates(bench_data, tmp_path, capsys):
    out = tmp_path / "lab-retarget-v1.json"
    rc = main(["edition", "create", "--data", str(bench_data), "--task", "retarget",
               "--name", "lab-retarget-v1", "--out", str(out)])
    assert rc == 0 and "lab-retarget-v1" in capsys.readouterr().out
    raw = json.loads(out.read_text())
    assert raw["dataset"] == {"kind": "real", "name": "bench-fixture",
                              "manifest_sha256": sha256_file(bench_data / "manifest.parquet")}
    ed = load_edition(out)
    assert ed.task == "retarget" and ed.primary.metric == "p2s" and "ir" in ed.metrics
    assert "18 items" in ed.description
    preds = gt_predictions(bench_data, ed)
    sub = make_submission(tmp_path / "sub", preds, ed, "GT")
    assert validate_submission(sub, ed, bench_data).ok

    # the same data with one manifest row changed is not the edition's data
    other = tmp_path / "other"
    shutil.copytree(bench_data, other)
    m = pd.read_parquet(other / "manifest.parquet")
    m.loc[0, "garment_type"] = "shirt"
    m.to_parquet(other / "manifest.parquet", index=False)
    report = validate_submission(sub, ed, other)
    assert not report.ok and "manifest sha256" in report.summary()

    with pytest.raises(InputError, match="name must use"):
        create_edition(bench_data, "retarget", "bad name!")
    # never overwrites silently
    rc = main(["edition", "create", "--data", str(bench_data), "--task", "retarget",
               "--name", "lab-retarget-v1", "--out", str(out)])
    assert rc != 0 and "already exists" in capsys.readouterr().err


def test_create_refuses_empty_split_and_missing_data(bench_data, tmp_path):
    with pytest.raises(InputError, match="split 'val'"):
        create_edition(bench_data, "retarget", "x-v1", split="val")
    with pytest.raises(InputError, match="manifest.parquet"):
        (tmp_path / "empty").mkdir()
        create_edition(tmp_path / "empty", "retarget", "x-v1")
    ed = create_edition(bench_data, "retarget", "x-v1", metrics=["ed", "p2s"])
    assert ed.primary.metric == "ed" and ed.per_category == ("ed",)
