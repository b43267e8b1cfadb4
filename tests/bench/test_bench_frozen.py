"""Frozen expected scores of every task: a seeded, perturbed submission on fixed data keeps
its numbers to 1e-6 (relative).

The values live in ``tests/bench/frozen/<task>.json``; ``tests/bench/frozen/CHANGES.md`` says,
with a date, why a frozen value ever changed (a changed number without a line there is a
regression). The retarget values are checked in ``test_bench_score.py`` from the same folder.

To print the current values (after a deliberate change, to update the JSON and CHANGES.md)::

    DRESSMEUP_PRINT_FROZEN=1 python -m pytest tests/bench/test_bench_frozen.py -s
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from dressmeup.bench import score_submission, write_submission

FROZEN = Path(__file__).parent / "frozen"


def frozen(task: str) -> dict:
    """The frozen values of ``task`` (``tests/bench/frozen/<task>.json``)."""
    return json.loads((FROZEN / f"{task}.json").read_text())


def _edition(tmp_path, task, metrics, options):
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_conftest", Path(__file__).parent / "conftest.py")
    helpers = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(helpers)
    write_edition = helpers.write_edition

    return write_edition(tmp_path / f"{task}.json", name=f"bench-fixture-{task}-v1", task=task,
                         metrics=metrics, options=options, primary_metric=metrics[0],
                         per_category=[])


def _check(task: str, summary: dict) -> None:
    got = {m: v["mean"] for m, v in summary["metrics"].items()}
    if os.environ.get("DRESSMEUP_PRINT_FROZEN"):
        print(f"\n{task}: " + json.dumps(got, indent=2))
    want = frozen(task)
    assert set(want["metrics"]) == set(got), task
    for m, v in want["metrics"].items():
        assert got[m] == pytest.approx(v, rel=1e-6, abs=1e-12), f"{task} {m}"


def test_frozen_registration(bench_data, tmp_path):
    from dressmeup.data import Dataset

    ed = _edition(tmp_path, "registration", ["v2v", "mpjpe", "scan_p2s"],
                  {"n_samples": 2000, "seed": 0})
    rng = np.random.default_rng(11)
    sub = tmp_path / "sub"
    sub.mkdir()
    for s in Dataset(bench_data):
        b = s.body()
        b.transl = b.transl + rng.normal(0.0, 0.005, 3)
        b.pose = b.pose + rng.normal(0.0, 0.02, b.pose.shape)
        b.save(sub / f"{s.sample_id}.npz")
    write_submission(sub, {}, edition=ed, method="perturbed", overwrite=True)
    res = score_submission(sub, ed, bench_data, tmp_path / "r", workers=1, show_progress=False)
    _check("registration", res.summary)


def test_frozen_correspondence(bench_data, tmp_path):
    from dressmeup.data import Dataset

    ed = _edition(tmp_path, "correspondence", ["richness"], {"k": 5, "max_vertices": 150, "seed": 0})
    rng = np.random.default_rng(12)
    preds = {}
    for s in Dataset(bench_data):
        V = s.garment().vertices
        preds[s.sample_id] = {"embedding": np.c_[V, V[:, :1] * V[:, 1:2]] + rng.normal(0, 0.02, (len(V), 4))}
    sub = write_submission(tmp_path / "sub", preds, edition=ed, method="xyz+noise")
    res = score_submission(sub, ed, bench_data, tmp_path / "r", workers=1, show_progress=False)
    _check("correspondence", res.summary)


def test_frozen_fusion(bench_data, tmp_path):
    from dressmeup.data import Dataset
    from dressmeup.io.mesh import save_mesh

    ed = _edition(tmp_path, "fusion", ["accuracy", "completeness", "chamfer_l1", "fscore_1mm",
                                       "fscore_5mm"], {"n_samples": 3000, "seed": 0})
    rng = np.random.default_rng(13)
    sub = tmp_path / "sub"
    sub.mkdir()
    for s in Dataset(bench_data):
        V, F = s.scan()
        keep = F[rng.random(len(F)) > 0.1]  # a reconstruction with holes and noise
        save_mesh(sub / f"{s.sample_id}.ply", V + rng.normal(0, 0.002, V.shape), keep)
    write_submission(sub, {}, edition=ed, method="scan+noise", overwrite=True)
    res = score_submission(sub, ed, bench_data, tmp_path / "r", workers=1, show_progress=False)
    _check("fusion", res.summary)


def test_frozen_uvparam(tmp_path):
    from dressmeup import runs
    from dressmeup.bench.tasks.uvparam.data import meshes
    from dressmeup.io.mesh import load_mesh

    ed = tmp_path / "uv.json"
    ed.write_text(json.dumps({
        "name": "uv-frozen-v1", "version": 1, "task": "uvparam",
        "dataset": {"kind": "generated", "generator": "dressmeup-uvparam-shapes",
                    "generator_version": "uvparam-shapes-v1",
                    "params": {"mesh_ids": ["sheet-2k", "sphere-2k"]}, "seed": 0},
        "split": "test", "metrics": ["qce", "qce_max", "ase", "flip", "overlap", "zero_area"],
        "options": {"overlap_resolution": 256}}))
    data = runs.build_data(ed, tmp_path / "meshes")
    rng = np.random.default_rng(14)
    preds = {}
    for m in meshes(data):
        V = load_mesh(m.path).vertices
        # a per-vertex projection: planar for the sheet, folded (flips, overlaps) for the sphere
        uv = V[:, [0, 2]] + rng.normal(0, 0.002, (len(V), 2))
        preds[m.mesh_id] = {"uv": uv}
    sub = write_submission(tmp_path / "sub", preds, edition=ed, method="projection")
    res = score_submission(sub, ed, data, tmp_path / "r", workers=1, show_progress=False)
    _check("uvparam", res.summary)
