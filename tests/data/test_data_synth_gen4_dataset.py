"""Generator 4.0.0 writes a dataset: sources declared, parameters and secret kept out of
dataset.json, failures recorded, resumable, train and val without the secret."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from dressmeup.bench.tasks.retarget.data import sample_pairs
from dressmeup.data import Dataset
from dressmeup.data.synth import generate_dataset
from dressmeup.data.synth.secret import commitment

SECRET = bytes(range(32))
SETTINGS = dict(
    version="4.0.0", body_model="procedural", edge_length=0.07, write_scan=False,
    texture_size=16, workers=2,
    plan={"bodies": [5, 0, 5], "poses_per_family": [1, 0, 1], "garments": [1, 0, 1],
          "categories": ["bottomwear"], "families": ["standing", "walking"], "fits": ["loose"],
          "targets": {"re-pose": [0, 0, 1], "re-shape": [1, 0, 1], "cross": [0, 0, 1]}},
    motion={"rest_frames": 2, "shape_frames": 4, "pose_frames": 6, "settle_frames": 2})


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return generate_dataset(tmp_path_factory.mktemp("g4") / "d", secret=SECRET, **SETTINGS)


def test_dataset_records_sources_not_secrets(root):
    info = json.loads((root / "dataset.json").read_text())
    assert info["generator"]["params"]["test_split_commitment"] == commitment(SECRET)
    assert SECRET.hex() not in (root / "dataset.json").read_text()
    ds = Dataset(root)
    rows = ds.manifest
    assert set(rows["split"]) == {"train", "test"}
    for gid, g in info["garments"].items():
        assert "params" not in g
        plan = json.loads((root / "generator" / "garments" / f"{gid}.json").read_text())
        assert plan["params"]["offset"] >= 0.018  # loose
        src = g["source"]
        failed = (root / "generator" / "failed" / f"{src}.json").is_file()
        assert failed or src in set(rows["sample_id"])
        written = sorted(rows[rows["garment_id"] == gid]["sample_id"])
        planned = sorted(f"{s}-{gid}-{p}" for s, p, _ in plan["targets"])
        recorded = sorted(p.stem for p in (root / "generator" / "failed").glob(f"*-{gid}-*"))
        assert sorted(written + recorded) == planned


def test_pairs_from_declared_sources(root):
    ds = Dataset(root)
    info = ds.info
    declared = {g: v["source"] for g, v in info["garments"].items()}
    pairs = sample_pairs(ds.retarget_pairs("test"), {
        "seed": 0, "per_track": {"re-pose": 1, "re-shape": 1, "cross": 1},
        "sources": "dataset"}, declared)
    assert pairs, "the test garment's pairs"
    for p in pairs:
        assert p.source.sample_id == declared[p.source.garment_id]
    assert {p.track for p in pairs} <= {"re-pose", "re-shape", "cross"}


def test_samples_are_plausible(root):
    for path in sorted((root / "generator" / "stats").glob("*.json")):
        st = json.loads(path.read_text())
        assert st["generator"] == "4.0.0" and st["motion"]["pose_frames"] == 6
        assert st["intersection_free"] and st["inside_area_pct"] == 0.0, path.name


def test_resume_and_public_splits_alone(root, tmp_path):
    from dressmeup.bench.tasks.common import manifest_sha256

    before = manifest_sha256(root)
    generate_dataset(root, secret=SECRET, **SETTINGS)  # nothing left to do
    assert manifest_sha256(root) == before
    alone = generate_dataset(tmp_path / "public", splits=("train", "val"), **SETTINGS)
    rows = Dataset(alone).manifest
    full = Dataset(root).manifest
    assert set(rows["split"]) == {"train"}
    assert sorted(rows["sample_id"]) == sorted(full[full["split"] == "train"]["sample_id"])
    assert sorted(rows["garment_sha256"]) == sorted(
        full[full["split"] == "train"]["garment_sha256"])


def test_designed_garments_are_the_generated_rest_garments(root, tmp_path):
    """``write_designed`` writes the rest garments and plan records of a full generation,
    byte for byte, without a motion; the test split only with the secret; and the neural
    UV training script reads them per split."""
    import importlib.util

    from dressmeup.data.synth import synth_config
    from dressmeup.data.synth.designed4 import (
        DESIGNED_JSON,
        designed_garments,
        garment_record,
        write_designed,
    )
    from dressmeup.errors import InputError

    settings = {k: v for k, v in SETTINGS.items() if k != "workers"}
    out = write_designed(tmp_path / "designed", synth_config(**settings, secret=SECRET),
                         workers=2)
    for sub in ("rest", "garments"):
        made = sorted(p.name for p in (out / "generator" / sub).iterdir())
        assert made == sorted(p.name for p in (root / "generator" / sub).iterdir()) and made
        for name in made:
            assert (out / "generator" / sub / name).read_bytes() == \
                (root / "generator" / sub / name).read_bytes(), f"{sub}/{name}"
    assert not (out / "generator" / "stats").exists()
    info = json.loads((out / DESIGNED_JSON).read_text())
    assert info["generator"]["version"] == "4.0.0"
    assert {g["split"] for g in info["garments"].values()} == {"train", "test"}
    assert SECRET.hex() not in (out / DESIGNED_JSON).read_text()

    with pytest.raises(InputError, match="secret"):
        write_designed(tmp_path / "no-secret", synth_config(**settings))
    public = write_designed(tmp_path / "public", synth_config(**settings,
                                                              splits=("train", "val")))
    assert sorted(p.name for p in (public / "generator" / "rest").iterdir()) == \
        sorted(f"{g}.ply" for g, v in info["garments"].items() if v["split"] == "train")

    script = Path(__file__).resolve().parents[2] / "benchmarks" / "train_uvparam_pretrained.py"
    spec = importlib.util.spec_from_file_location("train_uvparam_pretrained", script)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    meshes, ids = mod.garment_meshes(public, "train", ("bottomwear",))
    assert ids == [g for g, v in sorted(info["garments"].items()) if v["split"] == "train"]
    assert meshes[0][0].shape[1] == 3 and meshes[0][1].shape[1] == 3
    assert mod.garment_meshes(public, "val", ("bottomwear",)) == ([], [])
    assert designed_garments(root, "test") == [
        (g, v, root / "generator" / "rest" / f"{g}.ply")
        for g, v in sorted(json.loads((root / "dataset.json").read_text())["garments"].items())
        if v["split"] == "test"]
    with pytest.raises(InputError, match="neither"):
        garment_record(tmp_path / "no-secret")
