"""Format adapters, tested on tiny files written here in each published layout, with the
conventions of each dataset's official code (named in docs/dataset-format.md):

- CLOTH3D: the starter kit's ``read.py`` (garment = zRot (V + trans); body = zRot (SMPL - J0 +
  trans); gender 1 = male; texture in ``info['outfit'][g]['texture']``);
- 4D-DRESS: eth-ait/4d-dress ``dataset/*.py`` (basic_info has scan_frames/rotation/offset,
  labels skin/hair/shoe/upper/lower/outer, garments cut by per-vertex labels, atlas flipped);
- THuman2.x: ICON ``load_fit_body`` (male SMPL-X, ``model * scale + translation``, no transl).
"""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

from dressmeup.body import SMPL22_PARENTS, BodyParams, get_body_model
from dressmeup.data.adapters import read_4ddress, read_cloth3d, read_pc2, read_thuman, write_pc2
from dressmeup.data.adapters.cloth3d import z_rotation
from dressmeup.errors import InputError
from dressmeup.io.mesh import save_mesh


def _tri_mesh(n=5, seed=0):
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(n, 3))
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    return V, F


def _pkl(path, obj):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        pickle.dump(obj, fh, protocol=2)


def _fake_smpl(path, n=300, j=24, s=10, seed=0):
    """A small SMPL-format model file of random arrays (never a real SMPL file)."""
    rng = np.random.default_rng(seed)
    parents = np.r_[SMPL22_PARENTS, 20, 21][:j]
    W = rng.uniform(0, 1, (n, j)) ** 4
    W /= W.sum(1, keepdims=True)
    Jr = rng.uniform(0, 1, (j, n)) * (rng.uniform(size=(j, n)) < 0.05)
    Jr[np.arange(j), rng.integers(0, n, j)] += 1.0
    Jr /= Jr.sum(1, keepdims=True)
    np.savez(path, v_template=rng.normal(0, 0.3, (n, 3)) + [0.1, 0.9, -0.05],
             f=rng.integers(0, n, (200, 3)).astype(np.uint32), J_regressor=Jr, weights=W,
             kintree_table=np.stack([np.r_[4294967295, parents[1:]], np.arange(j)]).astype(
                 np.int64),
             shapedirs=rng.normal(0, 0.05, (n, 3, s)),
             posedirs=rng.normal(0, 0.01, (n, 3, (j - 1) * 9)))
    return path


def test_pc2_roundtrip(tmp_path):
    frames = np.random.default_rng(0).normal(size=(4, 7, 3))
    write_pc2(tmp_path / "a.pc2", frames)
    np.testing.assert_allclose(read_pc2(tmp_path / "a.pc2"), frames.astype(np.float32))
    write_pc2(tmp_path / "a.pc16", frames, float16=True)
    np.testing.assert_allclose(read_pc2(tmp_path / "a.pc16"), frames.astype(np.float16))
    (tmp_path / "bad.pc2").write_bytes((tmp_path / "a.pc2").read_bytes()[:50])
    with pytest.raises(InputError, match="truncated"):
        read_pc2(tmp_path / "bad.pc2")


