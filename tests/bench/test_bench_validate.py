"""Validation reports every problem of a submission at once."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from dressmeup.bench import validate_submission
from dressmeup.cli import main


@pytest.fixture
def gt_sub(scored, tmp_path):
    sub = tmp_path / "sub"
    shutil.copytree(scored["gt"]["sub"], sub)
    return sub


def _pair_files(sub):
    return sorted(sub.glob("*.npz"))


def test_ground_truth_submission_is_valid(scored, bench_edition, bench_data):
    rep = validate_submission(scored["gt"]["sub"], bench_edition, bench_data)
    assert rep.ok, rep.summary()
    assert len(rep.items) == 18 and len(rep.files) == 18


def test_missing_nan_and_wrong_count_are_all_listed(gt_sub, bench_edition, bench_data, capsys):
    files = _pair_files(gt_sub)
    missing = files[0].stem
    files[0].unlink()
    V = np.load(files[1])["vertices"].copy()
    V[5, 1] = np.nan
    np.savez(files[1], vertices=V)
    V = np.load(files[2])["vertices"]
    np.savez(files[2], vertices=V[:-3])
    rep = validate_submission(gt_sub, bench_edition, bench_data)
    kinds = sorted((p.kind, p.item_id) for p in rep.problems)
    assert kinds == sorted([("missing", missing), ("invalid", files[1].stem),
                            ("invalid", files[2].stem)])
    text = rep.summary()
    assert "NaN" in text and f"{V.shape[0] - 3} rows, expected {V.shape[0]}" in text
    # The CLI prints the same report and exits non-zero.
    status = main(["validate-submission", str(gt_sub), "--edition", str(bench_edition),
                   "--data", str(bench_data)])
    err = capsys.readouterr().err
    assert status == 1
    assert missing in err and files[1].stem in err and files[2].stem in err


def test_every_other_kind_of_problem(gt_sub, bench_edition, bench_data, tmp_path):
    from dressmeup.io.mesh import save_mesh

    files = _pair_files(gt_sub)
    # extra id, stray file, unreadable file, duplicate answer, faces out of range (npz)
    shutil.copy(files[0], gt_sub / "S09-G09-P0__to__S09-G09-P1.npz")
    (gt_sub / "notes.txt").write_text("hello")
    files[1].write_bytes(b"not an npz")
    V = np.load(files[2])["vertices"]
    from dressmeup.data import Dataset

    src = Dataset(bench_data)[files[2].stem.split("__to__")[0]].garment()
    save_mesh(gt_sub / f"{files[2].stem}.ply", V, src.faces)
    F = src.faces.copy()
    F[0, 0] = 10_000
    np.savez(files[3], vertices=np.load(files[3])["vertices"], faces=F)
    np.savez(files[4], points=np.load(files[4])["vertices"])
    inf = np.load(files[5])["vertices"].copy()
    inf[0, 0] = np.inf
    np.savez(files[5], vertices=inf)
    info = json.loads((gt_sub / "submission.json").read_text())
    del info["hardware"], info["authors"]
    info["edition"] = "another-edition"
    (gt_sub / "submission.json").write_text(json.dumps(info))
    rep = validate_submission(gt_sub, bench_edition, bench_data)
    by_kind = {}
    for p in rep.problems:
        by_kind.setdefault(p.kind, []).append(str(p))
    assert len(by_kind["extra"]) == 2
    assert any("S09-G09-P0" in m for m in by_kind["extra"])
    assert any("notes.txt" in m for m in by_kind["extra"])
    assert len(by_kind["duplicate"]) == 1 and files[2].stem in by_kind["duplicate"][0]
    assert len(by_kind["unreadable"]) == 2   # garbage bytes, no 'vertices' array
    assert len(by_kind["invalid"]) == 2      # faces out of range, inf
    assert any("outside [0," in m for m in by_kind["invalid"])
    assert any("NaN/inf" in m for m in by_kind["invalid"])
    meta = " ".join(by_kind["metadata"])
    assert "hardware" in meta and "authors" in meta and "another-edition" in meta


def test_ply_with_source_faces_is_accepted_and_other_faces_refused(gt_sub, bench_edition,
                                                                    bench_data):
    from dressmeup.data import Dataset
    from dressmeup.io.mesh import save_mesh

    f0, f1 = _pair_files(gt_sub)[:2]
    ds = Dataset(bench_data)
    V0 = np.load(f0)["vertices"]
    F0 = ds[f0.stem.split("__to__")[0]].garment().faces
    f0.unlink()
    save_mesh(gt_sub / f"{f0.stem}.ply", V0, F0)
    V1 = np.load(f1)["vertices"]
    F1 = ds[f1.stem.split("__to__")[0]].garment().faces[:, [0, 2, 1]]
    f1.unlink()
    save_mesh(gt_sub / f"{f1.stem}.obj", V1, F1)
    rep = validate_submission(gt_sub, bench_edition, bench_data)
    assert [(p.kind, p.item_id) for p in rep.problems] == [("invalid", f1.stem)]
    assert "faces differ" in rep.problems[0].message


def test_size_limit_and_dataset_pin(scored, bench_data, tmp_path):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from conftest import write_edition

    small = write_edition(tmp_path / "small.json", options={"n_samples": 2000, "seed": 0,
                                                            "size_limit_mb": 0.001},
                          name="bench-fixture-small")
    rep = validate_submission(scored["gt"]["sub"], small, bench_data)
    kinds = {p.kind for p in rep.problems}
    assert {"size", "metadata"} <= kinds
    assert sum(p.kind == "size" for p in rep.problems) == 18
    other = write_edition(tmp_path / "other.json",
                          dataset={"kind": "generated", "generator": "bench-test-fixture",
                                   "generator_version": "1",
                                   "params": {"garments": 3, "poses": 5}, "seed": 1})
    rep = validate_submission(scored["gt"]["sub"], other, bench_data)
    msgs = [p.message for p in rep.problems if p.kind == "dataset"]
    assert len(msgs) == 3 and "poses=3, edition pins 5" in msgs[1] and "seed is 0" in msgs[0]
    assert "generate it with" in msgs[2]
    real = write_edition(tmp_path / "real.json",
                         dataset={"kind": "real", "manifest_sha256": "0" * 64})
    rep = validate_submission(scored["gt"]["sub"], real, bench_data)
    assert [p.kind for p in rep.problems] == ["dataset"]
    assert "manifest sha256" in rep.problems[0].message


def test_a_pinned_settings_override_matches_the_recorded_settings(bench_data, tmp_path):
    """An edition pins the overrides of a settings object (``{"dress": {"body_step": 0.04}}``);
    the generator records the complete settings: the data match when every pinned entry
    does, and not when one differs."""
    import json
    import shutil
    import sys
    from pathlib import Path

    from dressmeup.bench import load_edition
    from dressmeup.bench.tasks.common import check_pin

    sys.path.insert(0, str(Path(__file__).parent))
    from conftest import FIXTURE_GENERATOR, write_edition

    root = tmp_path / "data"
    shutil.copytree(bench_data, root)
    meta = json.loads((root / "dataset.json").read_text())
    full = {"body_step": 0.04, "near": 0.1, "cloth": {"youngs": 200.0, "tolerance": 0.001}}
    meta["generator"]["params"] = {**meta["generator"]["params"], "dress": full}
    (root / "dataset.json").write_text(json.dumps(meta))

    def pinned(dress):
        return load_edition(write_edition(
            tmp_path / "ed.json",
            dataset={"kind": "generated", "generator": FIXTURE_GENERATOR["name"],
                     "generator_version": FIXTURE_GENERATOR["version"],
                     "params": {**FIXTURE_GENERATOR["params"], "dress": dress}, "seed": 0}))

    assert check_pin(pinned({"body_step": 0.04}), root)[1] == []
    assert check_pin(pinned({"cloth": {"youngs": 200}}), root)[1] == []
    problems = check_pin(pinned({"body_step": 0.05}), root)[1]
    assert problems and "dress=" in problems[0]
