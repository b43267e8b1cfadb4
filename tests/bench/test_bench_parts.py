"""Withheld answers: public and private parts of an edition's data.

The tiny retargeting edition (v5: generator 4.0.0, the same bytes on every x86 CPU) is exported; the public part must hold no withheld answer (no
test scan, no target garment, no generator file of a test garment), every shipped
retargeting baseline must run on it alone, scoring must refuse it and score the private part
exactly as the full data. The registration and fusion rules are checked on the bench fixture.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dressmeup import runs
from dressmeup.bench import load_edition
from dressmeup.bench.parts import export_parts, leaks
from dressmeup.bench.scoring.score import score_submission
from dressmeup.bench.tasks.retarget.data import edition_pairs
from dressmeup.data import Dataset
from dressmeup.data.manifest import read_manifest, write_manifest
from dressmeup.data.parts import part_of
from dressmeup.data.validate import validate_dataset
from dressmeup.errors import InputError

#: generator 4.0.0: portable, so its private part is the pinned one on any x86 CPU
EDITION = "synth-retarget-tiny-v5"

_spec = importlib.util.spec_from_file_location(
    "bench_fixtures", Path(__file__).resolve().parent / "conftest.py")
bench_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench_fixtures)


@pytest.fixture(scope="module")
def tiny_parts(other_data, tmp_path_factory):
    from dressmeup.cache import cache_dir

    ed = load_edition(EDITION)
    full = runs.build_data(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}" / "full")
    other = other_data(ed, full) is not None
    base = tmp_path_factory.mktemp("parts")
    res = export_parts(ed, full, base / "public", base / "private", allow_other_data=other)
    return ed, full, base / "public", base / "private", res, other


def test_public_part_holds_no_answer(tiny_parts):
    ed, full, public, private, res, _ = tiny_parts
    assert part_of(public) == "public" and part_of(private) == "private"
    man = pd.read_parquet(public / "manifest.parquet")
    test = man[man["split"] == ed.split]
    assert test["scan_path"].isna().all()                  # every test scan withheld
    # no fitted, rest or stats file of a test garment (tiny has only test garments)
    assert not [p for p in (public / "generator").rglob("*") if p.is_file()] \
        if (public / "generator").exists() else True
    pairs = edition_pairs(ed, Dataset(public))
    sources = {p.source.sample_id for p in pairs}
    for r in test.itertuples():
        has_garment = isinstance(r.garment_path, str)
        assert has_garment == (r.sample_id in sources), r.sample_id
        assert isinstance(r.body_path, str)               # every target body is an input
    assert leaks(public, private) == []
    assert validate_dataset(public).ok and validate_dataset(private).ok
    # the private part carries the full manifest byte for byte (the edition's pin holds)
    assert (private / "manifest.parquet").read_bytes() == (full / "manifest.parquet").read_bytes()
    # v4 and v5 draw one source per test garment, disjoint from the targets: 6 pairs, no target
    # is another pair's source, so no answer is public
    assert len(res.public_answers) == 0 and len(pairs) == 6
    assert not sources & {p.target.sample_id for p in pairs}


def test_withheld_file_reads_say_private(tiny_parts):
    ed, _, public, _, _, _ = tiny_parts
    ds = Dataset(public)
    target = next(s for s in ds if s.split == ed.split and s.row.get("withheld")
                  and "garment" in s.row["withheld"])
    with pytest.raises(InputError, match="withheld.*private part"):
        target.garment()
    with pytest.raises(InputError, match="withheld"):
        target.scan()
    assert target.body() is not None


def test_leak_check_finds_copies(tiny_parts, tmp_path):
    """A withheld garment put into the public part (same bytes, moved rigidly, or with its
    vertices reordered) is found."""
    from dressmeup.io.mesh import load_mesh, save_mesh

    _, _, public, private, _, _ = tiny_parts
    pub = tmp_path / "public"
    shutil.copytree(public, pub)
    man = pd.read_parquet(private / "manifest.parquet")
    withheld = next(r.garment_path for r in man.itertuples()
                    if not (pub / r.garment_path).exists())
    m = load_mesh(private / withheld)
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    perm = np.random.default_rng(0).permutation(len(m.vertices))
    inv = np.argsort(perm)
    save_mesh(pub / "extra" / "moved.ply", m.vertices[perm] @ R.T + 0.3, inv[m.faces])
    found = leaks(pub, private)
    assert any(withheld in line and "rigid or reordered copy" in line for line in found)
    shutil.copyfile(private / withheld, pub / "extra" / "same.ply")
    assert any("the same bytes" in line for line in leaks(pub, private))


def test_scoring_refuses_the_public_part_and_matches_full_on_the_private(tiny_parts,
                                                                          tmp_path):
    ed, full, public, private, _, other = tiny_parts
    sub = runs.run_retarget_baseline("rigid", ed, public, tmp_path / "sub")
    with pytest.raises(InputError, match="public part.*private part"):
        score_submission(sub, ed, public, tmp_path / "res-public", workers=1)
    a = score_submission(sub, ed, private, tmp_path / "res-private", workers=1,
                         allow_other_data=other)
    b = score_submission(sub, ed, full, tmp_path / "res-full", workers=1,
                         allow_other_data=other)
    for m in ed.metrics:
        assert np.array_equal(a.table[m].to_numpy(), b.table[m].to_numpy()), m


def _untrained_weights(name: str, path, model):
    """A checkpoint of an untrained small network (the no-peeking test needs weights for the
    procedural body, which ships none)."""
    from dressmeup.methods.retarget import get_method

    m = get_method(name, width=16, depth=2, code_dim=8, pointnet_hidden=8, n_points=64,
                   dim=16)
    m.network_ = m.new_network()
    m.body_model_name_ = model
    return m.save(path)


def test_every_baseline_runs_on_the_public_part_alone(tiny_parts, tmp_path):
    """No retargeting baseline reads a withheld file: each runs on the public part (the
    withheld files are absent, so any read would fail)."""
    ed, _, public, _, _, _ = tiny_parts
    names = runs.retarget_methods()
    assert len(names) >= 8
    done = []
    for name in names:
        kw = {}
        base = name.split("+")[0]
        if base.startswith("isomap-refine"):
            kw["weights"] = str(_untrained_weights(base, tmp_path / f"{base}.pt", "procedural"))
            kw.update(width=16, depth=2, code_dim=8, pointnet_hidden=8, n_points=64, dim=16)
        sub = runs.run_retarget_baseline(name, ed, public, tmp_path / name.replace("+", "_"),
                                         **kw)
        info = json.loads((sub / "submission.json").read_text())
        assert info["method"] == name
        done.append(name)
    assert done == names


@pytest.fixture(scope="module")
def fixture_data(tmp_path_factory):
    base = tmp_path_factory.mktemp("fixture-parts")
    return bench_fixtures.build_fixture_dataset(base / "data"), base


def test_registration_rule_withholds_true_bodies(fixture_data):
    data, base = fixture_data
    ed = bench_fixtures.write_edition(base / "reg.json", name="fixture-registration-v1", task="registration",
                       metrics=["v2v", "mpjpe", "scan_p2s"], primary_metric="v2v",
                       per_category=["v2v"])
    export_parts(ed, data, base / "reg-public", base / "reg-private")
    man = pd.read_parquet(base / "reg-public" / "manifest.parquet")
    assert man["body_path"].isna().all() and man["garment_path"].isna().all()
    assert man["scan_path"].notna().all()
    assert leaks(base / "reg-public", base / "reg-private") == []
    assert validate_dataset(base / "reg-public").ok


def test_fusion_rule_gives_captures_instead_of_scans(fixture_data):
    data, base = fixture_data
    ed = bench_fixtures.write_edition(base / "fusion.json", name="fixture-fusion-v1", task="fusion",
                       metrics=["chamfer_l1", "accuracy", "completeness"],
                       primary_metric="chamfer_l1", per_category=["chamfer_l1"])
    # three items are enough to check the rule (each renders a 7-camera capture)
    man = pd.read_parquet(data / "manifest.parquet")
    small = base / "fusion-data"
    shutil.copytree(data, small)
    for g in ("G02", "G03"):
        shutil.rmtree(small / "samples" / "S01" / g)
    keep = man[man["garment_id"] == "G01"]
    rows = [r for r in read_manifest(data / "manifest.parquet").to_pylist()
            if r["garment_id"] == "G01"]
    write_manifest(small / "manifest.parquet", rows)
    res = export_parts(ed, small, base / "fus-public", base / "fus-private")
    pub = base / "fus-public"
    sessions = sorted(p.name for p in (pub / "captures").iterdir())
    assert sessions == sorted(keep["sample_id"])
    for s in sessions:
        assert not (pub / "captures" / s / "ground_truth").exists()
        T = json.loads((pub / "captures" / s / "sample_to_world.json").read_text())
        assert np.asarray(T["sample_to_world"]).shape == (4, 4)
    assert pd.read_parquet(pub / "manifest.parquet")["scan_path"].isna().all()
    assert leaks(pub, base / "fus-private") == []
    assert res.parts.public_files > 3


def test_stats_copies_leave_out_timings_at_any_depth(tmp_path):
    """Two builds differ in the CPU seconds they record (generator 3.x per stage): the parts
    copy their statistics without them, so the archives are the same bytes."""
    from dressmeup.data.parts import _copy_stats

    a = {"energy": 1.5, "cpu_s": 3.0, "dress": {"steps": 4, "cpu_s": 22.9},
         "runs": [{"wall_s": 1.0, "iterations": 7}]}
    b = {"energy": 1.5, "cpu_s": 4.0, "dress": {"steps": 4, "cpu_s": 23.4},
         "runs": [{"wall_s": 2.0, "iterations": 7}]}
    for name, data in (("a", a), ("b", b)):
        (tmp_path / f"{name}.json").write_text(json.dumps(data))
        _copy_stats(tmp_path / f"{name}.json", tmp_path / f"{name}-copy.json")
    assert (tmp_path / "a-copy.json").read_bytes() == (tmp_path / "b-copy.json").read_bytes()
    assert json.loads((tmp_path / "a-copy.json").read_text()) == {
        "energy": 1.5, "dress": {"steps": 4}, "runs": [{"iterations": 7}]}


def test_generator_files_of_a_split_include_its_garments_failed_targets(tmp_path):
    """Generator 4 writes a garment's plan, its rest mesh, its samples' stats and its failed
    targets (no manifest row) under generator/: all are the garment's files."""
    from dressmeup.bench.parts import _generator_files

    names = ["garments/G07.json", "rest/G07.ply", "stats/S01-G07-P2.json",
             "failed/S05-G07-P3.json", "fitted/G07-S02.ply", "garments/G08.json",
             "stats/S01-G08-P2.json", "failed/S05-G08-P3.json"]
    for n in names:
        (tmp_path / "generator" / n).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "generator" / n).write_text("{}")
    got = set(_generator_files(tmp_path, {"G07", "S01-G07-P2"}))
    assert got == {f"generator/{n}" for n in names if "G07" in n}
