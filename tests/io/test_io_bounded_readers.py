"""Bounded, named-error readers for .npz and JSON."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

from dressmeup.errors import InputError
from dressmeup.io.jsonio import read_json, schema_problems
from dressmeup.io.npz import load_npz, npz_arrays_info


def test_npz_bomb_is_refused_from_its_header(tmp_path):
    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, vertices=np.zeros((20_000_000, 3)))  # 480 MB declared
    assert path.stat().st_size < 2_000_000
    assert npz_arrays_info(path)["vertices"].nbytes == 480_000_000
    with pytest.raises(InputError, match=r"480,000,000 bytes .* over the limit .*array_bytes"):
        load_npz(path, max_bytes=100 << 20)


@pytest.mark.parametrize("damage", ["truncated", "crc", "npy", "empty", "object"])
def test_damaged_npz_is_a_named_error(tmp_path, damage):
    path = tmp_path / "pred.npz"
    np.savez(path, vertices=np.arange(3000.0).reshape(-1, 3))
    raw = path.read_bytes()
    if damage == "truncated":
        path.write_bytes(raw[: len(raw) // 2])
    elif damage == "crc":
        with zipfile.ZipFile(path) as z:
            off = z.infolist()[0].header_offset
        i = off + 200
        path.write_bytes(raw[:i] + bytes([raw[i] ^ 0xFF]) + raw[i + 1:])
    elif damage == "npy":
        np.save(tmp_path / "x.npy", np.zeros(3))
        path.write_bytes((tmp_path / "x.npy").read_bytes())
    elif damage == "empty":
        path.write_bytes(b"")
    else:
        np.savez(path, vertices=np.array([{"a": 1}], dtype=object))
    with pytest.raises(InputError, match="pred.npz"):
        load_npz(path, what="prediction")


def test_body_params_load_on_damaged_file_is_named(tmp_path):
    from dressmeup.body.params import BodyParams

    path = tmp_path / "body.npz"
    path.write_bytes(b"PK\x03\x04garbage")
    with pytest.raises(InputError, match="body.npz"):
        BodyParams.load(path)


def test_json_reader_names_file_and_field(tmp_path):
    p = tmp_path / "dataset.json"
    p.write_bytes(b"\xff\xfe{}")
    with pytest.raises(InputError, match="not UTF-8"):
        read_json(p, "dataset")
    p.write_text('{"name": "x",')
    with pytest.raises(InputError, match="line 1"):
        read_json(p, "dataset")
    p.write_text(json.dumps({"name": "x", "format": "dressmeup-dataset",
                             "manifest_version": "9.0"}))
    with pytest.raises(InputError, match="manifest_version"):
        read_json(p, "dataset")


@pytest.mark.parametrize("info, field", [
    ({}, "name"), ({"name": 5, "format": "dressmeup-dataset", "manifest_version": "1.0"},
                   "field name"),
    ({"name": "x", "format": "obj", "manifest_version": "1.0"}, "field format"),
    ({"name": "x", "format": "dressmeup-dataset", "manifest_version": "9.0"},
     "field manifest_version"),
    ({"name": "x", "format": "dressmeup-dataset", "manifest_version": "1.0", "units": "mm"},
     "field units"),
])
def test_dataset_schema_refuses_bad_info(info, field):
    problems = schema_problems(info, "dataset", "dataset.json")
    assert problems and any(field in p for p in problems), problems


def test_keypoints_and_session_schemas():
    assert schema_problems([[0, 1, 2]], "keypoints")  # a list, not {joint: xyz}
    assert schema_problems({"pelvis": [0, 1]}, "keypoints")
    assert not schema_problems({"pelvis": [0.0, 1.0, 0.1]}, "keypoints")
    assert any("garments" in p for p in
               schema_problems({"subject_id": "S1", "pose_id": "P1", "garments": 5}, "session"))


def test_rig_and_imported_params_name_bad_files(tmp_path):
    from dressmeup.body.importers import import_body_params
    from dressmeup.capture.rig import load_rig

    rig = tmp_path / "rig.json"
    rig.write_bytes(b"\xff\xfe not utf-8")
    with pytest.raises(InputError, match="rig.json: not UTF-8"):
        load_rig(rig)
    params = tmp_path / "params.npz"
    params.write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(InputError, match="params.npz"):
        import_body_params(params, body_model="procedural")
