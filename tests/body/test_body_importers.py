"""Importers: hand-written EasyMocap / PAMIR / smplify-x files give the same posed vertices
as the source tool's own convention."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dressmeup.body import SMPL22_PARENTS, BodyParams
from dressmeup.body.importers import guess_format, import_body_params
from dressmeup.body.smpl import SMPLBody
from dressmeup.errors import InputError

# 72 SMPL pose values written out by hand: a walking-like pose with the root tilted.
POSE72 = [0.3, 0.0, 0.1,  -0.4, 0.0, 0.05,  0.3, 0.0, -0.05,  0.1, 0.0, 0.0,
          0.6, 0.0, 0.0,  0.2, 0.0, 0.0,  0.0, 0.1, 0.0,  -0.1, 0.0, 0.0,
          0.0, 0.0, 0.1,  0.05, 0.0, 0.0,  0.0, 0.0, 0.0,  0.0, 0.0, 0.0,
          0.0, 0.0, 0.2,  0.0, 0.0, -0.1,  0.0, 0.0, 0.1,  0.1, 0.2, 0.0,
          0.0, 0.0, -1.0,  0.0, 0.0, 1.0,  0.0, -0.8, 0.0,  0.0, 0.8, 0.0,
          0.1, 0.0, 0.0,  -0.1, 0.0, 0.0,  0.0, 0.0, 0.0,  0.0, 0.0, 0.0]
BETAS = [0.5, -1.0, 0.3, 0.0, 0.2, 0.0, 0.0, -0.4, 0.0, 0.1]


@pytest.fixture(scope="module")
def smpl(tmp_path_factory):
    rng = np.random.default_rng(0)
    n, j = 300, 24
    parents = np.r_[SMPL22_PARENTS, 20, 21]
    W = rng.uniform(0, 1, (n, j)) ** 4
    Jr = rng.uniform(0, 1, (j, n))
    d = tmp_path_factory.mktemp("smpl")
    np.savez(d / "SMPL_NEUTRAL.npz", v_template=rng.normal(0, 0.3, (n, 3)) + [0, 1.0, 0],
             f=rng.integers(0, n, (50, 3)), J_regressor=Jr / Jr.sum(1, keepdims=True),
             weights=W / W.sum(1, keepdims=True),
             kintree_table=np.stack([np.r_[-1, parents[1:]], np.arange(j)]),
             shapedirs=rng.normal(0, 0.02, (n, 3, 10)),
             posedirs=rng.normal(0, 0.01, (n, 3, 207)))
    return SMPLBody(model_path=d)


def _raw(model, betas, pose):
    """The model evaluated with no translation/scale: M(betas, pose)."""
    out = model.forward(np.asarray(betas, float)[None], np.asarray(pose, float).reshape(1, -1, 3))
    return out.vertices[0].double().numpy()


def test_easymocap(tmp_path, smpl):
    Rh, Th = [0.2, -1.3, 0.4], [0.5, 0.1, 2.0]
    path = tmp_path / "000000.json"
    path.write_text(json.dumps([{"id": 0, "Rh": [Rh], "Th": [Th], "poses": [POSE72],
                                 "shapes": [BETAS]}]))
    params = import_body_params(path, body_model=smpl)
    assert guess_format(path) == "easymocap"
    # EasyMocap: v = R(Rh) M(shapes, poses) + Th (rotation about the model origin).
    expected = _raw(smpl, BETAS, POSE72) @ Rotation.from_rotvec(Rh).as_matrix().T + Th
    np.testing.assert_allclose(smpl.posed(params).vertices, expected, atol=1e-5)


def test_pamir(tmp_path, smpl):
    path = tmp_path / "smpl_param.pkl"
    with open(path, "wb") as fh:
        pickle.dump({"betas": np.array([BETAS]), "body_pose": np.array([POSE72]),
                     "body_scale": np.array([1.3]),
                     "global_body_translation": np.array([0.0, -0.2, 0.1])}, fh, protocol=2)
    params = import_body_params(path, body_model=smpl)
    assert guess_format(path) == "pamir" and params.scale == pytest.approx(1.3)
    expected = 1.3 * _raw(smpl, BETAS, POSE72) + [0.0, -0.2, 0.1]
    np.testing.assert_allclose(smpl.posed(params).vertices, expected, atol=1e-5)


@pytest.mark.parametrize("style", ["ipnet", "smplify-x"])
def test_smplify_and_ipnet(tmp_path, smpl, style):
    if style == "ipnet":  # IPNet: betas, pose (72), trans in a pickle
        path = tmp_path / "registration.pkl"
        with open(path, "wb") as fh:
            pickle.dump({"betas": np.array(BETAS), "pose": np.array(POSE72),
                         "trans": np.array([0.1, 0.2, 0.3])}, fh, protocol=2)
    else:  # smplify-x: global_orient + body_pose, transl (written as JSON here)
        path = tmp_path / "000.json"
        path.write_text(json.dumps({"betas": [BETAS], "global_orient": [POSE72[:3]],
                                    "body_pose": [POSE72[3:]], "transl": [[0.1, 0.2, 0.3]]}))
    params = import_body_params(path, body_model=smpl)
    assert guess_format(path) == "smplify"
    expected = _raw(smpl, BETAS, POSE72) + [0.1, 0.2, 0.3]
    np.testing.assert_allclose(smpl.posed(params).vertices, expected, atol=1e-5)


def test_easymocap_on_open_model(tmp_path):
    from dressmeup.body import get_body_model

    m = get_body_model("procedural")
    shapes = [0.2, 0.7, 0.5, 0.6, 0.3, 0.5]
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"Rh": [0.0, 1.0, 0.0], "Th": [1.0, 0.0, 0.0],
                                "poses": POSE72[:66], "shapes": shapes}))
    params = import_body_params(path, format="easymocap", body_model=m)
    expected = _raw(m, shapes, POSE72[:66]) @ Rotation.from_rotvec([0, 1, 0]).as_matrix().T
    np.testing.assert_allclose(m.posed(params).vertices, expected + [1, 0, 0], atol=1e-5)
    # ... and survives our own file format.
    back = import_body_params(params.save(tmp_path / "b.npz"), body_model=m)
    np.testing.assert_allclose(m.posed(back).vertices, m.posed(params).vertices, atol=1e-12)
    assert isinstance(back, BodyParams)


def test_bad_files_name_the_field(tmp_path, smpl):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"Rh": [0, 0, 0], "Th": [0, 0, 0], "poses": [0.0] * 70,
                                "shapes": BETAS}))
    with pytest.raises(InputError, match="'poses'"):
        import_body_params(path, format="easymocap", body_model=smpl)
    path.write_text(json.dumps({"betas": BETAS, "global_orient": [0, 0, 0],
                                "body_pose": [0.0] * 63, "jaw_pose": [0, 0, 0],
                                "leye_pose": [0, 0, 0], "reye_pose": [0, 0, 0],
                                "left_hand_pose": [0.0] * 12}))
    with pytest.raises(InputError, match="PCA"):
        import_body_params(path, format="smplify", body_model=smpl)