def test_cloth3d_garment_sits_on_body_as_the_starter_kit_builds_them(tmp_path):
    """Rebuild a body/garment pair the way the starter kit's read.py does and check the
    adapter's garment lies on the adapter's body (today's convention failed: the garment
    stayed root-relative and unrotated, the body kept trans without -J0)."""
    import scipy.io

    model_file = _fake_smpl(tmp_path / "SMPL_MALE.npz")
    smpl = get_body_model("smpl", gender="male", model_path=str(model_file))
    rng = np.random.default_rng(4)
    T, zrot = 3, 0.7
    poses = rng.normal(0, 0.25, (72, T))
    trans = rng.normal(0, 0.5, (3, T))
    beta = rng.normal(0, 1.0, 10)
    seq = tmp_path / "data" / "00042"
    seq.mkdir(parents=True)
    scipy.io.savemat(seq / "info.mat", {
        "gender": 1, "shape": beta, "poses": poses, "trans": trans, "zrot": zrot,
        "outfit": {"Tshirt": {"type": "Tshirt", "fabric": "cotton",
                              "texture": {"type": "color", "data": [0.2, 0.4, 0.6]}}}})
    # starter kit read_human: V, J = smpl.set_params(pose, beta, trans); V -= J[0]; zRot V
    # (its J is the rest joint set of the shaped body, so V - J[0] is root-relative + trans)
    ids = np.arange(0, 300, 3)
    frames_rel, bodies_abs = [], []
    for t in range(T):
        rest = BodyParams("smpl", shape=beta, pose=poses[:, t].reshape(24, 3), gender="male")
        out = smpl.posed(rest)
        j0 = out.rest_joints[0]
        rel = out.vertices - j0                     # relative to the root joint
        normals = rng.normal(size=(len(ids), 3))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        frames_rel.append(rel[ids] + 0.01 * normals)  # the cached garment: 1 cm off the skin
        bodies_abs.append((rel + trans[:, t]) @ z_rotation(zrot).T)
    F = np.array([[0, 1, 2], [2, 3, 4]])
    save_mesh(seq / "Tshirt.obj", np.asarray(frames_rel[0]), F)
    write_pc2(seq / "Tshirt.pc2", np.asarray(frames_rel))
    ds = read_cloth3d(tmp_path / "data", stride=1, smpl_model_path=model_file)
    assert len(ds) == T
    for t in range(T):
        s = ds[f"00042_Tshirt-F{t:04d}"]
        g = s.garment().vertices
        body = smpl.posed(s.body()).vertices
        np.testing.assert_allclose(body, bodies_abs[t], atol=1e-6)   # body as the starter kit
        d = np.linalg.norm(g - body[ids], axis=1)
        np.testing.assert_allclose(d, 0.01, atol=2e-5)              # garment 1 cm off its skin
    s = ds[0]
    assert s.row["gender"] == "male" and s.body().gender == "male"
    assert s.row["texture_kind"] == "color"
    np.testing.assert_allclose(s.row["texture_color"], [0.2, 0.4, 0.6])


def test_cloth3d_rows_texture_image_and_single_frame(tmp_path):
    import scipy.io
    from scipy.spatial.transform import Rotation

    model_file = _fake_smpl(tmp_path / "SMPL_FEMALE.npz")
    seq = tmp_path / "s1"
    seq.mkdir()
    scipy.io.savemat(seq / "info.mat", {
        "gender": 0, "shape": np.zeros(10), "poses": np.zeros(72), "trans": np.zeros(3),
        "zrot": np.pi / 2, "outfit": {"Skirt": {"type": "Skirt", "texture": {"type": "pattern"}}}})
    V, F = _tri_mesh()
    save_mesh(seq / "Skirt.obj", V, F)
    write_pc2(seq / "Skirt.pc2", V[None])
    from PIL import Image

    Image.fromarray(np.full((4, 4, 3), 200, np.uint8)).save(seq / "Skirt.png")
    ds = read_cloth3d(tmp_path, frames=[0], smpl_model_path=model_file)
    s = ds[0]
    assert s.category == "bottomwear" and s.row["texture_kind"] == "image"
    assert s.garment().texture_path == seq / "Skirt.png"
    # single-frame info.mat: (72,) poses and (3,) trans; zrot composes into the root
    np.testing.assert_allclose(s.garment().vertices, V.astype(np.float32) @ z_rotation(
        np.pi / 2).T, atol=1e-6)
    b = s.body()
    assert b.gender == "female"
    np.testing.assert_allclose(Rotation.from_rotvec(b.pose[0]).as_matrix(),
                               z_rotation(np.pi / 2), atol=1e-12)
    assert len(ds.filter(category="bottomwear").retarget_pairs()) == 0
    assert ds.report.dataset == "cloth3d"


def test_thuman_icon_convention_ignores_transl_and_is_male(tmp_path):
    scans, fits = tmp_path / "THuman2.0_Release", tmp_path / "THuman2.0_smplx"
    V, F = _tri_mesh()
    save_mesh(scans / "0007" / "0007.obj", V, F, uv=np.zeros((len(V), 2)),
              texture=np.full((4, 4, 3), 9, np.uint8))
    param = {"betas": np.ones((1, 10)), "global_orient": np.full((1, 3), 0.1),
             "body_pose": np.full((1, 63), 0.2), "transl": np.array([[0.1, 0.2, 0.3]]),
             "left_hand_pose": np.zeros((1, 12)), "scale": np.array([0.9]),
             "translation": np.array([1.0, 2.0, 3.0])}
    _pkl(fits / "0007" / "smplx_param.pkl", param)
    ds = read_thuman(scans, fits)
    s = ds["0007"]
    np.testing.assert_allclose(s.garment().vertices, V)
    np.testing.assert_allclose(s.scan()[0], V)
    b = s.body()
    assert b.model == "smplx" and b.pose.shape == (22, 3) and b.gender == "male"
    # ICON: smplx(...) * scale + translation, the model built without transl
    assert b.scale == pytest.approx(0.9)
    np.testing.assert_allclose(b.transl, [1.0, 2.0, 3.0])
    assert read_thuman(scans, fits, gender="female")["0007"].body().gender == "female"


