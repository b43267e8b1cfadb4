"""Body parameter files: .npz round trip without pickle, validation naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body import BodyParams
from dressmeup.errors import InputError


def test_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    p = BodyParams("smplx", gender="female", shape=rng.normal(size=10),
                   pose=rng.normal(size=(55, 3)), transl=[0.1, 0.2, 0.3], scale=1.25)
    path = p.save(tmp_path / "body.npz")
    q = BodyParams.load(path)
    assert (q.model, q.gender, q.scale) == ("smplx", "female", 1.25)
    np.testing.assert_array_equal(q.shape, p.shape)
    np.testing.assert_array_equal(q.pose, p.pose)
    np.testing.assert_array_equal(q.transl, p.transl)
    with np.load(path, allow_pickle=False) as data:  # plain arrays only
        assert set(data.files) == {"model", "gender", "shape", "pose", "transl", "scale"}


def test_flat_pose_is_reshaped():
    assert BodyParams("anny", shape=np.zeros(6), pose=np.zeros(66)).pose.shape == (22, 3)


@pytest.mark.parametrize("field,value,match", [
    ("pose", np.zeros((22, 4)), "'pose'"),
    ("transl", np.zeros(2), "'transl'"),
    ("shape", np.zeros((2, 3)), "'shape'"),
    ("scale", -1.0, "'scale'"),
    ("pose", np.full((22, 3), np.nan), "'pose'"),
])
def test_validation_names_the_field(field, value, match):
    kw = dict(model="anny", shape=np.zeros(6), pose=np.zeros((22, 3)))
    kw[field] = value
    with pytest.raises(InputError, match=match):
        BodyParams(**kw)


def test_load_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothere.npz"):
        BodyParams.load(tmp_path / "nothere.npz")
    np.savez(tmp_path / "bad.npz", model=np.array("anny"), shape=np.zeros(6), pose=np.zeros((22, 2)))
    with pytest.raises(InputError, match=r"bad\.npz.*'pose'"):
        BodyParams.load(tmp_path / "bad.npz")
    np.savez(tmp_path / "nopose.npz", model=np.array("anny"), shape=np.zeros(6))
    with pytest.raises(InputError, match="pose"):
        BodyParams.load(tmp_path / "nopose.npz")
    np.savez(tmp_path / "obj.npz", model=np.array([{"a": 1}], dtype=object),
             shape=np.zeros(6), pose=np.zeros((22, 3)))
    with pytest.raises(InputError, match=r"obj\.npz.*Python objects"):
        BodyParams.load(tmp_path / "obj.npz")
