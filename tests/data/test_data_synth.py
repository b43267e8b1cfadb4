"""The synthetic generator on the tiny procedural body: validity, plausibility numbers,
determinism and resuming after a crash."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dressmeup.data import Dataset, validate_dataset
from dressmeup.data.synth import DrapeSettings, generate_dataset
from dressmeup.errors import InputError

# small and quick: coarse garments, a short solver budget (the physics is the same)
KW = {"body_model": "procedural", "edge_length": 0.035, "texture_size": 32,
      "drape_settings": DrapeSettings(outer_iterations=3, inner_iterations=40)}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    root = tmp_path_factory.mktemp("synth") / "ds"
    generate_dataset(root, subjects=1, garments=2, poses=2, seed=3, **KW)
    return root


def _signed_distance(body_V, body_F, x):
    from dressmeup.geometry.proximity import closest_points
    from dressmeup.geometry.winding import winding_number

    d, _, _ = closest_points(body_V, body_F, x)
    return np.where(winding_number(body_V, body_F, x) > 0.5, -d, d)


def test_tiny_dataset_is_valid(tiny):
    rep = validate_dataset(tiny)
    assert rep.ok and not rep.warnings, rep.format()
    ds = Dataset(tiny)
    assert len(ds) == 4
    m = ds.manifest
    assert m["topology_shared"].all()
    assert sorted(m["split"].unique()) == ["test", "train"]  # split by garment
    assert m.groupby("garment_id")["split"].nunique().max() == 1
    info = ds.info
    assert info["generator"]["seed"] == 3 and info["generator"]["params"]["poses"] == 2
    assert info["generator"]["version"] == info["version"]
    assert info["generator"]["params"]["split_strategy"] == "stratified"
    assert len(ds.retarget_pairs()) == 4
    s = ds[0]
    g = s.garment()
    assert g.uv is not None and g.texture_path.is_file()
    sv, sf = s.scan()
    assert len(sv) > len(g.vertices) and sf.max() < len(sv)


def test_draped_garments_are_plausible(tiny):
    """No vertex deeper than 2 mm in the body; edges within 10 % of rest on average;
    the relaxation really moves the garment away from pure skinning."""
    from dressmeup.body import get_body_model
    from dressmeup.io.mesh import load_mesh

    model = get_body_model("procedural")
    ds = Dataset(tiny)
    for s in ds:
        g = s.garment()
        body = model.posed(s.body())
        sd = _signed_distance(body.vertices, model.faces, g.vertices)
        assert sd.min() > -0.002, (s.sample_id, sd.min())
        rest = load_mesh(tiny / "generator" / "rest" / f"{s.garment_id}.ply")
        np.testing.assert_array_equal(rest.faces, g.faces)
        E = np.unique(np.sort(np.concatenate([g.faces[:, [0, 1]], g.faces[:, [1, 2]],
                                              g.faces[:, [2, 0]]]), 1), axis=0)
        L0 = np.linalg.norm(rest.vertices[E[:, 1]] - rest.vertices[E[:, 0]], axis=1)
        L = np.linalg.norm(g.vertices[E[:, 1]] - g.vertices[E[:, 0]], axis=1)
        assert np.mean(np.abs(L / L0 - 1)) < 0.10, s.sample_id
        st = json.loads((tiny / "generator" / "stats" / f"{s.sample_id}.json").read_text())
        assert st["energy_end"] < st["energy_start"]
        assert st["skinning_mean_m"] > 1e-4  # ground truth is not the skinned garment
    rep = ds.info["report"]
    assert rep["n"] == 4 and rep["min_signed_distance_mm"] > -2.0


def test_rest_garments_have_no_self_intersections(tiny):
    import pymeshlab

    from dressmeup.io.mesh import load_mesh

    for f in sorted((tiny / "generator" / "rest").glob("*.ply")):
        m = load_mesh(f)
        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(m.vertices, m.faces))
        ms.compute_selection_by_self_intersections_per_face()
        assert ms.current_mesh().selected_face_number() == 0, f.name


def test_deterministic_and_resumes_after_crash(tmp_path, monkeypatch):
    import dressmeup.data.writer as wmod

    ref = generate_dataset(tmp_path / "ref", subjects=1, garments=1, poses=2, seed=5, **KW)
    real = wmod.DatasetWriter.add_sample
    calls = {"n": 0}

    def crash_after_one(self, **kw):
        calls["n"] += 1
        if calls["n"] == 2:
            raise RuntimeError("killed")
        return real(self, **kw)

    monkeypatch.setattr(wmod.DatasetWriter, "add_sample", crash_after_one)
    with pytest.raises(RuntimeError, match="killed"):
        generate_dataset(tmp_path / "run", subjects=1, garments=1, poses=2, seed=5, **KW)
    monkeypatch.setattr(wmod.DatasetWriter, "add_sample", real)
    assert len(Dataset(tmp_path / "run")) == 1
    generate_dataset(tmp_path / "run", subjects=1, garments=1, poses=2, seed=5, **KW)
    a, b = Dataset(ref).manifest, Dataset(tmp_path / "run").manifest
    assert b["sample_id"].is_unique and len(b) == 2
    cols = ["sample_id", "garment_sha256", "body_sha256", "scan_sha256", "texture_sha256"]
    assert a[cols].sort_values("sample_id").values.tolist() == \
        b[cols].sort_values("sample_id").values.tolist()
    rep = validate_dataset(tmp_path / "run")
    assert rep.ok and not rep.warnings, rep.format()
    # re-running a finished dataset is a no-op
    generate_dataset(tmp_path / "run", subjects=1, garments=1, poses=2, seed=5, **KW)
    c = Dataset(tmp_path / "run").manifest
    assert c[cols].values.tolist() == b[cols].values.tolist()
    with pytest.raises(InputError, match="different dataset"):
        generate_dataset(tmp_path / "run", subjects=1, garments=1, poses=2, seed=6, **KW)


def test_pose_library_mirrors_and_is_exact():
    from dressmeup.body import SMPL22_JOINT_NAMES
    from dressmeup.data.synth.garments import BodyFrame
    from dressmeup.data.synth.poses import pose_axis_angle, pose_names

    class F:  # canonical frame, arms already horizontal (no alignment)
        up, left, forward = np.eye(3)[1], np.eye(3)[0], np.eye(3)[2]
        joints: dict = {}

    assert len(pose_names()) >= 8
    p = pose_axis_angle("arms-down", SMPL22_JOINT_NAMES, F)
    li, ri = SMPL22_JOINT_NAMES.index("left_shoulder"), SMPL22_JOINT_NAMES.index("right_shoulder")
    np.testing.assert_allclose(p[li], [0, 0, np.deg2rad(-70)])
    np.testing.assert_allclose(p[ri], p[li] * [1, -1, -1])
    # an A-pose rest body: library angles stay relative to the canonical T-pose
    J = np.zeros((22, 3))
    names = SMPL22_JOINT_NAMES
    for n, v in {"pelvis": (0, 0, 0), "head": (0, 0.6, 0), "left_shoulder": (0.15, 0.45, 0),
                 "right_shoulder": (-0.15, 0.45, 0), "left_elbow": (0.35, 0.25, 0),
                 "right_elbow": (-0.35, 0.25, 0)}.items():
        J[names.index(n)] = v
    fr = BodyFrame.from_joints(J, names)
    from scipy.spatial.transform import Rotation

    q = pose_axis_angle("arms-down", names, fr)
    arm = (J[names.index("left_elbow")] - J[names.index("left_shoulder")])
    arm /= np.linalg.norm(arm)
    down = Rotation.from_rotvec(q[li]).apply(arm)
    np.testing.assert_allclose(down, [np.cos(np.deg2rad(-70)), np.sin(np.deg2rad(-70)), 0],
                               atol=1e-9)


def test_corrupted_copy_of_generated_dataset_fails(tiny, tmp_path):
    import shutil

    from dressmeup.data.manifest import read_manifest, write_manifest

    bad = tmp_path / "bad"
    shutil.copytree(tiny, bad)
    ids = Dataset(bad).manifest["sample_id"].tolist()
    rows = read_manifest(bad / "manifest.parquet").to_pylist()
    by = {r["sample_id"]: r for r in rows}
    (bad / by[ids[0]]["body_path"]).unlink()                                  # deleted file
    g = bad / by[ids[1]]["garment_path"]                                      # edited mesh
    data = bytearray(g.read_bytes())
    data[len(data) // 2] ^= 0x5A
    g.write_bytes(bytes(data))
    by[ids[2]]["scan_path"] = "../../etc/passwd"                              # outside ROOT
    write_manifest(bad / "manifest.parquet", rows)
    text = validate_dataset(bad).format()
    assert f"'{ids[0]}'" in text and "body_path file" in text and "does not exist" in text
    assert f"'{ids[1]}'" in text and "garment_sha256" in text
    assert f"'{ids[2]}'" in text and "escapes the dataset root" in text
    mp = bad / "manifest.parquet"                                             # truncated
    mp.write_bytes(mp.read_bytes()[:-40])
    rep = validate_dataset(bad)
    assert not rep.ok and "damaged or truncated" in rep.format()


@pytest.mark.slow
def test_every_garment_type_is_plausible(tmp_path):
    """All seven types on the procedural body in the hardest library poses."""
    root = generate_dataset(tmp_path / "all", subjects=7, garments=1, poses=2, seed=11,
                            body_model="procedural", edge_length=0.03, texture_size=16)
    from dressmeup.body import get_body_model

    ds = Dataset(root)
    assert sorted(ds.manifest["garment_type"].unique()) == sorted(
        ["dress", "long-sleeve", "shorts", "skirt", "t-shirt", "tank-top", "trousers"]) or \
        len(ds.manifest["garment_type"].unique()) >= 5
    model = get_body_model("procedural")
    for s in ds:
        g = s.garment()
        body = model.posed(s.body())
        assert _signed_distance(body.vertices, model.faces, g.vertices).min() > -0.002
    assert validate_dataset(root).ok


@pytest.mark.slow
def test_anny_tiny_dataset(tmp_path):
    root = generate_dataset(tmp_path / "anny", subjects=1, garments=1, poses=2, seed=0,
                            body_model="anny", texture_size=16)
    rep = validate_dataset(root)
    assert rep.ok, rep.format()
    assert Dataset(root).info["report"]["min_signed_distance_mm"] > -2.0