def test_thuman21_transl_convention_detected(tmp_path):
    scans, fits = tmp_path / "scans", tmp_path / "fits"
    V, F = _tri_mesh()
    save_mesh(scans / "0600" / "0600.obj", V, F)
    _pkl(fits / "0600" / "smplx_param.pkl", {
        "betas": np.zeros((1, 10)), "global_orient": np.zeros((1, 3)),
        "body_pose": np.zeros((1, 63)), "transl": np.array([[0.1, -0.2, 0.3]])})
    b = read_thuman(scans, fits)["0600"].body()
    assert b.scale == 1.0
    np.testing.assert_allclose(b.transl, [0.1, -0.2, 0.3])
    with pytest.raises(InputError, match="'icon' needs field 'scale'"):
        read_thuman(scans, fits, convention="icon")["0600"].body()
    with pytest.raises(InputError, match="convention"):
        read_thuman(scans, fits, convention="pifu")


def _dress4d_take(root, subject, outfit, take, frames, labels_per_frame, with_cloth=True,
                  colors=True, seed=0):
    """Write one take as the official release lays it out (basic_info without 'outfit')."""
    d = root / subject / outfit / take
    _pkl(d / "basic_info.pkl", {"scan_frames": frames, "rotation": np.eye(3),
                                "offset": np.zeros(3)})
    rng = np.random.default_rng(seed)
    names = ["skin", "hair", "shoe", "upper", "lower", "outer"]
    for f, present in zip(frames, labels_per_frame, strict=True):
        # a strip of 4 triangles per label present, plus skin
        V, F, lab = [], [], []
        for name in ["skin", *present]:
            base = len(V)
            V += list(rng.normal(size=(6, 3)))
            F += [[base + a, base + a + 1, base + a + 2] for a in range(4)]
            lab += [names.index(name)] * 6
        V, F, lab = np.asarray(V), np.asarray(F), np.asarray(lab)
        uv = rng.uniform(size=(len(V), 2))
        mesh = {"vertices": V, "faces": F, "normals": np.zeros_like(V), "uvs": uv}
        if colors:
            mesh["colors"] = np.full((len(V), 3), 128, np.uint8)
        _pkl(d / "Meshes_pkl" / f"mesh-f{f}.pkl", mesh)
        atlas = np.zeros((8, 8, 3), np.uint8)
        atlas[0] = 255  # first stored row (the bottom of the image once flipped)
        _pkl(d / "Meshes_pkl" / f"atlas-f{f}.pkl", atlas)
        _pkl(d / "SMPL" / f"mesh-f{f}_smpl.pkl", {
            "global_orient": rng.normal(size=3), "body_pose": rng.normal(size=69),
            "transl": rng.normal(size=3), "betas": rng.normal(size=10)})
        _pkl(d / "Semantic" / "labels" / f"label-f{f}.pkl", {"scan_labels": lab})
        if with_cloth:
            cloth = {}
            for name in present:
                keep = np.flatnonzero(lab == names.index(name))
                remap = -np.ones(len(V), int)
                remap[keep] = np.arange(len(keep))
                fm = np.all(lab[F] == names.index(name), axis=1)
                cloth[name] = {"vertices": V[keep], "faces": remap[F[fm]], "uvs": uv[keep],
                               "colors": None if not colors else mesh["colors"][keep]}
            _pkl(d / "Semantic" / "clothes" / f"cloth-f{f}.pkl", cloth)
    return d


def test_4ddress_real_layout_one_garment_per_outfit_across_takes(tmp_path):
    # basic_info as released: scan_frames, rotation, offset (no 'outfit', no 'gender')
    _dress4d_take(tmp_path, "00122", "Inner", "Take2", ["00011", "00012"],
                  [["upper", "lower"], ["upper", "lower"]], seed=1)
    _dress4d_take(tmp_path, "00122", "Inner", "Take5", ["00020"], [["upper"]], seed=2)
    ds = read_4ddress(tmp_path)
    assert len(ds) == 5
    assert sorted({s.garment_id for s in ds}) == ["00122_Inner_lower", "00122_Inner_upper"]
    upper = ds.filter(garment="00122_Inner_upper")
    assert sorted(s.pose_id for s in upper) == ["Take2-F00011", "Take2-F00012", "Take5-F00020"]
    assert len(upper.retarget_pairs()) == 6  # pairs cross takes
    s = ds["00122_Inner_upper-Take5-F00020"]
    assert (s.category, s.garment_type, s.subject_id) == ("topwear", "upper", "00122")
    g = s.garment()
    assert g.vertices.shape == (6, 3) and g.faces.shape == (4, 3)
    b = s.body()
    assert b.model == "smpl" and b.gender == "male" and b.pose.shape == (24, 3)  # official list
    assert s.scan()[0].shape == (12, 3)
    # Take5 has no lower garment in frame 00020: no sample for it
    assert "00122_Inner_lower-Take5-F00020" not in [x.sample_id for x in ds]


