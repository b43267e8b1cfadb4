"""The other tasks: uvparam, registration, correspondence, fusion (validation + analytic
scores on the fixture dataset)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from dressmeup.bench import score_submission, validate_submission, write_submission


def _fixture_edition(tmp_path, task, metrics, options=None, name=None):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from conftest import write_edition

    return write_edition(tmp_path / f"{task}.json", name=name or f"bench-fixture-{task}-v1",
                         task=task, metrics=metrics, options=options or {},
                         primary_metric=metrics[0], per_category=[])


def test_registration_true_bodies_score_zero_and_shift_scores_its_size(bench_data, tmp_path):
    from dressmeup.data import Dataset

    ed = _fixture_edition(tmp_path, "registration", ["v2v", "mpjpe", "scan_p2s"],
                          {"n_samples": 2000, "seed": 0})
    ds = Dataset(bench_data)
    for name, shift in (("true", 0.0), ("shifted", 0.01)):
        sub = tmp_path / name
        sub.mkdir()
        for s in ds:
            b = s.body()
            b.transl = b.transl + np.array([shift, 0.0, 0.0])
            b.save(sub / f"{s.sample_id}.npz")
        write_submission(sub, {}, edition=ed, method=name, overwrite=True)
        res = score_submission(sub, ed, bench_data, tmp_path / f"r-{name}", workers=1,
                               show_progress=False)
        m = res.summary["metrics"]
        assert m["v2v"]["mean"] == pytest.approx(shift, abs=1e-9)
        assert m["mpjpe"]["mean"] == pytest.approx(shift, abs=1e-9)
        assert 0 < m["scan_p2s"]["mean"] < 0.1
    (sub / f"{ds[0].sample_id}.npz").write_bytes(b"junk")
    rep = validate_submission(sub, ed, bench_data)
    assert [p.kind for p in rep.problems] == ["unreadable"]


def test_correspondence_positions_beat_a_random_embedding(bench_data, tmp_path):
    from dressmeup.data import Dataset

    ed = _fixture_edition(tmp_path, "correspondence", ["richness"],
                          {"k": 5, "max_vertices": 150, "seed": 0})
    ds = Dataset(bench_data)
    rng = np.random.default_rng(0)
    scores = {}
    for name in ("xyz", "random"):
        preds = {}
        for s in ds:
            V = s.garment().vertices
            preds[s.sample_id] = {"embedding": V if name == "xyz" else rng.normal(size=(len(V), 8))}
        sub = write_submission(tmp_path / name, preds, edition=ed, method=name)
        res = score_submission(sub, ed, bench_data, tmp_path / f"r-{name}", workers=1,
                               show_progress=False)
        scores[name] = res.summary["metrics"]["richness"]["mean"]
    assert 0 <= scores["xyz"] < 0.5 * scores["random"]
    bad = tmp_path / "bad"
    shutil.copytree(tmp_path / "xyz", bad)
    f = next(bad.glob("*.npz"))
    np.savez(f, embedding=np.zeros((3, 8)))
    rep = validate_submission(bad, ed, bench_data)
    assert [(p.kind, p.item_id) for p in rep.problems] == [("invalid", f.stem)]


def test_fusion_scan_as_reconstruction_is_perfect(bench_data, tmp_path):
    from dressmeup.data import Dataset
    from dressmeup.io.mesh import save_mesh

    ed = _fixture_edition(tmp_path, "fusion", ["accuracy", "completeness", "chamfer_l1",
                                               "fscore_1mm"], {"n_samples": 3000, "seed": 0})
    sub = tmp_path / "sub"
    sub.mkdir()
    for s in Dataset(bench_data):
        V, F = s.scan()
        save_mesh(sub / f"{s.sample_id}.ply", V, F)
    write_submission(sub, {}, edition=ed, method="scan", overwrite=True)
    res = score_submission(sub, ed, bench_data, tmp_path / "r", workers=1, show_progress=False)
    m = res.summary["metrics"]
    assert m["accuracy"]["mean"] < 1e-6 and m["completeness"]["mean"] < 1e-6
    assert m["fscore_1mm"]["mean"] == 1.0


def test_uvparam_mesh_set_validation_and_scores(tmp_path):
    from dressmeup import runs

    ed_path = tmp_path / "uv.json"
    ed_path.write_text(json.dumps({
        "name": "uv-test-v1", "version": 1, "task": "uvparam",
        "dataset": {"kind": "generated", "generator": "dressmeup-uvparam-shapes",
                    "generator_version": "uvparam-shapes-v1",
                    "params": {"mesh_ids": ["sheet-2k", "sphere-2k"]}, "seed": 0},
        "split": "test", "metrics": ["qce", "ase", "flip", "overlap", "time"],
        "options": {"overlap_resolution": 256}}))
    data = runs.build_data(ed_path, tmp_path / "meshes")
    sub = runs.run_uvparam_baseline("lscm", ed_path, data, tmp_path / "lscm")
    assert validate_submission(sub, ed_path, data).ok
    res = score_submission(sub, ed_path, data, tmp_path / "r", workers=1, show_progress=False)
    t = res.table.set_index("sample_id")
    assert set(t.index) == {"sheet-2k", "sphere-2k"}
    assert (t["qce"] >= 1.0).all() and (t["qce"] < 2.0).all()
    assert (t["flip"] == 0).all() and (t["time"] > 0).all()
    # A UV map with the wrong face count and a NaN is refused, listing both files.
    z = dict(np.load(sub / "sheet-2k.npz"))
    z["uv_faces"] = z["uv_faces"][:-1]
    np.savez(sub / "sheet-2k.npz", **z)
    z = dict(np.load(sub / "sphere-2k.npz"))
    z["uv"][3] = np.nan
    np.savez(sub / "sphere-2k.npz", **z)
    rep = validate_submission(sub, ed_path, data)
    assert sorted(p.item_id for p in rep.problems) == ["sheet-2k", "sphere-2k"]
