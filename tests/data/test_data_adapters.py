"""Format adapters read tiny files written here in each published layout."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

from dressmeup.data.adapters import read_4ddress, read_cloth3d, read_pc2, read_thuman, write_pc2
from dressmeup.errors import InputError
from dressmeup.io.mesh import save_mesh


def _tri_mesh(n=5, seed=0):
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(n, 3))
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    return V, F


def test_pc2_roundtrip(tmp_path):
    frames = np.random.default_rng(0).normal(size=(4, 7, 3))
    write_pc2(tmp_path / "a.pc2", frames)
    np.testing.assert_allclose(read_pc2(tmp_path / "a.pc2"), frames.astype(np.float32))
    write_pc2(tmp_path / "a.pc16", frames, float16=True)
    np.testing.assert_allclose(read_pc2(tmp_path / "a.pc16"), frames.astype(np.float16))
    (tmp_path / "bad.pc2").write_bytes((tmp_path / "a.pc2").read_bytes()[:50])
    with pytest.raises(InputError, match="truncated"):
        read_pc2(tmp_path / "bad.pc2")


def test_cloth3d(tmp_path):
    import scipy.io

    seq = tmp_path / "01234"
    seq.mkdir()
    T = 6
    rng = np.random.default_rng(1)
    poses = rng.normal(0, 0.2, size=(72, T))
    trans = rng.normal(size=(3, T))
    scipy.io.savemat(seq / "info.mat", {
        "gender": 1, "shape": np.arange(10.0), "poses": poses, "trans": trans, "zrot": 0.0,
        "outfit": {"Top": {"type": "Tshirt", "fabric": "cotton"},
                   "Trousers": {"type": "Trousers", "fabric": "denim"}}})
    V, F = _tri_mesh()
    uv = np.random.default_rng(2).uniform(size=(len(V), 2))
    save_mesh(seq / "Top.obj", V, F, uv=uv)
    save_mesh(seq / "Trousers.obj", V, F)
    anim = V[None] + np.arange(T)[:, None, None] * 0.01
    write_pc2(seq / "Top.pc16", anim, float16=True)
    write_pc2(seq / "Trousers.pc2", anim)
    ds = read_cloth3d(tmp_path, stride=2)
    assert len(ds) == 6  # 2 garments x frames 0, 2, 4
    s = ds["01234_Top-F0002"]
    assert (s.category, s.garment_type, s.subject_id, s.pose_id) == ("topwear", "top", "01234",
                                                                    "F0002")
    g = s.garment()
    np.testing.assert_allclose(g.vertices, anim[2].astype(np.float16), atol=0)
    np.testing.assert_array_equal(g.faces, F)
    assert g.uv is not None
    b = s.body()
    assert b.model == "smpl" and b.gender == "male" and b.pose.shape == (24, 3)
    np.testing.assert_allclose(b.pose.ravel(), poses[:, 2])
    np.testing.assert_allclose(b.transl, trans[:, 2])
    assert s.scan() is None
    assert len(ds.filter(category="bottomwear").retarget_pairs()) == 6  # 3 frames -> 6 pairs


def test_cloth3d_zrot_composes_root(tmp_path):
    import scipy.io
    from scipy.spatial.transform import Rotation

    seq = tmp_path / "s1"
    seq.mkdir()
    poses = np.zeros((72, 1))
    scipy.io.savemat(seq / "info.mat", {"gender": 0, "shape": np.zeros(10), "poses": poses,
                                        "trans": np.zeros((3, 1)), "zrot": np.pi / 2,
                                        "outfit": {"Skirt": {"type": "Skirt"}}})
    V, F = _tri_mesh()
    save_mesh(seq / "Skirt.obj", V, F)
    write_pc2(seq / "Skirt.pc2", V[None])
    s = read_cloth3d(tmp_path, frames=[0])[0]
    b = s.body()
    assert b.gender == "female" and s.category == "bottomwear"
    np.testing.assert_allclose(Rotation.from_rotvec(b.pose[0]).as_matrix(),
                               Rotation.from_rotvec([0, 0, np.pi / 2]).as_matrix(), atol=1e-12)


def _pkl(path, obj):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        pickle.dump(obj, fh, protocol=2)


def test_thuman(tmp_path):
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
    assert len(ds) == 1
    s = ds["0007"]
    np.testing.assert_allclose(s.garment().vertices, V)
    np.testing.assert_allclose(s.scan()[0], V)
    b = s.body()
    assert b.model == "smplx" and b.pose.shape == (22, 3)
    assert b.scale == pytest.approx(0.9)
    # scale * (model + transl) + translation == scale * model + (scale * transl + translation)
    np.testing.assert_allclose(b.transl, 0.9 * np.array([0.1, 0.2, 0.3]) + [1.0, 2.0, 3.0])


def test_4ddress(tmp_path):
    take = tmp_path / "00122" / "Inner" / "Take2"
    _pkl(take / "basic_info.pkl", {"gender": "female", "outfit": {"upper": "shirt",
                                                                 "lower": "pants"},
                                   "scan_frames": ["00011", "00012"]})
    rng = np.random.default_rng(3)
    for f in ("00011", "00012"):
        V, F = _tri_mesh(seed=int(f))
        _pkl(take / "Meshes_pkl" / f"mesh-f{f}.pkl", {"vertices": V, "faces": F,
                                                     "colors": np.zeros((5, 3))})
        _pkl(take / "SMPL" / f"mesh-f{f}_smpl.pkl", {
            "global_orient": rng.normal(size=3), "body_pose": rng.normal(size=69),
            "transl": rng.normal(size=3), "betas": rng.normal(size=10)})
        _pkl(take / "Semantic" / "clothes" / f"cloth-f{f}.pkl", {
            "upper": {"vertices": V[:4], "faces": F[:2]}, "lower": {"vertices": V, "faces": F}})
    ds = read_4ddress(tmp_path)
    assert len(ds) == 4
    s = ds["00122_Inner_Take2_upper-F00012"]
    assert (s.category, s.garment_type, s.subject_id) == ("topwear", "shirt", "00122")
    g = s.garment()
    assert g.vertices.shape == (4, 3) and g.faces.shape == (2, 3)
    b = s.body()
    assert b.model == "smpl" and b.gender == "female" and b.pose.shape == (24, 3)
    assert s.scan()[0].shape == (5, 3)
    assert not s.row["topology_shared"]
    assert [p.pair_id for p in ds.filter(garment="00122_Inner_Take2_lower").retarget_pairs()] == [
        "00122_Inner_Take2_lower-F00011__to__00122_Inner_Take2_lower-F00012",
        "00122_Inner_Take2_lower-F00012__to__00122_Inner_Take2_lower-F00011"]


def test_pickles_cannot_run_code(tmp_path):
    class Evil:
        def __reduce__(self):
            return (os.system, ("echo pwned > " + str(tmp_path / "pwned"),))

    take = tmp_path / "s" / "Inner" / "Take1"
    _pkl(take / "basic_info.pkl", {"outfit": {"upper": "shirt"}, "x": Evil()})
    with pytest.raises(InputError, match="refused"):
        read_4ddress(tmp_path)
    assert not (tmp_path / "pwned").exists()
