"""SMPL family from user files: safe loading, missing-file message, LBS against smplx.

Every model file here is a fake of plain random arrays written in the real format (never a
real SMPL file).
"""

from __future__ import annotations

import os
import pickle
import sys
import types

import numpy as np
import pytest
import scipy.sparse as sp

from dressmeup.body import SMPL22_PARENTS, BodyParams, get_body_model
from dressmeup.body.safe_pickle import safe_load_pickle
from dressmeup.body.smpl import SMPLBody, find_model_file
from dressmeup.errors import InputError, MissingModelError

N = 6890  # smplx's extra vertex joints index into the real vertex count


def fake_smpl_arrays(seed=0, n=N, j=24, s=10):
    rng = np.random.default_rng(seed)
    v = rng.normal(0, 0.3, (n, 3))
    parents = np.r_[SMPL22_PARENTS, 20, 21][:j]
    W = rng.uniform(0, 1, (n, j)) ** 4
    W /= W.sum(1, keepdims=True)
    Jr = rng.uniform(0, 1, (j, n)) * (rng.uniform(size=(j, n)) < 0.01)
    Jr[np.arange(j), rng.integers(0, n, j)] += 1.0
    Jr /= Jr.sum(1, keepdims=True)
    return {
        "v_template": v,
        "f": rng.integers(0, n, (200, 3)).astype(np.uint32),
        "J_regressor": Jr,
        "weights": W,
        "kintree_table": np.stack([np.r_[4294967295, parents[1:]], np.arange(j)]).astype(np.int64),
        "shapedirs": rng.normal(0, 0.01, (n, 3, s)),
        "posedirs": rng.normal(0, 0.01, (n, 3, (j - 1) * 9)),
    }


class _FakeCh:
    """Pickles like a chumpy.ch.Ch: state dict with the value in 'x'."""

    def __init__(self, x):
        self.x = x

    def __reduce_ex__(self, protocol):
        import copyreg

        return (copyreg._reconstructor, (type(self), object, None), {"x": self.x, "_dirty": True})


def write_fake_pickle(path, arrays):
    """Write arrays like the released SMPL pickles: chumpy shapedirs, sparse J_regressor."""
    pkg = types.ModuleType("chumpy")
    mod = types.ModuleType("chumpy.ch")
    _FakeCh.__module__ = "chumpy.ch"
    _FakeCh.__qualname__ = "Ch"
    mod.Ch = _FakeCh
    pkg.ch = mod
    sys.modules["chumpy"] = pkg
    sys.modules["chumpy.ch"] = mod
    try:
        data = dict(arrays)
        data["shapedirs"] = _FakeCh(arrays["shapedirs"])
        data["J_regressor"] = sp.csc_matrix(arrays["J_regressor"])
        data["bs_style"] = "lbs"
        with open(path, "wb") as fh:
            pickle.dump(data, fh, protocol=2)
    finally:
        del sys.modules["chumpy.ch"]
        del sys.modules["chumpy"]
        _FakeCh.__module__ = __name__
        _FakeCh.__qualname__ = "_FakeCh"


@pytest.fixture(scope="module")
def fake_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("models")
    (d / "smpl").mkdir()
    arrays = fake_smpl_arrays()
    write_fake_pickle(d / "smpl" / "SMPL_NEUTRAL.pkl", arrays)
    np.savez(d / "SMPL_FEMALE.npz", **arrays)
    return d, arrays


def test_chumpy_stripped_without_importing_it(fake_dir):
    d, arrays = fake_dir
    obj = safe_load_pickle(d / "smpl" / "SMPL_NEUTRAL.pkl")
    assert "chumpy" not in sys.modules
    np.testing.assert_array_equal(obj["shapedirs"], arrays["shapedirs"])
    np.testing.assert_allclose(obj["J_regressor"].toarray(), arrays["J_regressor"])


class _Evil:
    def __reduce__(self):
        return (os.system, ("echo pwned > /dev/null",))


