"""Layout, manifest, writer, Dataset API, splits and the validator (no body model needed)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pyarrow.parquet as pq
import pytest

from dressmeup.data import Dataset, DatasetWriter, layout, split_by_garment, validate_dataset
from dressmeup.data.manifest import MANIFEST_VERSION, VERSION_KEY, read_manifest, write_manifest
from dressmeup.errors import InputError


def _grid(n=6, seed=0):
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    V = np.stack([u.ravel(), v.ravel(), 0.01 * rng.standard_normal(n * n)], 1)
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j
            F += [[a, a + 1, a + n], [a + 1, a + n + 1, a + n]]
    return V, np.array(F), np.stack([u.ravel(), v.ravel()], 1)


def _body(pose_seed):
    return {"model": np.array("procedural"), "gender": np.array("neutral"),
            "shape": np.full(6, 0.5), "pose": np.random.default_rng(pose_seed).normal(0, .1, (22, 3)),
            "transl": np.zeros(3), "scale": np.array(1.0)}


def make_tiny(root, garments=("G01", "G02"), poses=("P1", "P2", "P3")):
    splits = {"G01": "train", "G02": "test", "G03": "val"}
    w = DatasetWriter(root, {"name": "tiny", "licence": "CC0"})
    for gi, g in enumerate(garments):
        for pi, p in enumerate(poses):
            V, F, uv = _grid(6, seed=10 * gi + pi)
            w.add_sample(subject_id="S01", garment_id=g, pose_id=p, category="topwear",
                         garment_type="t-shirt", split=splits[g], garment=(V, F, uv),
                         body=_body(pi), scan=(V + 0.01, F),
                         texture=np.full((4, 4, 3), 200, np.uint8))
    w.finalize()
    return root


def test_ids_and_paths(tmp_path):
    assert layout.make_sample_id("S01", "G03", "P2") == "S01-G03-P2"
    for bad in ("a b", "a/b", "", "..", "é"):
        with pytest.raises(InputError):
            layout.check_id(bad)
    for bad in ("../x.ply", "/etc/passwd", "samples/../../x", "C:/x"):
        with pytest.raises(InputError):
            layout.resolve_inside(tmp_path, bad)
    (tmp_path / "samples").mkdir()
    (tmp_path / "samples" / "link").symlink_to(tmp_path.parent)
    with pytest.raises(InputError, match="outside"):
        layout.resolve_inside(tmp_path, "samples/link/x.ply")
    assert layout.resolve_inside(tmp_path, "samples/a.ply") == (tmp_path / "samples/a.ply").resolve()


def test_writer_dataset_roundtrip(tmp_path):
    root = make_tiny(tmp_path / "ds")
    info = json.loads((root / "dataset.json").read_text())
    assert info["complete"] and info["n_samples"] == 6 and info["units"] == "m"
    assert info["splits"] == {"test": ["G02"], "train": ["G01"]}
    table = pq.read_table(root / "manifest.parquet")
    assert table.schema.metadata[VERSION_KEY].decode() == MANIFEST_VERSION
    ds = Dataset(root)
    assert len(ds) == 6
    s = ds["S01-G01-P2"]
    assert (s.garment_id, s.pose_id, s.split) == ("G01", "P2", "train")
    V, F, uv = _grid(6, seed=1)
    g = s.garment()
    np.testing.assert_allclose(g.vertices, V, atol=0)
    np.testing.assert_array_equal(g.faces, F)
    np.testing.assert_allclose(g.uv[g.uv_faces], uv[F], atol=0)
    assert g.texture_path is not None and g.texture_path.name == "garment.png"
    b = s.body()
    np.testing.assert_allclose(b.pose, _body(1)["pose"])
    sv, sf = s.scan()
    np.testing.assert_allclose(sv, V + 0.01)
    assert ds.manifest["topology_shared"].all()
    assert len(ds.filter(split="test")) == 3 and len(ds.filter(garment=["G01", "G02"], pose="P1")) == 2
    assert {x.sample_id for x in ds.filter(category="bottomwear")} == set()
    assert validate_dataset(root).ok


def test_retarget_pairs(tmp_path):
    root = make_tiny(tmp_path / "ds", poses=("P1", "P2", "P3", "P4", "P5"))
    ds = Dataset(root)
    pairs = ds.retarget_pairs("test")
    assert len(pairs) == 20  # 5 poses -> 20 ordered pairs
    ids = {p.pair_id for p in pairs}
    assert "S01-G02-P1__to__S01-G02-P5" in ids and "S01-G02-P5__to__S01-G02-P1" in ids
    assert all(p.source.garment_id == p.target.garment_id == "G02" for p in pairs)
    assert all(p.source.pose_id != p.target.pose_id for p in pairs)
    assert len(ds.retarget_pairs()) == 40


def test_torch_wrapper(tmp_path):
    torch = pytest.importorskip("torch")
    ds = Dataset(make_tiny(tmp_path / "ds"))
    tds = ds.torch()
    item = tds[0]
    assert item["vertices"].shape == (36, 3) and item["faces"].dtype == torch.int64
    assert item["body_pose"].shape == (22, 3)
    loader = torch.utils.data.DataLoader(tds, batch_size=1)
    assert len(list(loader)) == 6
    assert isinstance(tds, torch.utils.data.Dataset)


def test_writer_refuses_duplicates_and_mixed_splits(tmp_path):
    root = make_tiny(tmp_path / "ds")
    w = DatasetWriter(root, {"name": "tiny", "licence": "CC0"})
    V, F, _ = _grid()
    with pytest.raises(InputError, match="already"):
        w.add_sample(subject_id="S01", garment_id="G01", pose_id="P1", category="topwear",
                     garment_type="t-shirt", split="train", garment=(V, F))
    with pytest.raises(InputError, match="split"):
        w.add_sample(subject_id="S01", garment_id="G01", pose_id="P9", category="topwear",
                     garment_type="t-shirt", split="test", garment=(V, F))
    with pytest.raises(InputError, match="different dataset"):
        DatasetWriter(root, {"name": "other"})
    with pytest.raises(InputError):
        w.add_sample(subject_id="S 1", garment_id="G01", pose_id="P9", category="topwear",
                     garment_type="t-shirt", split="train", garment=(V, F))


def test_interrupted_build_resumes_without_duplicates(tmp_path, monkeypatch):
    import dressmeup.data.writer as wmod

    root = tmp_path / "ds"
    calls = {"n": 0}
    real = wmod.write_manifest

    def failing(path, rows):
        calls["n"] += 1
        if calls["n"] == 3:  # die after the 3rd sample's files, before its manifest row
            raise KeyboardInterrupt
        real(path, rows)

    monkeypatch.setattr(wmod, "write_manifest", failing)
    with pytest.raises(KeyboardInterrupt):
        make_tiny(root)
    monkeypatch.setattr(wmod, "write_manifest", real)
    assert len(read_manifest(root / "manifest.parquet")) == 2
    rep = validate_dataset(root)
    assert rep.ok and any("not finalized" in w for w in rep.warnings)
    # resume: skip what is there, finish the rest
    w = DatasetWriter(root, {"name": "tiny", "licence": "CC0"})
    assert w.has_sample("S01-G01-P2") and not w.has_sample("S01-G01-P3")
    splits = {"G01": "train", "G02": "test"}
    for gi, g in enumerate(("G01", "G02")):
        for pi, p in enumerate(("P1", "P2", "P3")):
            sid = f"S01-{g}-{p}"
            if w.has_sample(sid):
                continue
            V, F, uv = _grid(6, seed=10 * gi + pi)
            w.add_sample(subject_id="S01", garment_id=g, pose_id=p, category="topwear",
                         garment_type="t-shirt", split=splits[g], garment=(V, F, uv),
                         body=_body(pi), scan=(V + 0.01, F),
                         texture=np.full((4, 4, 3), 200, np.uint8))
    w.finalize()
    ids = Dataset(root).manifest["sample_id"].tolist()
    assert len(ids) == len(set(ids)) == 6
    rep = validate_dataset(root)
    assert rep.ok and not rep.warnings, rep.format()


def test_validator_reports_every_problem(tmp_path):
    root = make_tiny(tmp_path / "ds")
    bad = tmp_path / "bad"
    shutil.copytree(root, bad)
    (bad / "samples/S01/G01/P1/body.npz").unlink()                       # deleted file
    p = bad / "samples/S01/G01/P2/garment.ply"                           # edited mesh
    data = bytearray(p.read_bytes())
    data[-5] ^= 0xFF
    p.write_bytes(bytes(data))
    rows = read_manifest(bad / "manifest.parquet").to_pylist()
    rows[2]["scan_path"] = "../outside.ply"                              # escapes ROOT
    rows[3]["split"] = "train"                                           # garment G02 split mixed
    write_manifest(bad / "manifest.parquet", rows)
    rep = validate_dataset(bad)
    text = rep.format()
    assert not rep.ok
    assert "S01-G01-P1" in text and "body_path file" in text and "does not exist" in text
    assert "S01-G01-P2" in text and "checksum" in text
    assert "S01-G01-P3" in text and "escapes the dataset root" in text
    assert "garment 'G02' has split" in text
    # truncated parquet
    mp = bad / "manifest.parquet"
    mp.write_bytes(mp.read_bytes()[: mp.stat().st_size // 2])
    rep2 = validate_dataset(bad)
    assert not rep2.ok and "damaged or truncated" in rep2.format()


def test_validator_mesh_sanity(tmp_path):
    root = make_tiny(tmp_path / "ds")
    from dressmeup.io.mesh import save_mesh

    # replace a garment with a mesh whose faces point out of range and fix the hash so that
    # only the mesh check can catch it
    p = root / "samples/S01/G02/P1/garment.ply"
    V, F, _ = _grid()
    F[0, 0] = 999
    header = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n" \
             b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
    p.write_bytes(header + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    from dressmeup.io.hashing import sha256_file
    rows = read_manifest(root / "manifest.parquet").to_pylist()
    for r in rows:
        if r["sample_id"] == "S01-G02-P1":
            r["garment_sha256"] = sha256_file(p)
    write_manifest(root / "manifest.parquet", rows)
    save_mesh(root / "samples/S01/G02/P2/scan.ply", V, F[1:])
    rep = validate_dataset(root)
    text = rep.format()
    assert "'S01-G02-P1' (row 3): garment mesh garment.ply is not a valid mesh" in text
    assert "face indices out of range" in text
    assert "'S01-G02-P2' (row 4): scan has 49 faces, manifest says 50" in text


def test_split_by_garment():
    ids = [f"G{i:02d}" for i in range(10)]
    s = split_by_garment(ids, seed=3)
    assert s == split_by_garment(list(reversed(ids)), seed=3)
    assert sorted(s.values()).count("test") == 2 and sorted(s.values()).count("val") == 2
    two = split_by_garment(["A", "B"], seed=0)
    assert sorted(two.values()) == ["test", "train"]
    assert split_by_garment(["A"]) == {"A": "train"}
    # without categories the default is the plain shuffle, same as strategy="random"
    assert s == split_by_garment(ids, seed=3, strategy="random")


# the garments of synth-retarget-v1/v2 (3 subjects x 4 garments, seed 0)
REF_CATS = {"G01": "topwear", "G02": "dress", "G03": "bottomwear", "G04": "bottomwear",
            "G05": "topwear", "G06": "bottomwear", "G07": "topwear", "G08": "bottomwear",
            "G09": "bottomwear", "G10": "bottomwear", "G11": "topwear", "G12": "dress"}


def test_split_by_garment_stratified_covers_every_category():
    s = split_by_garment(list(REF_CATS), seed=0, categories=REF_CATS)
    assert s == split_by_garment(sorted(REF_CATS, reverse=True), seed=0, categories=REF_CATS)
    for cat in ("topwear", "bottomwear", "dress"):
        got = [s[g] for g in REF_CATS if REF_CATS[g] == cat]
        assert got.count("test") == 1 and "train" in got, cat
    # val: categories with >= 3 garments (topwear 4, bottomwear 6), not the 2 dresses
    assert sorted(REF_CATS[g] for g in s if s[g] == "val") == ["bottomwear", "topwear"]
    # the old random split of this seed put only bottomwear (G03 trousers, G10 skirt) in test
    old = split_by_garment(list(REF_CATS), seed=0, strategy="random")
    assert sorted(g for g in old if old[g] == "test") == ["G03", "G10"]
    # frozen for generator 1.1.0 (editions synth-*-v2 pin it)
    assert sorted(g for g in s if s[g] == "test") == ["G01", "G02", "G10"]
    assert sorted(g for g in s if s[g] == "val") == ["G05", "G08"]
    # a category's split does not depend on the other categories' garments
    tops = {g: c for g, c in REF_CATS.items() if c == "topwear"}
    s_tops = split_by_garment(list(tops), seed=0, categories=tops)
    assert s_tops == {g: s[g] for g in tops}


def test_split_by_garment_singleton_categories_are_pooled():
    cats = {"A": "topwear", "B": "dress"}
    s = split_by_garment(list(cats), seed=0, categories=cats)
    assert sorted(s.values()) == ["test", "train"]
    cats = {"A": "topwear", "B": "topwear", "C": "topwear", "D": "dress"}
    s = split_by_garment(list(cats), seed=1, categories=cats)
    assert s["D"] == "train"                      # alone: train keeps it
    assert sorted(s[g] for g in "ABC") == ["test", "train", "val"]
    assert split_by_garment(["A"], categories={"A": "dress"}) == {"A": "train"}


def test_split_by_garment_rejects_bad_input():
    with pytest.raises(ValueError, match="categories"):
        split_by_garment(["A", "B"], categories={"A": "topwear"})
    with pytest.raises(ValueError, match="categories"):
        split_by_garment(["A", "B"], strategy="stratified")
    with pytest.raises(ValueError, match="strategy"):
        split_by_garment(["A", "B"], strategy="balanced")
    with pytest.raises(ValueError, match="fractions"):
        split_by_garment(["A", "B"], fractions=(0.5, 0.5, 0.5))


def test_fast_ply_path_matches_general_reader(tmp_path):
    from dressmeup.data.dataset import read_dataset_ply
    from dressmeup.io.mesh import load_mesh, save_mesh

    V, F, uv = _grid(7, seed=4)
    uvf = F[:, [1, 2, 0]]
    save_mesh(tmp_path / "g.ply", V, F, uv=uv, uv_faces=uvf,
              texture=np.zeros((2, 2, 3), np.uint8))
    fast, ref = read_dataset_ply(tmp_path / "g.ply"), load_mesh(tmp_path / "g.ply")
    np.testing.assert_array_equal(fast.vertices, ref.vertices)
    np.testing.assert_array_equal(fast.faces, ref.faces)
    np.testing.assert_array_equal(fast.uv[fast.uv_faces], ref.uv[ref.uv_faces])
    assert fast.texture_path == ref.texture_path
    save_mesh(tmp_path / "c.ply", V, F, vertex_colors=np.zeros((len(V), 3), np.uint8))
    assert read_dataset_ply(tmp_path / "c.ply") is None  # other layouts: general reader


def test_cli_validate_dataset_exit_codes(tmp_path, capsys):
    from dressmeup.cli import main

    root = make_tiny(tmp_path / "ds")
    assert main(["validate-dataset", str(root)]) == 0
    assert "OK" in capsys.readouterr().out
    (root / "samples/S01/G02/P3/scan.ply").unlink()
    assert main(["validate-dataset", str(root)]) == 1
    out = capsys.readouterr().out
    assert "S01-G02-P3" in out and "scan_path file" in out and "INVALID" in out