def test_4ddress_cut_by_labels_dress_outer_and_atlas(tmp_path):
    # no Semantic/clothes (users make them with the official postprocess): cut by labels
    _dress4d_take(tmp_path, "00148", "Inner", "Take4", ["00001"], [["upper", "lower"]],
                  with_cloth=False, colors=False, seed=3)
    _dress4d_take(tmp_path, "00123", "Outer", "Take8", ["00001"], [["upper", "lower", "outer"]],
                  seed=4)
    ds = read_4ddress(tmp_path)
    dress = ds["00148_Inner_upper-Take4-F00001"]
    assert (dress.category, dress.garment_type) == ("dress", "dress")  # official dress outfit
    g = dress.garment()
    assert g.vertices.shape == (6, 3) and g.faces.shape == (4, 3) and g.uv.shape == (6, 2)
    # no colours in the mesh: the texture is the atlas flipped top to bottom
    assert g.texture_image is not None and g.texture_image[-1].min() == 255
    assert g.texture_image[0].max() == 0
    ids = {s.sample_id for s in ds}
    assert "00123_Outer_upper-Take8-F00001" not in ids  # covered inner layer skipped
    assert ds["00123_Outer_outer-Take8-F00001"].category == "topwear"
    assert any("Outer" in why for _, why in ds.report.skipped)
    assert "skipped 1" in ds.report.summary(ds.samples())


def test_pickles_cannot_run_code(tmp_path):
    class Evil:
        def __reduce__(self):
            return (os.system, ("echo pwned > " + str(tmp_path / "pwned"),))

    take = tmp_path / "s" / "Inner" / "Take1"
    _pkl(take / "basic_info.pkl", {"scan_frames": ["00001"], "x": Evil()})
    with pytest.raises(InputError, match="refused"):
        read_4ddress(tmp_path)
    assert not (tmp_path / "pwned").exists()


def test_import_dataset_cli_writes_a_valid_dataset_with_report_and_pictures(tmp_path, capsys):
    from dressmeup.cli import main
    from dressmeup.data import Dataset
    from dressmeup.data.validate import validate_dataset

    src = tmp_path / "4D-DRESS"
    _dress4d_take(src, "00122", "Inner", "Take2", ["00011", "00012"],
                  [["upper", "lower"], ["upper", "lower"]], seed=1)
    _dress4d_take(src, "00148", "Inner", "Take4", ["00001", "00002"],
                  [["upper"], ["upper"]], with_cloth=False, colors=False, seed=3)
    out = tmp_path / "imported"
    assert main(["import-dataset", "4ddress", str(src), "--out", str(out),
                 "--pictures", "2"]) == 0
    text = capsys.readouterr().out
    assert "6 samples, 2 subjects, 3 garments" in text and "wrote 6 samples" in text
    ds = Dataset(out)
    assert len(ds) == 6 and validate_dataset(out).ok
    assert {s.category for s in ds} == {"topwear", "bottomwear", "dress"}
    # splits go by garment: every garment's samples share one split
    for gid in {s.garment_id for s in ds}:
        assert len({s.split for s in ds.filter(garment=gid)}) == 1
    pics = sorted((out / "pictures").glob("*.png"))
    assert len(pics) == 2 and all(p.stat().st_size > 1000 for p in pics)
    # the atlas-textured garment kept its texture
    dress = ds.filter(category="dress")[0].garment()
    assert dress.texture_path is not None and dress.uv is not None
    # a re-run resumes
    assert main(["import-dataset", "4ddress", str(src), "--out", str(out)]) == 0
    assert "wrote 0 samples (6 already there)" in capsys.readouterr().out


def test_import_dataset_zero_samples_is_an_error(tmp_path):
    from dressmeup.data.importing import import_dataset

    take = tmp_path / "src" / "00122" / "Outer" / "Take1"
    _dress4d_take(tmp_path / "src", "00122", "Outer", "Take1", ["00001"], [["upper"]], seed=5)
    assert take.is_dir()
    with pytest.raises(InputError, match="(?s)no samples found.*inner layer of an Outer outfit"):
        import_dataset("4ddress", tmp_path / "src", tmp_path / "out")
    assert not (tmp_path / "out").exists()