def test_code_running_pickles_are_refused(tmp_path):
    p = tmp_path / "SMPL_NEUTRAL.pkl"
    p.write_bytes(pickle.dumps({"v_template": _Evil()}, protocol=2))
    with pytest.raises(InputError, match=r"refused.*(posix|os|nt)\.system"):
        safe_load_pickle(p)
    # Hand-written opcodes: a code object built from marshal data, and a call to eval.
    q = tmp_path / "code.pkl"
    q.write_bytes(b"cmarshal\nloads\n(C\x00tR.")
    with pytest.raises(InputError, match=r"refused.*marshal\.loads"):
        safe_load_pickle(q)
    q.write_bytes(b"c__builtin__\neval\n(S'1+1'\ntR.")
    with pytest.raises(InputError, match=r"refused.*(__builtin__|builtins)\.eval"):
        safe_load_pickle(q)
    q.write_bytes(b"ctypes\nCodeType\n.")
    with pytest.raises(InputError, match=r"refused.*types\.CodeType"):
        safe_load_pickle(q)
    with pytest.raises(InputError, match="refused"):
        SMPLBody(model_path=p)


def test_missing_file_message(tmp_path):
    with pytest.raises(MissingModelError) as err:
        get_body_model("smplx", gender="female", model_path=tmp_path)
    msg = str(err.value)
    assert str(tmp_path / "SMPLX_FEMALE.npz") in msg and str(tmp_path / "smplx") in msg
    assert "smpl-x.is.tue.mpg.de" in msg and "licence" in msg
    assert "SMPLX_FEMALE.pkl" in msg


def test_finds_files_in_both_layouts(fake_dir):
    d, _ = fake_dir
    assert find_model_file("smpl", "neutral", d) == d / "smpl" / "SMPL_NEUTRAL.pkl"
    assert find_model_file("smpl", "female", d) == d / "SMPL_FEMALE.npz"


def test_wrong_shapes_name_the_field(tmp_path):
    arrays = fake_smpl_arrays(n=100)
    arrays["weights"] = arrays["weights"][:, :20]
    np.savez(tmp_path / "SMPL_NEUTRAL.npz", **arrays)
    with pytest.raises(InputError, match="'weights'"):
        SMPLBody(model_path=tmp_path)


def test_lbs_matches_smplx_package(fake_dir):
    smplx = pytest.importorskip("smplx")
    import torch

    d, arrays = fake_dir
    ours = SMPLBody(model_path=d)  # the pickle
    npz = SMPLBody(gender="female", model_path=d)  # same arrays as .npz
    rng = np.random.default_rng(5)
    betas = rng.normal(0, 1, (2, 10))
    pose = rng.normal(0, 0.4, (2, 24, 3))
    transl = rng.normal(0, 0.1, (2, 3))
    out = ours.forward(torch.tensor(betas), torch.tensor(pose), torch.tensor(transl))
    out2 = npz.forward(torch.tensor(betas), torch.tensor(pose), torch.tensor(transl))
    torch.testing.assert_close(out.vertices, out2.vertices)
    struct = smplx.utils.Struct(**{k: (sp.csc_matrix(v) if k == "J_regressor" else v)
                                   for k, v in arrays.items()})
    ref = smplx.SMPL(model_path=str(d), data_struct=struct, batch_size=2, dtype=torch.float64)
    r = ref(betas=torch.tensor(betas), global_orient=torch.tensor(pose[:, 0]),
            body_pose=torch.tensor(pose[:, 1:].reshape(2, -1)), transl=torch.tensor(transl))
    # smplx adds 1e-8 to every axis-angle before taking its norm: agreement to ~1e-7 m.
    np.testing.assert_allclose(out.vertices.numpy(), r.vertices.detach().numpy(), atol=1e-6)
    np.testing.assert_allclose(out.joints.numpy(), r.joints[:, :24].detach().numpy(), atol=1e-6)


def test_params_with_smpl_model(fake_dir):
    d, _ = fake_dir
    m = get_body_model("smpl", model_path=d)
    p = BodyParams("smpl", shape=np.zeros(10), pose=np.zeros((24, 3)), transl=[0, 1, 0])
    np.testing.assert_allclose(m.posed(p).vertices, m.template_vertices + [0, 1, 0], atol=1e-12)
